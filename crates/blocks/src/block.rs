//! The component contract: what every block exposes to `graph` and `solve`.
//!
//! `graph` and `solve` know a block only through this trait: they never
//! match on a block's type name. What they read:
//!
//! - **Ports** ([`Block::ports`]): each port declares its domain and causal
//!   role ([`PortKind`]) and, for signals, its SI unit ([`PortSpec::unit`]).
//!   `graph` wires ports of one domain only, gives a pneumatic node its
//!   pressure from its one effort port, and makes a node without one an
//!   algebraic junction.
//! - **Gas role** ([`Block::gas_role`], [`GasRole`]): whether the block
//!   stores gas (a capacity: chamber, tube), passes it without storing it (a
//!   pure restriction: conductance, valves, regulators), lets it cross the
//!   circuit boundary (sources, atmosphere), or carries none. The balance
//!   check counts boundary flows and stored gas by this declaration, the rest
//!   state finds sources, capacities and passages by it.
//! - **Internal states** ([`Block::states`]) with their units, integrated by
//!   `solve`; a block with none is algebraic. Discrete states change only in
//!   [`Block::on_event`].
//! - **Parameters** ([`crate::params::ParamSpec`], listed in the registry):
//!   shared sets — the ISO 6358 characteristic ([`crate::iso6358::PARAMS`]),
//!   the thermal wall ([`crate::chamber::THERMAL_WALL`]) — are declared once
//!   and joined into a block's list with [`crate::param_set!`].
//! - **Live parameters** ([`Block::live_parameters`]): the few parameters a
//!   block lets change during a run (a supply pressure, an external force),
//!   which a netlist's interface inputs may drive from outside.
//!
//! `solve` calls the evaluation phases below, in this order, once per
//! right-hand-side evaluation:
//!
//! 1. [`Block::kinematics`] — inertias publish position and velocity of their
//!    mechanical port from their states (integral causality).
//! 2. [`Block::effort`] — capacities and pressure sources publish the gas state
//!    (p, T, ρ, h) at their pneumatic effort ports.
//! 3. [`Block::signal_outputs`] — signal values (sensors, controllers).
//! 4. [`Block::flows`] — restrictions and flow sources compute mass and energy
//!    flows at their pneumatic flow ports from the gas states on both sides
//!    (conductance form). Junction pressures between restrictions are solved
//!    by `solve` around this call.
//! 5. [`Block::forces`] — forces on mechanical nodes, including dry friction
//!    laws that the node's stick–slip logic (Karnopp 1985) uses.
//! 6. [`Block::derivatives`] — state derivatives from the balances that
//!    `solve` gathered on each node.
//!
//! ## Exact derivatives
//! A block may give the partial derivatives of each phase's outputs with
//! respect to its own inputs ([`Block::partials`], laid out by [`Shape`]):
//! `solve` chains them through the wiring (and through the junction
//! solves, by implicit differentiation) into the exact Jacobian ∂f/∂y of the
//! whole model. A block that does not give them for a phase is
//! differentiated alone by central differences (a fallback that `pneumo
//! simulate --summary` names).
//!
//! ## Sign conventions (the only place they are written)
//! - Pneumatic port: mass flow ṁ [kg/s] and energy flow Ė [W] are positive
//!   INTO the block. Ė is the total energy carried through the port: enthalpy
//!   flow ṁ·h of the upstream gas plus any conduction Q_c (paper Eq. 7, 9, 10).
//! - Mechanical translational port: position x [m], velocity v [m/s] and force
//!   F [N] are positive in the extend direction; a force returned by a block
//!   is the force it exerts ON the node.
//! - Signal ports carry plain f64 values in the SI unit their [`PortSpec`]
//!   declares ("1" for on/off signals: ≥ 0.5 is on).

use gas::{GasModel, GasState};

/// Domain and causal role of a port.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PortKind {
    /// Pneumatic port where the block imposes p and T (chamber, pressure source).
    PneumaticEffort,
    /// Pneumatic port where the block computes ṁ and Ė from the node state
    /// (restriction, flow source, a sensor that only reads the node). The
    /// flow into the block must be continuous and non-decreasing in the
    /// port's node pressure (all else fixed): the junction solve between
    /// restrictions brackets its root on that.
    PneumaticFlow,
    /// Mechanical port where the block imposes x and v (moving mass).
    MechanicalInertia,
    /// Mechanical port where the block computes a force (chamber piston face, friction, spring).
    MechanicalForce,
    /// Signal input.
    SignalIn,
    /// Signal output.
    SignalOut,
}

