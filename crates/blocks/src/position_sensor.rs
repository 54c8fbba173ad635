//! Position sensor: reads the position of a mechanical node (a linear
//! encoder or potentiometer on the rod) with a first-order lag.
//!
//! # Ports
//! - `rod` — mechanical, force: reads x, exerts no force.
//! - `x` [m] — signal output: the reading.
//!
//! # Parameters (defaults in brackets)
//! - `time_constant` [s, 0, ≥ 0]: τ of the reading; 0 = ideal.
//! - `offset` [m, 0]: subtracted from the position (the sensor's zero).
//!
//! # Equations
//! τ·ẏ = (x − offset) − y (first-order instrument, Doebelin, *Measurement
//! Systems*, §3.3); the reading starts at the initial position.
//!
//! The lag, states and partials are the shared [`crate::lagged_sensor`]
//! pattern; this file says only what is read.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::lagged_sensor::{LaggedSensor, Reading};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("time_constant", dim::TIME, Some(0.0), Range::NonNegative, "ms", "response time constant (0 = ideal)"),
    ParamSpec::quantity("offset", dim::LENGTH, Some(0.0), Range::Any, "mm", "position read as zero"),
];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("rod", PortKind::MechanicalForce, "the moving mass whose position is read (no force)"),
    PortSpec::signal("x", PortKind::SignalOut, "m", "position reading"),
];

/// What a position sensor reads: the node's position less the sensor's zero.
#[derive(Debug, Clone, PartialEq)]
pub struct Position {
    /// Position read as zero [m].
    pub offset: f64,
}

impl Reading for Position {
    const TYPE_NAME: &'static str = "position_sensor";
    const PORTS: &'static [PortSpec] = PORTS;
    const SCALE: f64 = 0.1;
    const INPUT: In = In::X(0);
    fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Position { offset: p.get("offset") })
    }
    fn value(&self, ctx: &Ctx) -> f64 {
        ctx.mechanical[0].x - self.offset
    }
}

/// The position sensor: [`Position`] behind a first-order lag.
pub type PositionSensor = LaggedSensor<Position>;

/// Registry entry of `position_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: <Position as Reading>::TYPE_NAME,
    family: crate::registry::Family::Sensors,
    doc: "position of a moving mass with a first-order lag",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(PositionSensor::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::Lag;

    #[test]
    fn reads_the_node_and_exerts_no_force() {
        let gas = gas::IdealGas::air();
        let s = PositionSensor { lag: Lag { tau: 0.0 }, reading: Position { offset: 0.01 } };
        let mech = [MechState { x: 0.25, v: 0.3 }];
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &mech, signals: &[] };
        let mut out = [0.0];
        s.signal_outputs(&ctx, &mut out);
        assert!((out[0] - 0.24).abs() < 1e-15);
        let mut f = [PortForce { applied: 3.0, friction: None }];
        s.forces(&ctx, &mut f);
        assert_eq!(f[0], PortForce::default());
        // with a lag, a ramp x = v t is read late by τ once the transient is over
        let lagged = PositionSensor { lag: Lag { tau: 0.002 }, reading: Position { offset: 0.0 } };
        let (mut y, dt, v) = (0.0, 1e-6, 0.5);
        let mut d = [0.0];
        for k in 0..20_000 {
            let mech = [MechState { x: v * k as f64 * dt, v }];
            let c = Ctx { t: 0.0, gas: &gas, states: &[y], pneumatic: &[], mechanical: &mech, signals: &[] };
            lagged.derivatives(&c, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
            y += dt * d[0];
        }
        let x_end = v * 20_000.0 * dt;
        assert!((x_end - y - v * 0.002).abs() < 1e-5, "lag {}", x_end - y);
    }
}
