//! The hybrid simulation: integrates the rig mode by mode and handles the
//! discrete events between modes.
//!
//! # Events
//!
//! | event | detected by | action |
//! |---|---|---|
//! | breakaway (stuck → slide) | F_a − F_s or −F_a − F_s crosses 0 (not into an end stop) | slide in that direction, v = 0 |
//! | stop (slide → stuck or reversal) | d·v crosses 0 | v = 0, then decide stuck/slide by Karnopp's stick condition |
//! | end stop | x reaches 0 or L while sliding towards it | x clamped, v = 0 (inelastic), then decide |
//! | limit switch | x crosses L − tol (extending) or tol (retracting) | cycler: record time, schedule the valve |
//! | valve switch | its scheduled time (command + latency/dwell + valve delay) | new spool position |
//!
//! State events are located precisely: after each accepted step the event
//! functions are checked at the end point and at three interior points of
//! the interpolant; a sign change is then bracketed and narrowed by the
//! Illinois method on *trial steps* (the last step repeated with a shorter
//! step size, `Sdirk::trial`) to a bracket of 10⁻¹¹ s. The event state is
//! the trial-step state at the upper end of the bracket, where the event
//! condition already holds — so a piston is never released before
//! |F_a| ≥ F_s, and is held at most 10⁻¹¹ s past that instant. Timed events
//! (valve switches) are hit exactly by ending a step on them.
//!
//! Right after a breakaway v = 0, so the stop event is armed only once the
//! velocity has left the noise band (ten times its absolute error weight)
//! in the sliding direction. If instead the velocity turns against the
//! sliding direction first — the net force grazed the breakaway level and
//! fell back — the piston is taken never to have moved: v = 0 and the
//! decision at rest below is made again (a "graze").
//!
//! Decision at rest (Karnopp 1985): with v = 0 the piston slides in
//! direction d = sgn(F_a) if |F_a| ≥ F_s and no end stop blocks direction d;
//! otherwise it is held (by friction, or by the stop for forces into it).
//!
//! # Cycler
//! Extend is commanded at t = 0 (the valve, un-actuated before, follows
//! after the valve delay). The extend switch (x ≥ L − tol) records the
//! extend time and commands retract; the retract switch (x ≤ tol) records
//! the retract time, closes the cycle and commands extend. Times are
//! measured between switch trips (the first cycle from t = 0): extend =
//! t_trip,ext − t_cycle start, retract = t_trip,ret − t_trip,ext,
//! total = extend + retract. Latency and dwells delay the command after a
//! trip and are therefore included in the following phase.

use crate::error::RigError;
use crate::model::{Mech, Mode, ModeSystem, Plant, ValvePos, I_V, I_X, N_QUAD};
use crate::params::{Effects, ModelForm, Rig, RunSpec, Sampling};
use crate::roots::illinois;
use crate::sdirk::{Sdirk, SolverStats, StepError};

/// Times of one completed cycle [s].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleTimes {
    /// From the start of the cycle to the extend switch.
    pub extend: f64,
    /// From the extend switch to the retract switch.
    pub retract: f64,
    /// extend + retract.
    pub total: f64,
}

/// What happened at an event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EventKind {
    /// The spool moved to this position.
    ValveSwitch(ValvePos),
    /// The piston broke away in this direction (+1 extend, −1 retract).
    Breakaway(f64),
    /// The piston came to rest by friction (velocity crossed zero) and stuck.
    Stick,
    /// The velocity crossed zero and the piston slid on in the other direction.
    Reversal(f64),
    /// The piston hit an end stop (`true`: x = stroke).
    EndStop(bool),
    /// The extend limit switch tripped.
    SwitchExtended,
    /// The retract limit switch tripped (a cycle closed).
    SwitchRetracted,
}

/// A discrete event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventRecord {
    /// Time [s].
    pub t: f64,
    /// Kind.
    pub kind: EventKind,
}

