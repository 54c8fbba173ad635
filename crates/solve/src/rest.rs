//! The state a circuit rests in before t = 0 (`"simulation": {"initial": "rest"}`).
//!
//! A test rig is switched on, left alone with its controllers released, and
//! only then commanded. Its initial state is therefore not a free choice: a
//! chamber open to the supply through the released valves sits at the supply
//! pressure, a chamber open to the exhaust at atmospheric pressure, and the
//! piston rests against the stop its net force pushes it to. This module
//! finds that state from the block contract alone (no block type is named):
//!
//! 1. **Released controllers.** Signals are evaluated with
//!    [`blocks::Block::rest_signal_outputs`] (a cycler commands 0, a schedule
//!    holds its initial value, a delay passes its input through), and every
//!    block with two or more pneumatic flow ports is probed in that state:
//!    with 10 bar on one port and 1 bar on all others, gas passing from port
//!    a out of port b means the block lets gas go from a's node to b's node.
//!    This gives a directed graph on the pneumatic nodes (a check valve
//!    appears as a one-way edge).
//! 2. **Pressures.** The sources of the circuit are the effort ports of blocks
//!    without states (pressure sources, atmospheres); the capacities are
//!    effort ports with states (chambers). Following the edges (never through
//!    another source), a capacity whose free pressure
//!    - exchanges gas both ways with sources of one pressure p_s takes p_s;
//!    - can only receive gas from them takes p_s if it was below (otherwise it
//!      keeps its value); can only lose gas to them takes p_s if it was above;
//!    - reaches no source keeps its given (or default) value: a closed volume;
//!    - reaches sources at different pressures takes the level it reaches
//!      through the widest path (the path whose narrowest block passes the
//!      most gas in the probe) when every path to another level is at least
//!      [`DOMINANCE`] (100) times narrower: a piston seal leak does not move
//!      the rod chamber off the supply pressure. This neglects the pressure
//!      drop the leak flow causes on the main path (60 Pa in the rod chamber
//!      of the meter-out circuit with a 0.3 L/(min·bar) seal leak, where the
//!      check valve's opening range makes the main path soft);
//!    - otherwise (a bleed, a divider of comparable restrictions) rests in a
//!      flow equilibrium: the circuit is integrated at rest (controllers
//!      released, pistons held) until its pressures no longer change, and
//!      those chambers take the settled pressure and temperature. If nothing
//!      settles within 10⁵ s, that is an error naming the chamber.
//!
//!    A capacity that takes a source's pressure also takes its temperature
//!    (if its `T0` is free). Values written explicitly (`p0`, `T0`) are kept.
//! 3. **Pistons.** With those pressures, the net applied force on each free
//!    inertia decides where it rests: within the breakaway level it stays at
//!    its (default) position; beyond it, it rests on the stop the force points
//!    to. If, after moving it there, the force no longer holds it against
//!    that stop (a closed chamber acting as a gas spring), the rest position
//!    lies between the stops and is not computed: an error asks for `x0`.
//!
//! A block that holds a port at a pressure at rest
//! ([`blocks::Block::rest_pressure`], a regulator's outlet at its set
//! pressure) is not probed: its port's node is fed from a source at that
//! pressure instead (both ways if it relieves), and its other ports are not
//! joined to it.
//!
//! Limits: the graph rule is exact for chambers open to one pressure level
//! (every shipped model); flow equilibria are found to the integrator's
//! tolerance (1e-10). A force equilibrium between the stops (a gas spring, a
//! spring) is reported as an error rather than guessed.
//! A closed-centre valve leaves both chambers closed: they keep their given
//! values.

use crate::model::{Model, ModelError};
use blocks::block::{Ctx, GasRole, PortFlow};
use gas::GasState;
use graph::NodeCausality;
use units::show::fixed;

/// Probe pressures [Pa] used to find the open paths of a block.
const PROBE_HIGH: f64 = 10e5;
const PROBE_LOW: f64 = 1e5;
const PROBE_T: f64 = 293.15;

/// One initial value the rest state chose.
#[derive(Debug, Clone, PartialEq)]
pub struct RestValue {
    /// Component id.
    pub id: String,
    /// Parameter it stands for ("p0", "T0", "x0").
    pub param: &'static str,
    /// SI value.
    pub value: f64,
    /// Why: "open to supply", "closed volume", "pushed to the lower stop".
    pub reason: String,
}

