//! Cycler: an end-of-stroke (limit-switch) controller that runs an actuator
//! back and forth for a number of cycles.
//!
//! # Ports
//! - `x` — signal input: piston position [m].
//! - `command` — signal output: 1 = extend (valve actuated), 0 = retract.
//!
//! # Parameters (defaults in brackets)
//! - `stroke` [m, required]: position of the far limit switch.
//! - `cycles` [count, 0]: cycles after which the cycler stops and the run may end;
//!   0 = keep cycling until the run ends (end time or the run's own cycle count).
//! - `dwell_extended` [s, 0], `dwell_retracted` [s, 0]: waits at each end.
//! - `switch_tolerance` [m, 10 µm]: a limit switch trips this close to the end.
//! - `start` [s, 0]: time of the first extend command.
//!
//! # Behaviour
//! Extend is commanded at `start`; when x rises through stroke − tol the
//! extend time is recorded and, after the dwell, retract is commanded; when x
//! falls through tol the retract time is recorded and the cycle closes.
//! Extend time runs from the extend command to the end of stroke, retract
//! time from the retract command back to 0, total from one extend command to
//! the next (dwells included). Each switch is a root of an event function, so
//! the solver restarts exactly there.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("stroke", dim::LENGTH, None, Range::Positive, "mm", "far limit switch position"),
    ParamSpec::count("cycles", Some(0.0), "cycles after which the cycler stops (0 = until the run ends)"),
    ParamSpec::quantity("dwell_extended", dim::TIME, Some(0.0), Range::NonNegative, "s", "wait at the extended end"),
    ParamSpec::quantity("dwell_retracted", dim::TIME, Some(0.0), Range::NonNegative, "s", "wait at the retracted end"),
    ParamSpec::quantity("switch_tolerance", dim::LENGTH, Some(1e-5), Range::Positive, "mm", "limit switches trip this close to the ends"),
    ParamSpec::quantity("start", dim::TIME, Some(0.0), Range::NonNegative, "s", "time of the first extend command"),
];
pub const PORTS: &[PortSpec] = &[
    PortSpec::signal("x", PortKind::SignalIn, "m", "piston position"),
    PortSpec::signal("command", PortKind::SignalOut, "1", "1 = extend, 0 = retract"),
];

/// Where the cycler is in its cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    Waiting,
    Extending,
    DwellExtended,
    Retracting,
    DwellRetracted,
    Done,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Cycler {
    pub stroke: f64,
    pub cycles: u64,
    pub dwell_extended: f64,
    pub dwell_retracted: f64,
    pub tolerance: f64,
    pub start: f64,
    pub phase: Phase,
    phase_start: f64,
    cycle_start: f64,
    extend_time: f64,
    retract_start: f64,
    done: u64,
}

impl Cycler {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let start = p.get("start");
        let c = Cycler {
            stroke: p.get("stroke"),
            cycles: p.get("cycles") as u64,
            dwell_extended: p.get("dwell_extended"),
            dwell_retracted: p.get("dwell_retracted"),
            tolerance: p.get("switch_tolerance"),
            start,
            phase: if start > 0.0 { Phase::Waiting } else { Phase::Extending },
            phase_start: 0.0,
            cycle_start: start,
            extend_time: 0.0,
            retract_start: 0.0,
            done: 0,
        };
        if 2.0 * c.tolerance >= c.stroke {
            return Err(crate::BlockError::invalid("switch_tolerance", "must be well below half the stroke"));
        }
        Ok(c)
    }

    /// Cycles completed so far.
    pub fn completed(&self) -> u64 {
        self.done
    }

    fn command(&self) -> f64 {
        match self.phase {
            Phase::Extending | Phase::DwellExtended => 1.0,
            _ => 0.0,
        }
    }

    fn retract(&mut self, t: f64) {
        self.phase = Phase::Retracting;
        self.retract_start = t;
    }

    fn extend(&mut self, t: f64) {
        self.phase = Phase::Extending;
        self.cycle_start = t;
    }
}