/// Mass and energy accounts of the gas at the end of a run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Balance {
    /// Net mass that entered from the supply and the atmosphere [kg].
    pub mass_in: f64,
    /// Change of the stored gas mass [kg].
    pub mass_change: f64,
    /// mass_change − mass_in [kg].
    pub mass_residual: f64,
    /// Net enthalpy that entered with the boundary flows [J].
    pub enthalpy_in: f64,
    /// Wall heat into the gas [J].
    pub wall_heat: f64,
    /// Work done by the gas on the piston [J].
    pub work: f64,
    /// Change of the internal energy of the gas [J].
    pub energy_change: f64,
    /// energy_change − (enthalpy_in + wall_heat − work) [J].
    pub energy_residual: f64,
    /// |energy_residual| over the largest of |U(0)|, |U(end)|, |H_in|, |Q|, |W|.
    pub energy_residual_rel: f64,
}

/// The result of a run: samples at the requested instants, cycles, events.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Sample instants [s].
    pub t: Vec<f64>,
    /// Head-chamber (chamber 1) pressure [Pa].
    pub p1: Vec<f64>,
    /// Rod-chamber (chamber 2) pressure [Pa].
    pub p2: Vec<f64>,
    /// Piston position [m].
    pub x: Vec<f64>,
    /// Piston velocity [m/s].
    pub v: Vec<f64>,
    /// Head-chamber temperature [K].
    pub temp1: Vec<f64>,
    /// Rod-chamber temperature [K].
    pub temp2: Vec<f64>,
    /// Head-chamber gas mass [kg].
    pub m1: Vec<f64>,
    /// Rod-chamber gas mass [kg].
    pub m2: Vec<f64>,
    /// Pressure at the 5/2 valve's supply port [Pa] (the supply, or the line
    /// volume with supply droop).
    pub p_supply: Vec<f64>,
    /// Pressure of the junction between the 5/2 valve and the speed-control valve [Pa].
    pub p_junction: Vec<f64>,
    /// Net pneumatic force on the piston F_a [N].
    pub f_applied: Vec<f64>,
    /// Breakaway friction level F_s [N].
    pub f_breakaway: Vec<f64>,
    /// Piston held (stuck mode).
    pub stuck: Vec<bool>,
    /// Spool in the extend position.
    pub valve_extend: Vec<bool>,
    /// Completed cycles.
    pub cycles: Vec<CycleTimes>,
    /// Discrete events in time order.
    pub events: Vec<EventRecord>,
    /// Integrator counters.
    pub stats: SolverStats,
    /// Largest excess of the applied force over the breakaway level while
    /// the piston was held, at every integration point (accepted step ends
    /// and event states), forces into an end stop excluded [N]. (Samples are
    /// interpolated between integration points and may show excesses at the
    /// level of the integration tolerance; they are not counted here.)
    pub max_hold_excess: f64,
    /// Gas mass and energy accounts.
    pub balance: Balance,
    /// Time the run ended [s].
    pub t_final: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Extending,
    Retracting,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Ev {
    BreakFwd,
    BreakBwd,
    Stop,
    EndStop,
    Switch,
    /// A breakaway that did not lead to motion: the velocity went against
    /// the sliding direction before leaving the noise band.
    Graze,
}

/// An event found in a step: time, state, the events that hold there.
type Located = (f64, Vec<f64>, Vec<Ev>);

const F_REF: f64 = 1.0;
const X_REF: f64 = 1e-3;
const V_REF: f64 = 1e-3;
const EVENT_TIME_TOL: f64 = 1e-11;

struct Driver<'a> {
    plant: &'a Plant,
    form: &'a ModelForm,
    valve_delay: f64,
    mode: Mode,
    phase: Phase,
    cycle_start: f64,
    t_ext_trip: f64,
    pending: Vec<(f64, ValvePos)>,
    /// While stuck: which end stop holds the piston (`Some(true)`: x = L),
    /// if any.
    at_stop: Option<bool>,
    /// Velocity the piston must exceed in its sliding direction before the
    /// stop event is armed: ten times the velocity's absolute error weight,
    /// so integration noise around v = 0 right after a breakaway is not
    /// taken for a stop [m/s].
    v_arm: f64,
    trace: Trace,
    samples: SampleClock,
    target_cycles: Option<usize>,
    done: bool,
    max_events: usize,
}

struct SampleClock {
    every: Option<f64>,
    list: Vec<f64>,
    next: usize,
    t_end: f64,
}

