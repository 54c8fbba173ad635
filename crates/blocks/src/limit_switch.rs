//! Limit switch: a position switch on a moving mass (a reed switch on the
//! cylinder barrel, a roller lever at the end of stroke), giving an on/off
//! signal with hysteresis.
//!
//! # Ports
//! - `rod` — mechanical, force: reads x, exerts no force.
//! - `on` [1] — signal output: 1 while actuated, 0 otherwise.
//!
//! # Parameters (defaults in brackets)
//! - `position` [m, required]: where the switch trips.
//! - `actuated` [`above`]: `above` — actuated while x ≥ position (a switch
//!   at the extended end, "a1"); `below` — actuated while x ≤ position
//!   (at the retracted end, "a0").
//! - `hysteresis` [m, 0.5 mm, > 0]: how far back the mass must move before
//!   the switch releases (the differential travel of a real switch).
//!
//! # Behaviour
//! A switch `above` turns on when x rises through `position` and off when
//! x falls through `position − hysteresis` (mirrored for `below`). Each
//! switching is an event: its root function is negative while the switch
//! keeps its state (off: x − position; on: position − hysteresis − x), so
//! the solver restarts exactly at the switching and a mass resting at the
//! trip point cannot make it chatter. At t = 0 the switch takes the state
//! of the initial position (an event at the first instant).

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("position", dim::LENGTH, None, Range::Any, "mm", "trip position"),
    ParamSpec::choice("actuated", &["above", "below"], 0, "actuated while x >= position (above) or x <= position (below)"),
    ParamSpec::quantity("hysteresis", dim::LENGTH, Some(0.5e-3), Range::Positive, "mm", "differential travel before release"),
];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("rod", PortKind::MechanicalForce, "the moving mass it senses (no force)"),
    PortSpec::signal("on", PortKind::SignalOut, "1", "1 = actuated, 0 = released"),
];

#[derive(Debug, Clone, PartialEq)]
pub struct LimitSwitch {
    pub position: f64,
    /// +1: actuated above `position`; −1: below.
    pub sense: f64,
    pub hysteresis: f64,
    /// Current state.
    pub on: bool,
}

impl LimitSwitch {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(LimitSwitch {
            position: p.get("position"),
            sense: if p.choice("actuated") == 0 { 1.0 } else { -1.0 },
            hysteresis: p.get("hysteresis"),
            on: false,
        })
    }
    /// Root function: negative while the switch keeps its state.
    pub fn root(&self, x: f64) -> f64 {
        // distance into the actuated side, positive when past the trip point
        let d = self.sense * (x - self.position);
        if self.on {
            -self.hysteresis - d
        } else {
            d
        }
    }
    /// State for position x without memory (at rest, where the mass has been for ever).
    fn state_at(&self, x: f64) -> bool {
        self.sense * (x - self.position) >= 0.0
    }
}

impl Block for LimitSwitch {
    fn type_name(&self) -> &'static str {
        "limit_switch"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn forces(&self, _ctx: &Ctx, out: &mut [PortForce]) {
        out[0] = PortForce::default();
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = if self.on { 1.0 } else { 0.0 };
    }
    fn rest_signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = if self.state_at(ctx.mechanical[0].x) { 1.0 } else { 0.0 };
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        vec![(0, Fact::SwitchPosition { x: self.position, param: "position" }), (1, Fact::CommandLevels(vec![0.0, 1.0]))]
    }
    fn n_event_functions(&self) -> usize {
        1
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.root(ctx.mechanical[0].x);
    }
    fn on_event(&mut self, event: EventKind, ctx: &Ctx) -> EventOutcome {
        if event != EventKind::Crossing(0) || self.root(ctx.mechanical[0].x) <= 0.0 {
            return EventOutcome::default();
        }
        self.on = !self.on;
        EventOutcome { cycle: None, note: Some(if self.on { "actuated".into() } else { "released".into() }) }
    }
}

/// Registry entry of `limit_switch`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "limit_switch",
    family: crate::registry::Family::Sensors,
    doc: "position switch: on/off signal with hysteresis",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(LimitSwitch::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64) -> [MechState; 1] {
        [MechState { x, v: 0.0 }]
    }

    #[test]
    fn switches_with_hysteresis_and_never_chatters() {
        let gas = gas::IdealGas::air();
        let mut s = LimitSwitch { position: 0.1, sense: 1.0, hysteresis: 0.5e-3, on: false };
        let fire = |s: &mut LimitSwitch, x: f64| {
            let m = at(x);
            let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &m, signals: &[] };
            let mut g = [0.0];
            s.event_functions(&ctx, &mut g);
            if g[0] > 0.0 {
                s.on_event(EventKind::Crossing(0), &ctx);
            }
            s.event_functions(&ctx, &mut g);
            assert!(g[0] <= 0.0, "after handling, the root is back on its quiet side");
            s.on
        };
        assert!(!fire(&mut s, 0.0999));
        assert!(fire(&mut s, 0.1001));
        // moving back a little less than the hysteresis keeps it on
        assert!(fire(&mut s, 0.0996));
        assert!(fire(&mut s, 0.1));
        assert!(!fire(&mut s, 0.0994));
        // a switch at the retracted end
        let mut a0 = LimitSwitch { position: 0.0005, sense: -1.0, hysteresis: 0.5e-3, on: false };
        assert!(fire(&mut a0, 0.0));
        assert!(fire(&mut a0, 0.0009));
        assert!(!fire(&mut a0, 0.0011));
    }
}