/// The physical domain of a port; connections join ports of one domain only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Domain {
    Pneumatic,
    Mechanical,
    Signal,
}

impl PortKind {
    pub fn domain(self) -> Domain {
        match self {
            PortKind::PneumaticEffort | PortKind::PneumaticFlow => Domain::Pneumatic,
            PortKind::MechanicalInertia | PortKind::MechanicalForce => Domain::Mechanical,
            PortKind::SignalIn | PortKind::SignalOut => Domain::Signal,
        }
    }
}

impl Domain {
    /// The variables a port of this domain carries, with their SI units.
    pub fn variables(self) -> &'static str {
        match self {
            Domain::Pneumatic => "p [Pa], T [K]; mass flow [kg/s] and energy flow [W] into the block",
            Domain::Mechanical => "x [m], v [m/s]; force [N] in the extend direction",
            Domain::Signal => "a value in the port's unit",
        }
    }
}

impl std::fmt::Display for Domain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Domain::Pneumatic => "pneumatic",
            Domain::Mechanical => "mechanical",
            Domain::Signal => "signal",
        })
    }
}

/// A named port of a block.
#[derive(Debug, Clone, PartialEq)]
pub struct PortSpec {
    pub name: &'static str,
    pub kind: PortKind,
    /// SI unit of a signal ("Pa", "m", "1" for a pure number, "" when it
    /// carries whatever its input carries). Power ports have the units of
    /// their domain (see [`Domain::variables`]).
    pub unit: &'static str,
    /// One line: what flows through it.
    pub doc: &'static str,
}

impl PortSpec {
    /// A pneumatic or mechanical port.
    pub const fn new(name: &'static str, kind: PortKind, doc: &'static str) -> Self {
        Self { name, kind, unit: "", doc }
    }
    /// A signal port carrying a value in `unit`.
    pub const fn signal(name: &'static str, kind: PortKind, unit: &'static str, doc: &'static str) -> Self {
        Self { name, kind, unit, doc }
    }
}

/// A continuous state of a block.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpec {
    pub name: &'static str,
    pub unit: &'static str,
}

/// A recorded output of a block (written to result files), computed after
/// the derivatives so it may depend on them (e.g. the polytropic index).
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSpec {
    pub name: &'static str,
    pub unit: &'static str,
}

/// Position and velocity of a mechanical node.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MechState {
    pub x: f64,
    pub v: f64,
}

/// Mass and energy flow through a pneumatic port, positive into the block.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PortFlow {
    /// Mass flow [kg/s].
    pub mdot: f64,
    /// Energy flow [W]: ṁ·h_upstream + conduction.
    pub edot: f64,
}

impl std::ops::AddAssign for PortFlow {
    fn add_assign(&mut self, rhs: Self) {
        self.mdot += rhs.mdot;
        self.edot += rhs.edot;
    }
}

impl std::ops::Neg for PortFlow {
    type Output = PortFlow;
    fn neg(self) -> PortFlow {
        PortFlow { mdot: -self.mdot, edot: -self.edot }
    }
}

/// Dry friction acting at a mechanical port, used by the stick–slip logic.
///
/// Magnitudes only: the node logic applies them against the motion (sliding)
/// or up to the breakaway level (sticking), after Karnopp (1985).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DryFriction {
    /// Sliding friction magnitude at the port's current speed |v| [N] (≥ 0).
    pub sliding: f64,
    /// Breakaway (static) level: the largest force held while stuck [N] (≥ 0).
    pub breakaway: f64,
    /// Viscous slope c [N s/m] (≥ 0): the part c·|v| of `sliding`. The node
    /// logic continues it as −c·v past v = 0, so that a sliding mode's
    /// equations stay smooth across the reversal that ends the mode.
    pub viscous: f64,
}

/// Force a block exerts on a mechanical node.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PortForce {
    /// Force that does not depend on the sign of motion [N], positive in the extend direction.
    pub applied: f64,
    /// Dry friction, if the block is a friction element.
    pub friction: Option<DryFriction>,
}

/// Everything a block may read during one evaluation.
///
/// Port values are indexed per kind in declaration order: `pneumatic[i]` is
/// the node state at the block's i-th pneumatic port (effort or flow),
/// `mechanical[i]` the i-th mechanical port, `signals[i]` the i-th signal input.
#[derive(Debug, Clone, Copy)]
pub struct Ctx<'a> {
    pub t: f64,
    pub gas: &'a dyn GasModel,
    pub states: &'a [f64],
    pub pneumatic: &'a [GasState],
    pub mechanical: &'a [MechState],
    pub signals: &'a [f64],
}