impl SampleClock {
    fn peek(&self) -> Option<f64> {
        let t = match self.every {
            Some(dt) => self.next as f64 * dt,
            None => *self.list.get(self.next)?,
        };
        (t <= self.t_end).then_some(t)
    }
}

/// The state at an integration failure, for the error message: chamber
/// pressures and temperatures, position, velocity and the discrete mode.
fn describe_state(plant: &Plant, mode: &Mode, y: &[f64]) -> String {
    let (p1, p2) = plant.pressures(y);
    let mut text = format!(
        "p_head {:.5} bar, T_head {:.2} K, p_rod {:.5} bar, T_rod {:.2} K, x {:.4} mm, v {:.5} m/s, valve {:?}, piston {}",
        p1 / 1e5,
        y[crate::model::I_T1],
        p2 / 1e5,
        y[crate::model::I_T2],
        y[I_X] * 1e3,
        y[I_V],
        mode.valve,
        match mode.mech {
            Mech::Stuck => "held".to_string(),
            Mech::Slide(d) => format!("sliding {}", if d > 0.0 { "out" } else { "in" }),
        }
    );
    if let Some((_, volume, _)) = plant.line {
        text += &format!(", supply line {:.5} bar", plant.gas.pressure(y[crate::model::I_ML] / volume, y[crate::model::I_TL]) / 1e5);
    }
    text
}

impl Driver<'_> {
    /// An integrator failure as a rig error naming the time and the state
    /// (the stepper's current point).
    fn step_error(&self, e: StepError, y: &[f64], limit: usize) -> RigError {
        let state = describe_state(self.plant, &self.mode, y);
        match e {
            StepError::TooSmall { t, h } => RigError::StepSizeTooSmall { t, h, state },
            StepError::TooManySteps { t, h, attempts } => RigError::StepLimit { t, h, attempts, limit, state },
            StepError::NonPhysical { t } => {
                RigError::NonPhysical { t, what: format!("mass, temperature or volume not positive; state {state}") }
            }
        }
    }
}

