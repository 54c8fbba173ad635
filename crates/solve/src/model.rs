//! The flattened model: one state vector, one right-hand side, root
//! functions — built from a [`graph::Circuit`] without naming any block type.
//!
//! State vector layout: the blocks' states in block order, then the blocks'
//! own quadratures ([`Block::quadratures`], e.g. the integrals behind a
//! chamber's mean polytropic index) in block order, then four quadrature
//! states used only for the balance report:
//! [∫ṁ_boundary, ∫Ė_boundary, ∫Q_wall, ∫p·V̇] (boundary = flows entering
//! through blocks declared [`GasRole::Boundary`]; heat and work of blocks
//! declared [`GasRole::Capacity`]). No derivative reads a quadrature. Root functions: the
//! blocks' event functions in block order, then [`mechanics::N_ROOTS`] per
//! mechanical node; every one of them is negative while nothing happens and
//! the event is its becoming positive (a rising crossing,
//! [`ode::RootDirection::Rising`]).
//!
//! One evaluation runs the phases of [`blocks::block`] in order:
//! kinematics → efforts → signals → junction pressures → flows → forces and
//! node motion → derivatives.

use crate::junction;
use crate::mechanics::{self, Mode, NodeForces};
use blocks::block::*;
use gas::{GasModel, GasState};
use graph::{Circuit, NodeCausality, PortRef};
use std::ops::Range;
use std::sync::Arc;

/// Quadrature states appended after the block states.
pub const N_QUADRATURE: usize = 4;

/// Per-block index tables and scratch buffers.
#[derive(Debug, Clone)]
pub(crate) struct Slot {
    pub states: Range<usize>,
    /// The block's own quadratures in the state vector.
    pub quad: Range<usize>,
    /// Node of each pneumatic port, in the block's pneumatic-port order.
    pub pneu_nodes: Vec<usize>,
    pub pneu_is_effort: Vec<bool>,
    pub mech_nodes: Vec<usize>,
    /// Global signal index read by each signal input.
    pub sig_in: Vec<usize>,
    /// Global signal indices written by the signal outputs.
    pub sig_out: Range<usize>,
    pub events: Range<usize>,
    pub outputs: Range<usize>,
    pub has_flow: bool,
    pub has_effort: bool,
    /// What the block does with gas (its contract declaration, read once).
    pub role: GasRole,
    // scratch
    pub gas: Vec<GasState>,
    pub gas_out: Vec<GasState>,
    pub mech: Vec<MechState>,
    pub sig: Vec<f64>,
    pub sig_buf: Vec<f64>,
    pub flows: Vec<PortFlow>,
    pub forces: Vec<PortForce>,
    pub bal_flow: Vec<PortFlow>,
    pub motion: Vec<Motion>,
}

/// A circuit ready for integration; a clone is an independent copy with
/// every block's discrete state (see [`blocks::block::BlockClone`]).
#[derive(Debug, Clone)]
pub struct Model {
    pub circuit: Circuit,
    pub gas: Arc<dyn GasModel>,
    pub(crate) slots: Vec<Slot>,
    /// Number of block states (quadratures excluded).
    pub n_states: usize,
    /// Number of the blocks' own quadratures (after the block states).
    pub n_block_quadratures: usize,
    pub n_block_events: usize,
    pub n_signals: usize,
    pub n_outputs: usize,
    pub node_gas: Vec<GasState>,
    pub(crate) node_inflow: Vec<PortFlow>,
    pub node_mech: Vec<MechState>,
    pub node_forces: Vec<NodeForces>,
    pub modes: Vec<Mode>,
    /// Karnopp's velocity band of every node [m/s] (see [`mechanics::Body`]); 0 until a run sets it.
    pub velocity_band: f64,
    pub(crate) signals: Vec<f64>,
    /// For each junction node: (block, pneumatic-port index) pairs attached to it.
    pub(crate) junction_ports: Vec<Vec<(usize, usize)>>,
    /// Last solved junction pressures (warm start), per pneumatic node.
    pub(crate) junction_guess: Vec<f64>,
    /// Last change of each junction pressure (sizes the next warm-start probe).
    pub(crate) junction_step: Vec<f64>,
    /// Slope of each junction's flow balance at its last solution (first secant step).
    pub(crate) junction_slope: Vec<f64>,
    /// Number of right-hand-side evaluations.
    pub evaluations: u64,
    /// Number of those evaluations that computed the root functions.
    pub root_evaluations: u64,
    /// Evaluate signals as at rest before t = 0 (see [`crate::rest`]).
    pub(crate) at_rest: bool,
    /// Derivative and warm-start buffers reused by [`Model::record`].
    record_scratch: (Vec<f64>, WarmStart),
    /// Current value of each interface input [SI] (see [`crate::interface`]).
    pub(crate) input_values: Vec<f64>,
    /// The point (t, y) of the last evaluation that computed the
    /// derivatives, and those derivatives, while the blocks' buffers still
    /// hold that evaluation and no discrete state has changed since.
    last: LastEvaluation,
    /// Whether phases 1–3 of an evaluation alone leave the model as a
    /// whole evaluation would for every later one (see
    /// [`Model::record_signals`]).
    signals_alone: bool,
}

