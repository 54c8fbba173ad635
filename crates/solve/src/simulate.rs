//! The hybrid simulation loop: integrate until a root or a time event, hand
//! the event to the blocks and node logic, restart; sample results along the
//! way from the integrator's dense output.
//!
//! Events cannot be missed (see `resolve_events`): every root function is
//! declared rising (negative while nothing happens), so the integrator
//! watches a function left exactly at zero from its "no event" side and
//! reports it as soon as it becomes positive; the roots that fired decide the
//! new modes; afterwards every root is checked again at the event instant and
//! any that is still positive is handled again there (bounded; an event
//! condition that no handling clears is an error naming the root). Time
//! events due at the instant of a root are handled with it.

use crate::exact::Exact;
use crate::jacobian::{Structure, Workspace};
use crate::mechanics::{self, Mode};
use crate::model::{Model, ModelError, N_QUADRATURE};
use crate::sensitivity::Tracker;
use blocks::block::{CycleRecord, EventKind, MechState};
use ode::{Advance, Dense, Integrator, IntegratorError, OdeSystem, Options, RhsError, RootDirection, Rosenbrock};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use units::show::{fixed, num};

/// A request to stop runs early, shared between the runs and whoever may
/// cancel them (Ctrl-C in the Python package). Clones share one flag; a run
/// given one in [`SimOptions::cancel`] looks at it at every evaluation of the
/// right-hand side and between events, and ends with [`SolveError::Cancelled`].
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    pub fn new() -> Self {
        Self::default()
    }
    /// Ask every run holding this flag (or a clone of it) to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Two flags are equal when they are the same flag.
impl PartialEq for Cancel {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Settings of one run, in SI.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// End time [s]; the run also ends when the requested cycles are done.
    pub t_end: f64,
    /// Stop after this many completed cycles.
    pub cycles: Option<u64>,
    pub rtol: f64,
    /// Absolute tolerance relative to each state's typical size.
    pub atol: f64,
    /// Output sample interval [s] (0 = no grid: only event instants, and
    /// step ends if `record_steps`).
    pub sample_interval: f64,
    /// Record the state at the end of every accepted step (for summaries of
    /// runs whose traces nobody asked for: far fewer rows than a fine grid).
    pub record_steps: bool,
    /// Record only these output columns ("head.p"); the others stay
    /// empty. `None` records every column. When every column named is a
    /// block's signal output (a chamber's p and T, a piston's x and v, a
    /// sensor's reading), an output row costs no model evaluation
    /// ([`Model::record_signals`]) and the run's numbers do not change:
    /// this is what a fit reading a few channels on a 1 ms grid asks for.
    pub record_only: Option<Vec<String>>,
    /// Largest step [s].
    pub max_step: f64,
    /// Safety limit on the number of discrete events.
    pub max_events: usize,
    /// Integration method.
    pub method: ode::Method,
    /// How the Jacobian is formed: grouped differences (the default, the
    /// fastest measured, see docs/performance.md), exact, or plain
    /// differences (for comparisons).
    pub jacobian: JacobianMethod,
    /// Stop early when this flag is raised (see [`Cancel`]).
    pub cancel: Option<Cancel>,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            t_end: 10.0,
            cycles: None,
            rtol: 1e-6,
            atol: 1e-6,
            sample_interval: 1e-3,
            record_steps: false,
            record_only: None,
            max_step: 0.05,
            max_events: 100_000,
            method: ode::Method::default(),
            jacobian: JacobianMethod::GroupedDifferences,
            cancel: None,
        }
    }
}

/// How a run forms the Jacobian ∂f/∂y.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JacobianMethod {
    /// Exact, by the chain rule over the blocks' partial derivatives
    /// ([`crate::exact`]); a block without them is differenced alone.
    Exact,
    /// Differences of the whole model with the columns grouped by the
    /// circuit's structure ([`crate::jacobian`]) where that pays (the
    /// default: fewer evaluations do not yet make exact faster).
    #[default]
    GroupedDifferences,
    /// Plain forward differences, one model evaluation per state, dense LU.
    PlainDifferences,
}

impl JacobianMethod {
    /// How the summary names it.
    pub fn name(self) -> &'static str {
        match self {
            JacobianMethod::Exact => "exact",
            JacobianMethod::GroupedDifferences => "grouped differences",
            JacobianMethod::PlainDifferences => "differences",
        }
    }
}

/// A discrete event that happened.
#[derive(Debug, Clone, PartialEq)]
pub struct EventLog {
    pub t: f64,
    pub what: String,
}

/// Mass and energy balance of the gas over the run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Balance {
    pub mass_initial: f64,
    pub mass_final: f64,
    /// Mass that entered through sources [kg].
    pub mass_in: f64,
    /// (m_final − m_initial − m_in) / max(m_initial, m_final).
    pub mass_residual: f64,
    pub energy_initial: f64,
    pub energy_final: f64,
    /// Energy that entered through sources (enthalpy flow) [J].
    pub energy_in: f64,
    /// Heat from the walls into the gas [J].
    pub heat_in: f64,
    /// Boundary work done by the gas on the pistons [J].
    pub work_out: f64,
    /// (U_final − U_initial − E_in − Q + W) / max(|U|, |E_in|, |Q|, |W|).
    pub energy_residual: f64,
}

/// A moving mass at the end of a run: where it is and the forces on it.
#[derive(Debug, Clone, PartialEq)]
pub struct MassState {
    /// Id of the inertia block ("piston").
    pub id: String,
    /// "held", "at the lower stop", "sliding, extending", ...
    pub mode: String,
    pub x: f64,
    pub v: f64,
    /// Net force other than dry friction [N], positive in the extend direction.
    pub applied: f64,
    /// Breakaway level of the dry friction [N].
    pub breakaway: f64,
}

/// The state at the end of a run, for explaining a run that did not finish
/// what it was asked to (a stalled actuator).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FinalState {
    pub masses: Vec<MassState>,
    /// Pressure [Pa] of every capacity, by component id.
    pub pressures: Vec<(String, f64)>,
}