/// What a mechanical node computed for an inertia port.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Acceleration [m/s²] decided by the node logic (zero while stuck or at a stop).
    pub accel: f64,
}

/// Balances gathered by `solve` for one block, indexed like the ports.
#[derive(Debug, Clone, Copy)]
pub struct Balances<'a> {
    /// Net flow into the block at each pneumatic port (meaningful at effort ports:
    /// the sum of flows arriving from every restriction on that node).
    pub pneumatic: &'a [PortFlow],
    /// Motion decided for each mechanical port (meaningful at inertia ports).
    pub mechanical: &'a [Motion],
}

/// End stops of a moving mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stops {
    /// Lower stop position [m].
    pub lower: f64,
    /// Upper stop position [m].
    pub upper: f64,
    /// Coefficient of restitution e: impact speed v becomes −e·v (0 = inelastic).
    pub restitution: f64,
}

/// Gas stored in a capacity.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stored {
    /// Mass [kg].
    pub mass: f64,
    /// Internal energy m·u [J].
    pub energy: f64,
}

/// Energy exchanged by stored gas with its surroundings, other than through ports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Exchange {
    /// Heat into the gas from the walls [W].
    pub heat: f64,
    /// Boundary work done by the gas, p·V̇ [W].
    pub work: f64,
}

/// A discrete event a block asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EventKind {
    /// Root function `index` of [`Block::event_functions`] changed sign.
    Crossing(usize),
    /// The time returned by [`Block::next_time_event`] was reached.
    Time,
}

/// Record of one completed cycle of a controller (an actuator's extend and
/// retract for a cycler; one pass through a sequencer's steps).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CycleRecord {
    /// Id of the controller that completed it (filled in by `solve`; blocks leave it empty).
    pub controller: String,
    /// Time of the extend command [s].
    pub start: f64,
    /// Extend stroke time, from the extend command to the end of stroke [s]
    /// (NaN for a controller without strokes).
    pub extend: f64,
    /// Retract stroke time, from the retract command back to 0 [s] (NaN without strokes).
    pub retract: f64,
    /// Time of the retract command [s] (NaN without strokes).
    pub retract_start: f64,
    /// Whole cycle, including dwells [s].
    pub total: f64,
}

/// What handling an event produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EventOutcome {
    /// A cycle completed at this event.
    pub cycle: Option<CycleRecord>,
    /// A short note for the event log ("retract commanded").
    pub note: Option<String>,
}

/// Physical constants a block needs at initialisation.
#[derive(Debug, Clone, Copy)]
pub struct InitCtx<'a> {
    pub gas: &'a dyn GasModel,
    /// Position and velocity at each mechanical port (inertias initialised first).
    pub mechanical: &'a [MechState],
}

/// A port a block holds at a pressure while the circuit rests (see [`Block::rest_pressure`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestPressure {
    /// The held port, as an index among the block's pneumatic ports.
    pub port: usize,
    /// The port the gas comes from, among the pneumatic ports (its temperature is taken).
    pub from: usize,
    /// Pressure held [Pa] (absolute).
    pub pressure: f64,
    /// Whether gas above that pressure is let out too (a relieving regulator), or only gas below is filled up.
    pub relieving: bool,
}

/// Initial values a block leaves open, which a rest-state computation may
/// choose (those the user gave explicitly are never changed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FreeInitial {
    /// The initial gas pressure of a capacity.
    pub pressure: bool,
    /// The initial gas temperature of a capacity.
    pub temperature: bool,
    /// The initial position of an inertia (which then starts at rest).
    pub position: bool,
}