/// What the rest-state computation decided.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RestReport {
    pub values: Vec<RestValue>,
}

/// Why no rest state could be named.
#[derive(Debug, thiserror::Error)]
pub enum RestError {
    #[error("rest state of \"{id}\": {message}")]
    Undetermined { id: String, message: String },
    #[error("rest state: {0}")]
    Model(#[from] ModelError),
}

/// Compute the rest state and write it into the blocks' free initial values.
/// Idempotent: values the user gave are never changed, free ones are
/// recomputed the same way.
pub fn apply(model: &mut Model) -> Result<RestReport, RestError> {
    model.at_rest = true;
    let result = compute(model);
    model.at_rest = false;
    result
}

fn compute(model: &mut Model) -> Result<RestReport, RestError> {
    let mut report = RestReport::default();
    let y = model.initial_state();
    model.eval(0.0, &y, None, None)?;
    let (edges, held) = open_paths(model, &y);
    set_pressures(model, &edges, &held, &mut report)?;
    set_positions(model, &mut report)?;
    Ok(report)
}

/// A node a block holds at a pressure at rest ([`blocks::Block::rest_pressure`]).
struct Held {
    block: usize,
    node: usize,
    state: GasState,
    relieving: bool,
}

/// Directed edges between pneumatic nodes, with the probe flow [kg/s] as
/// their width: gas can pass from `a` to `b` at rest; and the nodes blocks
/// hold at a pressure (a regulator's outlet), which act as sources.
fn open_paths(model: &Model, y: &[f64]) -> (Vec<Vec<(usize, f64)>>, Vec<Held>) {
    let mut held = Vec::new();
    let gas = &*model.gas;
    let state = |p: f64| GasState { p, t: PROBE_T, rho: gas.density(p, PROBE_T), h: gas.enthalpy(gas.density(p, PROBE_T), PROBE_T) };
    let (high, low) = (state(PROBE_HIGH), state(PROBE_LOW));
    let mut edges: Vec<Vec<(usize, f64)>> = vec![Vec::new(); model.circuit.pneumatic_nodes.len()];
    let add = |edges: &mut Vec<Vec<(usize, f64)>>, na: usize, nb: usize, passed: f64| match edges[na].iter_mut().find(|(m, _)| *m == nb) {
        Some((_, w)) => *w = w.max(passed),
        None => edges[na].push((nb, passed)),
    };
    for (bi, slot) in model.slots.iter().enumerate() {
        let flow_ports: Vec<usize> = (0..slot.pneu_nodes.len()).filter(|&k| !slot.pneu_is_effort[k]).collect();
        if flow_ports.len() < 2 {
            continue;
        }
        let block = &model.circuit.instances[bi].block;
        let ctx = Ctx { t: 0.0, gas, states: &y[slot.states.clone()], pneumatic: &slot.gas, mechanical: &slot.mech, signals: &slot.sig };
        if let Some(r) = block.rest_pressure(&ctx) {
            if let (Some(&node), Some(from)) = (slot.pneu_nodes.get(r.port), slot.gas.get(r.from)) {
                held.push(Held {
                    block: bi,
                    node,
                    state: GasState { p: r.pressure, ..gas.state_pt(r.pressure, from.t) },
                    relieving: r.relieving,
                });
            }
            continue;
        }
        if slot.role == GasRole::Capacity {
            // a capacity between flow ports (a tube) is an open passage both ways;
            // its probe flows would only tell its own initial content
            for &a in &flow_ports {
                for &b in &flow_ports {
                    let (na, nb) = (slot.pneu_nodes[a], slot.pneu_nodes[b]);
                    if na != nb {
                        add(&mut edges, na, nb, f64::INFINITY);
                    }
                }
            }
            continue;
        }
        let mut probe = vec![low; slot.pneu_nodes.len()];
        let mut out = vec![PortFlow::default(); slot.pneu_nodes.len()];
        for &a in &flow_ports {
            probe.fill(low);
            probe[a] = high;
            out.fill(PortFlow::default());
            let ctx = Ctx { t: 0.0, gas, states: &y[slot.states.clone()], pneumatic: &probe, mechanical: &slot.mech, signals: &slot.sig };
            block.flows(&ctx, &mut out);
            let inflow = out[a].mdot;
            if !(inflow.is_finite() && inflow > 0.0) {
                continue;
            }
            for &b in &flow_ports {
                let passed = -out[b].mdot;
                if b != a && passed > 1e-9 * inflow {
                    let (na, nb) = (slot.pneu_nodes[a], slot.pneu_nodes[b]);
                    if na == nb {
                        continue;
                    }
                    add(&mut edges, na, nb, passed);
                }
            }
        }
    }
    (edges, held)
}

/// Role of a pneumatic node at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// Fixed pressure and temperature (an effort port of a block without states).
    Source { block: usize },
    /// A capacity (effort port of a block with states).
    Capacity { block: usize },
    /// An algebraic junction or anything else gas passes through.
    Passage,
}