impl FinalState {
    /// One line: each mass's position, mode and net force against its
    /// breakaway level, then the chamber pressures.
    pub fn describe(&self) -> String {
        let mut parts: Vec<String> = self
            .masses
            .iter()
            .map(|m| {
                format!(
                    "{} {} at x = {} mm, net force {} N against a breakaway level of {} N",
                    m.id,
                    m.mode,
                    fixed(m.x * 1e3 + 0.0, 1), // + 0.0 turns -0.0 into 0.0
                    fixed(m.applied, 1),
                    fixed(m.breakaway, 1)
                )
            })
            .collect();
        if !self.pressures.is_empty() {
            let p: Vec<String> = self.pressures.iter().map(|(id, p)| format!("{id}.p = {} bar", fixed(p / 1e5, 3))).collect();
            parts.push(p.join(", "));
        }
        parts.join("; ")
    }
}

pub(crate) fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Sliding { dir } if dir > 0.0 => "sliding, extending",
        Mode::Sliding { .. } => "sliding, retracting",
        Mode::Held { may_extend: false, .. } => "at the upper stop",
        Mode::Held { may_retract: false, .. } => "at the lower stop",
        Mode::Held { .. } => "stuck",
        Mode::SlidingViscous => "sliding about v = 0 (viscous friction only)",
    }
}

fn final_state(model: &Model) -> FinalState {
    let masses = model
        .circuit
        .mechanical_nodes
        .iter()
        .enumerate()
        .map(|(node, mn)| {
            let m = model.node_mech[node];
            let f = model.node_forces[node];
            MassState {
                id: model.circuit.instances[mn.inertia.block].id.clone(),
                mode: mode_name(model.modes[node]).to_string(),
                x: m.x,
                v: m.v,
                applied: f.applied,
                breakaway: f.breakaway,
            }
        })
        .collect();
    let pressures = model
        .circuit
        .pneumatic_nodes
        .iter()
        .enumerate()
        .filter_map(|(n, pn)| match pn.causality {
            graph::NodeCausality::Effort(r) if model.circuit.instances[r.block].block.gas_role() == blocks::block::GasRole::Capacity => {
                Some((model.circuit.instances[r.block].id.clone(), model.node_gas[n].p))
            }
            _ => None,
        })
        .collect();
    FinalState { masses, pressures }
}

/// Everything a run produced.
#[derive(Debug, Clone, Default)]
pub struct SimResult {
    pub columns: Vec<String>,
    pub units: Vec<String>,
    pub times: Vec<f64>,
    /// One row per time; `None` = undefined at that instant.
    pub rows: Vec<Vec<Option<f64>>>,
    pub cycles: Vec<CycleRecord>,
    pub events: Vec<EventLog>,
    pub balance: Balance,
    pub t_final: f64,
    pub stats: ode::Stats,
    pub rhs_evaluations: u64,
    /// How the integrator solved its linear systems: "dense" (plain finite
    /// differences, dense LU), "structured" (Jacobian from the circuit's
    /// structure, dense LU) or "sparse" (structured Jacobian, sparse LU).
    pub linear_algebra: &'static str,
    /// Model evaluations per Jacobian (one per column for plain differences,
    /// one per column group plus one with the structure, one when exact).
    pub evaluations_per_jacobian: usize,
    /// How the Jacobian was formed: "exact", "grouped differences" or "differences".
    pub jacobian: &'static str,
    /// Blocks the exact Jacobian differentiated by differences (they give no
    /// partial derivatives for some phase), by id.
    pub finite_difference_blocks: Vec<String>,
    /// Initial values chosen by the rest state (`"initial": "rest"`), if any.
    pub rest: crate::rest::RestReport,
    /// Where the moving masses and chamber pressures ended.
    pub final_state: FinalState,
    /// Statistics of blocks over each stroke of each completed cycle (the
    /// mean polytropic index of every chamber, say).
    pub stroke_statistics: Vec<StrokeStatistic>,
    /// Statistics of blocks over each completed cycle of each controller (the
    /// free air a supply delivered, say).
    pub cycle_statistics: Vec<StrokeStatistic>,
    /// Statistics of blocks over the whole run (`stroke` is "run", `cycle` 0).
    pub run_statistics: Vec<StrokeStatistic>,
    /// Ids of the controllers that count cycles ([`blocks::Block::counts_cycles`]).
    pub cycle_controllers: Vec<String>,
}

/// A statistic of one block over one stroke, one cycle or the whole run.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeStatistic {
    /// Id of the controller whose cycle it is ("" for the whole run).
    pub controller: String,
    /// Cycle number of that controller, from 1 (0 for the whole run).
    pub cycle: usize,
    /// "extend", "retract", "cycle" or "run".
    pub stroke: &'static str,
    /// Block id ("head").
    pub id: String,
    /// Statistic name ("n_mean").
    pub name: &'static str,
    pub value: Option<f64>,
}

