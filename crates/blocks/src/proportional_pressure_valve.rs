//! Proportional pressure valve (electronic pressure regulator): a relieving
//! pressure regulator whose set pressure is a signal, reached through the
//! response of its pilot stage.
//!
//! # Ports
//! - `P` (supply), `A` (regulated outlet), `E` (exhaust) — pneumatic, flow
//!   (`E` only when relieving).
//! - `p_set` [Pa] — signal input: the set pressure, gauge (default) or
//!   absolute as `reading` says; negative values are taken as zero gauge.
//!
//! # Parameters (defaults in brackets)
//! - the regulator's (see [`crate::pressure_regulator`]): ISO 6358 set
//!   `C`, `b` (required), `droop` [0.2 bar], `relieving` [`yes`],
//!   `C_relief`, `b_relief`, `relief_offset` [0.05 bar], `response_time` [0].
//! - set-point response: `spool_order` [`first`], `time_constant` [5 ms];
//!   `natural_frequency` [50 Hz], `damping` [0.7] (second order).
//! - `reading` [`gauge`]: `gauge` (p_set relative to `p_atm`) or `absolute`;
//!   `p_atm` [Pa, 101 325 Pa].
//!
//! # Equations
//! The effective set pressure w follows the command with first- or
//! second-order dynamics (τ·ẇ = u − w, or ẅ = ω²(u − w) − 2ζω·ẇ); the
//! passages then open as in the pressure regulator: x = clamp((w − p_A)/Δp_droop, 0, 1)
//! to the supply, y = clamp((p_A − w − Δp_offset)/Δp_droop, 0, 1) to the
//! exhaust (ISO 6358 flows, paper Eq. 33–35).
//!
//! # Assumptions
//! As the regulator; the inner pressure loop of the real valve is lumped
//! into the set-point response.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::pressure_regulator::{Regulation, OUTPUTS};
use crate::support::Spool;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::pressure_regulator::REGULATOR,
    crate::support::SPOOL_DYNAMICS,
    &[
        ParamSpec::choice("reading", &["gauge", "absolute"], 0, "the p_set signal is gauge or absolute"),
        ParamSpec::quantity("p_atm", dim::PRESSURE, Some(101_325.0), Range::AbsolutePressure, "bar", "reference of a gauge set pressure"),
    ]
);
pub const PORTS_RELIEVING: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "regulated outlet"),
    PortSpec::new("E", PortKind::PneumaticFlow, "relief exhaust (relieving only)"),
    PortSpec::signal("p_set", PortKind::SignalIn, "Pa", "set pressure"),
];
pub const PORTS_NON_RELIEVING: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "regulated outlet"),
    PortSpec::signal("p_set", PortKind::SignalIn, "Pa", "set pressure"),
];

#[derive(Debug, Clone, PartialEq)]
pub struct ProportionalPressureValve {
    pub regulation: Regulation,
    pub setpoint: Spool,
    /// Added to the signal to make it absolute [Pa].
    pub offset: f64,
}

impl ProportionalPressureValve {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let offset = if p.choice("reading") == 0 { p.get("p_atm") } else { 0.0 };
        Ok(ProportionalPressureValve { regulation: Regulation::from_params(p)?, setpoint: Spool::from_params(p, 1e5), offset })
    }
    /// Commanded absolute set pressure.
    fn command(&self, ctx: &Ctx) -> f64 {
        let u = ctx.signals[ctx.signals.len() - 1];
        (u + self.offset).max(self.offset)
    }
    fn n_spool(&self) -> usize {
        self.setpoint.states().len()
    }
}

const STATES_1: &[StateSpec] = &[StateSpec { name: "p_set", unit: "Pa" }];
const STATES_2: &[StateSpec] = &[StateSpec { name: "p_set", unit: "Pa" }, StateSpec { name: "p_set_rate", unit: "Pa/s" }];
const STATES_1L: &[StateSpec] =
    &[StateSpec { name: "p_set", unit: "Pa" }, StateSpec { name: "x_supply", unit: "1" }, StateSpec { name: "x_relief", unit: "1" }];
const STATES_2L: &[StateSpec] = &[
    StateSpec { name: "p_set", unit: "Pa" },
    StateSpec { name: "p_set_rate", unit: "Pa/s" },
    StateSpec { name: "x_supply", unit: "1" },
    StateSpec { name: "x_relief", unit: "1" },
];

