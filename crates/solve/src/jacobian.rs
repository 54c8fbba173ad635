//! The Jacobian ∂f/∂y of the circuit model from its structure, at a cost
//! that grows linearly with the circuit.
//!
//! Plain finite differences perturb one state per evaluation of the whole
//! model (n evaluations of cost ∝ n), and column grouping (Curtis, Powell &
//! Reid 1974) does not help here: a chamber that feeds N drives has a row
//! that depends on every drive, so no two drives could share a group. This
//! module uses the fact that the model is a sum of block contributions (a
//! partially separable function, Griewank & Toint 1981):
//!
//! * Every quantity an evaluation computes — the motion of a mechanical node,
//!   a block's effort (node gas), signal outputs, flows and forces, a junction
//!   cluster's pressures, a node's acceleration — is a *unit* that depends on
//!   a known set of states, found once from the wiring ([`Structure::new`]).
//! * The only sums over many blocks are the gas flows into a capacity's node,
//!   Σ ṁ over the restrictions attached to it (and the balance quadratures).
//!   Those are split by restriction.
//! * States that share no unit are perturbed together: one evaluation of the
//!   model per group. Each unit then changed because of exactly one of the
//!   perturbed states, so its change is that state's.
//! * For each perturbed state j, every block whose derivative it reaches is
//!   evaluated once more, alone, with its inputs as the base evaluation had
//!   them except those that j changed (and its node inflow changed only by the
//!   restrictions j changed): the exact finite-difference column of a
//!   one-state perturbation, written into the rows of that block, its
//!   quadratures and the balance quadratures.
//!
//! The cost per Jacobian is (1 + groups) model evaluations plus one block
//! evaluation per (state, reached block) pair. For N drives on one manifold
//! the number of groups is that of one drive plus the manifold's states, so
//! the cost is O(N). The structure also gives the sparsity pattern for the
//! sparse LU (see `ode::Sparsity`).
//!
//! Quantities read from the previous evaluation (a signal block reading a
//! junction node, solved later in the same evaluation) are not dependencies
//! here, as they are not in the evaluation itself. A perturbed evaluation's
//! values are read from the model's block buffers, where it left them (an
//! evaluation writes every buffer before it reads it; an effort is handed its
//! block's gas and signal buffers too, but reads only its states and
//! mechanical ports, as the structure above assumes), and the buffers of the
//! base evaluation are put back once, after the last group: two copies of
//! every block's buffers per Jacobian rather than two per group, which with
//! hundreds of drives was memory traffic that outgrew the caches.

use crate::model::{Model, ModelError, Slot, WarmStart};
use blocks::block::{Balances, Ctx, Exchange, MechState, Motion, PortFlow};
use gas::GasState;
use graph::NodeCausality;
use ode::Sparsity;
use std::collections::BTreeMap;

/// Which inputs of one block a perturbed state changes.
#[derive(Debug, Clone, Default)]
struct Reach {
    block: usize,
    /// The state is one of the block's own.
    own_state: bool,
    /// Bit k: gas at pneumatic port k.
    gas: u64,
    /// Bit k: motion of mechanical port k's node.
    mech: u64,
    /// Bit k: signal input k.
    signals: u64,
    /// Bit k: acceleration of mechanical port k's node.
    accel: u64,
    /// The block's own flows (the balance of its flow ports).
    own_flow: bool,
    /// Changes of the inflow at the block's effort ports: (port k, restriction block, its port).
    inflow: Vec<(usize, usize, usize)>,
    /// Where the column's entries in the block's rows are in the Jacobian's
    /// values: its first state row, its first quadrature row (its other rows
    /// follow them: a block's rows are consecutive) and the four balance rows
    /// (`ABSENT` where the column has no such row), found once so that
    /// filling a column searches nothing.
    states_at: usize,
    quad_at: usize,
    balance_at: [usize; 4],
}

/// Position of a row the column does not have.
const ABSENT: usize = usize::MAX;

/// Position of the i-th of consecutive rows that start at position `first`.
fn nth(first: usize, i: usize) -> usize {
    if first == ABSENT {
        ABSENT
    } else {
        first + i
    }
}