/// See [`Model::last_evaluation_at`].
#[derive(Debug, Clone, Default)]
struct LastEvaluation {
    valid: bool,
    t: f64,
    y: Vec<f64>,
    dy: Vec<f64>,
}

/// Saved junction warm starts (see [`Model::save_warm_start_into`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct WarmStart {
    guess: Vec<f64>,
    step: Vec<f64>,
    slope: Vec<f64>,
}

/// Why the model could not be built or evaluated.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("{what} is not finite at t = {} s", units::show::num(*t))]
    NonFinite { t: f64, what: String },
    #[error(
        "{id} left the physical domain at t = {} s: p = {p:.4e} Pa, T = {temp:.4e} K (the integrator could not recover with smaller steps)",
        units::show::num(*t)
    )]
    NonPhysical { t: f64, id: String, p: f64, temp: f64 },
    #[error("junction of {ports} at t = {} s: {message}", units::show::num(*t))]
    Junction { t: f64, ports: String, message: String },
}

impl Model {
    pub fn new(circuit: Circuit) -> Model {
        let gas = circuit.gas.clone();
        let mut slots = Vec::new();
        let (mut ns, mut nsig, mut nev, mut nout) = (0, 0, 0, 0);
        // first pass: signal output indices
        let mut sig_base = Vec::new();
        for inst in &circuit.instances {
            sig_base.push(nsig);
            nsig += inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalOut).count();
        }
        for (bi, inst) in circuit.instances.iter().enumerate() {
            let ports = inst.block.ports();
            let mut pneu_nodes = Vec::new();
            let mut pneu_is_effort = Vec::new();
            let mut mech_nodes = Vec::new();
            let mut n_out = 0;
            for (pi, p) in ports.iter().enumerate() {
                match p.kind.domain() {
                    Domain::Pneumatic => {
                        pneu_nodes.push(inst.port_nodes[pi].unwrap_or(0));
                        pneu_is_effort.push(p.kind == PortKind::PneumaticEffort);
                    }
                    Domain::Mechanical => {
                        mech_nodes.push(inst.port_nodes[pi].unwrap_or(0));
                    }
                    Domain::Signal => {
                        if p.kind == PortKind::SignalOut {
                            n_out += 1;
                        }
                    }
                }
            }
            let sig_in: Vec<usize> = inst
                .signal_sources
                .iter()
                .map(|src| {
                    let k = circuit.instances[src.block].block.ports()[..src.port].iter().filter(|p| p.kind == PortKind::SignalOut).count();
                    sig_base[src.block] + k
                })
                .collect();
            let n_states = inst.block.states().len();
            let n_events = inst.block.n_event_functions();
            let n_rec = n_out + inst.block.outputs().len();
            let blank = GasState { p: 0.0, t: 0.0, rho: 0.0, h: 0.0 };
            slots.push(Slot {
                states: ns..ns + n_states,
                quad: 0..0,
                has_flow: pneu_is_effort.iter().any(|e| !e),
                has_effort: pneu_is_effort.iter().any(|e| *e),
                role: inst.block.gas_role(),
                gas: vec![blank; pneu_nodes.len()],
                gas_out: vec![blank; pneu_nodes.len()],
                flows: vec![PortFlow::default(); pneu_nodes.len()],
                bal_flow: vec![PortFlow::default(); pneu_nodes.len()],
                mech: vec![MechState::default(); mech_nodes.len()],
                forces: vec![PortForce::default(); mech_nodes.len()],
                motion: vec![Motion::default(); mech_nodes.len()],
                sig: vec![0.0; sig_in.len()],
                sig_buf: vec![0.0; n_out],
                pneu_nodes,
                pneu_is_effort,
                mech_nodes,
                sig_in,
                sig_out: sig_base[bi]..sig_base[bi] + n_out,
                events: nev..nev + n_events,
                outputs: nout..nout + n_rec,
            });
            ns += n_states;
            nev += n_events;
            nout += n_rec;
        }
        // block quadratures follow all block states
        let mut nq = 0;
        for (bi, inst) in circuit.instances.iter().enumerate() {
            let k = inst.block.quadratures().len();
            slots[bi].quad = ns + nq..ns + nq + k;
            nq += k;
        }
        let n_nodes = circuit.pneumatic_nodes.len();
        let mut junction_ports = vec![Vec::new(); n_nodes];
        for (node, pn) in circuit.pneumatic_nodes.iter().enumerate() {
            if pn.causality == NodeCausality::Junction {
                for r in &pn.ports {
                    let k = pneumatic_index(&circuit, *r);
                    junction_ports[node].push((r.block, k));
                }
            }
        }
        let n_mech = circuit.mechanical_nodes.len();
        let blank = GasState { p: 101_325.0, t: 293.15, rho: 1.2, h: 0.0 };
        let signals_alone = signals_stand_alone(&circuit, &slots);
        Model {
            gas,
            slots,
            n_states: ns,
            n_block_quadratures: nq,
            n_block_events: nev,
            n_signals: nsig,
            n_outputs: nout,
            node_gas: vec![blank; n_nodes],
            node_inflow: vec![PortFlow::default(); n_nodes],
            node_mech: vec![MechState::default(); n_mech],
            node_forces: vec![NodeForces::default(); n_mech],
            modes: vec![Mode::Held { may_extend: true, may_retract: true }; n_mech],
            velocity_band: 0.0,
            signals: vec![0.0; nsig],
            junction_ports,
            junction_guess: vec![f64::NAN; n_nodes],
            junction_step: vec![0.0; n_nodes],
            junction_slope: vec![f64::NAN; n_nodes],
            evaluations: 0,
            root_evaluations: 0,
            at_rest: false,
            record_scratch: Default::default(),
            input_values: circuit.interface.inputs.iter().map(|i| i.start).collect(),
            last: LastEvaluation::default(),
            signals_alone,
            circuit,
        }
    }

    /// Total length of the ODE state vector (block states plus quadratures).
    pub fn dim(&self) -> usize {
        self.n_states + self.n_block_quadratures + N_QUADRATURE
    }

    /// Number of trailing quadrature components (block quadratures and balances).
    pub fn n_quadratures(&self) -> usize {
        self.n_block_quadratures + N_QUADRATURE
    }

    /// Names ("head.w_poly") of the blocks' quadratures, in state order.
    pub fn quadrature_names(&self) -> Vec<String> {
        self.circuit.instances.iter().flat_map(|i| i.block.quadratures().iter().map(move |q| format!("{}.{}", i.id, q.name))).collect()
    }

    /// Number of root functions.
    pub fn n_roots(&self) -> usize {
        self.n_block_events + mechanics::N_ROOTS * self.circuit.mechanical_nodes.len()
    }

    /// The block whose event function is root `i` (`i < n_block_events`).
    pub(crate) fn event_owner(&self, i: usize) -> usize {
        // slots are in block order and their event ranges ascend
        self.slots.partition_point(|s| s.events.end <= i)
    }

    /// Index of the first root function of mechanical node `node`.
    pub fn node_root_base(&self, node: usize) -> usize {
        self.n_block_events + node * mechanics::N_ROOTS
    }

    /// Which block (and which of its event functions) or which mechanical node
    /// (and which of its roots) root function `i` belongs to, as
    /// "controller event 0" or "piston breakaway (retract)".
    pub fn root_name(&self, i: usize) -> String {
        if i < self.n_block_events {
            let bi = self.event_owner(i);
            return format!("{} event {}", self.circuit.instances[bi].id, i - self.slots[bi].events.start);
        }
        let k = i.saturating_sub(self.n_block_events);
        let (node, which) = (k / mechanics::N_ROOTS, k % mechanics::N_ROOTS);
        let Some(mn) = self.circuit.mechanical_nodes.get(node) else {
            return format!("root {i}");
        };
        let id = &self.circuit.instances[mn.inertia.block].id;
        let what = match (self.modes.get(node), which) {
            (Some(Mode::Sliding { .. }), 0) => "velocity reversal",
            (Some(Mode::Sliding { .. }), _) => "end stop",
            (_, 0) => "breakaway (extend)",
            (_, _) => "breakaway (retract)",
        };
        format!("{id} {what}")
    }

    /// [`Model::eval`] that leaves no trace in the model: the junction warm
    /// starts and the evaluation counter are restored afterwards, so an
    /// observer that calls it does not change the run it observes.
    pub fn eval_detached(&mut self, t: f64, y: &[f64], dy: Option<&mut [f64]>, g: Option<&mut [f64]>) -> Result<(), ModelError> {
        let guess = self.junction_guess.clone();
        let step = self.junction_step.clone();
        let slope = self.junction_slope.clone();
        let (evaluations, root_evaluations) = (self.evaluations, self.root_evaluations);
        let r = self.eval(t, y, dy, g);
        self.junction_guess = guess;
        self.junction_step = step;
        self.junction_slope = slope;
        (self.evaluations, self.root_evaluations) = (evaluations, root_evaluations);
        r
    }

    /// Copy the junction solver's warm starts into `w` (to evaluate elsewhere and come back).
    pub(crate) fn save_warm_start_into(&self, w: &mut WarmStart) {
        for (to, from) in [(&mut w.guess, &self.junction_guess), (&mut w.step, &self.junction_step), (&mut w.slope, &self.junction_slope)] {
            to.clear();
            to.extend_from_slice(from);
        }
    }

    /// Put back warm starts saved by [`Model::save_warm_start_into`].
    pub(crate) fn restore_warm_start_from(&mut self, w: &WarmStart) {
        self.junction_guess.copy_from_slice(&w.guess);
        self.junction_step.copy_from_slice(&w.step);
        self.junction_slope.copy_from_slice(&w.slope);
    }

    /// Initial state vector: inertias first (their positions fix chamber volumes).
    pub fn initial_state(&mut self) -> Vec<f64> {
        let mut y = vec![0.0; self.dim()];
        let gas = self.gas.clone();
        for node in 0..self.circuit.mechanical_nodes.len() {
            let r = self.circuit.mechanical_nodes[node].inertia;
            let slot = &mut self.slots[r.block];
            let block = &self.circuit.instances[r.block].block;
            let ctx = InitCtx { gas: &*gas, mechanical: &[] };
            block.initial_states(&ctx, &mut y[slot.states.clone()]);
            block.kinematics(&y[slot.states.clone()], &mut slot.mech);
            let k = mech_index(&self.circuit, r);
            self.node_mech[node] = slot.mech[k];
        }
        let inertia_blocks: Vec<usize> = self.circuit.mechanical_nodes.iter().map(|n| n.inertia.block).collect();
        for (bi, slot) in self.slots.iter_mut().enumerate() {
            if inertia_blocks.contains(&bi) {
                continue;
            }
            for (k, &node) in slot.mech_nodes.iter().enumerate() {
                slot.mech[k] = self.node_mech[node];
            }
            let ctx = InitCtx { gas: &*gas, mechanical: &slot.mech };
            self.circuit.instances[bi].block.initial_states(&ctx, &mut y[slot.states.clone()]);
        }
        // states that track an input start at the value of that input
        if self.eval_detached(0.0, &y, None, None).is_ok() {
            for bi in 0..self.slots.len() {
                let range = self.slots[bi].states.clone();
                if range.is_empty() {
                    continue;
                }
                let mut own = y[range.clone()].to_vec();
                self.circuit.instances[bi].block.initial_states_from_inputs(&self.ctx(bi, 0.0, &y), &mut own);
                y[range].copy_from_slice(&own);
            }
        }
        y
    }

    /// Typical magnitudes of the states, for absolute tolerances.
    pub fn state_scales(&self, y0: &[f64]) -> Vec<f64> {
        let mut s = vec![1.0; self.dim()];
        for (bi, slot) in self.slots.iter().enumerate() {
            self.circuit.instances[bi].block.state_scales(&y0[slot.states.clone()], &mut s[slot.states.clone()]);
        }
        s
    }

    /// Evaluate everything at (t, y): node values, flows, forces, and if
    /// asked the derivatives `dy` and root functions `g`.
    pub fn eval(&mut self, t: f64, y: &[f64], dy: Option<&mut [f64]>, g: Option<&mut [f64]>) -> Result<(), ModelError> {
        let mut last = std::mem::take(&mut self.last);
        last.valid = false;
        let result = self.eval_uncached(t, y, dy, g, &mut last);
        last.valid &= result.is_ok();
        self.last = last;
        result
    }

    /// Whether the blocks' buffers hold an evaluation at exactly (t, y) with
    /// the discrete state as it is now; if so its derivatives are copied to `dy`.
    pub fn last_evaluation_at(&self, t: f64, y: &[f64], dy: &mut [f64]) -> bool {
        let l = &self.last;
        if l.valid && l.t == t && l.y == y && l.dy.len() == dy.len() {
            dy.copy_from_slice(&l.dy);
            true
        } else {
            false
        }
    }

    /// Forget the last evaluation (a discrete state or a block changed).
    pub(crate) fn forget_last_evaluation(&mut self) {
        self.last.valid = false;
    }

    fn eval_uncached(
        &mut self,
        t: f64,
        y: &[f64],
        dy: Option<&mut [f64]>,
        g: Option<&mut [f64]>,
        last: &mut LastEvaluation,
    ) -> Result<(), ModelError> {
        self.evaluations += 1;
        self.root_evaluations += u64::from(g.is_some());
        let gas = self.gas.clone();
        let gas: &dyn GasModel = &*gas;
        let Model {
            circuit,
            slots,
            node_gas,
            node_inflow,
            node_mech,
            node_forces,
            modes,
            velocity_band,
            signals,
            junction_ports,
            junction_guess,
            junction_step,
            junction_slope,
            at_rest,
            n_states,
            ..
        } = self;
        let n_states = *n_states;

        signal_pass(circuit, slots, node_gas, node_mech, signals, *at_rest, gas, t, y)?;
        // 4. junction pressures
        for cluster in &circuit.junction_clusters {
            junction::solve_cluster(
                circuit,
                slots,
                node_gas,
                junction_ports,
                junction_guess,
                junction_step,
                junction_slope,
                cluster,
                gas,
                t,
                y,
            )?;
        }
        // 5. flows
        for f in node_inflow.iter_mut() {
            *f = PortFlow::default();
        }
        for (bi, slot) in slots.iter_mut().enumerate() {
            if !slot.has_flow {
                continue;
            }
            let ctx = Ctx { t, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
            circuit.instances[bi].block.flows(&ctx, &mut slot.flows);
            for (k, &node) in slot.pneu_nodes.iter().enumerate() {
                if !slot.pneu_is_effort[k] {
                    node_inflow[node] += -slot.flows[k];
                }
            }
        }
        for slot in slots.iter_mut() {
            for (k, &node) in slot.pneu_nodes.iter().enumerate() {
                slot.bal_flow[k] = if slot.pneu_is_effort[k] { node_inflow[node] } else { slot.flows[k] };
            }
        }
        // 6. forces and node motion
        for f in node_forces.iter_mut() {
            *f = NodeForces::default();
        }
        for (bi, slot) in slots.iter_mut().enumerate() {
            if slot.mech_nodes.is_empty() {
                continue;
            }
            let ctx = Ctx { t, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
            circuit.instances[bi].block.forces(&ctx, &mut slot.forces);
            for (k, &node) in slot.mech_nodes.iter().enumerate() {
                let f = slot.forces[k];
                node_forces[node].applied += f.applied;
                if let Some(dry) = f.friction {
                    node_forces[node].sliding += dry.sliding;
                    node_forces[node].breakaway += dry.breakaway;
                    node_forces[node].viscous += dry.viscous;
                }
            }
        }
        for (node, mn) in circuit.mechanical_nodes.iter().enumerate() {
            let r = mn.inertia;
            let mass = node_mass(circuit, node);
            let accel = mechanics::acceleration(modes[node], &node_forces[node], node_mech[node].v, mass);
            if !accel.is_finite() {
                return Err(ModelError::NonFinite { t, what: format!("acceleration of {}", circuit.instances[r.block].id) });
            }
            let k = mech_index(circuit, r);
            slots[r.block].motion[k] = Motion { accel };
        }
        // 7. derivatives, quadratures
        if let Some(dy) = dy {
            let nq = dy.len() - N_QUADRATURE;
            let mut quad = [0.0; N_QUADRATURE];
            let (dstates, dquad) = dy.split_at_mut(n_states);
            for (bi, slot) in slots.iter().enumerate() {
                let block = &circuit.instances[bi].block;
                let ctx = Ctx { t, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
                let bal = Balances { pneumatic: &slot.bal_flow, mechanical: &slot.motion };
                if !slot.states.is_empty() {
                    block.derivatives(&ctx, &bal, &mut dstates[slot.states.clone()]);
                }
                if !slot.quad.is_empty() {
                    let out = &mut dquad[slot.quad.start - n_states..slot.quad.end - n_states];
                    block.quadrature_rates(&ctx, &bal, &dstates[slot.states.clone()], out);
                }
                match slot.role {
                    GasRole::Capacity => {
                        let ex = block.exchange(&ctx, &bal);
                        quad[2] += ex.heat;
                        quad[3] += ex.work;
                    }
                    // what a boundary passes into the circuit crosses its boundary
                    GasRole::Boundary => {
                        for f in &slot.bal_flow {
                            quad[0] -= f.mdot;
                            quad[1] -= f.edot;
                        }
                    }
                    GasRole::Restriction | GasRole::None => {}
                }
            }
            dy[nq..].copy_from_slice(&quad);
            for (i, d) in dy.iter().enumerate() {
                if !d.is_finite() {
                    return Err(ModelError::NonFinite { t, what: format!("derivative of state {}", self_state_name(circuit, slots, i)) });
                }
            }
            if !*at_rest {
                last.valid = true;
                last.t = t;
                last.y.clear();
                last.y.extend_from_slice(y);
                last.dy.clear();
                last.dy.extend_from_slice(dy);
            }
        }
        // 8. root functions
        if let Some(g) = g {
            for (bi, slot) in slots.iter().enumerate() {
                if slot.events.is_empty() {
                    continue;
                }
                let ctx = Ctx { t, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
                circuit.instances[bi].block.event_functions(&ctx, &mut g[slot.events.clone()]);
            }
            let base = slots.last().map(|s| s.events.end).unwrap_or(0);
            for (node, mn) in circuit.mechanical_nodes.iter().enumerate() {
                let block = &circuit.instances[mn.inertia.block].block;
                let body = mechanics::Body { mass: node_mass(circuit, node), stops: block.stops(), velocity_band: *velocity_band };
                let m = node_mech[node];
                let out = &mut g[base + node * mechanics::N_ROOTS..base + (node + 1) * mechanics::N_ROOTS];
                mechanics::roots(modes[node], m.x, m.v, &node_forces[node], &body, out);
            }
        }
        Ok(())
    }

    /// Context of block `bi` from the buffers of the last evaluation.
    pub fn ctx<'a>(&'a self, bi: usize, t: f64, y: &'a [f64]) -> Ctx<'a> {
        let slot = &self.slots[bi];
        Ctx { t, gas: &*self.gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig }
    }

    /// Balances of block `bi` from the last evaluation.
    pub fn balances(&self, bi: usize) -> Balances<'_> {
        let slot = &self.slots[bi];
        Balances { pneumatic: &slot.bal_flow, mechanical: &slot.motion }
    }

    /// Names of all recorded columns ("id.signal"), in order.
    pub fn output_names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(self.n_outputs);
        for inst in &self.circuit.instances {
            for p in inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalOut) {
                names.push(format!("{}.{}", inst.id, p.name));
            }
            for o in inst.block.outputs() {
                names.push(format!("{}.{}", inst.id, o.name));
            }
        }
        names
    }

    /// Units of the recorded columns, aligned with [`Model::output_names`].
    pub fn output_units(&self) -> Vec<String> {
        let mut units = Vec::with_capacity(self.n_outputs);
        for inst in &self.circuit.instances {
            for p in inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalOut) {
                units.push(p.unit.to_string());
            }
            for o in inst.block.outputs() {
                units.push(o.unit.to_string());
            }
        }
        units
    }

    /// Recorded outputs at (t, y): evaluates the model, then asks every block.
    ///
    /// Recording leaves no trace in the run: the junction warm starts and the
    /// evaluation counter are restored, so a run gives the same numbers
    /// whether or not (and how densely) it is sampled.
    pub fn record(&mut self, t: f64, y: &[f64], row: &mut [Option<f64>]) -> Result<(), ModelError> {
        // scratch buffers kept in the model: recording runs at every step
        let (mut dy, mut warm) = std::mem::take(&mut self.record_scratch);
        dy.clear();
        dy.resize(self.dim(), 0.0);
        // the integrator has usually just evaluated f here (its step's end)
        let evaluated = if self.last_evaluation_at(t, y, &mut dy) {
            Ok(())
        } else {
            self.save_warm_start_into(&mut warm);
            let evaluations = self.evaluations;
            let evaluated = self.eval(t, y, Some(&mut dy), None);
            self.restore_warm_start_from(&warm);
            self.evaluations = evaluations;
            evaluated
        };
        let result = evaluated.and_then(|()| self.record_outputs(t, y, &dy, row));
        self.record_scratch = (dy, warm);
        result
    }

    /// The signal outputs `wanted` — (row column, signal index) pairs from
    /// [`Model::signal_columns`] — at (t, y) into `row`; every other column
    /// stays `None`. Only phases 1–3 of an evaluation run (kinematics,
    /// efforts, signals): no junction solve, no flows, the cost of a fit's
    /// 1 ms output grid (docs/performance.md). The values are those
    /// [`Model::record`] gives, and the run goes on with the same numbers:
    /// a later evaluation reads nothing phases 4–7 would have left behind —
    /// unless a block that computes efforts or signals sits on a junction
    /// node (it reads the junction's last pressure) or a junction cluster
    /// has several nodes (their sweep starts from the last pressures); such
    /// a model records in full.
    pub fn record_signals(&mut self, t: f64, y: &[f64], wanted: &[(usize, usize)], row: &mut [Option<f64>]) -> Result<(), ModelError> {
        if !self.signals_alone {
            return self.record(t, y, row);
        }
        let l = &self.last;
        if !(l.valid && l.t == t && l.y == y) {
            self.last.valid = false;
            let gas = self.gas.clone();
            let Model { circuit, slots, node_gas, node_mech, signals, at_rest, .. } = self;
            signal_pass(circuit, slots, node_gas, node_mech, signals, *at_rest, &*gas, t, y)?;
        }
        for &(column, signal) in wanted {
            row[column] = Some(self.signals[signal]).filter(|v| v.is_finite());
        }
        Ok(())
    }

    /// (row column, signal index) of each output column that is a block's
    /// signal output, by column name.
    pub fn signal_columns(&self) -> Vec<(String, usize, usize)> {
        let mut out = Vec::new();
        for (slot, inst) in self.slots.iter().zip(&self.circuit.instances) {
            let names = inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalOut);
            for ((k, p), signal) in names.enumerate().zip(slot.sig_out.clone()) {
                out.push((format!("{}.{}", inst.id, p.name), slot.outputs.start + k, signal));
            }
        }
        out
    }

    /// The recording half of [`Model::record`], after the evaluation.
    fn record_outputs(&self, t: f64, y: &[f64], dy: &[f64], row: &mut [Option<f64>]) -> Result<(), ModelError> {
        for (bi, slot) in self.slots.iter().enumerate() {
            let block = &self.circuit.instances[bi].block;
            let n_sig = slot.sig_out.len();
            let out = &mut row[slot.outputs.clone()];
            for (k, s) in slot.sig_out.clone().enumerate() {
                out[k] = Some(self.signals[s]);
            }
            let ctx = self.ctx(bi, t, y);
            let bal = self.balances(bi);
            block.record(&ctx, &bal, &dy[slot.states.clone()], &mut out[n_sig..]);
        }
        for v in row.iter_mut() {
            if matches!(v, Some(x) if !x.is_finite()) {
                *v = None;
            }
        }
        Ok(())
    }

    /// Gas mass and internal energy stored in all capacities (after an eval at y).
    pub fn stored(&self, t: f64, y: &[f64]) -> Stored {
        let mut total = Stored::default();
        for bi in 0..self.slots.len() {
            if let Some(s) = self.circuit.instances[bi].block.stored(&self.ctx(bi, t, y)) {
                total.mass += s.mass;
                total.energy += s.energy;
            }
        }
        total
    }
}