impl SimResult {
    /// Column index by name.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }
    /// Cycles every cycle-counting controller has completed (the least of
    /// their counts; 0 without such a controller).
    pub fn completed_cycles(&self) -> u64 {
        self.cycle_controllers.iter().map(|id| self.cycles.iter().filter(|c| &c.controller == id).count() as u64).min().unwrap_or(0)
    }
    /// The cycles of one controller, in order.
    pub fn cycles_of<'a>(&'a self, controller: &'a str) -> impl Iterator<Item = &'a CycleRecord> + 'a {
        self.cycles.iter().filter(move |c| c.controller == controller)
    }
    /// A whole column as (t, value) pairs, skipping undefined values.
    pub fn series(&self, name: &str) -> Option<Vec<(f64, f64)>> {
        let c = self.column(name)?;
        Some(self.times.iter().zip(&self.rows).filter_map(|(t, r)| r[c].map(|v| (*t, v))).collect())
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    #[error("{0}")]
    Model(#[from] ModelError),
    #[error("integration failed: {0}")]
    Integrator(#[from] IntegratorError),
    /// The step-size controller gave up: the state named had the largest
    /// weighted error (usually the component whose parameters make the
    /// problem ill-posed or whose time scale is far below the others).
    #[error("integration failed: step size fell below {h:.1e} s at t = {} s (largest error in {state}; check that component's parameters, or raise simulation.rtol)", num(*t))]
    StepTooSmall { t: f64, h: f64, state: String },
    /// The run took more steps than [`step_budget`] allows: a time scale
    /// far below the circuit's others, or a law too rough for the
    /// integrator, in the state named.
    #[error(
        "integration stopped after {steps} steps by t = {} s, each about {} s long (largest error in {state}): the circuit has a time scale far below the others; check that component's parameters (an implausibly large conductance, a tiny volume or mass); the limit is 20 steps of simulation.max_step per run, at least {MIN_STEP_BUDGET} (a smaller max_step allows more)",
        units::show::sig(*t, 6),
        units::show::sig(*h, 2)
    )]
    TooManySteps { t: f64, steps: usize, h: f64, state: String },
    #[error("more than {limit} events by t = {} s (chattering between modes?)", num(*t))]
    TooManyEvents { t: f64, limit: usize },
    #[error("at t = {} s the event conditions of {roots} still hold after handling them {rounds} times", num(*t))]
    Unsettled { t: f64, roots: String, rounds: usize },
    #[error("invalid settings: {0}")]
    Settings(String),
    #[error("{0}")]
    Rest(#[from] crate::rest::RestError),
    #[error("cancelled at t = {} s", num(*t))]
    Cancelled { t: f64 },
    /// A parameter sensitivity does not exist or could not be formed
    /// (see [`crate::sensitivity`]).
    #[error("sensitivities: {0}")]
    Sensitivity(String),
}

/// The model seen by the integrator.
pub(crate) struct System<'a> {
    pub(crate) model: &'a mut Model,
    pub(crate) error: Option<ModelError>,
    /// How the Jacobian is formed.
    pub(crate) jacobian: &'a mut Jacobian,
    pub(crate) cancel: Option<&'a Cancel>,
    /// Parameter sensitivities integrated beside the state, if asked.
    pub(crate) sens: Option<&'a mut Tracker>,
}

impl System<'_> {
    /// One evaluation of the model for f (and the root functions if asked).
    fn eval_both(&mut self, t: f64, y: &[f64], dydt: &mut [f64], g: Option<&mut [f64]>) -> Result<(), RhsError> {
        if self.cancel.is_some_and(Cancel::is_cancelled) {
            return Err(RhsError("cancelled".into()));
        }
        match self.model.eval(t, y, Some(dydt), g) {
            Ok(()) => {
                self.error = None;
                Ok(())
            }
            // A trial stage of a large step may leave the physical domain
            // (negative mass; a piston far past its stop, so that a chamber's
            // volume clamps to zero and its derivatives overflow): answer NaN
            // so the integrator rejects the step and retries with a smaller
            // one; keep the reason for the message in case it gives up.
            Err(e @ (ModelError::NonPhysical { .. } | ModelError::NonFinite { .. })) => {
                self.error = Some(e);
                dydt.fill(f64::NAN);
                Ok(())
            }
            Err(e) => {
                let msg = e.to_string();
                self.error = Some(e);
                Err(RhsError(msg))
            }
        }
    }
}

impl OdeSystem for System<'_> {
    fn dim(&self) -> usize {
        self.model.dim()
    }
    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) -> Result<(), RhsError> {
        self.eval_both(t, y, dydt, None)
    }
    fn rhs_and_roots(&mut self, t: f64, y: &[f64], dydt: &mut [f64], g: &mut [f64]) -> Result<(), RhsError> {
        self.eval_both(t, y, dydt, Some(g))
    }
    fn n_quadrature(&self) -> usize {
        self.model.n_quadratures()
    }
    fn autonomous(&self) -> bool {
        !self.model.circuit.instances.iter().any(|i| i.block.time_dependent())
    }
    fn n_roots(&self) -> usize {
        self.model.n_roots()
    }
    fn roots(&mut self, t: f64, y: &[f64], g: &mut [f64]) -> Result<(), RhsError> {
        self.model.eval(t, y, None, Some(g)).map_err(|e| {
            let msg = e.to_string();
            self.error = Some(e);
            RhsError(msg)
        })
    }
    fn root_directions(&self, out: &mut [RootDirection]) {
        // the convention of every root of the model (see `model.rs`)
        out.fill(RootDirection::Rising);
    }
    fn sensitivity_rhs(&mut self, k: usize, t: f64, y: &[f64], f: &[f64], s: &[f64], out: &mut [f64]) -> Result<(), RhsError> {
        match self.sens.as_deref_mut() {
            Some(tracker) => tracker.rhs(k, t, y, f, s, out),
            None => Err(RhsError("no sensitivities were asked for".into())),
        }
    }
    fn jacobian_sparsity(&self) -> Option<ode::Sparsity> {
        match &*self.jacobian {
            Jacobian::Exact(e) => Some(e.pattern().clone()),
            Jacobian::Grouped(g) => Some(g.0.pattern().clone()),
            Jacobian::Plain => None,
        }
    }
    fn jacobian(&mut self, t: f64, y: &[f64], _f0: &[f64], deltas: &[f64], values: &mut [f64]) -> Result<bool, RhsError> {
        let filled = match &mut *self.jacobian {
            Jacobian::Exact(e) => e.fill(self.model, t, y, values),
            Jacobian::Grouped(g) => {
                let (s, work) = &mut **g;
                s.fill(self.model, work, t, y, deltas, values)
            }
            Jacobian::Plain => return Ok(false),
        };
        match filled {
            Ok(()) => {
                self.error = None;
                Ok(true)
            }
            Err(e @ (ModelError::NonPhysical { .. } | ModelError::NonFinite { .. })) => {
                self.error = Some(e);
                values.fill(f64::NAN);
                Ok(true)
            }
            Err(e) => {
                let msg = e.to_string();
                self.error = Some(e);
                Err(RhsError(msg))
            }
        }
    }
}