/// Something a block states about itself that must agree with what other
/// blocks state (compared by `graph` to warn about inconsistent input).
/// Each fact is attached to one of the block's ports: facts about a moving
/// mass are compared between blocks on the same mechanical node (a signal
/// input counts as being on the node of the block that drives it).
#[derive(Debug, Clone, PartialEq)]
pub enum Fact {
    /// Stroke of the actuator [m], stated by a block's parameter `stroke`
    /// (the piston's travel, a cushion's end).
    Stroke(f64),
    /// Position [m] at which a switch on this mass trips (≤ stroke), and
    /// the block's parameter that sets it.
    SwitchPosition { x: f64, param: &'static str },
    /// A chamber's face on a piston: it pushes toward extend (`sigma` = +1,
    /// its volume grows as x grows) or retract (−1), with its area [m²],
    /// dead volume [m³] and gas column at x = 0 [m] (parameters
    /// `orientation`, `dead_volume`, `length_at_zero`); `rod` when a rod
    /// passes through it (`rod_diameter` > 0).
    PistonFace { sigma: f64, area: f64, dead_volume: f64, length_at_zero: f64, rod: bool },
    /// Piston diameter [m].
    Bore(f64),
    /// Rod diameter [m].
    RodDiameter(f64),
    /// Pressure [Pa] a supply imposes (compared with the ambient).
    SupplyPressure(f64),
    /// Ambient pressure [Pa] (an exhaust).
    AmbientPressure(f64),
    /// The values a command output takes.
    CommandLevels(Vec<f64>),
    /// An on/off command input: released at `released`, actuated at `actuated`.
    CommandThresholds { released: f64, actuated: f64 },
    /// Outlet pressure [Pa] a regulator is set to, stated at its supply
    /// port: the supply that reaches this port must be higher (an error otherwise).
    SetPressure(f64),
}

/// What a block does with gas (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GasRole {
    /// No gas passes through it or is stored in it: mechanical and signal
    /// blocks, and sensors whose pneumatic port only reads the node.
    None,
    /// Stores gas: its states hold a mass and an internal energy, reported by
    /// [`Block::stored`], with wall heat and boundary work reported by
    /// [`Block::exchange`]. A chamber (effort port) or a tube (flow ports).
    Capacity,
    /// Passes gas between its ports without storing any: at every instant
    /// Σ ṁ = 0 and Σ Ė = 0 over its ports (valves, regulators, restrictions).
    Restriction,
    /// Gas enters or leaves the circuit here (pressure source, atmosphere,
    /// mass-flow source): the flows at its ports cross the circuit boundary.
    Boundary,
}

/// A phase of the evaluation whose outputs [`Block::partials`] differentiates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    /// x, v of each mechanical port ([`Block::kinematics`]).
    Kinematics,
    /// p, T of each pneumatic port ([`Block::effort`]).
    Effort,
    /// Each signal output ([`Block::signal_outputs`]).
    Signals,
    /// ṁ, Ė of each pneumatic port ([`Block::flows`]).
    Flows,
    /// Applied force and the three dry-friction levels of each mechanical port ([`Block::forces`]).
    Forces,
    /// Each state derivative ([`Block::derivatives`]).
    Derivatives,
    /// Wall heat and boundary work ([`Block::exchange`]).
    Exchange,
    /// The rates of the block's own quadratures ([`Block::quadrature_rates`],
    /// differentiated by [`Block::quadrature_partials`]).
    Quadratures,
}

impl Phase {
    /// Every phase, in evaluation order.
    pub const ALL: [Phase; 8] = [
        Phase::Kinematics,
        Phase::Effort,
        Phase::Signals,
        Phase::Flows,
        Phase::Forces,
        Phase::Derivatives,
        Phase::Exchange,
        Phase::Quadratures,
    ];
}

/// An input of a block, by kind and index among the ports (or states) of that kind.
///
/// Gas at a port enters through its pressure and temperature: a block that
/// reads the density or enthalpy of a port differentiates them through the
/// gas model (see [`crate::support::GasSlopes`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum In {
    State(usize),
    P(usize),
    T(usize),
    X(usize),
    V(usize),
    Signal(usize),
    /// Net mass flow into pneumatic port k ([`Balances::pneumatic`]).
    Mdot(usize),
    /// Net energy flow into pneumatic port k.
    Edot(usize),
    /// Acceleration of mechanical port k's node ([`Balances::mechanical`]).
    Accel(usize),
    /// The derivative of the block's own state i (read by the quadratures only).
    Rate(usize),
}

/// An output of a phase (see [`Phase`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Out {
    X(usize),
    V(usize),
    P(usize),
    T(usize),
    Signal(usize),
    Mdot(usize),
    Edot(usize),
    Applied(usize),
    Sliding(usize),
    Breakaway(usize),
    Viscous(usize),
    /// Derivative of state i.
    Rate(usize),
    Heat,
    Work,
    /// Rate of the block's quadrature k.
    Quadrature(usize),
}

/// Numbers of a block's inputs and outputs of each kind: the layout of its [`Partials`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Shape {
    pub states: usize,
    pub pneumatic: usize,
    pub mechanical: usize,
    pub signals_in: usize,
    pub signals_out: usize,
    pub quadratures: usize,
}

