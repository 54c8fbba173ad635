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
//!
//! The lag, states and partials are the shared [`crate::lagged_sensor`]
//! pattern; this file says only what is read.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::lagged_sensor::{LaggedSensor, Reading};
use units::dim;

pub const PARAMS: &[ParamSpec] =
    &[ParamSpec::quantity("time_constant", dim::TIME, Some(0.0), Range::NonNegative, "ms", "response time constant (0 = ideal)")];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("rod", PortKind::MechanicalForce, "the moving mass whose velocity is read (no force)"),
    PortSpec::signal("v", PortKind::SignalOut, "m/s", "velocity reading"),
];

/// What a velocity sensor reads: the node's velocity.
#[derive(Debug, Clone, PartialEq)]
pub struct Velocity;

impl Reading for Velocity {
    const TYPE_NAME: &'static str = "velocity_sensor";
    const PORTS: &'static [PortSpec] = PORTS;
    const SCALE: f64 = 1.0;
    const INPUT: In = In::V(0);
    fn from_params(_p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Velocity)
    }
    fn value(&self, ctx: &Ctx) -> f64 {
        ctx.mechanical[0].v
    }
}

/// The velocity sensor: [`Velocity`] behind a first-order lag.
pub type VelocitySensor = LaggedSensor<Velocity>;

/// Registry entry of `velocity_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: <Velocity as Reading>::TYPE_NAME,
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
    use crate::support::Lag;

    #[test]
    fn derivative_is_the_first_order_law() {
        let gas = gas::IdealGas::air();
        let s = VelocitySensor { lag: Lag { tau: 0.004 }, reading: Velocity };
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