/// The structure of the model's Jacobian (see the module documentation).
#[derive(Debug, Clone)]
pub struct Structure {
    /// Groups of state columns perturbed together.
    groups: Vec<Vec<usize>>,
    /// Per state column: the blocks it reaches.
    reach: Vec<Vec<Reach>>,
    pattern: Sparsity,
}

/// Most ports of one domain a block may have for the structured Jacobian.
const MAX_PORTS: usize = 64;

impl Structure {
    /// The structure of `model`'s Jacobian, or `None` where a block has more
    /// than 64 ports of one kind (the model then uses plain differences).
    pub fn new(model: &Model) -> Option<Structure> {
        let c = &model.circuit;
        let slots = &model.slots;
        if slots.iter().any(|s| s.pneu_nodes.len() > MAX_PORTS || s.mech_nodes.len() > MAX_PORTS || s.sig_in.len() > MAX_PORTS) {
            return None;
        }
        let ns = model.n_states;
        let nb = slots.len();
        let states = |b: usize| -> Vec<usize> { slots[b].states.clone().collect() };
        // owner block of each signal
        let mut signal_block = vec![0; model.n_signals];
        for (b, s) in slots.iter().enumerate() {
            for k in s.sig_out.clone() {
                signal_block[k] = b;
            }
        }
        let kin: Vec<Vec<usize>> = c.mechanical_nodes.iter().map(|m| states(m.inertia.block)).collect();
        let mech_of = |b: usize| -> Vec<usize> { union(slots[b].mech_nodes.iter().map(|&n| kin[n].as_slice())) };
        // efforts read the block's states and its mechanical ports
        let eff: Vec<Vec<usize>> =
            (0..nb).map(|b| if slots[b].has_effort { union([states(b).as_slice(), &mech_of(b)]) } else { Vec::new() }).collect();
        let effort_block = |node: usize| -> Option<usize> {
            match c.pneumatic_nodes[node].causality {
                NodeCausality::Effort(r) => Some(r.block),
                NodeCausality::Junction => None,
            }
        };
        // signals, in evaluation order (junction gas is not yet solved when they are computed)
        let mut sig: Vec<Vec<usize>> = vec![Vec::new(); nb];
        let sig_in =
            |b: usize, sig: &[Vec<usize>]| -> Vec<usize> { union(slots[b].sig_in.iter().map(|&s| sig[signal_block[s]].as_slice())) };
        let effort_gas =
            |b: usize| -> Vec<usize> { union(slots[b].pneu_nodes.iter().filter_map(|&n| effort_block(n)).map(|e| eff[e].as_slice())) };
        for &b in &c.signal_order {
            sig[b] = union([states(b).as_slice(), &mech_of(b), &sig_in(b, &sig), &effort_gas(b)]);
        }
        // junction clusters: everything the attached blocks' flows read, except the cluster itself
        let mut cluster_of = vec![usize::MAX; c.pneumatic_nodes.len()];
        for (ci, cl) in c.junction_clusters.iter().enumerate() {
            for &n in cl {
                cluster_of[n] = ci;
            }
        }
        let mut clu: Vec<Vec<usize>> = vec![Vec::new(); c.junction_clusters.len()];
        for (b, slot) in slots.iter().enumerate() {
            let touched: Vec<usize> = slot.pneu_nodes.iter().map(|&n| cluster_of[n]).filter(|&ci| ci != usize::MAX).collect();
            if touched.is_empty() {
                continue;
            }
            let own = union([states(b).as_slice(), &mech_of(b), &sig_in(b, &sig), &effort_gas(b)]);
            for ci in touched {
                clu[ci] = union([clu[ci].as_slice(), &own]);
            }
        }
        let gas_at = |node: usize| -> &[usize] {
            match effort_block(node) {
                Some(e) => &eff[e],
                None => &clu[cluster_of[node]],
            }
        };
        // inputs of each block's flows, forces and derivatives
        let inputs: Vec<Vec<usize>> = (0..nb)
            .map(|b| {
                let gas = union(slots[b].pneu_nodes.iter().map(|&n| gas_at(n)));
                union([states(b).as_slice(), &mech_of(b), &sig_in(b, &sig), &gas])
            })
            .collect();
        let flow: Vec<Vec<usize>> = (0..nb).map(|b| if slots[b].has_flow { inputs[b].clone() } else { Vec::new() }).collect();
        let force: Vec<Vec<usize>> = (0..nb).map(|b| if slots[b].mech_nodes.is_empty() { Vec::new() } else { inputs[b].clone() }).collect();
        let mut accel: Vec<Vec<usize>> = kin.clone();
        for b in 0..nb {
            for &n in &slots[b].mech_nodes {
                accel[n] = union([accel[n].as_slice(), &force[b]]);
            }
        }

        // groups: two states may share one only if no unit depends on both
        let units: Vec<&Vec<usize>> = kin.iter().chain(&eff).chain(&sig).chain(&clu).chain(&flow).chain(&force).chain(&accel).collect();
        let groups = color(ns, &units);

        // what each state reaches
        let mut reach: Vec<BTreeMap<usize, Reach>> = vec![BTreeMap::new(); ns];
        // restrictions at each effort node
        let mut node_flows: Vec<Vec<(usize, usize)>> = vec![Vec::new(); c.pneumatic_nodes.len()];
        for (f, s) in slots.iter().enumerate() {
            for (fk, &n) in s.pneu_nodes.iter().enumerate() {
                if !s.pneu_is_effort[fk] {
                    node_flows[n].push((f, fk));
                }
            }
        }
        for b in 0..nb {
            let s = &slots[b];
            let consumer = !s.states.is_empty() || !s.pneu_nodes.is_empty();
            if !consumer {
                continue;
            }
            for j in s.states.clone() {
                entry(&mut reach, j, b).own_state = true;
            }
            for (k, &n) in s.pneu_nodes.iter().enumerate() {
                for &j in gas_at(n) {
                    entry(&mut reach, j, b).gas |= 1 << k;
                }
            }
            for (k, &n) in s.mech_nodes.iter().enumerate() {
                for &j in &kin[n] {
                    entry(&mut reach, j, b).mech |= 1 << k;
                }
                for &j in &accel[n] {
                    entry(&mut reach, j, b).accel |= 1 << k;
                }
            }
            for (k, &src) in s.sig_in.iter().enumerate() {
                for &j in &sig[signal_block[src]] {
                    entry(&mut reach, j, b).signals |= 1 << k;
                }
            }
            for &j in &flow[b] {
                entry(&mut reach, j, b).own_flow = true;
            }
            for (k, &n) in s.pneu_nodes.iter().enumerate() {
                if !s.pneu_is_effort[k] {
                    continue;
                }
                for &(f, fk) in &node_flows[n] {
                    for &j in &flow[f] {
                        entry(&mut reach, j, b).inflow.push((k, f, fk));
                    }
                }
            }
        }
        let mut reach: Vec<Vec<Reach>> = reach.into_iter().map(|m| m.into_values().collect()).collect();

        // rows of each column: the reached blocks' states and quadratures, and the balances
        let balance = model.n_states + model.n_block_quadratures;
        let columns: Vec<Vec<usize>> = reach
            .iter()
            .map(|rs| {
                let mut rows = Vec::new();
                for r in rs {
                    let s = &slots[r.block];
                    rows.extend(s.states.clone());
                    rows.extend(s.quad.clone());
                    // the balances: by what the block does with gas (the
                    // exact Jacobian's rule), and by whether it has states
                    // (the grouped differences')
                    if s.states.is_empty() || s.role == blocks::block::GasRole::Boundary {
                        rows.extend([balance, balance + 1]);
                    }
                    if !s.states.is_empty() || s.role == blocks::block::GasRole::Capacity {
                        rows.extend([balance + 2, balance + 3]);
                    }
                }
                rows
            })
            .collect();
        let pattern = Sparsity::from_columns(model.dim(), &columns).ok()?;
        for (j, rs) in reach.iter_mut().enumerate() {
            let (range, rows) = (pattern.column_range(j), pattern.column(j));
            let at = |row: usize| rows.binary_search(&row).map_or(ABSENT, |p| range.start + p);
            for r in rs {
                let s = &slots[r.block];
                r.states_at = at(s.states.start);
                r.quad_at = at(s.quad.start);
                r.balance_at = [at(balance), at(balance + 1), at(balance + 2), at(balance + 3)];
            }
        }
        Some(Structure { groups, reach, pattern })
    }