impl Block for ProportionalPressureValve {
    fn type_name(&self) -> &'static str {
        "proportional_pressure_valve"
    }
    fn ports(&self) -> &[PortSpec] {
        if self.regulation.relief.is_some() {
            PORTS_RELIEVING
        } else {
            PORTS_NON_RELIEVING
        }
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn states(&self) -> &[StateSpec] {
        match (self.setpoint.second_order, self.regulation.tau > 0.0) {
            (false, false) => STATES_1,
            (true, false) => STATES_2,
            (false, true) => STATES_1L,
            (true, true) => STATES_2L,
        }
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        let k = self.n_spool();
        self.setpoint.scales(&mut out[..k]);
        out[k..].fill(1.0);
    }
    /// At rest the outlet stands at the commanded set pressure.
    fn rest_pressure(&self, ctx: &Ctx) -> Option<RestPressure> {
        Some(self.regulation.rest(self.command(ctx), ctx))
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        let k = self.n_spool();
        let u = self.command(ctx);
        self.setpoint.start_at(u, &mut states[..k]);
        if states.len() >= k + 2 {
            let (x, y) = self.regulation.targets(u, ctx.pneumatic[1].p);
            states[k] = x;
            states[k + 1] = y;
        }
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let k = self.n_spool();
        let w = self.setpoint.position(ctx.states);
        let n = self.ports().len() - 1;
        self.regulation.flows(w, ctx, &ctx.states[k..], &mut out[..n]);
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        let k = self.n_spool();
        self.setpoint.derivatives(self.command(ctx), ctx.states, &mut out[..k]);
        let w = self.setpoint.position(ctx.states);
        self.regulation.derivatives(w, ctx.pneumatic[1].p, &ctx.states[k..], &mut out[k..]);
    }
    /// The set-point response's partials ([`Spool::partials`], command
    /// u = max(p_set + offset, offset): slope 1 above zero gauge) and the
    /// regulator's ([`Regulation::partials`]: ISO 6358 passages, paper Eq.
    /// 33–35, opened by the ramps of the effective set pressure w = first state).
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        let k = self.n_spool();
        let w = self.setpoint.position(ctx.states);
        if phase == Phase::Derivatives {
            let u = ctx.signals[ctx.signals.len() - 1];
            let du: &[(In, f64)] = if u > 0.0 { &[(In::Signal(0), 1.0)] } else { &[] };
            self.setpoint.partials(du, d);
        }
        self.regulation.partials(phase, w, &[(In::State(0), 1.0)], k, ctx, d);
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let k = self.n_spool();
        let (x, y) = self.regulation.openings(self.setpoint.position(ctx.states), ctx.pneumatic[1].p, &ctx.states[k..]);
        out[0] = Some(x);
        out[1] = Some(y);
    }
}

/// Registry entry of `proportional_pressure_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "proportional_pressure_valve",
    family: crate::registry::Family::ProportionalValves,
    doc: "proportional pressure regulator: set pressure from a signal",
    params: PARAMS,
    ports: PORTS_RELIEVING,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(ProportionalPressureValve::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;
    use gas::GasModel;

    #[test]
    fn regulates_to_the_signal_after_its_response() {
        let raw = [("C", RawValue::Text("20 L/min/bar".into())), ("b", RawValue::Number(0.3)), ("time_constant", RawValue::Text("10 ms".into()))];
        let v = ProportionalPressureValve::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (k as &str, v))).unwrap()).unwrap();
        let gas = gas::IdealGas::air();
        let n = [gas.state_pt(7e5, 293.15), gas.state_pt(3e5, 293.15), gas.state_pt(101_325.0, 293.15)];
        // command 3 barg: the effective set pressure heads for 4.01325 bar abs
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[101_325.0], pneumatic: &n, mechanical: &[], signals: &[3e5] };
        let mut d = [0.0];
        v.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
        assert!((d[0] - 3e5 / 0.01).abs() < 1e-6);
        // settled at the set pressure, an outlet at 3 bar abs draws through the fully open supply passage
        let ctx = Ctx { states: &[4.01325e5], ..ctx };
        let mut out = [PortFlow::default(); 3];
        v.flows(&ctx, &mut out);
        let iso = v.regulation.supply.mass_flow(7e5, 293.15, 3e5, 293.15);
        assert!((out[0].mdot - iso).abs() < 1e-15 && out[2].mdot == 0.0);
        // above the set pressure it relieves
        let n2 = [n[0], gas.state_pt(4.5e5, 293.15), n[2]];
        v.flows(&Ctx { pneumatic: &n2, ..ctx }, &mut out);
        assert!(out[0].mdot == 0.0 && out[2].mdot < 0.0);
    }

    #[test]
    fn partials_equal_central_differences() {
        use crate::partials_check::{build, point};
        let base = [("C", "10 L/min/bar"), ("b", "0.3")];
        let ports = |outlet: f64| [(7e5, 300.0), (outlet, 295.0), (1.01325e5, 290.0)];
        // set pressure w = 5 bar abs; outlet below it (supply opening, relief shut), above it (relieving)
        let first = build(&TYPE, &base);
        let second = build(&TYPE, &[base[0], base[1], ("spool_order", "second")]);
        for outlet in [4.9e5, 5.1e5] {
            point(&[5e5], &ports(outlet), &[3e5]).check(first.as_ref(), Phase::Flows);
            point(&[5e5], &ports(outlet), &[3e5]).check(first.as_ref(), Phase::Derivatives);
            point(&[5e5, 2e6], &ports(outlet), &[3e5]).check(second.as_ref(), Phase::Flows);
            point(&[5e5, 2e6], &ports(outlet), &[3e5]).check(second.as_ref(), Phase::Derivatives);
        }
        // lagged openings (states w, x, y), a negative command clipped at zero gauge
        let lagged = build(&TYPE, &[base[0], base[1], ("response_time", "5 ms")]);
        for signal in [3e5, -1e4] {
            let at = point(&[5e5, 0.4, 0.2], &ports(5.1e5), &[signal]);
            at.check(lagged.as_ref(), Phase::Flows);
            at.check(lagged.as_ref(), Phase::Derivatives);
        }
    }
}