impl Model {
    /// "component.state" of state `i` (for messages).
    pub fn state_name(&self, i: usize) -> String {
        self_state_name(&self.circuit, &self.slots, i)
    }
}

/// Whether a model may record its signals after phases 1–3 alone
/// ([`Model::record_signals`]): every junction cluster is one node, and no
/// block that computes efforts or signals has a port on a junction node.
fn signals_stand_alone(circuit: &Circuit, slots: &[Slot]) -> bool {
    let junction = |node: usize| circuit.pneumatic_nodes.get(node).is_some_and(|n| n.causality == NodeCausality::Junction);
    circuit.junction_clusters.iter().all(|c| c.len() == 1)
        && slots.iter().filter(|s| s.has_effort || !s.sig_out.is_empty()).all(|s| !s.pneu_nodes.iter().any(|&n| junction(n)))
}

/// Phases 1–3 of an evaluation — kinematics, efforts, signals — which need
/// no junction pressure and no flow (see the module header).
#[allow(clippy::too_many_arguments)]
fn signal_pass(
    circuit: &Circuit,
    slots: &mut [Slot],
    node_gas: &mut [GasState],
    node_mech: &mut [MechState],
    signals: &mut [f64],
    at_rest: bool,
    gas: &dyn GasModel,
    t: f64,
    y: &[f64],
) -> Result<(), ModelError> {
    // 1. kinematics of inertias
    for (node, mn) in circuit.mechanical_nodes.iter().enumerate() {
        let r = mn.inertia;
        let slot = &mut slots[r.block];
        circuit.instances[r.block].block.kinematics(&y[slot.states.clone()], &mut slot.mech);
        node_mech[node] = slot.mech[mech_index(circuit, r)];
    }
    for slot in slots.iter_mut() {
        for (k, &node) in slot.mech_nodes.iter().enumerate() {
            slot.mech[k] = node_mech[node];
        }
    }
    // 2. efforts
    for (bi, slot) in slots.iter_mut().enumerate() {
        if !slot.has_effort {
            continue;
        }
        let ctx = Ctx { t, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
        circuit.instances[bi].block.effort(&ctx, &mut slot.gas_out);
        for (k, &node) in slot.pneu_nodes.iter().enumerate() {
            if slot.pneu_is_effort[k] {
                let s = slot.gas_out[k];
                if !(s.p.is_finite() && s.t.is_finite() && s.p > 0.0 && s.t > 0.0 && s.rho > 0.0) {
                    return Err(ModelError::NonPhysical { t, id: circuit.instances[bi].id.clone(), p: s.p, temp: s.t });
                }
                node_gas[node] = s;
            }
        }
    }
    gather_gas(slots, node_gas);
    // 3. signals (at rest: every block in its idle state, repeated until
    // values settle, since a delayed signal then passes its input through)
    let passes = if at_rest { 1 + circuit.signal_order.len() } else { 1 };
    for _ in 0..passes {
        let mut changed = false;
        for &bi in &circuit.signal_order {
            let slot = &mut slots[bi];
            for (k, &s) in slot.sig_in.iter().enumerate() {
                slot.sig[k] = signals[s];
            }
            let ctx = Ctx { t, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
            let block = &circuit.instances[bi].block;
            if at_rest {
                block.rest_signal_outputs(&ctx, &mut slot.sig_buf);
            } else {
                block.signal_outputs(&ctx, &mut slot.sig_buf);
            }
            let out = &mut signals[slot.sig_out.clone()];
            changed |= out != slot.sig_buf.as_slice();
            out.copy_from_slice(&slot.sig_buf);
        }
        if !changed {
            break;
        }
    }
    for slot in slots.iter_mut() {
        for (k, &s) in slot.sig_in.iter().enumerate() {
            slot.sig[k] = signals[s];
        }
    }
    Ok(())
}

fn self_state_name(circuit: &Circuit, slots: &[Slot], i: usize) -> String {
    for (bi, slot) in slots.iter().enumerate() {
        if slot.states.contains(&i) {
            let inst = &circuit.instances[bi];
            return format!("{}.{}", inst.id, inst.block.states()[i - slot.states.start].name);
        }
    }
    format!("balance quadrature {}", i)
}

/// Moving mass [kg] of mechanical node `node`: its inertia's mass plus the
/// mass the other blocks on the node carry ([`Block::carried_mass`]).
pub fn node_mass(c: &Circuit, node: usize) -> f64 {
    let mn = &c.mechanical_nodes[node];
    let mut mass = c.instances[mn.inertia.block].block.inertia();
    // each block counted once, without allocating (this runs in every evaluation)
    for (k, r) in mn.ports.iter().enumerate() {
        let seen = r.block == mn.inertia.block || mn.ports[..k].iter().any(|q| q.block == r.block);
        if !seen {
            mass += c.instances[r.block].block.carried_mass();
        }
    }
    mass
}

/// Copy node gas states into every block's pneumatic buffer.
pub(crate) fn gather_gas(slots: &mut [Slot], node_gas: &[GasState]) {
    for slot in slots.iter_mut() {
        for (k, &node) in slot.pneu_nodes.iter().enumerate() {
            slot.gas[k] = node_gas[node];
        }
    }
}

/// Index of a port among its block's pneumatic ports.
pub(crate) fn pneumatic_index(c: &Circuit, r: PortRef) -> usize {
    c.instances[r.block].block.ports()[..r.port].iter().filter(|p| p.kind.domain() == Domain::Pneumatic).count()
}

/// Index of a port among its block's mechanical ports.
pub(crate) fn mech_index(c: &Circuit, r: PortRef) -> usize {
    c.instances[r.block].block.ports()[..r.port].iter().filter(|p| p.kind.domain() == Domain::Mechanical).count()
}