    /// The sparsity pattern (state columns; all rows).
    pub fn pattern(&self) -> &Sparsity {
        &self.pattern
    }

    /// Number of model evaluations per Jacobian (the base one and one per group).
    pub fn evaluations_per_jacobian(&self) -> usize {
        1 + self.groups.len()
    }

    /// Fill `values` (in the order of [`Structure::pattern`]) with ∂f/∂y at
    /// (t, y), column j perturbed by `deltas[j]` (backwards where the forward
    /// point leaves the model's domain). `work` holds buffers reused from
    /// call to call.
    ///
    /// Leaves the model's block buffers as the evaluation at (t, y) left them
    /// and its junction warm starts unchanged.
    pub fn fill(
        &self,
        model: &mut Model,
        work: &mut Workspace,
        t: f64,
        y: &[f64],
        deltas: &[f64],
        values: &mut [f64],
    ) -> Result<(), ModelError> {
        work.size_for(model);
        model.save_warm_start_into(&mut work.warm_outer);
        let result = self.fill_from(model, work, t, y, deltas, values);
        work.base.restore(&mut model.slots);
        model.restore_warm_start_from(&work.warm_outer);
        result
    }

    fn fill_from(
        &self,
        model: &mut Model,
        work: &mut Workspace,
        t: f64,
        y: &[f64],
        deltas: &[f64],
        values: &mut [f64],
    ) -> Result<(), ModelError> {
        model.eval(t, y, Some(&mut work.dy_base), None)?;
        work.base.take(&model.slots);
        for b in 0..model.slots.len() {
            let slot = &model.slots[b];
            work.ex_base[b] = if slot.states.is_empty() {
                Exchange::default()
            } else {
                let bs = &work.base.blocks[b];
                let ctx = Ctx {
                    t,
                    gas: &*model.gas,
                    states: &y[slot.states.clone()],
                    pneumatic: &bs.gas,
                    mechanical: &bs.mech,
                    signals: &bs.sig,
                };
                model.circuit.instances[b].block.exchange(&ctx, &Balances { pneumatic: &bs.bal_flow, mechanical: &bs.motion })
            };
        }
        work.yp.copy_from_slice(y);
        values.fill(0.0);
        model.save_warm_start_into(&mut work.warm_base);
        for group in &self.groups {
            let mut sign = 1.0;
            loop {
                for &j in group {
                    work.yp[j] = y[j] + sign * deltas[j];
                }
                let r = model.eval(t, &work.yp, Some(&mut work.dy), None);
                model.restore_warm_start_from(&work.warm_base);
                match r {
                    Ok(()) => break,
                    Err(ModelError::NonPhysical { .. } | ModelError::NonFinite { .. }) if sign > 0.0 => sign = -1.0,
                    Err(e) => return Err(e),
                }
            }
            // the perturbed evaluation is read where it left its values, in
            // the model's block buffers (restored once, after the last group)
            for &j in group {
                let dj = work.yp[j] - y[j];
                for r in &self.reach[j] {
                    self.column_entries(model, work, t, y, j, dj, r, values);
                }
                work.yp[j] = y[j];
            }
        }
        Ok(())
    }