fn roles(model: &Model) -> Vec<Role> {
    model
        .circuit
        .pneumatic_nodes
        .iter()
        .map(|n| match n.causality {
            NodeCausality::Effort(r) => match model.circuit.instances[r.block].block.gas_role() {
                GasRole::Boundary => Role::Source { block: r.block },
                GasRole::Capacity => Role::Capacity { block: r.block },
                GasRole::Restriction | GasRole::None => Role::Passage,
            },
            NodeCausality::Junction => Role::Passage,
        })
        .collect()
}

/// Width of the widest path (the largest bottleneck flow) from `start` to
/// every node along `edges`, not passing through sources; 0 if unreachable.
fn widest(start: usize, edges: &[Vec<(usize, f64)>], roles: &[Role]) -> Vec<f64> {
    #[derive(PartialEq)]
    struct Item(f64, usize);
    impl Eq for Item {}
    impl PartialOrd for Item {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Item {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            self.0.total_cmp(&o.0)
        }
    }
    let mut width = vec![0.0; edges.len()];
    width[start] = f64::INFINITY;
    let mut heap = std::collections::BinaryHeap::from([Item(f64::INFINITY, start)]);
    while let Some(Item(w, n)) = heap.pop() {
        if w < width[n] || (n != start && matches!(roles[n], Role::Source { .. })) {
            continue;
        }
        for &(m, e) in &edges[n] {
            let through = w.min(e);
            if through > width[m] {
                width[m] = through;
                heap.push(Item(through, m));
            }
        }
    }
    width
}

fn reversed(edges: &[Vec<(usize, f64)>]) -> Vec<Vec<(usize, f64)>> {
    let mut rev = vec![Vec::new(); edges.len()];
    for (a, targets) in edges.iter().enumerate() {
        for &(b, w) in targets {
            rev[b].push((a, w));
        }
    }
    rev
}

/// A path this many times narrower than the widest one to another pressure
/// level (a seal leak, a bleed) does not decide the rest pressure.
pub const DOMINANCE: f64 = 100.0;

/// The pressure level a node rests at, from the sources linked to it.
struct Level {
    /// State of the source(s) reached through the widest path.
    best: GasState,
    /// Mean temperature of the sources at that pressure.
    t: f64,
    /// Every path to another pressure level is at least [`DOMINANCE`] times narrower.
    dominant: bool,
    /// Gas can flow from that level to the node / from the node to it.
    fills: bool,
    drains: bool,
    /// "open to supply", for the report.
    reason: String,
}