/// How a run forms its Jacobian (see [`JacobianMethod`]).
#[derive(Debug)]
pub(crate) enum Jacobian {
    Exact(Box<Exact>),
    Grouped(Box<(Structure, Workspace)>),
    Plain,
}

impl Jacobian {
    /// The best of `method` this model allows: exact and grouped differences
    /// need the circuit's structure (a block with more than 64 ports of one
    /// kind has none), grouped differences are used only where they pay.
    pub(crate) fn for_model(model: &Model, method: JacobianMethod) -> Jacobian {
        match method {
            JacobianMethod::Exact => match Structure::new(model) {
                Some(s) => Jacobian::Exact(Box::new(Exact::new(model, s.pattern().clone()))),
                None => Jacobian::Plain,
            },
            JacobianMethod::GroupedDifferences => match worthwhile_structure(model) {
                Some(s) => Jacobian::Grouped(Box::new((s, Workspace::default()))),
                None => Jacobian::Plain,
            },
            JacobianMethod::PlainDifferences => Jacobian::Plain,
        }
    }

    /// The method actually in use.
    pub(crate) fn method(&self) -> JacobianMethod {
        match self {
            Jacobian::Exact(_) => JacobianMethod::Exact,
            Jacobian::Grouped(..) => JacobianMethod::GroupedDifferences,
            Jacobian::Plain => JacobianMethod::PlainDifferences,
        }
    }
}

/// The Jacobian structure of `model` if it saves work over plain differences:
/// always for systems large enough for the sparse LU, otherwise when it needs
/// at most half the model evaluations per Jacobian.
pub(crate) fn worthwhile_structure(model: &Model) -> Option<Structure> {
    let s = Structure::new(model)?;
    let ns = model.n_states;
    (ns >= ode::SPARSE_LU_MIN_STATES || 2 * s.evaluations_per_jacobian() <= ns).then_some(s)
}

/// Where an observed run is when it calls its observer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CheckpointKind {
    /// The end of an accepted integrator step, before any event found in it is
    /// handled (a step cut short at a root is not shown: its end is the event).
    Step,
    /// An event instant, after every event there has been handled.
    Event,
}

/// What an observer of [`simulate_observed`] sees: the model evaluated at
/// (t, y) in its current modes, and the values of all root functions there.
#[derive(Debug)]
pub struct Checkpoint<'a> {
    pub t: f64,
    pub kind: CheckpointKind,
    pub y: &'a [f64],
    pub roots: &'a [f64],
    pub model: &'a Model,
}

/// Run the model from its initial state.
pub fn simulate(model: &mut Model, opts: &SimOptions) -> Result<SimResult, SolveError> {
    run(model, opts, None, None)
}

/// [`simulate`] with parameter sensitivities (see [`crate::sensitivity`]).
pub(crate) fn run_tracked(model: &mut Model, opts: &SimOptions, tracker: &mut Tracker) -> Result<SimResult, SolveError> {
    run(model, opts, None, Some(tracker))
}

/// [`simulate`], calling `observer` at every accepted integrator step and every
/// event instant (for tests of the event logic). Observing does not change the
/// run: the extra evaluations leave no trace in the model.
pub fn simulate_observed(model: &mut Model, opts: &SimOptions, observer: &mut dyn FnMut(&Checkpoint)) -> Result<SimResult, SolveError> {
    run(model, opts, Some(observer), None)
}