    /// The entries of column j (perturbed by dj) in the rows of block `r.block`.
    #[allow(clippy::too_many_arguments)]
    fn column_entries(&self, model: &Model, work: &mut Workspace, t: f64, y: &[f64], j: usize, dj: f64, r: &Reach, values: &mut [f64]) {
        let b = r.block;
        let slot = &model.slots[b];
        let Workspace { base, dy_base, ex_base, scratch: w, .. } = work;
        let (bs, ps) = (&base.blocks[b], &model.slots[b]);
        let pick = |mask: u64, k: usize| mask & (1 << k) != 0;
        w.states.clear();
        w.states.extend_from_slice(&y[slot.states.clone()]);
        if r.own_state {
            w.states[j - slot.states.start] += dj;
        }
        choose(&mut w.gas, &bs.gas, &ps.gas, |k| pick(r.gas, k));
        choose(&mut w.mech, &bs.mech, &ps.mech, |k| pick(r.mech, k));
        choose(&mut w.sig, &bs.sig, &ps.sig, |k| pick(r.signals, k));
        choose(&mut w.motion, &bs.motion, &ps.motion, |k| pick(r.accel, k));
        w.bal.clear();
        for k in 0..bs.bal_flow.len() {
            w.bal.push(if slot.pneu_is_effort[k] {
                bs.bal_flow[k]
            } else if r.own_flow {
                ps.flows[k]
            } else {
                bs.flows[k]
            });
        }
        for &(k, f, fk) in &r.inflow {
            // the node's inflow is minus the restrictions' flows into themselves
            w.bal[k] += -difference(model.slots[f].flows[fk], base.blocks[f].flows[fk]);
        }
        let mut put = |at: usize, v: f64| {
            if at != ABSENT {
                values[at] += v;
            }
        };
        if slot.states.is_empty() {
            // a boundary: what it passes into the circuit
            for k in 0..w.bal.len() {
                let d_in = difference(w.bal[k], bs.bal_flow[k]);
                put(r.balance_at[0], -d_in.mdot / dj);
                put(r.balance_at[1], -d_in.edot / dj);
            }
            if slot.quad.is_empty() {
                return;
            }
        }
        let block = &model.circuit.instances[b].block;
        let ctx = Ctx { t, gas: &*model.gas, states: &w.states, pneumatic: &w.gas, mechanical: &w.mech, signals: &w.sig };
        let balances = Balances { pneumatic: &w.bal, mechanical: &w.motion };
        w.out.clear();
        w.out.resize(slot.states.len(), 0.0);
        if !slot.states.is_empty() {
            block.derivatives(&ctx, &balances, &mut w.out);
        }
        for (i, row) in slot.states.clone().enumerate() {
            put(nth(r.states_at, i), (w.out[i] - dy_base[row]) / dj);
        }
        if !slot.quad.is_empty() {
            w.qout.clear();
            w.qout.resize(slot.quad.len(), 0.0);
            block.quadrature_rates(&ctx, &balances, &w.out, &mut w.qout);
            for (i, row) in slot.quad.clone().enumerate() {
                put(nth(r.quad_at, i), (w.qout[i] - dy_base[row]) / dj);
            }
        }
        if slot.states.is_empty() {
            return; // a boundary exchanges no heat or work (its base was not taken)
        }
        let ex = block.exchange(&ctx, &balances);
        put(r.balance_at[2], (ex.heat - ex_base[b].heat) / dj);
        put(r.balance_at[3], (ex.work - ex_base[b].work) / dj);
    }
}