fn set_pressures(model: &mut Model, edges: &[Vec<(usize, f64)>], held: &[Held], report: &mut RestReport) -> Result<(), RestError> {
    // a held node is fed by a virtual source behind it (both ways if it relieves)
    let mut roles = roles(model);
    let mut edges = edges.to_vec();
    let mut node_gas = model.node_gas.clone();
    for h in held {
        let v = edges.len();
        edges.push(vec![(h.node, f64::INFINITY)]);
        if h.relieving {
            edges[h.node].push((v, f64::INFINITY));
        }
        roles.push(Role::Source { block: h.block });
        node_gas.push(h.state);
    }
    let edges = edges.as_slice();
    let back = reversed(edges);
    let sources: Vec<(usize, usize)> =
        roles.iter().enumerate().filter_map(|(n, r)| if let Role::Source { block } = r { Some((n, *block)) } else { None }).collect();
    // fill[s][n]: widest path for gas from source s to n; drain[s][n]: from n to s
    let fill: Vec<Vec<f64>> = sources.iter().map(|&(n, _)| widest(n, edges, &roles)).collect();
    let drain: Vec<Vec<f64>> = sources.iter().map(|&(n, _)| widest(n, &back, &roles)).collect();
    let name = |b: usize| model.circuit.instances[b].id.clone();
    // the level of a node; None if it reaches no source (a closed volume)
    let level_at = |node: usize| -> Option<Level> {
        // (source block, its state, fill width, drain width) of every source linked to this node
        let linked: Vec<(usize, GasState, f64, f64)> = sources
            .iter()
            .enumerate()
            .filter(|&(k, _)| fill[k][node] > 0.0 || drain[k][node] > 0.0)
            .map(|(k, &(snode, sblock))| (sblock, node_gas[snode], fill[k][node], drain[k][node]))
            .collect();
        if linked.is_empty() {
            return None;
        }
        // the pressure level reached through the widest path decides, unless another
        // level is reached through a path of comparable width (a flow divider)
        let width = |l: &(usize, GasState, f64, f64)| l.2.max(l.3);
        let best = linked.iter().max_by(|a, b| width(a).total_cmp(&width(b))).map(|l| l.1)?;
        let same_level = |s: &GasState| (s.p - best.p).abs() <= 1e-9 * best.p;
        let rival = linked.iter().filter(|l| !same_level(&l.1)).map(width).fold(0.0, f64::max);
        let level: Vec<&(usize, GasState, f64, f64)> = linked.iter().filter(|l| same_level(&l.1)).collect();
        let dominant = rival * DOMINANCE <= level.iter().map(|l| width(l)).fold(0.0, f64::max);
        let names: Vec<String> = level.iter().map(|l| name(l.0)).collect();
        let mut reason = format!("open to {}", names.join(" and "));
        if rival > 0.0 && dominant {
            let others: Vec<String> = linked.iter().filter(|l| !same_level(&l.1)).map(|l| name(l.0)).collect();
            reason.push_str(&format!(" (a path over {DOMINANCE} times narrower to {} is neglected)", others.join(", ")));
        }
        Some(Level {
            best,
            t: level.iter().map(|l| l.1.t).sum::<f64>() / level.len() as f64,
            dominant,
            fills: level.iter().any(|l| l.2 > 0.0),
            drains: level.iter().any(|l| l.3 > 0.0),
            reason,
        })
    };
    let mut dividers = Vec::new();
    // what each free capacity takes: (block, pressure or None to keep it, temperature, reason)
    let mut decided: Vec<(usize, Option<f64>, f64, String)> = Vec::new();
    for (node, role) in roles.iter().enumerate().take(model.circuit.pneumatic_nodes.len()) {
        let Role::Capacity { block } = *role else { continue };
        let free = model.circuit.instances[block].block.free_initial();
        if !free.pressure && !free.temperature {
            continue;
        }
        let given = node_gas[node];
        let Some(level) = level_at(node) else { continue }; // a closed volume keeps its given value
        if !free.pressure {
            // the pressure is given: only the temperature of the dominant level is taken
            if level.dominant {
                decided.push((block, None, level.t, level.reason));
            }
            continue;
        }
        if !level.dominant {
            // gas flows through it between two pressure levels: a flow equilibrium
            dividers.push(block);
            continue;
        }
        // both ways: always; one way: only towards the source's level
        let takes_source = match (level.fills, level.drains) {
            (true, true) => true,
            (true, false) => given.p < level.best.p,
            (false, true) => given.p > level.best.p,
            (false, false) => false,
        };
        if takes_source {
            decided.push((block, Some(level.best.p), if free.temperature { level.t } else { given.t }, level.reason));
        }
    }
    // capacities between flow ports (a tube): open both ways, they rest at the
    // level of the nodes at their ends, or in a flow equilibrium between them
    for (bi, slot) in model.slots.iter().enumerate() {
        if slot.role != GasRole::Capacity || slot.pneu_nodes.is_empty() || slot.pneu_is_effort.iter().any(|&e| e) {
            continue;
        }
        let free = model.circuit.instances[bi].block.free_initial();
        if !free.pressure && !free.temperature {
            continue;
        }
        let levels: Vec<Level> = slot.pneu_nodes.iter().filter_map(|&n| level_at(n)).collect();
        let Some(first) = levels.first() else { continue };
        let same = levels.iter().all(|l| l.dominant && (l.best.p - first.best.p).abs() <= 1e-9 * first.best.p);
        if same {
            decided.push((bi, free.pressure.then_some(first.best.p), first.t, first.reason.clone()));
        } else if free.pressure {
            dividers.push(bi);
        }
    }
    for (block, p, t, reason) in decided {
        let id = model.circuit.instances[block].id.clone();
        let free = model.circuit.instances[block].block.free_initial();
        let given = model.circuit.instances[block].block.initial_gas().unwrap_or((p.unwrap_or(0.0), t));
        let t = if free.temperature { t } else { given.1 };
        model.circuit.instances[block].block.set_initial_gas(p.unwrap_or(given.0), t);
        if let Some(p) = p {
            report.values.push(RestValue { id: id.clone(), param: "p0", value: p, reason: reason.clone() });
        }
        if free.temperature {
            report.values.push(RestValue { id, param: "T0", value: t, reason });
        }
    }
    if !dividers.is_empty() {
        steady_flow(model, &dividers, report)?;
    }
    Ok(())
}