impl<'a> Driver<'a> {
    fn sys(&self) -> ModeSystem<'a> {
        ModeSystem { plant: self.plant, mode: self.mode }
    }

    /// Normalised event functions that are meaningful in the current mode.
    fn event_values(&self, y: &[f64]) -> [(Ev, Option<f64>); 3] {
        let p = self.plant;
        let x = y[I_X];
        match self.mode.mech {
            Mech::Stuck => {
                let (fa, fs) = p.forces(y, &p.variant);
                let fwd = (self.at_stop != Some(true)).then_some((fa - fs) / F_REF);
                let bwd = (self.at_stop != Some(false)).then_some((-fa - fs) / F_REF);
                [(Ev::BreakFwd, fwd), (Ev::BreakBwd, bwd), (Ev::Switch, None)]
            }
            Mech::Slide(dir) => {
                let stop = Some(-dir * y[I_V] / V_REF);
                let end = Some(if dir > 0.0 { (x - p.stroke) / X_REF } else { -x / X_REF });
                let tol = self.form.switches.tolerance;
                let sw = match self.phase {
                    Phase::Extending => (x - (p.stroke - tol)) / X_REF,
                    Phase::Retracting => (tol - x) / X_REF,
                };
                [(Ev::Stop, stop), (Ev::EndStop, end), (Ev::Switch, Some(sw))]
            }
        }
    }

    fn hold_excess(&self, y: &[f64]) -> f64 {
        if self.mode.mech != Mech::Stuck {
            return f64::NEG_INFINITY;
        }
        let p = self.plant;
        let (fa, fs) = p.forces(y, &p.variant);
        let mut e = f64::NEG_INFINITY;
        if self.at_stop != Some(true) {
            e = e.max(fa - fs);
        }
        if self.at_stop != Some(false) {
            e = e.max(-fa - fs);
        }
        e
    }

    fn note_hold(&mut self, y: &[f64]) {
        let e = self.hold_excess(y);
        if e > self.trace.max_hold_excess {
            self.trace.max_hold_excess = e;
        }
    }

    fn record(&mut self, t: f64, kind: EventKind) -> Result<(), RigError> {
        self.trace.events.push(EventRecord { t, kind });
        if self.trace.events.len() > self.max_events {
            return Err(RigError::TooManyEvents { t, limit: self.max_events, last: format!("{kind:?}") });
        }
        Ok(())
    }

    fn push_sample(&mut self, t: f64, y: &[f64]) -> Result<(), RigError> {
        let ev = self
            .plant
            .evaluate(&self.mode, y, None)
            .ok_or_else(|| RigError::NonPhysical { t, what: format!("state {:?}", &y[..self.plant.n_dyn]) })?;
        let tr = &mut self.trace;
        tr.t.push(t);
        tr.p1.push(ev.p1);
        tr.p2.push(ev.p2);
        tr.x.push(y[I_X]);
        tr.v.push(y[I_V]);
        tr.temp1.push(y[crate::model::I_T1]);
        tr.temp2.push(y[crate::model::I_T2]);
        tr.m1.push(y[crate::model::I_M1]);
        tr.m2.push(y[crate::model::I_M2]);
        tr.p_supply.push(ev.p_line);
        tr.p_junction.push(ev.p_junction);
        tr.f_applied.push(ev.f_applied);
        tr.f_breakaway.push(ev.f_break);
        tr.stuck.push(self.mode.mech == Mech::Stuck);
        tr.valve_extend.push(self.mode.valve == ValvePos::Extend);
        Ok(())
    }

    /// Emits the samples in (last, t_hi] from the stepper's interpolant.
    fn emit_upto(&mut self, st: &Sdirk, t_hi: f64) -> Result<(), RigError> {
        let mut buf = vec![0.0; st.y.len()];
        while let Some(ts) = self.samples.peek() {
            if ts > t_hi {
                break;
            }
            if ts >= st.t {
                buf.copy_from_slice(&st.y);
            } else if ts <= st.t_prev {
                buf.copy_from_slice(&st.y_prev);
            } else {
                st.interpolate(ts, &mut buf);
            }
            self.push_sample(ts, &buf)?;
            self.samples.next += 1;
        }
        Ok(())
    }

    /// Karnopp's decision at rest (v = 0): slide or stay. Sets `at_stop`.
    fn settle(&mut self, y: &[f64]) -> Mech {
        let p = self.plant;
        let (fa, fs) = p.forces(y, &p.variant);
        let x = y[I_X];
        // a nanometre decides contact with a stop (x is clamped exactly at
        // a stop event; this only absorbs rounding)
        let eps = 1e-9;
        self.at_stop = if x >= p.stroke - eps {
            Some(true)
        } else if x <= eps {
            Some(false)
        } else {
            None
        };
        if fa >= fs && fa > 0.0 && self.at_stop != Some(true) {
            Mech::Slide(1.0)
        } else if -fa >= fs && fa < 0.0 && self.at_stop != Some(false) {
            Mech::Slide(-1.0)
        } else {
            Mech::Stuck
        }
    }

    fn schedule(&mut self, t_cmd: f64, pos: ValvePos) {
        let t = t_cmd + self.valve_delay;
        let i = self.pending.iter().position(|(tp, _)| *tp > t).unwrap_or(self.pending.len());
        self.pending.insert(i, (t, pos));
    }

    /// Applies valve switches due at or before `t`. Returns whether any did.
    fn apply_due_valves(&mut self, t: f64) -> Result<bool, RigError> {
        let mut any = false;
        while let Some(&(tp, pos)) = self.pending.first() {
            if tp > t {
                break;
            }
            self.pending.remove(0);
            if self.mode.valve != pos {
                self.mode.valve = pos;
                self.record(t, EventKind::ValveSwitch(pos))?;
            }
            any = true;
        }
        Ok(any)
    }

    /// Handles the state events found at `t` with state `y` (modified in place).
    fn handle(&mut self, t: f64, y: &mut [f64], fired: &[Ev]) -> Result<(), RigError> {
        let p = self.plant;
        let sw = self.form.switches;
        // mechanics first
        if fired.contains(&Ev::EndStop) {
            let upper = matches!(self.mode.mech, Mech::Slide(d) if d > 0.0);
            y[I_X] = if upper { p.stroke } else { 0.0 };
            y[I_V] = 0.0;
            self.mode.mech = self.settle(y);
            self.record(t, EventKind::EndStop(upper))?;
        } else if fired.contains(&Ev::Stop) || fired.contains(&Ev::Graze) {
            y[I_V] = 0.0;
            let m = self.settle(y);
            self.mode.mech = m;
            match m {
                Mech::Stuck => self.record(t, EventKind::Stick)?,
                Mech::Slide(d) => self.record(t, EventKind::Reversal(d))?,
            }
        } else if fired.contains(&Ev::BreakFwd) || fired.contains(&Ev::BreakBwd) {
            let dir = if fired.contains(&Ev::BreakFwd) { 1.0 } else { -1.0 };
            y[I_V] = 0.0;
            self.mode.mech = Mech::Slide(dir);
            self.record(t, EventKind::Breakaway(dir))?;
        }
        // the cycler: a switch is a level condition on x, so it also catches
        // a switch at the stop itself (tolerance 0)
        let x = y[I_X];
        let trip = fired.contains(&Ev::Switch)
            || match self.phase {
                Phase::Extending => x >= p.stroke - sw.tolerance,
                Phase::Retracting => x <= sw.tolerance,
            };
        if trip {
            match self.phase {
                Phase::Extending => {
                    self.record(t, EventKind::SwitchExtended)?;
                    self.t_ext_trip = t;
                    self.phase = Phase::Retracting;
                    self.schedule(t + sw.latency + sw.dwell_extended, ValvePos::Retract);
                }
                Phase::Retracting => {
                    self.record(t, EventKind::SwitchRetracted)?;
                    let extend = self.t_ext_trip - self.cycle_start;
                    let retract = t - self.t_ext_trip;
                    self.trace.cycles.push(CycleTimes { extend, retract, total: extend + retract });
                    self.cycle_start = t;
                    self.phase = Phase::Extending;
                    if self.target_cycles.is_some_and(|n| self.trace.cycles.len() >= n) {
                        self.done = true;
                    } else {
                        self.schedule(t + sw.latency + sw.dwell_retracted, ValvePos::Extend);
                    }
                }
            }
        }
        Ok(())
    }

    /// Looks for a state event in the last step [t_prev, t]. Returns the
    /// event time, state and the events that hold there.
    fn locate(&mut self, st: &mut Sdirk) -> Result<Option<Located>, RigError> {
        let t0 = st.t_prev;
        let h = st.t - t0;
        let g0 = self.event_values(&st.y_prev);
        // armed: strictly negative at the start of the step; the stop event
        // only once the velocity has clearly left zero (see `v_arm`)
        let v_arm = self.v_arm;
        let armed: Vec<(usize, Ev)> = g0
            .iter()
            .enumerate()
            .filter_map(|(i, (ev, g))| {
                let lim = if *ev == Ev::Stop { -v_arm / V_REF } else { 0.0 };
                g.filter(|v| *v < lim).map(|_| (i, *ev))
            })
            .collect();
        // grazing: the piston broke away (v = 0) but the net force turned
        // back before the velocity left the noise band: it never really moved
        let mut armed = armed;
        let mut lo_start: Option<(f64, f64)> = None;
        if let Mech::Slide(dir) = self.mode.mech {
            let stop_armed = armed.iter().any(|(_, e)| *e == Ev::Stop);
            let i_stop = g0.iter().position(|(e, _)| *e == Ev::Stop);
            if let (false, Some(i_stop)) = (stop_armed, i_stop) {
                if dir * st.y[I_V] < -v_arm {
                    if dir * st.y_prev[I_V] > 0.0 {
                        // it did move forward a little: locate the stop as usual
                        armed.push((i_stop, Ev::Stop));
                    } else if dir * st.y[I_V] > -1e3 * v_arm {
                        // within the noise band of v = 0: it never moved
                        return Ok(Some((st.t, st.y.clone(), vec![Ev::Graze])));
                    } else {
                        // a clear reversal within the first step: find a
                        // point where it still moved forward, by halving
                        let mut sys = self.sys();
                        let mut tau = 0.5 * (st.t - st.t_prev);
                        for _ in 0..40 {
                            if let Some(ys) = st.trial(&mut sys, tau) {
                                if dir * ys[I_V] > 0.0 {
                                    lo_start = Some((tau, -dir * ys[I_V] / V_REF));
                                    break;
                                }
                            }
                            tau *= 0.5;
                        }
                        if lo_start.is_none() {
                            return Ok(Some((st.t, st.y.clone(), vec![Ev::Graze])));
                        }
                        armed = vec![(i_stop, Ev::Stop)];
                    }
                }
            }
        }
        if armed.is_empty() {
            return Ok(None);
        }
        let big_g = |drv: &Self, y: &[f64]| -> f64 {
            let g = drv.event_values(y);
            armed.iter().map(|(i, _)| g[*i].1.unwrap_or(f64::NEG_INFINITY)).fold(f64::NEG_INFINITY, f64::max)
        };
        let glo0 = big_g(self, &st.y_prev);
        let (mut lo, mut glo) = lo_start.unwrap_or((0.0, glo0));
        let mut found: Option<(f64, f64, Vec<f64>)> = None;
        let mut buf = vec![0.0; st.y.len()];
        let mut sys = self.sys();
        for frac in [0.25, 0.5, 0.75] {
            let tau = frac * h;
            if tau <= lo {
                continue;
            }
            st.interpolate(t0 + tau, &mut buf);
            if big_g(self, &buf) < 0.0 {
                continue;
            }
            // the interpolant says the event is before tau: verify
            if let Some(ys) = st.trial(&mut sys, tau) {
                let gs = big_g(self, &ys);
                if gs >= 0.0 {
                    found = Some((tau, gs, ys));
                    break;
                }
                lo = tau;
                glo = gs;
            }
        }
        if found.is_none() {
            let g1 = big_g(self, &st.y);
            if g1 >= 0.0 {
                found = Some((h, g1, st.y.clone()));
            }
        }
        let Some((hi0, ghi0, y_hi0)) = found else {
            return Ok(None);
        };
        // narrow the bracket with trial steps, keeping the state at hi
        let mut best = (hi0, y_hi0);
        let plant = self.plant;
        let mode = self.mode;
        let br = {
            let this: &Self = self;
            let best_ref = &mut best;
            illinois(
                |tau| {
                    // a trial step, or if even that fails the interpolant
                    let ys = st.trial(&mut ModeSystem { plant, mode }, tau).unwrap_or_else(|| {
                        let mut b = vec![0.0; st.y.len()];
                        st.interpolate(st.t_prev + tau, &mut b);
                        b
                    });
                    let g = big_g(this, &ys);
                    if g >= 0.0 && tau < best_ref.0 {
                        *best_ref = (tau, ys);
                    }
                    Some(g)
                },
                lo,
                hi0,
                glo,
                ghi0,
                EVENT_TIME_TOL,
                0.0,
            )
        };
        debug_assert!(br.lo <= br.hi && br.hi >= best.0);
        let (tau, ys) = best;
        let g = self.event_values(&ys);
        let fired: Vec<Ev> = armed.iter().filter(|(i, _)| g[*i].1.is_some_and(|v| v >= 0.0)).map(|(_, e)| *e).collect();
        Ok(Some((t0 + tau, ys, fired)))
    }
}

