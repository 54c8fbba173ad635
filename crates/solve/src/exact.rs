//! The exact Jacobian ∂f/∂y of the flattened model, by the chain rule over
//! the blocks' own partial derivatives ([`blocks::Block::partials`]).
//!
//! One evaluation of the model fixes the point; then every quantity the
//! evaluation computed — a node's motion and gas state, a signal, a block's
//! flows and forces, a node's acceleration, a state derivative — gets its
//! gradient with respect to the states, in the order the evaluation computed
//! it (forward mode): the gradient of an output is the sum over the block's
//! inputs of its partial derivative times that input's gradient. Gradients
//! are sparse (a drive's quantities depend on a few states), so the cost is
//! proportional to the number of non-zeros of the Jacobian, with no model
//! evaluation per column and no truncation error.
//!
//! Junctions. A junction cluster's pressures and temperatures z solve
//! F(z, w) = 0, the net mass and energy flows out of each node into the
//! attached blocks, given everything else w. By the implicit function
//! theorem ∂z/∂y = −(∂F/∂z)⁻¹ (∂F/∂w · ∂w/∂y), with ∂F/∂z and ∂F/∂w the
//! attached blocks' flow partials. A node through which nothing flows has a
//! singular energy row (its temperature is then held, gradient zero) and,
//! with every path shut, a singular mass row (pressure held likewise).
//!
//! Fallback. A block that does not give the partials of a phase is
//! differentiated alone by central differences of that phase over its
//! inputs ([`crate::block_differences`]); [`Exact::fallback_blocks`] names
//! those blocks. The rows of the blocks' own quadratures (statistics no
//! state reads) chain through the state derivatives they read.
//!
//! Parameter columns. [`Exact::set_parameters`] adds a column per live
//! block parameter (an interface input's value, a supply pressure, an
//! external force) after the state columns: the block's
//! [`blocks::Block::live_partials`] seed it wherever the chain reads that
//! block's outputs, and it propagates like a state column, through the
//! junction solves too. [`Exact::gradient`] reads the gradient of a state
//! derivative or a signal over the state and parameter columns (∂f/∂u,
//! ∂y/∂x, ∂y/∂u of a linearisation).
//!
//! What the model reads from the previous evaluation (a signal block reading
//! a junction node, solved later in the same evaluation) is constant here,
//! as in [`crate::jacobian::Structure`].

use crate::block_differences::{differentiate, differentiate_record, Inputs};
use crate::mechanics;
use crate::model::{node_mass, Model, ModelError, N_QUADRATURE};
use blocks::block::{Balances, Ctx, GasRole, In, Partials, Phase, Shape};
use graph::NodeCausality;
use ode::Sparsity;

/// The gradient of one quantity over the state columns: for a small
/// system ([`DENSE_UP_TO`] states) dense, one value per state (empty when
/// zero), otherwise sparse (column, value) pairs, columns unsorted and unique.
#[derive(Debug, Default, Clone)]
pub struct Grad {
    dense: Vec<f64>,
    pairs: Vec<(usize, f64)>,
}

impl Grad {
    /// The zero gradient (keeping the storage).
    fn clear(&mut self) {
        self.dense.clear();
        self.pairs.clear();
    }
}

/// Accumulator of one gradient at a time over the state columns: dense for
/// a small system, where adding a gradient is a short loop without branches
/// (the representation of [`Grad`] follows it); otherwise dense storage with
/// a record of the touched columns.
#[derive(Debug, Default)]
struct Acc {
    dense: Vec<f64>,
    seen: Vec<bool>,
    touched: Vec<usize>,
    /// Number of state columns when gradients are dense, else 0.
    width: usize,
}

/// Most states for which gradients are dense (see [`Grad`]): measured on
/// meter_out (6 states), where sparse pairs made the chain rule cost more
/// than the evaluations it saves.
const DENSE_UP_TO: usize = 32;