/// The model at rest seen by the integrator (pistons held: v = 0, ẍ = 0).
struct AtRest<'a> {
    model: &'a mut Model,
}

impl ode::OdeSystem for AtRest<'_> {
    fn dim(&self) -> usize {
        self.model.dim()
    }
    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) -> Result<(), ode::RhsError> {
        match self.model.eval(t, y, Some(dydt), None) {
            Ok(()) => Ok(()),
            Err(ModelError::NonPhysical { .. }) => {
                dydt.fill(f64::NAN); // reject the step, retry smaller
                Ok(())
            }
            Err(e) => Err(ode::RhsError(e.to_string())),
        }
    }
    fn n_quadrature(&self) -> usize {
        self.model.n_quadratures()
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Longest time [s] the gas is given to settle into a flow equilibrium.
const SETTLE_LIMIT: f64 = 1e5;

/// Chambers through which gas flows between two pressure levels at rest
/// take the pressure and temperature of the flow equilibrium, found by
/// integrating the circuit at rest (controllers released, pistons held)
/// until no pressure changes any more.
fn steady_flow(model: &mut Model, dividers: &[usize], report: &mut RestReport) -> Result<(), RestError> {
    use ode::Integrator;
    let mut y = model.initial_state();
    let scales = model.state_scales(&y);
    let n = model.dim();
    let mut atol: Vec<f64> = scales.iter().map(|s| 1e-10 * s).collect();
    for a in atol[n - model.n_quadratures()..].iter_mut() {
        *a = 1e30;
    }
    let opts = ode::Options {
        rtol: 1e-10,
        atol,
        h_init: None,
        h_max: f64::INFINITY,
        h_min: 0.0,
        max_steps: 200_000,
        root_tol: 1e-10,
        ..ode::Options::default()
    };
    let mut integrator = ode::Rosenbrock::new(opts, n);
    // the node each divider imposes its pressure on, or the nodes at the ends of a tube
    let nodes: Vec<Vec<usize>> = dividers
        .iter()
        .map(|&b| {
            let effort =
                model.circuit.pneumatic_nodes.iter().position(|pn| matches!(pn.causality, NodeCausality::Effort(r) if r.block == b));
            match effort {
                Some(k) => vec![k],
                None => model.slots[b].pneu_nodes.clone(),
            }
        })
        .collect();
    let pressures = |model: &Model| nodes.iter().flatten().map(|&k| model.node_gas[k].p).collect::<Vec<f64>>();
    let mut t = 0.0;
    let mut last = pressures(model);
    let mut t_stop = 1e-3;
    let mut converged = false;
    while t_stop <= SETTLE_LIMIT {
        let mut sys = AtRest { model };
        integrator
            .advance(&mut sys, &mut t, &mut y, t_stop, &mut |_| {})
            .map_err(|e| RestError::Undetermined { id: sys.model.circuit.instances[dividers[0]].id.clone(), message: e.to_string() })?;
        model.eval(t, &y, None, None)?;
        let now = pressures(model);
        // unchanged to ten times the integrator's relative tolerance over a decade of time
        let settled = now.iter().zip(&last).all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs());
        last = now;
        if settled && t_stop >= 1.0 {
            converged = true;
            break;
        }
        t_stop *= 10.0;
    }
    if !converged {
        return Err(RestError::Undetermined {
            id: model.circuit.instances[dividers[0]].id.clone(),
            message: format!("gas flowing through it between two pressure levels did not settle within {SETTLE_LIMIT} s; give its p0"),
        });
    }
    for (&b, ks) in dividers.iter().zip(&nodes) {
        // one node: its state; the ends of a tube: their mean (the tube starts uniform)
        let n = ks.len().max(1) as f64;
        let gas = GasState {
            p: ks.iter().map(|&k| model.node_gas[k].p).sum::<f64>() / n,
            t: ks.iter().map(|&k| model.node_gas[k].t).sum::<f64>() / n,
            ..model.node_gas[ks[0]]
        };
        let free = model.circuit.instances[b].block.free_initial();
        let id = model.circuit.instances[b].id.clone();
        let reason = format!("flow equilibrium between sources (settled after {t:.3e} s)");
        model.circuit.instances[b].block.set_initial_gas(gas.p, gas.t);
        if free.pressure {
            report.values.push(RestValue { id: id.clone(), param: "p0", value: gas.p, reason: reason.clone() });
        }
        if free.temperature {
            report.values.push(RestValue { id, param: "T0", value: gas.t, reason });
        }
    }
    Ok(())
}

