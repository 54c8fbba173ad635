//! Delay: a pure transport delay of a piecewise-constant signal (e.g. the
//! dead time between a valve command and the valve actually switching).
//!
//! # Ports
//! - `in` — signal input, any unit.
//! - `out` — signal output: the input as it was `delay` seconds earlier.
//!
//! # Parameters (defaults in brackets)
//! - `delay` [s, required, ≥ 0]: the transport delay T.
//! - `initial` [-, 0]: output until the first change has come through.
//!
//! # Behaviour
//! The block holds an accepted level ℓ (its output). While the input differs
//! from ℓ, a clock state c runs (ċ = 1; otherwise ċ = 0). The event function
//! g = c − c_accepted − T crosses zero exactly T after the input left ℓ; the
//! event sets ℓ to the input and c_accepted = c. So out(t) = in(t − T) for
//! inputs that hold each value longer than T (the solver locates the switch
//! as a root, to its root tolerance). With T = 0 the output follows the input
//! directly (feedthrough).
//!
//! # Assumptions
//! The input is piecewise constant (a command). A pulse shorter than T is not
//! reproduced: the time it spent away from ℓ still counts towards the next
//! change.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("delay", dim::TIME, None, Range::NonNegative, "ms", "transport delay"),
    ParamSpec::quantity("initial", dim::DIMENSIONLESS, Some(0.0), Range::Any, "", "output before the first change arrives"),
];
pub const PORTS: &[PortSpec] = &[
    PortSpec::signal("in", PortKind::SignalIn, "", "signal to delay (any unit)"),
    PortSpec::signal("out", PortKind::SignalOut, "", "the input delayed by `delay` (its unit)"),
];
const STATES: &[StateSpec] = &[StateSpec { name: "clock", unit: "s" }];

/// Relative difference below which input and accepted level count as equal.
const SAME: f64 = 1e-12;

#[derive(Debug, Clone, PartialEq)]
pub struct Delay {
    pub delay: f64,
    /// Accepted level (the output).
    pub level: f64,
    /// Clock value when the level was last accepted [s].
    pub accepted_clock: f64,
}

impl Delay {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Delay { delay: p.get("delay"), level: p.get("initial"), accepted_clock: 0.0 })
    }
    /// Whether the input differs from the accepted level.
    pub fn pending(&self, input: f64) -> bool {
        (input - self.level).abs() > SAME * self.level.abs().max(1.0)
    }
}

impl Block for Delay {
    fn type_name(&self) -> &'static str {
        "delay"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn states(&self) -> &[StateSpec] {
        if self.delay > 0.0 {
            STATES
        } else {
            &[]
        }
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        if let Some(s) = out.first_mut() {
            *s = 1.0;
        }
    }
    fn initial_states(&self, _ctx: &InitCtx, out: &mut [f64]) {
        if let Some(s) = out.first_mut() {
            *s = 0.0;
        }
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = if self.delay > 0.0 { self.level } else { ctx.signals[0] };
    }
    fn feedthrough(&self) -> bool {
        self.delay <= 0.0
    }
    /// At rest the input has held its value for ever, so it has come through.
    fn rest_signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = ctx.signals[0];
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        if let Some(d) = out.first_mut() {
            *d = if self.pending(ctx.signals[0]) { 1.0 } else { 0.0 };
        }
    }
    /// The output is the held level (no slope) or, with T = 0, the input
    /// itself; the clock's rate is 0 or 1, piecewise constant.
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Signals && self.delay <= 0.0 {
            d.set(Out::Signal(0), In::Signal(0), 1.0);
        }
        true
    }
    fn n_event_functions(&self) -> usize {
        usize::from(self.delay > 0.0)
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        if let (Some(g), Some(c)) = (out.first_mut(), ctx.states.first()) {
            *g = c - self.accepted_clock - self.delay;
        }
    }
    fn on_event(&mut self, event: EventKind, ctx: &Ctx) -> EventOutcome {
        if event != EventKind::Crossing(0) {
            return EventOutcome::default();
        }
        self.level = ctx.signals[0];
        self.accepted_clock = ctx.states.first().copied().unwrap_or(0.0);
        EventOutcome { cycle: None, note: Some(format!("delayed change to {}", self.level)) }
    }
}

/// Registry entry of `delay`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "delay",
    family: crate::registry::Family::Control,
    doc: "transport delay of a piecewise-constant signal",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(Delay::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    fn ctx<'a>(t: f64, states: &'a [f64], input: &'a [f64]) -> Ctx<'a> {
        static GAS: std::sync::OnceLock<gas::IdealGas> = std::sync::OnceLock::new();
        Ctx { t, gas: GAS.get_or_init(gas::IdealGas::air), states, pneumatic: &[], mechanical: &[], signals: input }
    }

    #[test]
    fn the_change_comes_through_after_the_delay() {
        let mut d = Delay { delay: 0.03, level: 0.0, accepted_clock: 0.0 };
        let bal = Balances { pneumatic: &[], mechanical: &[] };
        let mut out = [0.0];
        // input steps to 1: the clock runs, the output still shows 0
        d.derivatives(&ctx(0.0, &[0.0], &[1.0]), &bal, &mut out);
        assert_eq!(out[0], 1.0);
        let mut y = [0.0];
        d.signal_outputs(&ctx(0.0, &[0.0], &[1.0]), &mut y);
        assert_eq!(y[0], 0.0);
        // integrate the clock by hand; g crosses zero at 30 ms
        let mut g = [0.0];
        d.event_functions(&ctx(0.029, &[0.029], &[1.0]), &mut g);
        assert!(g[0] < 0.0);
        d.event_functions(&ctx(0.031, &[0.031], &[1.0]), &mut g);
        assert!(g[0] > 0.0);
        d.on_event(EventKind::Crossing(0), &ctx(0.03, &[0.03], &[1.0]));
        d.signal_outputs(&ctx(0.03, &[0.03], &[1.0]), &mut y);
        assert_eq!(y[0], 1.0);
        // the clock stops and g rests at −T until the input changes again
        d.derivatives(&ctx(0.5, &[0.03], &[1.0]), &bal, &mut out);
        assert_eq!(out[0], 0.0);
        d.event_functions(&ctx(0.5, &[0.03], &[1.0]), &mut g);
        assert!((g[0] + 0.03).abs() < 1e-15);
        // the next change (back to 0) is delayed by the same amount
        d.event_functions(&ctx(1.03, &[0.06], &[0.0]), &mut g);
        assert!(g[0].abs() < 1e-15);
    }

    #[test]
    fn zero_delay_passes_through() {
        let d = Delay { delay: 0.0, level: 0.0, accepted_clock: 0.0 };
        assert!(d.feedthrough() && d.states().is_empty() && d.n_event_functions() == 0);
        let mut y = [0.0];
        d.signal_outputs(&ctx(0.0, &[], &[0.7]), &mut y);
        assert_eq!(y[0], 0.7);
    }

    #[test]
    fn partials_equal_central_differences() {
        use crate::partials_check::{build, point};
        let feedthrough = build(&TYPE, &[("delay", "0 s")]);
        point(&[], &[], &[0.7]).check(feedthrough.as_ref(), Phase::Signals);
        let delayed = build(&TYPE, &[("delay", "10 ms")]);
        // a change pending (the clock runs) and none (it stands)
        for input in [1.0, 0.0] {
            let at = point(&[0.004], &[], &[input]);
            at.check(delayed.as_ref(), Phase::Signals);
            at.check(delayed.as_ref(), Phase::Derivatives);
        }
    }
}