impl Acc {
    fn size(&mut self, n_states: usize) {
        self.dense.clear();
        self.dense.resize(n_states, 0.0);
        self.seen.clear();
        self.seen.resize(n_states, false);
        self.touched.clear();
        self.width = if n_states <= DENSE_UP_TO { n_states } else { 0 };
    }
    #[inline]
    fn unit(&mut self, j: usize, c: f64) {
        if self.width == 0 && !self.seen[j] {
            self.seen[j] = true;
            self.touched.push(j);
        }
        self.dense[j] += c;
    }
    #[inline]
    fn add(&mut self, g: &Grad, c: f64) {
        if c == 0.0 {
            return;
        }
        if self.width > 0 {
            for (a, &v) in self.dense.iter_mut().zip(&g.dense) {
                *a += c * v;
            }
            return;
        }
        for &(j, v) in &g.pairs {
            self.unit(j, c * v);
        }
    }
    fn take(&mut self, out: &mut Grad) {
        out.clear();
        if self.width > 0 {
            if self.dense.iter().any(|&v| v != 0.0) {
                out.dense.extend_from_slice(&self.dense);
                self.dense.fill(0.0);
            }
            return;
        }
        for &j in &self.touched {
            out.pairs.push((j, self.dense[j]));
            self.dense[j] = 0.0;
            self.seen[j] = false;
        }
        self.touched.clear();
    }
}

/// Gradients of everything one evaluation computes.
#[derive(Debug, Default)]
struct Grads {
    /// Per mechanical node: x, v.
    mech: Vec<[Grad; 2]>,
    /// Per pneumatic node: p, T.
    gas: Vec<[Grad; 2]>,
    /// Per signal.
    sig: Vec<Grad>,
    /// Per block and pneumatic port: ṁ, Ė into the block.
    flows: Vec<Vec<[Grad; 2]>>,
    /// Per pneumatic node: net inflow ṁ, Ė at an effort node.
    inflow: Vec<[Grad; 2]>,
    /// Per mechanical node: applied, sliding, breakaway, viscous.
    forces: Vec<[Grad; 4]>,
    /// Per mechanical node: acceleration.
    accel: Vec<Grad>,
    /// Per state: its derivative's row.
    rows: Vec<Grad>,
}

/// Which inputs a chain of partials must skip.
#[derive(Clone, Copy, PartialEq)]
enum Skip<'a> {
    Nothing,
    /// Gas at junction nodes (not yet solved when signals are computed).
    JunctionGas,
    /// Gas at the nodes of the cluster being solved (the unknowns).
    Cluster(&'a [usize]),
}

/// The exact Jacobian of one model (see the module documentation).
#[derive(Debug)]
pub struct Exact {
    pattern: Sparsity,
    shapes: Vec<Shape>,
    /// Per block: the input of each column of its partials.
    columns: Vec<Vec<In>>,
    /// Per block and phase (in [`Phase::ALL`] order): the last partials.
    partials: Vec<Vec<Partials>>,
    /// Blocks differentiated by differences in some phase (last fill).
    fallback: Vec<bool>,
    grads: Grads,
    acc: Acc,
    dy: Vec<f64>,
    cluster_rows: Vec<Grad>,
    inputs: Inputs,
    /// Entries the chain rule produced outside the pattern (should stay 0).
    dropped: usize,
    /// With dense gradients: the position in the pattern's values of
    /// (row r, state column j) at `r * n_states + j`, [`OUTSIDE`] if none.
    positions: Vec<u32>,
    /// Work space of the junction clusters' implicit differentiation.
    cluster: ClusterWork,
    /// Parameter columns (see the module documentation), column
    /// `n_states + k` for parameter k.
    parameters: Vec<ParameterColumn>,
    /// Work space of [`Exact::recorded_gradient`].
    record_partials: Vec<f64>,
}

/// A live block parameter differentiated as an extra column.
#[derive(Debug)]
struct ParameterColumn {
    block: usize,
    name: &'static str,
    /// Per phase (in [`Phase::ALL`] order): ∂(output row)/∂parameter.
    rows: Vec<Vec<f64>>,
    /// Whether the block gave the partials of every phase of the last fill.
    given: bool,
}

/// A quantity of the last evaluation whose gradient [`Exact::gradient`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The derivative of state (or quadrature) row r.
    Rate(usize),
    /// Signal s (a signal output of a block, as recorded).
    Signal(usize),
}