fn set_positions(model: &mut Model, report: &mut RestReport) -> Result<(), RestError> {
    // The forces on a node at rest depend on that node's position only (its
    // chambers are filled to their rest pressures at that position), so every
    // free inertia is decided from one evaluation and checked with a second:
    // two evaluations of the model, not two per node.
    let free: Vec<usize> = (0..model.circuit.mechanical_nodes.len())
        .filter(|&node| model.circuit.instances[model.circuit.mechanical_nodes[node].inertia.block].block.free_initial().position)
        .collect();
    if free.is_empty() {
        return Ok(());
    }
    let y = model.initial_state();
    model.eval(0.0, &y, None, None)?;
    // (node, force before, position before, the stop it goes to, which stop)
    let mut moved = Vec::new();
    for &node in &free {
        let block = model.circuit.mechanical_nodes[node].inertia.block;
        let f = model.node_forces[node];
        let x = model.node_mech[node].x;
        if f.applied.abs() <= f.breakaway {
            continue; // held where it is
        }
        let id = model.circuit.instances[block].id.clone();
        let Some(stops) = model.circuit.instances[block].block.stops() else {
            return Err(RestError::Undetermined {
                id,
                message: format!("a net force of {} N moves it and it has no end stop to rest on; give its x0", fixed(f.applied, 1)),
            });
        };
        let (at, which) = if f.applied > 0.0 { (stops.upper, "upper") } else { (stops.lower, "lower") };
        model.circuit.instances[block].block.set_initial_position(at);
        moved.push((node, f, x, at, which));
    }
    if moved.is_empty() {
        return Ok(());
    }
    let y = model.initial_state();
    model.eval(0.0, &y, None, None)?;
    for (node, f, x, at, which) in moved {
        let block = model.circuit.mechanical_nodes[node].inertia.block;
        let id = model.circuit.instances[block].id.clone();
        let g = model.node_forces[node];
        if g.applied.signum() != f.applied.signum() && g.applied.abs() > g.breakaway {
            model.circuit.instances[block].block.set_initial_position(x);
            return Err(RestError::Undetermined {
                id,
                message: format!(
                    "the net force changes sign between the stops ({} N at x = {} m, {} N at the {which} stop): it rests in between; give its x0",
                    fixed(f.applied, 1),
                    fixed(x, 4),
                    fixed(g.applied, 1)
                ),
            });
        }
        report.values.push(RestValue {
            id,
            param: "x0",
            value: at,
            reason: format!(
                "net force {} N beyond breakaway {} N pushes it to the {which} stop",
                fixed(f.applied, 1),
                fixed(f.breakaway, 1)
            ),
        });
    }
    Ok(())
}
