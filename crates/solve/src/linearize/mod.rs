//! Linear models of a circuit about an operating point:
//! δẋ = A δx + B δu, δy = C δx + D δu, with A = ∂f/∂x, B = ∂f/∂u,
//! C = ∂g/∂x, D = ∂g/∂u of the hybrid model ẋ = f(x, u), y = g(x, u) with
//! its discrete state held.
//!
//! - **Operating points** ([`point`]): a time of a simulation (the run's
//!   state and discrete state carried into the model driven from outside),
//!   the rest state, or a trim ([`trim`]): an equilibrium f(x*, u*) = 0
//!   meeting constraints the user states.
//! - **Inputs** are the netlist's interface inputs (the model built with
//!   [`graph::Drive::External`]: an input bound to a port replaces whatever
//!   drove it, so a loop through it is open); **outputs** the interface
//!   outputs, or every state.
//! - **Mechanical modes** are part of the discrete state. A node moving at
//!   v ≠ 0 slides in its direction: the linear model has the friction law's
//!   slope at that speed and the pressure dependence of its Coulomb level.
//!   About v = 0 the direction is undefined: "sliding" there means
//!   [`Mode::SlidingViscous`] — dry friction drops out, the viscous slope c
//!   stays (what `linearize` of Simulink Control Design gives for a
//!   `sign(v)` friction law, and what servo design uses); "stuck" holds the
//!   node (its position and velocity are then not states). A node on an end
//!   stop is held. [`set_modes`] decides and describes this per node.
//! - **States** of the linear model are the block states (the quadratures
//!   of balances and statistics are not), less those of held nodes, and —
//!   unless asked to keep all — less the states that reach no output through
//!   the circuit's structure (a controller left without its loop; like the
//!   block reduction of Simulink Control Design).
//!
//! The derivatives come through one seam, [`jacobians::jacobians`].

pub mod jacobians;
pub mod point;
pub mod trim;

use crate::jacobian::Structure;
use crate::mechanics::{self, Mode};
use crate::model::{Model, ModelError};
use graph::interface::OutputSource;
use linear::Matrix;

/// How mechanical nodes are linearised (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Friction {
    /// A simulation's own mode at a time point; sliding (viscous) elsewhere.
    #[default]
    Auto,
    /// Sliding: in the direction of motion, or about v = 0 with the viscous slope only.
    Sliding,
    /// Held where it is (only at v = 0).
    Stuck,
}

/// What the outputs of the linear model are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Outputs {
    /// The interface outputs, or every state when the netlist declares none.
    #[default]
    Interface,
    /// Every state of the linear model.
    States,
}

/// Settings of a linearisation.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    pub friction: Friction,
    pub outputs: Outputs,
    /// Keep states that reach no output.
    pub keep_all_states: bool,
}

/// A named variable with its SI unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Named {
    pub name: String,
    pub unit: String,
}

/// The mode a mechanical node has in the linear model, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeMode {
    /// Id of the node's moving mass ("cyl.piston").
    pub id: String,
    pub mode: Mode,
    /// One line: the mode and what it means for the linear model.
    pub description: String,
    /// States held constant (position and velocity of a held node).
    pub held_states: Vec<usize>,
}

/// Where a linear model is taken.
#[derive(Debug, Clone)]
pub struct OperatingPoint {
    pub t: f64,
    /// The whole state vector (block states and quadratures).
    pub y: Vec<f64>,
    /// "t = 1.2 s of a simulation", "rest", "trim".
    pub kind: PointKind,
    /// What a trim held and solved.
    pub trim: Option<trim::TrimReport>,
}

/// The kind of an operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PointKind {
    /// A time of a simulation; its mechanical modes come with it.
    Time,
    Rest,
    Trim,
}