/// A (row, column) outside the pattern (see `Exact::positions`).
const OUTSIDE: u32 = u32::MAX;

fn phase_index(p: Phase) -> usize {
    Phase::ALL.iter().position(|&q| q == p).unwrap_or(0)
}

impl Exact {
    /// The exact Jacobian of `model` in the structure `pattern` (from
    /// [`crate::jacobian::Structure::pattern`], a superset of the non-zeros).
    pub fn new(model: &Model, pattern: Sparsity) -> Exact {
        let shapes: Vec<Shape> = model.circuit.instances.iter().map(|i| Shape::of(&*i.block)).collect();
        let nb = shapes.len();
        let ns = model.n_states;
        let positions = if ns <= DENSE_UP_TO {
            let mut positions = vec![OUTSIDE; model.dim() * ns];
            for j in 0..ns.min(pattern.n_columns()) {
                for (k, &r) in pattern.column_range(j).zip(pattern.column(j)) {
                    positions[r * ns + j] = u32::try_from(k).unwrap_or(OUTSIDE);
                }
            }
            positions
        } else {
            Vec::new()
        };
        let mut exact = Exact {
            positions,
            cluster: ClusterWork::default(),
            pattern,
            partials: (0..nb).map(|_| (0..Phase::ALL.len()).map(|_| Partials::default()).collect()).collect(),
            fallback: vec![false; nb],
            columns: shapes.iter().map(|s| (0..s.n_inputs()).map(|c| s.input_at(c)).collect()).collect(),
            shapes,
            grads: Grads::default(),
            acc: Acc::default(),
            dy: Vec::new(),
            cluster_rows: Vec::new(),
            inputs: Inputs::default(),
            dropped: 0,
            parameters: Vec::new(),
            record_partials: Vec::new(),
        };
        exact.size(model);
        exact
    }

