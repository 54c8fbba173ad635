//! Velocity sensor: reads the velocity of a mechanical node with a
//! first-order lag (a tachometer, or the filtered derivative of an encoder).
//!
//! # Ports
//! - `rod` — mechanical, force: reads v, exerts no force.
//! - `v` [m/s] — signal output: the reading.
//!
//! # Parameters (defaults in brackets)
//! - `time_constant` [s, 0, ≥ 0]: τ of the reading; 0 = ideal.
//!
//! # Equations
//! τ·ẏ = v − y (first-order instrument, Doebelin, *Measurement Systems*,
//! §3.3); the reading starts at the initial velocity.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::support::Lag;
use units::dim;

pub const PARAMS: &[ParamSpec] =
    &[ParamSpec::quantity("time_constant", dim::TIME, Some(0.0), Range::NonNegative, "ms", "response time constant (0 = ideal)")];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("rod", PortKind::MechanicalForce, "the moving mass whose velocity is read (no force)"),
    PortSpec::signal("v", PortKind::SignalOut, "m/s", "velocity reading"),
];

#[derive(Debug, Clone, PartialEq)]
pub struct VelocitySensor {
    pub lag: Lag,
}

impl VelocitySensor {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(VelocitySensor { lag: Lag { tau: p.get("time_constant") } })
    }
}

impl Block for VelocitySensor {
    fn type_name(&self) -> &'static str {
        "velocity_sensor"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn states(&self) -> &[StateSpec] {
        self.lag.states()
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out.fill(1.0);
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        self.lag.start_at(ctx.mechanical[0].v, states);
    }
    fn forces(&self, _ctx: &Ctx, out: &mut [PortForce]) {
        out[0] = PortForce::default();
    }
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        self.lag.partials(phase, 0, &[(In::V(0), 1.0)], d);
        true
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.lag.output(ctx.mechanical[0].v, ctx.states);
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        self.lag.derivative(ctx.mechanical[0].v, ctx.states, out);
    }
}

/// Registry entry of `velocity_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "velocity_sensor",
    family: crate::registry::Family::Sensors,
    doc: "velocity of a moving mass with a first-order lag",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(VelocitySensor::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivative_is_the_first_order_law() {
        let gas = gas::IdealGas::air();
        let s = VelocitySensor { lag: Lag { tau: 0.004 } };
        let mech = [MechState { x: 0.0, v: 0.8 }];
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[0.2], pneumatic: &[], mechanical: &mech, signals: &[] };
        let mut d = [0.0];
        s.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
        assert!((d[0] - (0.8 - 0.2) / 0.004).abs() < 1e-9);
        let mut out = [0.0];
        s.signal_outputs(&ctx, &mut out);
        assert_eq!(out[0], 0.2, "the output is the lagged state");
        let mut x = [0.0];
        s.initial_states_from_inputs(&ctx, &mut x);
        assert_eq!(x[0], 0.8);
    }
}