/// A linear model about an operating point, SI throughout.
#[derive(Debug, Clone)]
pub struct LinearModel {
    pub a: Matrix,
    pub b: Matrix,
    pub c: Matrix,
    pub d: Matrix,
    pub states: Vec<Named>,
    pub inputs: Vec<Named>,
    pub outputs: Vec<Named>,
    /// The operating point: states, inputs, outputs, and f(x*, u*) (zero at an equilibrium).
    pub x0: Vec<f64>,
    pub u0: Vec<f64>,
    pub y0: Vec<f64>,
    pub dx0: Vec<f64>,
    pub t: f64,
    pub kind: PointKind,
    pub mechanics: Vec<NodeMode>,
    /// States of the model not in the linear model, with the reason.
    pub left_out: Vec<(String, String)>,
    /// Interface outputs not in the linear model, with the reason.
    pub skipped_outputs: Vec<(String, String)>,
    pub trim: Option<trim::TrimReport>,
    pub method: jacobians::Method,
    /// Blocks differentiated alone by differences (see [`jacobians::Jacobians`]).
    pub finite_difference_blocks: Vec<String>,
    /// Inputs whose columns of B and D are central differences of the whole
    /// model (no exact partials for the live parameter they set).
    pub difference_inputs: Vec<String>,
    /// Outputs whose rows of C and D are central differences of the whole
    /// model (see [`jacobians::Jacobians::difference_outputs`]).
    pub difference_outputs: Vec<String>,
    /// Outputs recorded by a block without partials for them, whose record
    /// was differentiated alone by central differences and chained exactly.
    pub record_difference_outputs: Vec<String>,
}