fn run(
    model: &mut Model,
    opts: &SimOptions,
    mut observer: Option<&mut dyn FnMut(&Checkpoint)>,
    mut sens: Option<&mut Tracker>,
) -> Result<SimResult, SolveError> {
    if !(opts.t_end > 0.0 && opts.t_end.is_finite()) {
        return Err(SolveError::Settings(format!("end time must be > 0 s, got {}", num(opts.t_end))));
    }
    let rest =
        if model.circuit.simulation.initial == graph::netlist::InitialMode::Rest { crate::rest::apply(model)? } else { Default::default() };
    let mut y = model.initial_state();
    let n = model.dim();
    // sensitivities read whole rows: they record in full
    let wanted = if sens.is_some() { None } else { signal_subset(model, opts.record_only.as_deref())? };
    let wanted = wanted.as_deref();
    let mut integrator = integrator_for(model, opts, &y)?;
    let mut jacobian = Jacobian::for_model(model, opts.jacobian);
    let mut t = 0.0;
    let mut result = SimResult {
        columns: model.output_names(),
        units: model.output_units(),
        times: Vec::new(),
        rows: Vec::new(),
        cycles: Vec::new(),
        events: Vec::new(),
        balance: Balance::default(),
        t_final: 0.0,
        stats: Default::default(),
        rhs_evaluations: 0,
        linear_algebra: "dense",
        evaluations_per_jacobian: {
            // ∂f/∂t costs one more unless no block depends on time
            let dt = usize::from(model.circuit.instances.iter().any(|i| i.block.time_dependent()));
            match &jacobian {
                Jacobian::Exact(_) => 1 + dt,
                Jacobian::Grouped(g) => g.0.evaluations_per_jacobian() + dt,
                Jacobian::Plain => model.n_states + dt,
            }
        },
        jacobian: jacobian.method().name(),
        finite_difference_blocks: Vec::new(),
        rest,
        final_state: FinalState::default(),
        stroke_statistics: Vec::new(),
        cycle_statistics: Vec::new(),
        run_statistics: Vec::new(),
        cycle_controllers: model.circuit.instances.iter().filter(|i| i.block.counts_cycles()).map(|i| i.id.clone()).collect(),
    };
    // the blocks' quadratures at t = 0 and after every event, to difference over strokes
    let quad = model.n_states..model.n_states + model.n_block_quadratures;
    let mut snapshots: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut roots = vec![0.0; model.n_roots()];
    // velocities have the absolute tolerance opts.atol (their typical size is 1 m/s)
    model.velocity_band = opts.atol;

    // initial modes: at rest where v = 0, then break away if the forces say so
    initial_modes(model, t, &y)?;
    resolve_events(model, t, &mut y, &[], &[], &mut result)?;
    model.eval(t, &y, None, None)?;
    let initial = model.stored(t, &y);
    record(model, t, &y, &mut result, wanted)?;
    let n_sens = sens.as_ref().map_or(0, |s| s.n_params());
    if let Some(tracker) = sens.as_deref_mut() {
        let columns = tracker.start(model, &y, opts)?;
        tracker.record(t, &y, &result.rows[result.rows.len() - 1], &columns)?;
        integrator.set_sensitivities(&columns);
    }
    snapshots.push((t, y[quad.clone()].to_vec()));
    if let Some(obs) = observer.as_mut() {
        checkpoint(model, t, &y, CheckpointKind::Event, &mut roots, &mut **obs)?;
    }

    let mut next_sample = opts.sample_interval;
    let mut n_events = 0usize;
    let mut finished = false;
    let budget = step_budget(opts);
    let mut step_ends: Vec<(f64, Vec<f64>)> = Vec::new();
    while !finished {
        if opts.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
            return Err(SolveError::Cancelled { t });
        }
        let t_time_event = model.circuit.instances.iter().filter_map(|i| i.block.next_time_event(t)).fold(f64::INFINITY, f64::min);
        let t_stop = opts.t_end.min(t_time_event);
        let mut samples: Vec<(f64, Vec<f64>, Vec<Vec<f64>>)> = Vec::new();
        let observing = observer.is_some();
        step_ends.clear();
        let (t_advanced, steps_before) = (t, integrator.stats().steps);
        let advance = {
            let mut sys = System { model, error: None, jacobian: &mut jacobian, cancel: opts.cancel.as_ref(), sens: sens.as_deref_mut() };
            let interval = opts.sample_interval;
            let record_steps = opts.record_steps && interval <= 0.0;
            // the sensitivity columns at a sample time
            let columns_at = |d: &dyn Dense, ts: f64| -> Vec<Vec<f64>> {
                (0..n_sens)
                    .map(|k| {
                        let mut s = vec![0.0; n];
                        d.eval_sensitivity(k, ts, &mut s);
                        s
                    })
                    .collect()
            };
            let mut dense_observer = |d: &dyn Dense| {
                if observing || record_steps {
                    let mut ys = vec![0.0; n];
                    d.eval(d.t_end(), &mut ys);
                    if record_steps {
                        samples.push((d.t_end(), ys.clone(), columns_at(d, d.t_end())));
                    }
                    if observing {
                        step_ends.push((d.t_end(), ys));
                    }
                }
                if interval <= 0.0 {
                    return;
                }
                while next_sample <= d.t_end() + 1e-15 {
                    let mut ys = vec![0.0; n];
                    let ts = next_sample.min(d.t_end());
                    d.eval(ts, &mut ys);
                    samples.push((next_sample, ys, columns_at(d, ts)));
                    next_sample += interval;
                    // avoid drift: snap to the grid
                    next_sample = (next_sample / interval).round() * interval;
                }
            };
            let r = integrator.advance(&mut sys, &mut t, &mut y, t_stop, &mut dense_observer);
            match r {
                Ok(a) => a,
                Err(e) => {
                    let cancelled = opts.cancel.as_ref().is_some_and(Cancel::is_cancelled);
                    return Err(advance_error(e, sys.error.take(), sys.model, cancelled, t));
                }
            }
        };
        if let Some(obs) = observer.as_mut() {
            // the step cut short at a root ends at the event itself, shown after handling
            let shown = if matches!(advance, Advance::Root { .. }) { step_ends.len().saturating_sub(1) } else { step_ends.len() };
            for (ts, ys) in &step_ends[..shown] {
                checkpoint(model, *ts, ys, CheckpointKind::Step, &mut roots, &mut **obs)?;
            }
        }
        for (ts, ys, columns) in samples {
            if ts < t - 1e-15 || ts <= t {
                record(model, ts, &ys, &mut result, wanted)?;
                if let Some(tracker) = sens.as_deref_mut() {
                    tracker.record(ts, &ys, &result.rows[result.rows.len() - 1], &columns)?;
                }
            }
        }
        let taken = integrator.stats().steps;
        if taken >= budget && t < opts.t_end {
            let h = (t - t_advanced) / (taken - steps_before).max(1) as f64;
            return Err(SolveError::TooManySteps { t, steps: taken, h, state: model.state_name(integrator.largest_error()) });
        }
        let crossings = match advance {
            Advance::Reached if t >= opts.t_end => {
                finished = true;
                None
            }
            Advance::Reached => Some(Vec::new()),
            Advance::Root { indices } => Some(indices),
        };
        if let Some(crossings) = crossings {
            // time events due now, also when a root landed on the same instant
            let due = due_time_events(model, t);
            if !crossings.is_empty() || !due.is_empty() {
                n_events += 1;
                if n_events > opts.max_events {
                    return Err(SolveError::TooManyEvents { t, limit: opts.max_events });
                }
                let before = match sens.as_deref_mut() {
                    Some(tracker) => {
                        let columns = integrator_columns(&integrator);
                        tracker.before_event(model, t, &y, &crossings, &columns)?;
                        Some((y.clone(), columns))
                    }
                    None => None,
                };
                resolve_events(model, t, &mut y, &crossings, &due, &mut result)?;
                integrator.reset();
                record(model, t, &y, &mut result, wanted)?;
                if let (Some(tracker), Some((y_before, columns))) = (sens.as_deref_mut(), before) {
                    let columns = tracker.after_event(model, t, &y_before, &y, &crossings, &due, &columns)?;
                    tracker.record(t, &y, &result.rows[result.rows.len() - 1], &columns)?;
                    integrator.set_sensitivities(&columns);
                }
                snapshots.push((t, y[quad.clone()].to_vec()));
                if let Some(obs) = observer.as_mut() {
                    checkpoint(model, t, &y, CheckpointKind::Event, &mut roots, &mut **obs)?;
                }
            }
        }
        if let Some(n) = opts.cycles {
            if result.completed_cycles() >= n {
                finished = true;
            }
        }
        if model.circuit.instances.iter().any(|i| i.block.finished()) {
            finished = true;
        }
    }
    if result.times.last() != Some(&t) {
        record(model, t, &y, &mut result, wanted)?;
        if let Some(tracker) = sens.as_deref_mut() {
            tracker.record(t, &y, &result.rows[result.rows.len() - 1], &integrator_columns(&integrator))?;
        }
    }
    if let Some(tracker) = sens {
        tracker.set_final(integrator_columns(&integrator));
    }
    model.eval(t, &y, None, None)?;
    let last = model.stored(t, &y);
    let q = &y[n - N_QUADRATURE..];
    let (mass_in, energy_in, heat_in, work_out) = (q[0], q[1], q[2], q[3]);
    let mass_scale = initial.mass.max(last.mass).max(f64::MIN_POSITIVE);
    let energy_scale = [initial.energy, last.energy, energy_in, heat_in, work_out].iter().fold(f64::MIN_POSITIVE, |a, b| a.max(b.abs()));
    result.balance = Balance {
        mass_initial: initial.mass,
        mass_final: last.mass,
        mass_in,
        mass_residual: (last.mass - initial.mass - mass_in) / mass_scale,
        energy_initial: initial.energy,
        energy_final: last.energy,
        energy_in,
        heat_in,
        work_out,
        energy_residual: (last.energy - initial.energy - energy_in - heat_in + work_out) / energy_scale,
    };
    result.final_state = final_state(model);
    snapshots.push((t, y[quad.clone()].to_vec()));
    result.stroke_statistics = stroke_statistics(model, &result.cycles, &snapshots);
    result.cycle_statistics = cycle_statistics(model, &result.cycles, &snapshots);
    result.run_statistics = interval_statistics(model, &snapshots[0].1, &snapshots[snapshots.len() - 1].1)
        .into_iter()
        .map(|(id, name, value)| StrokeStatistic { controller: String::new(), cycle: 0, stroke: "run", id, name, value })
        .collect();
    result.t_final = t;
    result.stats = integrator.stats();
    result.linear_algebra = integrator.linear_algebra();
    result.rhs_evaluations = model.evaluations;
    if let Jacobian::Exact(e) = &jacobian {
        result.finite_difference_blocks = e.fallback_blocks(model);
    }
    Ok(result)
}