    /// Add a column per live parameter `(block, name)` after the state
    /// columns (replacing earlier ones); see the module documentation.
    pub fn set_parameters(&mut self, model: &Model, parameters: &[(usize, &'static str)]) {
        self.parameters = parameters
            .iter()
            .map(|&(block, name)| ParameterColumn { block, name, rows: vec![Vec::new(); Phase::ALL.len()], given: true })
            .collect();
        self.size(model);
    }

    /// Whether the block of parameter column k gave its partials in the last
    /// [`Exact::evaluate`] (else that column is incomplete: differentiate
    /// that parameter otherwise).
    pub fn parameter_given(&self, k: usize) -> bool {
        self.parameters[k].given
    }

    /// Evaluate the model at (t, y) (unless it was just evaluated there) and
    /// form the gradients of everything it computed, for [`Exact::gradient`].
    pub fn evaluate(&mut self, model: &mut Model, t: f64, y: &[f64]) -> Result<(), ModelError> {
        self.dy.resize(model.dim(), 0.0);
        if !model.last_evaluation_at(t, y, &mut self.dy) {
            model.eval(t, y, Some(&mut self.dy), None)?;
        }
        self.gradients(model, t, y);
        Ok(())
    }

    /// The gradient of `q` at the last evaluation over the state columns
    /// then the parameter columns (dense).
    pub fn gradient(&self, model: &Model, q: Quantity) -> Vec<f64> {
        let g = match q {
            Quantity::Rate(r) => &self.grads.rows[r],
            Quantity::Signal(s) => &self.grads.sig[s],
        };
        self.dense(model, g)
    }

    /// The structure of the Jacobian this fills.
    pub fn pattern(&self) -> &Sparsity {
        &self.pattern
    }

    /// Ids of the blocks differentiated by differences in the last fill.
    pub fn fallback_blocks(&self, model: &Model) -> Vec<String> {
        self.fallback.iter().enumerate().filter(|(_, &f)| f).map(|(b, _)| model.circuit.instances[b].id.clone()).collect()
    }

    /// Entries the chain rule produced outside the pattern so far (dropped; a
    /// non-zero count means the pattern missed a dependency).
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    /// Fill `values` (in the order of [`Exact::pattern`]) with ∂f/∂y at (t, y).
    /// Evaluates the model once at (t, y); its junction warm starts are left as
    /// that evaluation leaves them.
    pub fn fill(&mut self, model: &mut Model, t: f64, y: &[f64], values: &mut [f64]) -> Result<(), ModelError> {
        self.dy.resize(model.dim(), 0.0);
        // the integrator has usually just evaluated f here (its step's end)
        if !model.last_evaluation_at(t, y, &mut self.dy) {
            model.eval(t, y, Some(&mut self.dy), None)?;
        }
        self.gradients(model, t, y);
        values.fill(0.0);
        let mut dropped = 0;
        let ns = model.n_states;
        for (r, row) in self.grads.rows.iter().enumerate() {
            for (j, &v) in row.dense.iter().enumerate().take(ns) {
                if v == 0.0 {
                    continue;
                }
                match self.positions[r * ns + j] {
                    OUTSIDE => dropped += 1,
                    p => values[p as usize] += v,
                }
            }
            for &(j, v) in &row.pairs {
                if v == 0.0 || j >= ns {
                    continue;
                }
                match self.pattern.column(j).binary_search(&r) {
                    Ok(p) => values[self.pattern.column_range(j).start + p] += v,
                    Err(_) => dropped += 1,
                }
            }
        }
        self.dropped += dropped;
        Ok(())
    }

    /// Partials of `phase` of block `b` at the model's last evaluation.
    fn compute_partials(&mut self, model: &Model, b: usize, phase: Phase, t: f64, y: &[f64]) {
        let slot = &model.slots[b];
        let block = &model.circuit.instances[b].block;
        let ctx =
            Ctx { t, gas: &*model.gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
        let with_balances = matches!(phase, Phase::Derivatives | Phase::Exchange | Phase::Quadratures);
        let balances = if with_balances {
            Balances { pneumatic: &slot.bal_flow, mechanical: &slot.motion }
        } else {
            Balances { pneumatic: &[], mechanical: &[] }
        };
        let shape = self.shapes[b];
        let d = &mut self.partials[b][phase_index(phase)];
        d.reset(shape, phase);
        let derivs = &self.dy[slot.states.clone()];
        let given = if phase == Phase::Quadratures {
            block.quadrature_partials(&ctx, &balances, derivs, d)
        } else {
            block.partials(phase, &ctx, &balances, d)
        };
        if !given {
            d.reset(shape, phase);
            let full = Balances { pneumatic: &slot.bal_flow, mechanical: &slot.motion };
            differentiate(&**block, phase, &ctx, &full, derivs, d, &mut self.inputs);
            self.fallback[b] = true;
        }
        for column in self.parameters.iter_mut().filter(|c| c.block == b) {
            let rows = &mut column.rows[phase_index(phase)];
            rows.clear();
            rows.resize(shape.outputs(phase), 0.0);
            column.given &= block.live_partials(column.name, phase, &ctx, rows);
        }
    }

    /// Sum the chain of block `b`'s partials row `row` of `phase` over its
    /// inputs' gradients into the accumulator.
    fn chain(&mut self, model: &Model, b: usize, phase: Phase, row: usize, skip: Skip) {
        let d = &self.partials[b][phase_index(phase)];
        chain_row(&mut self.acc, &self.grads, model, b, &self.columns[b], d.row(row), skip);
        let acc = &mut self.acc;
        for (k, column) in self.parameters.iter().enumerate() {
            if column.block == b {
                let v = column.rows[phase_index(phase)].get(row).copied().unwrap_or(0.0);
                if v != 0.0 {
                    acc.unit(model.n_states + k, v);
                }
            }
        }
    }

    /// The gradient (as [`Exact::gradient`]) of recorded value `index` of
    /// block `b` ([`blocks::Block::record`], which has no partials): the
    /// block's record differentiated alone by central differences over its
    /// inputs ([`crate::block_differences::differentiate_record`]), chained
    /// with its inputs' gradients from the last [`Exact::evaluate`] at (t, y)
    /// (call it before the model is evaluated elsewhere). A recorded value
    /// that reads a live parameter of its own block directly is not seen
    /// through the parameter columns. NaN entries where the value is
    /// undefined nearby.
    pub fn recorded_gradient(&mut self, model: &Model, t: f64, y: &[f64], b: usize, index: usize) -> Vec<f64> {
        let slot = &model.slots[b];
        let block = &model.circuit.instances[b].block;
        let ctx = model.ctx(b, t, y);
        let balances = model.balances(b);
        let mut partials = std::mem::take(&mut self.record_partials);
        differentiate_record(&**block, &ctx, &balances, &self.dy[slot.states.clone()], self.shapes[b], &mut partials, &mut self.inputs);
        let cols = self.shapes[b].n_inputs();
        chain_row(&mut self.acc, &self.grads, model, b, &self.columns[b], &partials[index * cols..(index + 1) * cols], Skip::Nothing);
        self.record_partials = partials;
        let mut g = Grad::default();
        self.acc.take(&mut g);
        self.dense(model, &g)
    }

    /// `g` over the state then parameter columns, dense.
    fn dense(&self, model: &Model, g: &Grad) -> Vec<f64> {
        let mut out = vec![0.0; model.n_states + self.parameters.len()];
        for (o, &v) in out.iter_mut().zip(&g.dense) {
            *o = v;
        }
        for &(j, v) in &g.pairs {
            out[j] += v;
        }
        out
    }

    fn size(&mut self, model: &Model) {
        let n = model.dim();
        let g = &mut self.grads;
        let resize2 = |v: &mut Vec<[Grad; 2]>, k: usize| v.resize_with(k, Default::default);
        resize2(&mut g.mech, model.circuit.mechanical_nodes.len());
        resize2(&mut g.gas, model.circuit.pneumatic_nodes.len());
        resize2(&mut g.inflow, model.circuit.pneumatic_nodes.len());
        g.sig.resize_with(model.n_signals, Default::default);
        g.forces.resize_with(model.circuit.mechanical_nodes.len(), Default::default);
        g.accel.resize_with(model.circuit.mechanical_nodes.len(), Default::default);
        g.rows.resize_with(n, Default::default);
        g.flows.resize_with(model.slots.len(), Default::default);
        for (b, slot) in model.slots.iter().enumerate() {
            g.flows[b].resize_with(slot.pneu_nodes.len(), Default::default);
        }
        self.acc.size(model.n_states + self.parameters.len());
    }

    /// Gradients of every quantity of the last evaluation, in its order.
    fn gradients(&mut self, model: &Model, t: f64, y: &[f64]) {
        self.fallback.fill(false);
        for column in &mut self.parameters {
            column.given = true;
        }
        let c = &model.circuit;
        // 1. kinematics of inertias
        for (node, mn) in c.mechanical_nodes.iter().enumerate() {
            let b = mn.inertia.block;
            self.compute_partials(model, b, Phase::Kinematics, t, y);
            let k = crate::model::mech_index(c, mn.inertia);
            for which in 0..2 {
                self.chain(model, b, Phase::Kinematics, 2 * k + which, Skip::Nothing);
                self.acc.take(&mut self.grads.mech[node][which]);
            }
        }
        // 2. efforts
        for (node, pn) in c.pneumatic_nodes.iter().enumerate() {
            if let NodeCausality::Effort(r) = pn.causality {
                let b = r.block;
                let k = crate::model::pneumatic_index(c, r);
                self.compute_partials(model, b, Phase::Effort, t, y);
                for which in 0..2 {
                    self.chain(model, b, Phase::Effort, 2 * k + which, Skip::Nothing);
                    self.acc.take(&mut self.grads.gas[node][which]);
                }
            } else {
                for g in self.grads.gas[node].iter_mut() {
                    g.clear();
                }
            }
        }
        // 3. signals, in evaluation order
        for &b in &c.signal_order {
            let slot = &model.slots[b];
            if slot.sig_out.is_empty() {
                continue;
            }
            self.compute_partials(model, b, Phase::Signals, t, y);
            for (k, s) in slot.sig_out.clone().enumerate() {
                self.chain(model, b, Phase::Signals, k, Skip::JunctionGas);
                self.acc.take(&mut self.grads.sig[s]);
            }
        }
        // 4. flows' partials, then the junction clusters by implicit differentiation
        for (b, slot) in model.slots.iter().enumerate() {
            if slot.has_flow {
                self.compute_partials(model, b, Phase::Flows, t, y);
            }
        }
        for cluster in &c.junction_clusters {
            self.solve_cluster(model, cluster);
        }
        // 5. flows, and the inflow of every node
        for (b, slot) in model.slots.iter().enumerate() {
            for k in 0..slot.pneu_nodes.len() {
                for which in 0..2 {
                    if slot.has_flow && !slot.pneu_is_effort[k] {
                        self.chain(model, b, Phase::Flows, 2 * k + which, Skip::Nothing);
                    }
                    self.acc.take(&mut self.grads.flows[b][k][which]);
                }
            }
        }
        self.node_inflows(model);
        // 6. forces and accelerations
        for node in 0..c.mechanical_nodes.len() {
            for g in self.grads.forces[node].iter_mut() {
                g.clear();
            }
        }
        for (b, slot) in model.slots.iter().enumerate() {
            if slot.mech_nodes.is_empty() {
                continue;
            }
            self.compute_partials(model, b, Phase::Forces, t, y);
            for (k, &node) in slot.mech_nodes.iter().enumerate() {
                for which in 0..4 {
                    // this block's share plus the node's sum so far
                    self.chain(model, b, Phase::Forces, 4 * k + which, Skip::Nothing);
                    let mut sum = std::mem::take(&mut self.grads.forces[node][which]);
                    self.acc.add(&sum, 1.0);
                    self.acc.take(&mut sum);
                    self.grads.forces[node][which] = sum;
                }
            }
        }
        for node in 0..c.mechanical_nodes.len() {
            let mass = node_mass(c, node);
            let d = mechanics::acceleration_partials(model.modes[node], &model.node_forces[node], model.node_mech[node].v, mass);
            for (which, &slope) in d.iter().enumerate().take(4) {
                let grad = std::mem::take(&mut self.grads.forces[node][which]);
                self.acc.add(&grad, slope);
                self.grads.forces[node][which] = grad;
            }
            let grad_v = std::mem::take(&mut self.grads.mech[node][1]);
            self.acc.add(&grad_v, d[4]);
            self.grads.mech[node][1] = grad_v;
            self.acc.take(&mut self.grads.accel[node]);
        }
        // 7. derivatives, then the blocks' quadratures and the balances
        let balance = model.n_states + model.n_block_quadratures;
        debug_assert_eq!(balance + N_QUADRATURE, model.dim());
        for (b, slot) in model.slots.iter().enumerate() {
            if !slot.states.is_empty() {
                self.compute_partials(model, b, Phase::Derivatives, t, y);
                for (i, row) in slot.states.clone().enumerate() {
                    self.chain(model, b, Phase::Derivatives, i, Skip::Nothing);
                    self.acc.take(&mut self.grads.rows[row]);
                }
            }
        }
        for row in balance..balance + N_QUADRATURE {
            self.grads.rows[row].clear();
        }
        for (b, slot) in model.slots.iter().enumerate() {
            if !slot.quad.is_empty() {
                self.compute_partials(model, b, Phase::Quadratures, t, y);
                for (k, row) in slot.quad.clone().enumerate() {
                    self.chain(model, b, Phase::Quadratures, k, Skip::Nothing);
                    self.acc.take(&mut self.grads.rows[row]);
                }
            }
            match slot.role {
                GasRole::Capacity => {
                    self.compute_partials(model, b, Phase::Exchange, t, y);
                    for which in 0..2 {
                        self.chain(model, b, Phase::Exchange, which, Skip::Nothing);
                        self.add_to_row(balance + 2 + which);
                    }
                }
                GasRole::Boundary => {
                    for k in 0..slot.pneu_nodes.len() {
                        for which in 0..2 {
                            let grad = if slot.pneu_is_effort[k] {
                                &self.grads.inflow[slot.pneu_nodes[k]][which]
                            } else {
                                &self.grads.flows[b][k][which]
                            };
                            self.acc.add(grad, -1.0);
                            self.add_to_row(balance + which);
                        }
                    }
                }
                GasRole::Restriction | GasRole::None => {}
            }
        }
    }

    /// Add the accumulator to the gradient of row `row`.
    fn add_to_row(&mut self, row: usize) {
        let mut sum = std::mem::take(&mut self.grads.rows[row]);
        self.acc.add(&sum, 1.0);
        self.acc.take(&mut sum);
        self.grads.rows[row] = sum;
    }

    /// Net inflow at every node: minus the flows into the blocks' flow ports on it.
    fn node_inflows(&mut self, model: &Model) {
        for node in 0..model.circuit.pneumatic_nodes.len() {
            for which in 0..2 {
                self.grads.inflow[node][which].clear();
            }
        }
        for (b, slot) in model.slots.iter().enumerate() {
            if !slot.has_flow {
                continue;
            }
            for (k, &node) in slot.pneu_nodes.iter().enumerate() {
                if slot.pneu_is_effort[k] {
                    continue;
                }
                for which in 0..2 {
                    let mut sum = std::mem::take(&mut self.grads.inflow[node][which]);
                    self.acc.add(&sum, 1.0);
                    self.acc.add(&self.grads.flows[b][k][which], -1.0);
                    self.acc.take(&mut sum);
                    self.grads.inflow[node][which] = sum;
                }
            }
        }
    }

    /// Gradients of a junction cluster's (p, T) by implicit differentiation.
    fn solve_cluster(&mut self, model: &Model, cluster: &[usize]) {
        let n = 2 * cluster.len();
        // ∂F/∂z (dense, small) and the explicit part G (one gradient per equation)
        let mut a = std::mem::take(&mut self.cluster.a);
        a.clear();
        a.resize(n * n, 0.0);
        self.cluster_rows.resize_with(n, Default::default);
        for (jj, &node) in cluster.iter().enumerate() {
            for which in 0..2 {
                let row = 2 * jj + which;
                for &(b, k) in &model.junction_ports[node] {
                    let slot = &model.slots[b];
                    self.chain(model, b, Phase::Flows, 2 * k + which, Skip::Cluster(cluster));
                    let d = &self.partials[b][phase_index(Phase::Flows)];
                    for (kk, &other) in slot.pneu_nodes.iter().enumerate() {
                        if let Some(ii) = cluster.iter().position(|&x| x == other) {
                            let shape = self.shapes[b];
                            let r = d.row(2 * k + which);
                            a[row * n + 2 * ii] += r[shape.input(In::P(kk)).unwrap_or(0)];
                            a[row * n + 2 * ii + 1] += r[shape.input(In::T(kk)).unwrap_or(0)];
                        }
                    }
                }
                self.acc.take(&mut self.cluster_rows[row]);
            }
        }
        let mut work = std::mem::take(&mut self.cluster);
        robust_inverse(&a, n, &mut work);
        let inverse = &work.inverse;
        for (ii, &node) in cluster.iter().enumerate() {
            for which in 0..2 {
                let u = 2 * ii + which;
                for r in 0..n {
                    let w = -inverse[u * n + r];
                    if w != 0.0 {
                        let g = std::mem::take(&mut self.cluster_rows[r]);
                        self.acc.add(&g, w);
                        self.cluster_rows[r] = g;
                    }
                }
                self.acc.take(&mut self.grads.gas[node][which]);
            }
        }
        work.a = a;
        self.cluster = work;
    }
}

/// Sum the chain of one row of block `b`'s partials (one value per input
/// column `columns`) over its inputs' gradients into `acc`.
fn chain_row(acc: &mut Acc, g: &Grads, model: &Model, b: usize, columns: &[In], row: &[f64], skip: Skip) {
    let slot = &model.slots[b];
    for (&input, &v) in columns.iter().zip(row) {
        if v == 0.0 {
            continue;
        }
        match input {
            In::State(i) => acc.unit(slot.states.start + i, v),
            In::P(k) | In::T(k) => {
                let node = slot.pneu_nodes[k];
                let skipped = match skip {
                    Skip::Nothing => false,
                    Skip::JunctionGas => model.circuit.pneumatic_nodes[node].causality == NodeCausality::Junction,
                    Skip::Cluster(nodes) => nodes.contains(&node),
                };
                if !skipped {
                    let which = usize::from(matches!(input, In::T(_)));
                    acc.add(&g.gas[node][which], v);
                }
            }
            In::X(k) => acc.add(&g.mech[slot.mech_nodes[k]][0], v),
            In::V(k) => acc.add(&g.mech[slot.mech_nodes[k]][1], v),
            In::Signal(k) => acc.add(&g.sig[slot.sig_in[k]], v),
            In::Mdot(k) | In::Edot(k) => {
                let which = usize::from(matches!(input, In::Edot(_)));
                let grad = if slot.pneu_is_effort[k] { &g.inflow[slot.pneu_nodes[k]][which] } else { &g.flows[b][k][which] };
                acc.add(grad, v);
            }
            In::Accel(k) => acc.add(&g.accel[slot.mech_nodes[k]], v),
            In::Rate(i) => acc.add(&g.rows[slot.states.start + i], v),
        }
    }
}

/// Reused storage of [`robust_inverse`] and of ∂F/∂z.
#[derive(Debug, Default)]
struct ClusterWork {
    a: Vec<f64>,
    scale: Vec<f64>,
    keep: Vec<bool>,
    idx: Vec<usize>,
    w: Vec<f64>,
    inverse: Vec<f64>,
}

/// Inverse of the n×n matrix `a` (row-major), into `k.inverse`, by Gauss–Jordan with partial
/// pivoting. A pivot that is zero, or negligible against its row, marks an
/// unknown the equations do not determine (no flow through a node): its
/// row and column are dropped and its gradient is zero.
fn robust_inverse(a: &[f64], n: usize, k: &mut ClusterWork) {
    k.scale.clear();
    k.scale.extend((0..n).map(|i| a[i * n..(i + 1) * n].iter().fold(0.0f64, |m, v| m.max(v.abs()))));
    k.keep.clear();
    k.keep.extend((0..n).map(|i| k.scale[i] > 0.0 && a[i * n + i].is_finite()));
    loop {
        k.idx.clear();
        k.idx.extend((0..n).filter(|&i| k.keep[i]));
        let (idx, scale, w) = (&k.idx, &k.scale, &mut k.w);
        let m = idx.len();
        w.clear();
        w.resize(m * 2 * m, 0.0);
        for (r, &i) in idx.iter().enumerate() {
            for (c, &j) in idx.iter().enumerate() {
                w[r * 2 * m + c] = a[i * n + j] / scale[i];
            }
            w[r * 2 * m + m + r] = 1.0 / scale[i];
        }
        let mut failed = None;
        for col in 0..m {
            let p = (col..m).max_by(|&x, &y| w[x * 2 * m + col].abs().total_cmp(&w[y * 2 * m + col].abs())).unwrap_or(col);
            let pivot = w[p * 2 * m + col].abs();
            if pivot.is_nan() || pivot <= 1e-12 {
                failed = Some(idx[col]);
                break;
            }
            if p != col {
                for c in 0..2 * m {
                    w.swap(p * 2 * m + c, col * 2 * m + c);
                }
            }
            let piv = w[col * 2 * m + col];
            for c in 0..2 * m {
                w[col * 2 * m + c] /= piv;
            }
            for r in 0..m {
                if r != col {
                    let f = w[r * 2 * m + col];
                    if f != 0.0 {
                        for c in 0..2 * m {
                            w[r * 2 * m + c] -= f * w[col * 2 * m + c];
                        }
                    }
                }
            }
        }
        match failed {
            Some(i) => k.keep[i] = false,
            None => {
                k.inverse.clear();
                k.inverse.resize(n * n, 0.0);
                for (r, &i) in idx.iter().enumerate() {
                    for (c, &j) in idx.iter().enumerate() {
                        k.inverse[i * n + j] = w[r * 2 * m + m + c];
                    }
                }
                return;
            }
        }
    }
}