impl Shape {
    /// The shape of `block` (its ports and states).
    pub fn of(block: &dyn Block) -> Shape {
        let ports = block.ports();
        let count = |k: PortKind| ports.iter().filter(|p| p.kind == k).count();
        Shape {
            states: block.states().len(),
            pneumatic: ports.iter().filter(|p| p.kind.domain() == Domain::Pneumatic).count(),
            mechanical: ports.iter().filter(|p| p.kind.domain() == Domain::Mechanical).count(),
            signals_in: count(PortKind::SignalIn),
            signals_out: count(PortKind::SignalOut),
            quadratures: block.quadratures().len(),
        }
    }
    /// Number of inputs (columns of a [`Partials`]).
    pub fn n_inputs(&self) -> usize {
        2 * self.states + 4 * self.pneumatic + 3 * self.mechanical + self.signals_in
    }
    /// Column of an input, or `None` if the block has no such input.
    pub fn input(&self, i: In) -> Option<usize> {
        let (ns, np, nm, nsi) = (self.states, self.pneumatic, self.mechanical, self.signals_in);
        let (col, k, count) = match i {
            In::State(k) => (k, k, ns),
            In::P(k) => (ns + 2 * k, k, np),
            In::T(k) => (ns + 2 * k + 1, k, np),
            In::X(k) => (ns + 2 * np + 2 * k, k, nm),
            In::V(k) => (ns + 2 * np + 2 * k + 1, k, nm),
            In::Signal(k) => (ns + 2 * np + 2 * nm + k, k, nsi),
            In::Mdot(k) => (ns + 2 * np + 2 * nm + nsi + 2 * k, k, np),
            In::Edot(k) => (ns + 2 * np + 2 * nm + nsi + 2 * k + 1, k, np),
            In::Accel(k) => (ns + 4 * np + 2 * nm + nsi + k, k, nm),
            In::Rate(k) => (ns + 4 * np + 3 * nm + nsi + k, k, ns),
        };
        (k < count).then_some(col)
    }
    /// The input of a column (inverse of [`Shape::input`]).
    pub fn input_at(&self, col: usize) -> In {
        let (ns, np, nm, nsi) = (self.states, self.pneumatic, self.mechanical, self.signals_in);
        let mut c = col;
        if c < ns {
            return In::State(c);
        }
        c -= ns;
        if c < 2 * np {
            return if c.is_multiple_of(2) { In::P(c / 2) } else { In::T(c / 2) };
        }
        c -= 2 * np;
        if c < 2 * nm {
            return if c.is_multiple_of(2) { In::X(c / 2) } else { In::V(c / 2) };
        }
        c -= 2 * nm;
        if c < nsi {
            return In::Signal(c);
        }
        c -= nsi;
        if c < 2 * np {
            return if c.is_multiple_of(2) { In::Mdot(c / 2) } else { In::Edot(c / 2) };
        }
        c -= 2 * np;
        if c < nm {
            return In::Accel(c);
        }
        In::Rate(c - nm)
    }
    /// Number of outputs (rows) of a phase.
    pub fn outputs(&self, phase: Phase) -> usize {
        match phase {
            Phase::Kinematics => 2 * self.mechanical,
            Phase::Effort | Phase::Flows => 2 * self.pneumatic,
            Phase::Signals => self.signals_out,
            Phase::Forces => 4 * self.mechanical,
            Phase::Derivatives => self.states,
            Phase::Exchange => 2,
            Phase::Quadratures => self.quadratures,
        }
    }
    /// Row of an output in a phase, or `None` if the phase has no such output.
    pub fn output(&self, phase: Phase, o: Out) -> Option<usize> {
        let row = match (phase, o) {
            (Phase::Kinematics, Out::X(k)) => 2 * k,
            (Phase::Kinematics, Out::V(k)) => 2 * k + 1,
            (Phase::Effort, Out::P(k)) => 2 * k,
            (Phase::Effort, Out::T(k)) => 2 * k + 1,
            (Phase::Signals, Out::Signal(k)) => k,
            (Phase::Flows, Out::Mdot(k)) => 2 * k,
            (Phase::Flows, Out::Edot(k)) => 2 * k + 1,
            (Phase::Forces, Out::Applied(k)) => 4 * k,
            (Phase::Forces, Out::Sliding(k)) => 4 * k + 1,
            (Phase::Forces, Out::Breakaway(k)) => 4 * k + 2,
            (Phase::Forces, Out::Viscous(k)) => 4 * k + 3,
            (Phase::Derivatives, Out::Rate(i)) => i,
            (Phase::Exchange, Out::Heat) => 0,
            (Phase::Exchange, Out::Work) => 1,
            (Phase::Quadratures, Out::Quadrature(k)) => k,
            _ => return None,
        };
        (row < self.outputs(phase)).then_some(row)
    }
}

