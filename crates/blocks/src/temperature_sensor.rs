//! Temperature sensor: reads the gas temperature of a pneumatic node with a
//! first-order lag (a thermocouple's response).
//!
//! # Ports
//! - `port` — pneumatic, flow: reads the node, passes no gas.
//! - `T` [K] — signal output: the reading.
//!
//! # Parameters (defaults in brackets)
//! - `time_constant` [s, 50 ms, ≥ 0]: τ of the sensor; 0 = ideal. A fine
//!   wire thermocouple in air answers in tens of milliseconds; a sheathed
//!   probe in seconds — slower than the chamber temperature swings of a
//!   stroke, which is why the paper measures them indirectly (§3).
//!
//! # Equations
//! τ·Ṫ_s = T − T_s (first-order instrument, Doebelin, *Measurement
//! Systems*, §3.3); the reading starts at the initial temperature.
//!
//! # Assumptions
//! No heat taken from the gas by the sensor.
//!
//! The lag, states and partials are the shared [`crate::lagged_sensor`]
//! pattern; this file says only what is read.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::lagged_sensor::{LaggedSensor, Reading};
use units::dim;

pub const PARAMS: &[ParamSpec] =
    &[ParamSpec::quantity("time_constant", dim::TIME, Some(0.05), Range::NonNegative, "ms", "response time constant (0 = ideal)")];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("port", PortKind::PneumaticFlow, "the node whose temperature is read (no flow)"),
    PortSpec::signal("T", PortKind::SignalOut, "K", "temperature reading"),
];

/// What a temperature sensor reads: the gas temperature of the node.
#[derive(Debug, Clone, PartialEq)]
pub struct Temperature;

impl Reading for Temperature {
    const TYPE_NAME: &'static str = "temperature_sensor";
    const PORTS: &'static [PortSpec] = PORTS;
    const SCALE: f64 = 300.0;
    const INPUT: In = In::T(0);
    fn from_params(_p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Temperature)
    }
    fn value(&self, ctx: &Ctx) -> f64 {
        ctx.pneumatic[0].t
    }
}

/// The temperature sensor: [`Temperature`] behind a first-order lag.
pub type TemperatureSensor = LaggedSensor<Temperature>;

/// Registry entry of `temperature_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: <Temperature as Reading>::TYPE_NAME,
    family: crate::registry::Family::Sensors,
    doc: "gas temperature of a node with a first-order lag",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(TemperatureSensor::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::Lag;
    use gas::GasModel;

    #[test]
    fn lags_behind_a_temperature_step_by_its_time_constant() {
        let gas = gas::IdealGas::air();
        let s = TemperatureSensor { lag: Lag { tau: 0.05 }, reading: Temperature };
        let node = [gas.state_pt(3e5, 350.0)];
        let (mut y, dt) = (300.0, 1e-5);
        let mut d = [0.0];
        let mut t = 0.0;
        while t < 0.05 - dt / 2.0 {
            let ctx = Ctx { t, gas: &gas, states: &[y], pneumatic: &node, mechanical: &[], signals: &[] };
            s.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
            y += dt * d[0];
            t += dt;
        }
        // 63.2 % of the step after one time constant
        let exact = 300.0 + 50.0 * (1.0 - (-1.0f64).exp());
        assert!((y - exact).abs() < 0.01, "{y} vs {exact}");
    }
}