/// Buffers of [`Structure::fill`], kept between calls so that forming a
/// Jacobian does not allocate.
#[derive(Debug, Default)]
pub struct Workspace {
    base: Snapshot,
    dy_base: Vec<f64>,
    dy: Vec<f64>,
    yp: Vec<f64>,
    ex_base: Vec<Exchange>,
    warm_outer: WarmStart,
    warm_base: WarmStart,
    scratch: Scratch,
}

/// One block's inputs, assembled for one column.
#[derive(Debug, Default)]
struct Scratch {
    states: Vec<f64>,
    gas: Vec<GasState>,
    mech: Vec<MechState>,
    sig: Vec<f64>,
    motion: Vec<Motion>,
    bal: Vec<PortFlow>,
    out: Vec<f64>,
    qout: Vec<f64>,
}

impl Workspace {
    fn size_for(&mut self, model: &Model) {
        let n = model.dim();
        if self.dy.len() != n || self.base.blocks.len() != model.slots.len() {
            self.dy_base = vec![0.0; n];
            self.dy = vec![0.0; n];
            self.yp = vec![0.0; n];
            self.ex_base = vec![Exchange::default(); model.slots.len()];
            self.base = Snapshot::shaped(&model.slots);
        }
    }
}

/// out[k] = if changed(k) { perturbed[k] } else { base[k] }.
fn choose<T: Copy>(out: &mut Vec<T>, base: &[T], perturbed: &[T], changed: impl Fn(usize) -> bool) {
    out.clear();
    out.extend((0..base.len()).map(|k| if changed(k) { perturbed[k] } else { base[k] }));
}