/// Partial derivatives of one phase's outputs with respect to a block's
/// inputs: a dense matrix with a row per output and a column per input (see
/// [`Shape`]), zero where an output does not depend on an input.
#[derive(Debug, Clone, Default)]
pub struct Partials {
    shape: Shape,
    phase: Option<Phase>,
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Partials {
    /// All-zero partials of `phase` for a block of `shape` (reusing the storage).
    pub fn reset(&mut self, shape: Shape, phase: Phase) {
        self.shape = shape;
        self.phase = Some(phase);
        self.rows = shape.outputs(phase);
        self.cols = shape.n_inputs();
        self.data.clear();
        self.data.resize(self.rows * self.cols, 0.0);
    }
    pub fn shape(&self) -> Shape {
        self.shape
    }
    pub fn n_rows(&self) -> usize {
        self.rows
    }
    /// Position of (out, input), if both exist for this block and phase.
    fn index(&self, out: Out, input: In) -> Option<usize> {
        let r = self.phase.and_then(|p| self.shape.output(p, out))?;
        Some(r * self.cols + self.shape.input(input)?)
    }
    /// ∂out/∂input := v (ignored if the block or phase has no such output or input).
    pub fn set(&mut self, out: Out, input: In, v: f64) {
        if let Some(i) = self.index(out, input) {
            self.data[i] = v;
        }
    }
    /// ∂out/∂input += v.
    pub fn add(&mut self, out: Out, input: In, v: f64) {
        if let Some(i) = self.index(out, input) {
            self.data[i] += v;
        }
    }
    /// ∂out/∂input.
    pub fn get(&self, out: Out, input: In) -> f64 {
        self.index(out, input).map_or(0.0, |i| self.data[i])
    }
    /// The partials of output row `r`, one per input column.
    pub fn row(&self, r: usize) -> &[f64] {
        &self.data[r * self.cols..(r + 1) * self.cols]
    }
    /// Mutable row `r`.
    pub fn row_mut(&mut self, r: usize) -> &mut [f64] {
        &mut self.data[r * self.cols..(r + 1) * self.cols]
    }
}

/// A copy of a boxed block with its discrete state (a valve's position, a
/// controller's phase): what lets a whole model be copied, e.g. for an FMU's
/// `fmi2GetFMUstate`. Every `Block` that is `Clone` has it.
pub trait BlockClone {
    fn clone_block(&self) -> Box<dyn Block>;
}

impl<T: Block + Clone + 'static> BlockClone for T {
    fn clone_block(&self) -> Box<dyn Block> {
        Box::new(self.clone())
    }
}

impl Clone for Box<dyn Block> {
    fn clone(&self) -> Self {
        self.clone_block()
    }
}