/// Why no linear model could be made.
#[derive(Debug, thiserror::Error)]
pub enum LinearizeError {
    #[error("{0}")]
    Model(#[from] ModelError),
    #[error("{0}")]
    Input(#[from] crate::interface::InputError),
    #[error("{0}")]
    Solve(Box<crate::simulate::SolveError>),
    #[error("{0}")]
    Rest(#[from] crate::rest::RestError),
    /// The operating point asked for does not exist or cannot be reached.
    #[error("{0}")]
    Point(String),
    /// A trim that is under- or over-determined, or has no solution.
    #[error("trim: {0}")]
    Trim(String),
    #[error("{0}")]
    Linear(#[from] linear::LinearError),
}

impl From<crate::simulate::SolveError> for LinearizeError {
    fn from(e: crate::simulate::SolveError) -> Self {
        LinearizeError::Solve(Box::new(e))
    }
}

/// Unit of block state `i`.
pub fn state_unit(model: &Model, i: usize) -> String {
    for (bi, slot) in model.slots.iter().enumerate() {
        if slot.states.contains(&i) {
            return model.circuit.instances[bi].block.states()[i - slot.states.start].unit.to_string();
        }
    }
    String::new()
}

/// Set the mode of every mechanical node for a linearisation at (t, y) and
/// say what it means. At a time point (`kind` [`PointKind::Time`]) with
/// [`Friction::Auto`] the simulation's modes (already in the model) stay.
pub fn set_modes(model: &mut Model, t: f64, y: &[f64], kind: PointKind, friction: Friction) -> Result<Vec<NodeMode>, LinearizeError> {
    model.eval_detached(t, y, None, None)?;
    let mut out = Vec::new();
    for node in 0..model.circuit.mechanical_nodes.len() {
        let r = model.circuit.mechanical_nodes[node].inertia;
        let inst = &model.circuit.instances[r.block];
        let id = inst.id.clone();
        let stops = inst.block.stops();
        let m = model.node_mech[node];
        let on_stop = m.v == 0.0 && stops.is_some_and(|s| m.x <= s.lower || m.x >= s.upper);
        let current = model.modes[node];
        let mode = match (friction, kind) {
            (Friction::Auto, PointKind::Time) => current,
            (Friction::Stuck, _) if m.v != 0.0 => {
                return Err(LinearizeError::Point(format!(
                    "{id} moves at v = {} m/s: it cannot be held stuck (choose sliding)",
                    units::show::num(m.v)
                )))
            }
            _ if m.v != 0.0 => Mode::Sliding { dir: m.v.signum() },
            _ if on_stop => mechanics::held_at(m.x, stops),
            (Friction::Stuck, _) => Mode::Held { may_extend: true, may_retract: true },
            (Friction::Auto | Friction::Sliding, _) => Mode::SlidingViscous,
        };
        model.modes[node] = mode;
        let held_states: Vec<usize> =
            if matches!(mode, Mode::Held { .. }) { model.slots[r.block].states.clone().collect() } else { Vec::new() };
        out.push(NodeMode { id, mode, description: String::new(), held_states });
    }
    // describe with the forces of the chosen modes
    model.eval_detached(t, y, None, None)?;
    for (node, nm) in out.iter_mut().enumerate() {
        let (m, f) = (model.node_mech[node], model.node_forces[node]);
        let x_mm = units::show::sig(m.x * 1e3, 6);
        nm.description = match nm.mode {
            Mode::Sliding { dir } => format!(
                "sliding {} at v = {} m/s: friction slope and Coulomb level (with its pressure dependence) at that speed",
                if dir > 0.0 { "extending" } else { "retracting" },
                units::show::sig(m.v, 6)
            ),
            Mode::SlidingViscous => format!(
                "sliding about v = 0 at x = {x_mm} mm: viscous friction c = {} N s/m only; the dry friction (Coulomb {} N, breakaway {} N) drops out",
                units::show::sig(f.viscous, 6),
                units::show::sig(f.sliding - f.viscous * m.v.abs(), 6),
                units::show::sig(f.breakaway, 6)
            ),
            Mode::Held { may_extend: false, .. } => {
                format!("on its upper stop (x = {x_mm} mm): held, position and velocity are not states")
            }
            Mode::Held { may_retract: false, .. } => {
                format!("on its lower stop (x = {x_mm} mm): held, position and velocity are not states")
            }
            Mode::Held { .. } => format!(
                "stuck at x = {x_mm} mm (net force {} N, breakaway level {} N): position and velocity are not states",
                units::show::sig(f.applied, 6),
                units::show::sig(f.breakaway, 6)
            ),
        };
    }
    Ok(out)
}

/// Outputs with their recorded columns, and those left out with the reason.
pub type OutputColumns = (Vec<(Named, usize)>, Vec<(String, String)>);

/// The recorded columns of the outputs, with names and SI units; the
/// interface outputs that cannot be in a linear model, with the reason.
pub fn output_columns(model: &Model) -> OutputColumns {
    let units = model.output_units();
    let mut cols = Vec::new();
    let mut skipped = Vec::new();
    for o in &model.circuit.interface.outputs {
        let col = match o.source {
            OutputSource::Signal { block, index } => model.slots[block].outputs.start + index,
            OutputSource::Recorded { block, index } => model.slots[block].outputs.start + model.slots[block].sig_out.len() + index,
            OutputSource::Quadrature { .. } => {
                skipped.push((o.name.clone(), format!("{} is a running total since t = 0, not a function of the state", o.from)));
                continue;
            }
        };
        cols.push((Named { name: o.name.clone(), unit: si(&units[col]) }, col));
    }
    (cols, skipped)
}

/// "1" for a dimensionless SI unit written "".
fn si(unit: &str) -> String {
    if unit.is_empty() {
        "1".into()
    } else {
        unit.to_string()
    }
}

/// The interface inputs as named variables in SI.
pub(crate) fn input_names(model: &Model) -> Vec<Named> {
    model
        .circuit
        .interface
        .inputs
        .iter()
        .map(|i| Named { name: i.name.clone(), unit: si(&i.unit.dim.map(graph::params::si_unit).unwrap_or_default()) })
        .collect()
}

/// Of the `candidates` states, those that reach an output: a nonzero entry
/// of `c` (columns over all states), or through A's structure (the circuit's
/// wiring, [`Structure`], united with the nonzeros of `a`) a state that does.
pub(crate) fn reaching_outputs(model: &Model, a: &Matrix, c: &Matrix, candidates: &[usize]) -> Vec<usize> {
    let n = model.n_states;
    let allowed: Vec<bool> = (0..n).map(|j| candidates.contains(&j)).collect();
    // depends[i]: the states row i reads
    let mut depends: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        for j in 0..n {
            if a[(i, j)] != 0.0 {
                depends[i].push(j);
            }
        }
    }
    if let Some(s) = Structure::new(model) {
        let pattern = s.pattern();
        for j in 0..n {
            for &i in pattern.column(j) {
                if i < n && !depends[i].contains(&j) {
                    depends[i].push(j);
                }
            }
        }
    }
    let mut reach = vec![false; n];
    let mut stack: Vec<usize> = (0..n).filter(|&j| allowed[j] && (0..c.rows()).any(|i| c[(i, j)] != 0.0)).collect();
    while let Some(i) = stack.pop() {
        if reach[i] {
            continue;
        }
        reach[i] = true;
        for &j in &depends[i] {
            if allowed[j] && !reach[j] {
                stack.push(j);
            }
        }
    }
    candidates.iter().copied().filter(|&j| reach[j]).collect()
}

/// The linear model at `op`. Sets the mechanical modes ([`set_modes`]); the
/// inputs keep the values the model holds.
pub fn linearize(model: &mut Model, op: &OperatingPoint, opts: &Options) -> Result<LinearModel, LinearizeError> {
    let (t, y) = (op.t, op.y.as_slice());
    let n = model.n_states;
    let mechanics = set_modes(model, t, y, op.kind, opts.friction)?;
    let held: Vec<usize> = mechanics.iter().flat_map(|m| m.held_states.iter().copied()).collect();
    let (outputs, skipped) = match opts.outputs {
        Outputs::Interface if !model.circuit.interface.outputs.is_empty() => output_columns(model),
        _ => (Vec::new(), Vec::new()),
    };
    let states_as_outputs = outputs.is_empty() && (opts.outputs == Outputs::States || model.circuit.interface.outputs.is_empty());
    let columns: Vec<usize> = (0..n).collect();
    let out_cols: Vec<usize> = outputs.iter().map(|o| o.1).collect();
    let j = jacobians::jacobians(model, t, y, &columns, &out_cols)?;
    let y0_all = jacobians::recorded(model, t, y, &out_cols)?;
    if let Some(k) = y0_all.iter().position(|v| !v.is_finite()) {
        return Err(LinearizeError::Point(format!(
            "output \"{}\" is undefined at the operating point (choose another output or point)",
            outputs[k].0.name
        )));
    }
    let free: Vec<usize> = (0..n).filter(|i| !held.contains(i)).collect();
    let mut left_out: Vec<(String, String)> = held
        .iter()
        .map(|&i| {
            let node = mechanics.iter().find(|m| m.held_states.contains(&i)).map_or(String::new(), |m| m.id.clone());
            (model.state_name(i), format!("{node} is held"))
        })
        .collect();
    let kept = if states_as_outputs || opts.keep_all_states { free.clone() } else { reaching_outputs(model, &j.a, &j.c, &free) };
    for &i in &free {
        if !kept.contains(&i) {
            left_out.push((model.state_name(i), "reaches no output".into()));
        }
    }
    let m = model.n_inputs();
    let all_inputs: Vec<usize> = (0..m).collect();
    let a = j.a.select(&kept, &kept);
    let b = j.b.select(&kept, &all_inputs);
    let states: Vec<Named> = kept.iter().map(|&i| Named { name: model.state_name(i), unit: si(&state_unit(model, i)) }).collect();
    let (c, d, out_named, y0) = if states_as_outputs {
        (Matrix::identity(kept.len()), Matrix::zeros(kept.len(), m), states.clone(), kept.iter().map(|&i| y[i]).collect())
    } else {
        let rows: Vec<usize> = (0..outputs.len()).collect();
        (j.c.select(&rows, &kept), j.d.clone(), outputs.iter().map(|o| o.0.clone()).collect(), y0_all)
    };
    let f = jacobians::rates(model, t, y)?;
    let inputs = input_names(model);
    let difference_inputs = j.difference_inputs.iter().map(|&k| inputs[k].name.clone()).collect();
    let names = |list: &[usize]| list.iter().map(|&i| outputs[i].0.name.clone()).collect();
    let difference_outputs = names(&j.difference_outputs);
    let record_difference_outputs = names(&j.record_difference_outputs);
    Ok(LinearModel {
        a,
        b,
        c,
        d,
        states,
        inputs,
        outputs: out_named,
        x0: kept.iter().map(|&i| y[i]).collect(),
        u0: (0..m).map(|k| model.input_value(k)).collect(),
        y0,
        dx0: kept.iter().map(|&i| f[i]).collect(),
        t,
        kind: op.kind,
        mechanics,
        left_out,
        skipped_outputs: skipped,
        trim: op.trim.clone(),
        method: j.method,
        finite_difference_blocks: j.finite_difference_blocks,
        difference_inputs,
        difference_outputs,
        record_difference_outputs,
    })
}