/// The integrator's sensitivity columns at its current point.
fn integrator_columns(integrator: &Rosenbrock) -> Vec<Vec<f64>> {
    (0..integrator.n_sensitivities()).map(|k| integrator.sensitivity(k).to_vec()).collect()
}

/// Fewest steps a run may take before it is stopped.
pub const MIN_STEP_BUDGET: usize = 200_000;

/// Most accepted steps a run may take: twenty times the steps of `max_step`
/// that fill the run, and at least [`MIN_STEP_BUDGET`], at most 5·10⁷. A
/// pneumatic circuit takes tens to thousands of steps per second of circuit
/// time (meter-out: about 60); a run that needs 10⁵ times more has a
/// component whose time scale is far below the others (a conductance of
/// 10¹⁰ L/min/bar found by a random test took 9·10⁵ steps of 6e-8 s for
/// 50 ms of circuit time), and would otherwise run for hours instead of
/// saying so. Checked after every `advance` (its own limit is the same
/// number), so a run stops within twice the budget.
pub fn step_budget(opts: &SimOptions) -> usize {
    let filled = 20.0 * opts.t_end / opts.max_step;
    if filled.is_nan() {
        return MIN_STEP_BUDGET;
    }
    filled.clamp(MIN_STEP_BUDGET as f64, 5e7) as usize
}

/// The integrator of a run: tolerances checked, absolute tolerances scaled
/// by each state's typical size at `y`.
pub(crate) fn integrator_for(model: &Model, opts: &SimOptions, y: &[f64]) -> Result<Rosenbrock, SolveError> {
    if !(opts.rtol > 0.0 && opts.rtol < 1.0 && opts.atol > 0.0) {
        return Err(SolveError::Settings(format!("tolerances must be in (0, 1): rtol {} atol {}", num(opts.rtol), num(opts.atol))));
    }
    let n = model.dim();
    let scales = model.state_scales(y);
    let mut atol: Vec<f64> = scales.iter().map(|s| opts.atol * s).collect();
    for a in atol[n - model.n_quadratures()..].iter_mut() {
        *a = 1e30; // quadratures (balances, statistics) do not steer the step size
    }
    let options = Options {
        rtol: opts.rtol,
        atol,
        h_init: None,
        h_max: opts.max_step,
        h_min: 1e-14,
        max_steps: step_budget(opts),
        root_tol: 1e-12,
        event_window: 0.0,
        event_window_per_step: opts.rtol,
    };
    Ok(Rosenbrock::with_method(options, n, opts.method))
}

/// Modes of the mechanical nodes at the start of a run: at rest where v = 0
/// (the event handling that follows breaks them away if the forces say so).
pub(crate) fn initial_modes(model: &mut Model, t: f64, y: &[f64]) -> Result<(), SolveError> {
    model.eval(t, y, None, None)?;
    for node in 0..model.circuit.mechanical_nodes.len() {
        let m = model.node_mech[node];
        let stops = model.circuit.instances[model.circuit.mechanical_nodes[node].inertia.block].block.stops();
        model.modes[node] = if m.v == 0.0 { mechanics::held_at(m.x, stops) } else { Mode::Sliding { dir: m.v.signum() } };
    }
    Ok(())
}

/// The blocks whose time events are due at `t`.
pub(crate) fn due_time_events(model: &Model, t: f64) -> Vec<usize> {
    (0..model.circuit.instances.len())
        .filter(|&bi| {
            let next = model.circuit.instances[bi].block.next_time_event(t - 1e-12 * t.max(1.0));
            matches!(next, Some(d) if (d - t).abs() <= 1e-12 * t.max(1.0))
        })
        .collect()
}