/// The inputs every block saw in one evaluation.
#[derive(Debug, Default)]
struct Snapshot {
    blocks: Vec<BlockInputs>,
}

#[derive(Debug, Clone)]
struct BlockInputs {
    gas: Vec<GasState>,
    mech: Vec<MechState>,
    sig: Vec<f64>,
    flows: Vec<PortFlow>,
    bal_flow: Vec<PortFlow>,
    motion: Vec<Motion>,
}

impl Snapshot {
    /// Buffers shaped like the model's blocks.
    fn shaped(slots: &[Slot]) -> Snapshot {
        Snapshot {
            blocks: slots
                .iter()
                .map(|s| BlockInputs {
                    gas: s.gas.clone(),
                    mech: s.mech.clone(),
                    sig: s.sig.clone(),
                    flows: s.flows.clone(),
                    bal_flow: s.bal_flow.clone(),
                    motion: s.motion.clone(),
                })
                .collect(),
        }
    }

    fn take(&mut self, slots: &[Slot]) {
        for (b, s) in self.blocks.iter_mut().zip(slots) {
            b.gas.copy_from_slice(&s.gas);
            b.mech.copy_from_slice(&s.mech);
            b.sig.copy_from_slice(&s.sig);
            b.flows.copy_from_slice(&s.flows);
            b.bal_flow.copy_from_slice(&s.bal_flow);
            b.motion.copy_from_slice(&s.motion);
        }
    }

    fn restore(&self, slots: &mut [Slot]) {
        for (s, b) in slots.iter_mut().zip(&self.blocks) {
            s.gas.copy_from_slice(&b.gas);
            s.mech.copy_from_slice(&b.mech);
            s.sig.copy_from_slice(&b.sig);
            s.flows.copy_from_slice(&b.flows);
            s.bal_flow.copy_from_slice(&b.bal_flow);
            s.motion.copy_from_slice(&b.motion);
        }
    }
}

/// The record of state j reaching block b, created on first use.
fn entry(reach: &mut [BTreeMap<usize, Reach>], j: usize, b: usize) -> &mut Reach {
    reach[j].entry(b).or_insert_with(|| Reach { block: b, states_at: ABSENT, quad_at: ABSENT, balance_at: [ABSENT; 4], ..Reach::default() })
}

/// a − b.
fn difference(a: PortFlow, b: PortFlow) -> PortFlow {
    PortFlow { mdot: a.mdot - b.mdot, edot: a.edot - b.edot }
}

/// Sorted union of sorted sets.
fn union<'a>(sets: impl IntoIterator<Item = &'a [usize]>) -> Vec<usize> {
    let mut v: Vec<usize> = sets.into_iter().flatten().copied().collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Greedy colouring of the states 0..ns so that no unit contains two states
/// of one colour; returns the colour classes.
fn color(ns: usize, units: &[&Vec<usize>]) -> Vec<Vec<usize>> {
    let mut unit_of: Vec<Vec<usize>> = vec![Vec::new(); ns];
    for (u, set) in units.iter().enumerate() {
        for &j in set.iter() {
            unit_of[j].push(u);
        }
    }
    let mut colour = vec![usize::MAX; ns];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut mark: Vec<usize> = Vec::new();
    for j in 0..ns {
        for &u in &unit_of[j] {
            for &k in units[u].iter() {
                if colour[k] != usize::MAX {
                    mark[colour[k]] = j + 1;
                }
            }
        }
        let g = (0..groups.len()).find(|&g| mark[g] != j + 1).unwrap_or(groups.len());
        if g == groups.len() {
            groups.push(Vec::new());
            mark.push(0);
        }
        groups[g].push(j);
        colour[j] = g;
    }
    groups
}