impl Block for Cycler {
    fn type_name(&self) -> &'static str {
        "cycler"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: crate::block::Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.command();
    }
    /// At rest before the first extend command the valve is released.
    fn rest_signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = 0.0;
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        vec![(0, Fact::SwitchPosition { x: self.stroke - self.tolerance, param: "stroke" }), (1, Fact::CommandLevels(vec![0.0, 1.0]))]
    }
    fn n_event_functions(&self) -> usize {
        1
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        let x = ctx.signals[0];
        out[0] = match self.phase {
            Phase::Extending => x - (self.stroke - self.tolerance),
            Phase::Retracting => self.tolerance - x,
            _ => -1.0,
        };
    }
    fn next_time_event(&self, t: f64) -> Option<f64> {
        let due = match self.phase {
            Phase::Waiting => self.start,
            Phase::DwellExtended => self.phase_start + self.dwell_extended,
            Phase::DwellRetracted => self.phase_start + self.dwell_retracted,
            _ => return None,
        };
        (due > t).then_some(due)
    }
    fn on_event(&mut self, event: EventKind, ctx: &Ctx) -> EventOutcome {
        let t = ctx.t;
        let mut outcome = EventOutcome::default();
        match (self.phase, event) {
            (Phase::Waiting, EventKind::Time) => {
                self.extend(t);
                outcome.note = Some("extend commanded".into());
            }
            (Phase::Extending, EventKind::Crossing(0)) => {
                self.extend_time = t - self.cycle_start;
                outcome.note = Some("end of stroke reached".into());
                if self.dwell_extended > 0.0 {
                    self.phase = Phase::DwellExtended;
                    self.phase_start = t;
                } else {
                    self.retract(t);
                }
            }
            (Phase::DwellExtended, EventKind::Time) => {
                self.retract(t);
                outcome.note = Some("retract commanded".into());
            }
            (Phase::Retracting, EventKind::Crossing(0)) => {
                let retract = t - self.retract_start;
                self.done += 1;
                outcome.note = Some("back at the start".into());
                let finished = self.cycles > 0 && self.done >= self.cycles;
                let next = if finished { t } else { t + self.dwell_retracted };
                outcome.cycle = Some(CycleRecord {
                    controller: String::new(),
                    start: self.cycle_start,
                    extend: self.extend_time,
                    retract,
                    retract_start: self.retract_start,
                    total: next - self.cycle_start,
                });
                if finished {
                    self.phase = Phase::Done;
                } else if self.dwell_retracted > 0.0 {
                    self.phase = Phase::DwellRetracted;
                    self.phase_start = t;
                } else {
                    self.extend(t);
                }
            }
            (Phase::DwellRetracted, EventKind::Time) => {
                self.extend(t);
                outcome.note = Some("extend commanded".into());
            }
            _ => {}
        }
        outcome
    }
    fn finished(&self) -> bool {
        self.phase == Phase::Done
    }
    fn counts_cycles(&self) -> bool {
        true
    }
}

/// Registry entry of `cycler`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "cycler",
    family: crate::registry::Family::Control,
    doc: "limit-switch cycler (extend/retract for N cycles)",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(Cycler::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;

    fn cycler(extra: &[(&str, RawValue)]) -> Cycler {
        let mut raw = vec![("stroke", RawValue::Text("450 mm".into()))];
        raw.extend(extra.iter().cloned());
        Cycler::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).unwrap()
    }

    fn at(t: f64, x: &[f64]) -> Ctx<'_> {
        // a static gas model for the context
        static GAS: std::sync::OnceLock<gas::IdealGas> = std::sync::OnceLock::new();
        Ctx { t, gas: GAS.get_or_init(gas::IdealGas::air), states: &[], pneumatic: &[], mechanical: &[], signals: x }
    }

    #[test]
    fn runs_the_cycle_and_times_it() {
        let mut c = cycler(&[("cycles", RawValue::Number(2.0)), ("dwell_extended", RawValue::Number(0.2))]);
        let mut g = [0.0];
        assert_eq!(c.command(), 1.0);
        c.event_functions(&at(0.0, &[0.0]), &mut g);
        assert!(g[0] < 0.0);
        c.event_functions(&at(1.0, &[0.45]), &mut g);
        assert!(g[0] > 0.0, "crossing the far switch");
        c.on_event(EventKind::Crossing(0), &at(1.0, &[0.45]));
        assert_eq!(c.phase, Phase::DwellExtended);
        assert_eq!(c.command(), 1.0);
        assert_eq!(c.next_time_event(1.0), Some(1.2));
        c.on_event(EventKind::Time, &at(1.2, &[0.45]));
        assert_eq!(c.command(), 0.0);
        let out = c.on_event(EventKind::Crossing(0), &at(2.0, &[0.0]));
        let rec = out.cycle.unwrap();
        assert!((rec.extend - 1.0).abs() < 1e-12 && (rec.retract - 0.8).abs() < 1e-12 && (rec.total - 2.0).abs() < 1e-12);
        assert!(!c.finished());
        assert_eq!(c.command(), 1.0);
        c.on_event(EventKind::Crossing(0), &at(3.0, &[0.45]));
        c.on_event(EventKind::Time, &at(3.2, &[0.45]));
        let rec = c.on_event(EventKind::Crossing(0), &at(4.5, &[0.0])).cycle.unwrap();
        assert!((rec.start - 2.0).abs() < 1e-12 && (rec.total - 2.5).abs() < 1e-12);
        assert!(c.finished());
    }
}