/// The error of a failed `advance`: cancellation, the model's own error if it
/// gave one, else the integrator's (a step-size failure names the state).
pub(crate) fn advance_error(e: IntegratorError, model_error: Option<ModelError>, model: &Model, cancelled: bool, t: f64) -> SolveError {
    match (e, model_error) {
        _ if cancelled => SolveError::Cancelled { t },
        (_, Some(model_error)) => model_error.into(),
        (IntegratorError::StepSizeTooSmall { t, h, index }, None) => SolveError::StepTooSmall { t, h, state: model.state_name(index) },
        (IntegratorError::TooManySteps { t, steps, h, index }, None) => {
            SolveError::TooManySteps { t, steps, h, state: model.state_name(index) }
        }
        (e, None) => e.into(),
    }
}

/// The quadratures recorded at the instant `t` (an event), if any.
fn snapshot_at(snapshots: &[(f64, Vec<f64>)], t: f64) -> Option<&[f64]> {
    snapshots.iter().find(|(ts, _)| (ts - t).abs() <= 1e-9 * t.abs().max(1.0)).map(|(_, v)| v.as_slice())
}

/// Every block's statistics from the increments of its quadratures between two snapshots.
fn interval_statistics(model: &Model, a: &[f64], b: &[f64]) -> Vec<(String, &'static str, Option<f64>)> {
    let mut out = Vec::new();
    let base = model.n_states;
    for (bi, slot) in model.slots.iter().enumerate() {
        if slot.quad.is_empty() {
            continue;
        }
        let inc: Vec<f64> = slot.quad.clone().map(|i| b[i - base] - a[i - base]).collect();
        let inst = &model.circuit.instances[bi];
        for (name, value) in inst.block.quadrature_statistics(&inc) {
            out.push((inst.id.clone(), name, value));
        }
    }
    out
}

/// Number of each cycle within its controller's cycles, from 1.
fn cycle_numbers(cycles: &[CycleRecord]) -> Vec<usize> {
    let mut seen: Vec<(&str, usize)> = Vec::new();
    cycles
        .iter()
        .map(|c| match seen.iter_mut().find(|(id, _)| *id == c.controller) {
            Some((_, n)) => {
                *n += 1;
                *n
            }
            None => {
                seen.push((&c.controller, 1));
                1
            }
        })
        .collect()
}

/// Block statistics over the extend and retract strokes of every cycle, from
/// the quadratures recorded at the events that bound them (controllers
/// without strokes have none).
fn stroke_statistics(model: &Model, cycles: &[CycleRecord], snapshots: &[(f64, Vec<f64>)]) -> Vec<StrokeStatistic> {
    let mut out = Vec::new();
    for (c, k) in cycles.iter().zip(cycle_numbers(cycles)) {
        let strokes = [("extend", c.start, c.start + c.extend), ("retract", c.retract_start, c.retract_start + c.retract)];
        for (stroke, t0, t1) in strokes {
            if !(t0.is_finite() && t1.is_finite()) {
                continue;
            }
            let (Some(a), Some(b)) = (snapshot_at(snapshots, t0), snapshot_at(snapshots, t1)) else { continue };
            for (id, name, value) in interval_statistics(model, a, b) {
                out.push(StrokeStatistic { controller: c.controller.clone(), cycle: k, stroke, id, name, value });
            }
        }
    }
    out
}

/// Block statistics over every whole cycle (from its start to the start of
/// the next, dwells included) of every controller.
fn cycle_statistics(model: &Model, cycles: &[CycleRecord], snapshots: &[(f64, Vec<f64>)]) -> Vec<StrokeStatistic> {
    let mut out = Vec::new();
    for (c, k) in cycles.iter().zip(cycle_numbers(cycles)) {
        let (Some(a), Some(b)) = (snapshot_at(snapshots, c.start), snapshot_at(snapshots, c.start + c.total)) else { continue };
        for (id, name, value) in interval_statistics(model, a, b) {
            out.push(StrokeStatistic { controller: c.controller.clone(), cycle: k, stroke: "cycle", id, name, value });
        }
    }
    out
}

/// Evaluate the model and its roots at (t, y) without disturbing the run and show them to the observer.
fn checkpoint(
    model: &mut Model,
    t: f64,
    y: &[f64],
    kind: CheckpointKind,
    roots: &mut [f64],
    observer: &mut dyn FnMut(&Checkpoint),
) -> Result<(), SolveError> {
    model.eval_detached(t, y, None, Some(roots))?;
    observer(&Checkpoint { t, kind, y, roots, model });
    Ok(())
}

/// Rounds of event handling at one instant before an event condition that
/// does not clear is reported as [`SolveError::Unsettled`].
const MAX_ROUNDS: usize = 8;