/// A component of a pneumatic circuit.
///
/// Every method has a do-nothing default so a block implements only the
/// phases its ports need. Methods must be pure functions of their inputs
/// (except `on_event`, which updates discrete state) and must not panic.
/// A block is `Clone` ([`BlockClone`]): a copy carries its discrete state.
pub trait Block: BlockClone + std::fmt::Debug + Send + Sync {
    /// The netlist type name ("chamber", "conductance", ...).
    fn type_name(&self) -> &'static str;
    /// Ports, in a fixed order.
    fn ports(&self) -> &[PortSpec];
    /// What the block does with gas; every block declares it.
    fn gas_role(&self) -> GasRole;
    /// Continuous states.
    fn states(&self) -> &[StateSpec] {
        &[]
    }
    /// Initial states that follow from the block's inputs at t = 0, for a
    /// block whose states track an input (a sensor's lag starts at the value
    /// it reads, a filter at its input). Called once the other initial states
    /// are set and the circuit has been evaluated with them; `states` holds
    /// the values [`Block::initial_states`] gave.
    fn initial_states_from_inputs(&self, _ctx: &Ctx, _states: &mut [f64]) {}
    /// Typical magnitude of each state, for absolute tolerances.
    fn state_scales(&self, _init: &[f64], _out: &mut [f64]) {}
    /// Initial values of the states.
    fn initial_states(&self, _ctx: &InitCtx, _out: &mut [f64]) {}
    /// Phase 1: position and velocity at inertia ports.
    fn kinematics(&self, _states: &[f64], _out: &mut [MechState]) {}
    /// Phase 2: gas state at effort ports (entries of other ports are left untouched).
    fn effort(&self, _ctx: &Ctx, _out: &mut [GasState]) {}
    /// Phase 3: values of the signal outputs.
    fn signal_outputs(&self, _ctx: &Ctx, _out: &mut [f64]) {}
    /// True if a signal output depends on a signal input in the same instant.
    fn feedthrough(&self) -> bool {
        false
    }
    /// Phase 4: flows into the block at each pneumatic flow port.
    fn flows(&self, _ctx: &Ctx, _out: &mut [PortFlow]) {}
    /// The flow into the block at its `port`-th pneumatic port (indexing as
    /// in `ctx.pneumatic`) and the derivative of its mass flow with respect
    /// to that port's pressure, the other ports and all temperatures held.
    /// Used by the junction solve for Newton steps; `None` (the default)
    /// makes it fall back to secant steps on [`Block::flows`].
    fn port_flow(&self, _ctx: &Ctx, _port: usize) -> Option<(PortFlow, f64)> {
        None
    }
    /// Phase 5: forces on each mechanical port's node (inertia ports included).
    fn forces(&self, _ctx: &Ctx, _out: &mut [PortForce]) {}
    /// Mass [kg] moved by an inertia port.
    fn inertia(&self) -> f64 {
        0.0
    }
    /// End stops of an inertia port, if any.
    fn stops(&self) -> Option<Stops> {
        None
    }
    /// Overwrite position and velocity in the states of an inertia after an
    /// impact, a stop or a stick event decided by the node logic.
    fn reset_motion(&self, _states: &mut [f64], _motion: MechState) {}
    /// Gas mass and internal energy stored in the block, for balance checks.
    fn stored(&self, _ctx: &Ctx) -> Option<Stored> {
        None
    }
    /// Heat received and boundary work done by the stored gas, for balance checks.
    fn exchange(&self, _ctx: &Ctx, _balances: &Balances) -> Exchange {
        Exchange::default()
    }
    /// Phase 6: time derivatives of the states.
    fn derivatives(&self, _ctx: &Ctx, _balances: &Balances, _out: &mut [f64]) {}
    /// Recorded outputs (besides signal outputs).
    fn outputs(&self) -> &[OutputSpec] {
        &[]
    }
    /// Values of the recorded outputs, given the derivatives just computed.
    /// `None` means undefined at this instant (e.g. n when ρ̇ = 0).
    fn record(&self, _ctx: &Ctx, _balances: &Balances, _derivs: &[f64], _out: &mut [Option<f64>]) {}
    /// Number of root functions this block watches.
    fn n_event_functions(&self) -> usize {
        0
    }
    /// Root functions: each is negative while nothing happens, and the event
    /// is its becoming strictly positive (zero is not yet an event). After
    /// [`Block::on_event`] the function must be back at or below zero, or it
    /// is handled again at the same instant (a condition that stays true is an
    /// error, not a silent loop). One that cannot fire in the current state is −1.
    fn event_functions(&self, _ctx: &Ctx, _out: &mut [f64]) {}
    /// Next time-triggered event strictly after `t`, if any.
    fn next_time_event(&self, _t: f64) -> Option<f64> {
        None
    }
    /// Handle an event: update discrete state. `ctx` is the state at the event.
    fn on_event(&mut self, _event: EventKind, _ctx: &Ctx) -> EventOutcome {
        EventOutcome::default()
    }
    /// True if the block's equations depend on time explicitly and smoothly
    /// (a sine source, say). Piecewise-constant time dependence announced
    /// through [`Block::next_time_event`] does not count.
    fn time_dependent(&self) -> bool {
        false
    }
    /// Whether the block's discrete state asks the simulation to stop.
    fn finished(&self) -> bool {
        false
    }
    /// Whether the block reports completed cycles ([`EventOutcome::cycle`]):
    /// a run asked for N cycles ends when every such controller has completed N.
    fn counts_cycles(&self) -> bool {
        false
    }
    /// Mass [kg] a force block adds to the moving mass of the mechanical node
    /// it acts on (a load carried by the rod). Piecewise constant: it may
    /// change only in [`Block::on_event`].
    fn carried_mass(&self) -> f64 {
        0.0
    }
    /// Signal outputs while the circuit rests before t = 0: a controller is
    /// released (its commands at their idle value), a sensor reads the state.
    /// Default: the same as [`Block::signal_outputs`].
    fn rest_signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        self.signal_outputs(ctx, out)
    }
    /// A pressure this block holds one of its pneumatic ports at while the
    /// circuit rests (a regulator's outlet at its set pressure), which the
    /// rest state uses instead of probing the block for open paths.
    fn rest_pressure(&self, _ctx: &Ctx) -> Option<RestPressure> {
        None
    }
    /// Initial values left open by the user, which a rest-state computation may set.
    fn free_initial(&self) -> FreeInitial {
        FreeInitial::default()
    }
    /// Set the initial gas state of a capacity (absolute p [Pa], T [K]).
    fn set_initial_gas(&mut self, _p: f64, _t: f64) {}
    /// The initial gas state (p [Pa], T [K]) of a capacity, given or default.
    fn initial_gas(&self) -> Option<(f64, f64)> {
        None
    }
    /// Set the initial position [m] of an inertia, at rest.
    fn set_initial_position(&mut self, _x: f64) {}
    /// Running integrals the block keeps for statistics of the run (not read
    /// by any derivative, so the integrator neither differentiates them nor
    /// steers its step by them), e.g. the weights of a mean polytropic index.
    fn quadratures(&self) -> &[OutputSpec] {
        &[]
    }
    /// Rates of the [`Block::quadratures`], given the state derivatives just computed.
    fn quadrature_rates(&self, _ctx: &Ctx, _balances: &Balances, _derivs: &[f64], _out: &mut [f64]) {}
    /// Statistics over an interval from the increments of the quadratures
    /// over it ("n_mean" of a chamber); `None` where undefined.
    fn quadrature_statistics(&self, _increments: &[f64]) -> Vec<(&'static str, Option<f64>)> {
        Vec::new()
    }
    /// Facts to compare with other blocks, each with the index of the port it concerns.
    fn facts(&self) -> Vec<(usize, Fact)> {
        Vec::new()
    }
    /// Parameters that may change while the circuit runs — a supply
    /// pressure, an external force — named as in the block's parameter list.
    /// A netlist's interface may bind an input to one of them
    /// (`"parameter": "supply.p"`); the value then changes between
    /// integration steps only (piecewise constant), and the solver restarts
    /// after each change. Default: none.
    fn live_parameters(&self) -> &'static [&'static str] {
        &[]
    }
    /// Set live parameter `name` (one of [`Block::live_parameters`]) to
    /// `value` in SI, already checked against the parameter's range.
    fn set_live_parameter(&mut self, _name: &str, _value: f64) {}
    /// Exact partial derivatives of the outputs of `phase` with respect to
    /// the block's inputs at `ctx` (and `balances`, read by the derivatives
    /// and the exchange; empty in the other phases), written into `out`,
    /// which arrives zeroed and shaped for this block and phase. Outputs
    /// that are piecewise constant (a valve's spool switched by a threshold)
    /// have zero partials. Returns false if the block does not give them for
    /// this phase (the default): `solve` then differentiates the block alone
    /// by central differences.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _balances: &Balances, _out: &mut Partials) -> bool {
        false
    }
    /// Exact partial derivatives of the outputs of `phase` with respect to
    /// live parameter `name` (one of [`Block::live_parameters`]) at `ctx`,
    /// one per output row of the phase, written into `out` (zeroed, sized to
    /// the phase's rows). What an interface input bound to the parameter
    /// does to the circuit: `solve`'s linearisation seeds it as an extra
    /// column of the chain rule (∂f/∂u, ∂y/∂u). Returns false if the block
    /// does not give them for this phase (the default): that input is then
    /// differentiated by central differences of the whole model.
    fn live_partials(&self, _name: &str, _phase: Phase, _ctx: &Ctx, _out: &mut [f64]) -> bool {
        false
    }
    /// Exact partials of [`Block::quadrature_rates`] (phase
    /// [`Phase::Quadratures`]), which also read the state derivatives
    /// `derivs` ([`In::Rate`]). Returns false by default (differences).
    fn quadrature_partials(&self, _ctx: &Ctx, _balances: &Balances, _derivs: &[f64], _out: &mut Partials) -> bool {
        false
    }
}

/// Number of ports of one kind.
pub fn count_ports(ports: &[PortSpec], pred: impl Fn(PortKind) -> bool) -> usize {
    ports.iter().filter(|p| pred(p.kind)).count()
}

/// Helper for blocks with one state vector that must stay physical.
pub fn is_finite_all(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}