/// Runs the rig. See the crate documentation for the model and the
/// conventions; `run.cycles` completed cycles end the run early.
pub fn simulate(rig: &Rig, form: &ModelForm, effects: &Effects, run: &RunSpec) -> Result<Trace, RigError> {
    rig.validate()?;
    form.validate(rig)?;
    effects.validate()?;
    run.validate()?;
    let plant = Plant::new(rig, form, effects);
    let (every, list) = match &run.sampling {
        Sampling::Every(dt) => (Some(*dt), Vec::new()),
        Sampling::At(v) => (None, v.clone()),
    };
    let mut drv = Driver {
        plant: &plant,
        form,
        valve_delay: effects.valve_delay,
        mode: Mode { valve: ValvePos::Retract, mech: Mech::Stuck },
        phase: Phase::Extending,
        cycle_start: 0.0,
        t_ext_trip: 0.0,
        pending: Vec::new(),
        trace: Trace { max_hold_excess: f64::NEG_INFINITY, ..Trace::default() },
        samples: SampleClock { every, list, next: 0, t_end: run.t_end },
        target_cycles: run.cycles,
        done: false,
        at_stop: None,
        v_arm: 10.0 * run.rtol * plant.error_floors()[I_V],
        max_events: run.max_events,
    };
    let mut y = plant.initial_state(rig);
    let y0 = y.clone();
    drv.mode.mech = drv.settle(&y);
    let mut st = Sdirk::new(plant.n_dyn, N_QUAD, run.rtol, plant.error_floors(), run.max_step);
    st.limit_attempts(run.max_steps);
    let mut t = 0.0;
    // samples before t = 0 (a logger started early) show the rest state
    while let Some(ts) = drv.samples.peek() {
        if ts >= 0.0 {
            break;
        }
        drv.push_sample(ts, &y)?;
        drv.samples.next += 1;
    }
    // extend commanded at t = 0
    drv.schedule(0.0, ValvePos::Extend);
    drv.apply_due_valves(t)?;
    {
        let mut sys = drv.sys();
        st.restart(&mut sys, t, &y).map_err(|e| drv.step_error(e, &y, run.max_steps))?;
    }
    drv.emit_upto(&st, t)?;
    while !drv.done && t < run.t_end {
        let t_limit = drv.pending.first().map_or(run.t_end, |(tp, _)| tp.min(run.t_end));
        {
            let mut sys = drv.sys();
            st.advance(&mut sys, t_limit).map_err(|e| drv.step_error(e, &st.y, run.max_steps))?;
        }
        if drv.mode.mech == Mech::Stuck {
            // a held piston does not move, not even by rounding
            st.pin(I_X, y[I_X]);
            st.pin(I_V, 0.0);
        }
        match drv.locate(&mut st)? {
            Some((te, mut ye, fired)) => {
                st.truncate(te, &ye);
                drv.note_hold(&ye);
                drv.emit_upto(&st, te)?;
                t = te;
                drv.handle(t, &mut ye, &fired)?;
                drv.apply_due_valves(t)?;
                y = ye;
                let mut sys = drv.sys();
                st.restart(&mut sys, t, &y).map_err(|e| drv.step_error(e, &y, run.max_steps))?;
            }
            None => {
                t = st.t;
                let y_end = st.y.clone();
                drv.note_hold(&y_end);
                drv.emit_upto(&st, t)?;
                if drv.apply_due_valves(t)? {
                    y = st.y.clone();
                    // a valve switch may leave a piston at rest able to move
                    if drv.mode.mech == Mech::Stuck {
                        let m = drv.settle(&y);
                        if let Mech::Slide(d) = m {
                            drv.mode.mech = m;
                            drv.record(t, EventKind::Breakaway(d))?;
                        }
                    }
                    let mut sys = drv.sys();
                    st.restart(&mut sys, t, &y).map_err(|e| drv.step_error(e, &y, run.max_steps))?;
                }
            }
        }
    }
    let y_final = st.y.clone();
    drv.trace.t_final = t;
    drv.trace.stats = st.stats;
    // balances
    let nd = plant.n_dyn;
    let (u0, m0) = plant.gas_totals(&y0);
    let (u1, m1) = plant.gas_totals(&y_final);
    let (bm, bh, q, w) = (y_final[nd], y_final[nd + 1], y_final[nd + 2], y_final[nd + 3]);
    let de = u1 - u0;
    let res = de - (bh + q - w);
    let scale = u0.abs().max(u1.abs()).max(bh.abs()).max(q.abs()).max(w.abs()).max(1e-300);
    drv.trace.balance = Balance {
        mass_in: bm,
        mass_change: m1 - m0,
        mass_residual: (m1 - m0) - bm,
        enthalpy_in: bh,
        wall_heat: q,
        work: w,
        energy_change: de,
        energy_residual: res,
        energy_residual_rel: res.abs() / scale,
    };
    if drv.trace.max_hold_excess == f64::NEG_INFINITY {
        drv.trace.max_hold_excess = 0.0;
    }
    Ok(drv.trace)
}