/// Handle everything that happens at the instant t: the block events whose
/// roots fired (`crossings`, model root indices), the time events of the
/// blocks in `due`, and the transitions of the mechanical nodes (the fired
/// node roots decide them, see [`mechanics::transition`]). Then evaluate every
/// root again in the new state: one that is still positive (its event
/// condition holds although nothing reported it) is handled as fired, so a
/// held or closed mode never outlives its exit condition; the integrator
/// then restarts with every root ≤ 0, i.e. watched from its "no event" side.
pub(crate) fn resolve_events(
    model: &mut Model,
    t: f64,
    y: &mut [f64],
    crossings: &[usize],
    due: &[usize],
    result: &mut SimResult,
) -> Result<(), SolveError> {
    // The work per instant is a few evaluations of the model and one look at
    // each fired root: handling k coincident events never loops over all
    // roots once per event (which made N drives switching together cost N²).
    model.forget_last_evaluation(); // blocks and modes change here
    let mut fired: Vec<usize> = crossings.to_vec();
    fired.sort_unstable();
    fired.dedup();
    let n_block_events = model.n_block_events;
    let mut g = vec![0.0; model.n_roots()];
    let mut node_fired = vec![[false; mechanics::N_ROOTS]; model.circuit.mechanical_nodes.len()];
    for round in 0..MAX_ROUNDS {
        model.eval(t, y, None, None)?;
        // block events in block order (the order of their root indices)
        for &idx in fired.iter().take_while(|&&i| i < n_block_events) {
            let bi = model.event_owner(idx);
            let k = idx - model.slots[bi].events.start;
            handle_block_event(model, bi, EventKind::Crossing(k), t, y, result)?;
        }
        if round == 0 {
            for &bi in due {
                handle_block_event(model, bi, EventKind::Time, t, y, result)?;
            }
        }
        node_fired.iter_mut().for_each(|f| *f = [false; mechanics::N_ROOTS]);
        for &idx in fired.iter().filter(|&&i| i >= n_block_events) {
            let k = idx - n_block_events;
            node_fired[k / mechanics::N_ROOTS][k % mechanics::N_ROOTS] = true;
        }
        settle(model, t, y, &node_fired, &mut result.events)?;
        model.eval(t, y, None, Some(&mut g))?;
        fired = (0..g.len()).filter(|&i| g[i] > 0.0).collect();
        if fired.is_empty() {
            return Ok(());
        }
    }
    let roots = fired.iter().map(|&i| model.root_name(i)).collect::<Vec<_>>().join(", ");
    Err(SolveError::Unsettled { t, roots, rounds: MAX_ROUNDS })
}

fn handle_block_event(model: &mut Model, bi: usize, kind: EventKind, t: f64, y: &[f64], result: &mut SimResult) -> Result<(), SolveError> {
    // the context must outlive the mutable borrow of the block: copy the buffers
    let slot = model.slots[bi].clone();
    let gas = model.gas.clone();
    let ctx = blocks::block::Ctx {
        t,
        gas: &*gas,
        states: &y[slot.states.clone()],
        pneumatic: &slot.gas,
        mechanical: &slot.mech,
        signals: &slot.sig,
    };
    model.forget_last_evaluation();
    let inst = &mut model.circuit.instances[bi];
    let outcome = inst.block.on_event(kind, &ctx);
    if let Some(note) = outcome.note {
        result.events.push(EventLog { t, what: format!("{}: {note}", inst.id) });
    }
    if let Some(mut c) = outcome.cycle {
        c.controller = inst.id.clone();
        result.cycles.push(c);
    }
    Ok(())
}

/// Apply node transitions until no node changes mode. `fired[node]` are the
/// node's roots that fired at this instant (used in the first pass only).
/// Transitions are final (see [`mechanics::transition`]), so two passes
/// settle every node; one that still changes after [`MAX_ROUNDS`] is an error.
fn settle(
    model: &mut Model,
    t: f64,
    y: &mut [f64],
    fired: &[[bool; mechanics::N_ROOTS]],
    log: &mut Vec<EventLog>,
) -> Result<(), SolveError> {
    for pass in 0..MAX_ROUNDS {
        model.eval(t, y, None, None)?;
        let mut changed = Vec::new();
        for node in 0..model.circuit.mechanical_nodes.len() {
            let r = model.circuit.mechanical_nodes[node].inertia;
            let block = &model.circuit.instances[r.block].block;
            let body = mechanics::Body {
                mass: crate::model::node_mass(&model.circuit, node),
                stops: block.stops(),
                velocity_band: model.velocity_band,
            };
            let m = model.node_mech[node];
            let f = model.node_forces[node];
            let fired_now = if pass == 0 { fired.get(node).copied().unwrap_or_default() } else { [false; mechanics::N_ROOTS] };
            if let Some(tr) = mechanics::transition(model.modes[node], m.x, m.v, &f, &body, fired_now) {
                if let Some((x, v)) = tr.reset {
                    let states = model.slots[r.block].states.clone();
                    model.circuit.instances[r.block].block.reset_motion(&mut y[states], MechState { x, v });
                }
                let id = &model.circuit.instances[r.block].id;
                let what = mode_name(tr.mode);
                if tr.mode != model.modes[node] || tr.reset.is_some_and(|(x, v)| x != m.x || v != m.v) {
                    log.push(EventLog { t, what: format!("{id}: {what}") });
                    changed.push(id.clone());
                }
                model.modes[node] = tr.mode;
            }
        }
        if changed.is_empty() {
            return Ok(());
        }
        if pass + 1 == MAX_ROUNDS {
            return Err(SolveError::Unsettled { t, roots: format!("the modes of {}", changed.join(", ")), rounds: MAX_ROUNDS });
        }
    }
    Ok(())
}

/// The (row column, signal index) pairs of `record_only` if every name in
/// it is a signal output; `None` (record every column) if some name is a
/// block output computed from a whole evaluation or no names were given.
fn signal_subset(model: &Model, record_only: Option<&[String]>) -> Result<Option<Vec<(usize, usize)>>, SolveError> {
    let Some(names) = record_only else { return Ok(None) };
    let signals = model.signal_columns();
    let columns = model.output_names();
    let mut wanted = Vec::with_capacity(names.len());
    let mut all_signals = true;
    for name in names {
        match signals.iter().find(|(s, ..)| s == name) {
            Some(&(_, column, signal)) => wanted.push((column, signal)),
            None if columns.contains(name) => all_signals = false,
            None => return Err(SolveError::Settings(format!("record_only: the model has no output \"{}\"", units::show::text(name)))),
        }
    }
    Ok(all_signals.then_some(wanted))
}

fn record(model: &mut Model, t: f64, y: &[f64], result: &mut SimResult, wanted: Option<&[(usize, usize)]>) -> Result<(), SolveError> {
    let mut row = vec![None; model.n_outputs];
    match wanted {
        Some(w) => model.record_signals(t, y, w, &mut row)?,
        None => model.record(t, y, &mut row)?,
    }
    result.times.push(t);
    result.rows.push(row);
    Ok(())
}
