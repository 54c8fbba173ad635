//! Timer on an on/off signal: on-delay, off-delay or pulse (the TON, TOF
//! and TP timers of IEC 61131-3; the time-delay valves of pneumatic logic).
//!
//! # Ports
//! - `in` [1] — signal input: on above 0.55, off below 0.45.
//! - `out` [1] — signal output: 1 or 0.
//!
//! # Parameters (defaults in brackets)
//! - `mode` [`on_delay`]: `on_delay` — out turns on `delay` after in turned
//!   on (and off with it); `off_delay` — out turns on with in and off
//!   `delay` after in turned off; `pulse` — a rising input starts a pulse
//!   of length `delay` (not retriggered while it runs).
//! - `delay` [s, required, > 0].
//!
//! # Behaviour
//! Input changes are events (root functions with hysteresis); the delayed
//! switching is a time event, so the solver restarts exactly there. At rest
//! the input is taken to have held its value for ever (on- and off-delay
//! pass it, a pulse is over).

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::support::{switch_root, switch_state};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::choice("mode", &["on_delay", "off_delay", "pulse"], 0, "TON, TOF or TP"),
    ParamSpec::quantity("delay", dim::TIME, None, Range::Positive, "s", "delay or pulse length"),
];
pub const PORTS: &[PortSpec] =
    &[PortSpec::signal("in", PortKind::SignalIn, "1", "input"), PortSpec::signal("out", PortKind::SignalOut, "1", "timed output")];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    OnDelay,
    OffDelay,
    Pulse,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Timer {
    pub mode: Mode,
    pub delay: f64,
    input: bool,
    output: bool,
    /// When the output switches next (a running delay or pulse).
    due: Option<f64>,
}

impl Timer {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let mode = [Mode::OnDelay, Mode::OffDelay, Mode::Pulse][p.choice("mode")];
        Ok(Timer { mode, delay: p.get("delay"), input: false, output: false, due: None })
    }
    fn input_changed(&mut self, t: f64) {
        match (self.mode, self.input) {
            (Mode::OnDelay, true) => self.due = Some(t + self.delay),
            (Mode::OnDelay, false) => {
                self.due = None;
                self.output = false;
            }
            (Mode::OffDelay, true) => {
                self.due = None;
                self.output = true;
            }
            (Mode::OffDelay, false) => self.due = Some(t + self.delay),
            (Mode::Pulse, true) if self.due.is_none() => {
                self.output = true;
                self.due = Some(t + self.delay);
            }
            (Mode::Pulse, _) => {}
        }
    }
    fn elapsed(&mut self) {
        self.due = None;
        self.output = match self.mode {
            Mode::OnDelay => true,
            Mode::OffDelay | Mode::Pulse => false,
        };
    }
}

impl Block for Timer {
    fn type_name(&self) -> &'static str {
        "timer"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = if self.output { 1.0 } else { 0.0 };
    }
    fn rest_signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        let on = ctx.signals[0] > 0.5 && self.mode != Mode::Pulse;
        out[0] = if on { 1.0 } else { 0.0 };
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        vec![(1, Fact::CommandLevels(vec![0.0, 1.0]))]
    }
    fn n_event_functions(&self) -> usize {
        1
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = switch_root(self.input, ctx.signals[0]);
    }
    fn next_time_event(&self, t: f64) -> Option<f64> {
        self.due.filter(|&d| d > t)
    }
    fn on_event(&mut self, event: EventKind, ctx: &Ctx) -> EventOutcome {
        match event {
            EventKind::Crossing(_) => {
                let now = switch_state(self.input, ctx.signals[0]);
                if now != self.input {
                    self.input = now;
                    self.input_changed(ctx.t);
                }
            }
            EventKind::Time => {
                if self.due.is_some_and(|d| ctx.t >= d - 1e-12 * d.max(1.0)) {
                    self.elapsed();
                    return EventOutcome { cycle: None, note: Some(format!("output {}", u8::from(self.output))) };
                }
            }
        }
        EventOutcome::default()
    }
}

/// Registry entry of `timer`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "timer",
    family: crate::registry::Family::Control,
    doc: "on-delay, off-delay or pulse timer (IEC 61131-3 TON, TOF, TP)",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(Timer::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Drive a timer with input steps at the given instants; return its output at `probe` times.
    fn run(mode: Mode, steps: &[(f64, f64)], probes: &[f64]) -> Vec<f64> {
        let gas = gas::IdealGas::air();
        let mut tm = Timer { mode, delay: 1.0, input: false, output: false, due: None };
        let mut events: Vec<f64> = steps.iter().map(|s| s.0).collect();
        events.extend(probes);
        events.sort_by(f64::total_cmp);
        let mut out = Vec::new();
        let mut t = 0.0;
        let input_at = |t: f64| steps.iter().rev().find(|s| s.0 <= t).map_or(0.0, |s| s.1);
        for &e in &events {
            // time events due before e
            while let Some(d) = tm.next_time_event(t).filter(|&d| d <= e) {
                let u = [input_at(d)];
                tm.on_event(EventKind::Time, &Ctx { t: d, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: &u });
                t = d;
            }
            t = e;
            let u = [input_at(e)];
            let ctx = Ctx { t, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: &u };
            let mut g = [0.0];
            tm.event_functions(&ctx, &mut g);
            if g[0] > 0.0 {
                tm.on_event(EventKind::Crossing(0), &ctx);
            }
            if probes.contains(&e) {
                let mut o = [0.0];
                tm.signal_outputs(&ctx, &mut o);
                out.push(o[0]);
            }
        }
        out
    }

    #[test]
    fn on_delay_off_delay_and_pulse() {
        let probes = [0.5, 1.5, 2.5, 3.2, 3.7, 4.5];
        // input on at 0.2 s, off at 3 s, on again at 3.5 s for 0.3 s
        let steps = [(0.2, 1.0), (3.0, 0.0), (3.5, 1.0), (3.8, 0.0)];
        assert_eq!(run(Mode::OnDelay, &steps, &probes), [0.0, 1.0, 1.0, 0.0, 0.0, 0.0]);
        assert_eq!(run(Mode::OffDelay, &steps, &probes), [1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(run(Mode::Pulse, &steps, &probes), [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        // off-delay lets go 1 s after the input's last fall (3.8 s)
        assert_eq!(run(Mode::OffDelay, &steps, &[4.7, 4.9]), [1.0, 0.0]);
    }
}
