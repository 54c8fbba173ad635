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

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::support::Lag;
use units::dim;

pub const PARAMS: &[ParamSpec] =
    &[ParamSpec::quantity("time_constant", dim::TIME, Some(0.05), Range::NonNegative, "ms", "response time constant (0 = ideal)")];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("port", PortKind::PneumaticFlow, "the node whose temperature is read (no flow)"),
    PortSpec::signal("T", PortKind::SignalOut, "K", "temperature reading"),
];

#[derive(Debug, Clone, PartialEq)]
pub struct TemperatureSensor {
    pub lag: Lag,
}

impl TemperatureSensor {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(TemperatureSensor { lag: Lag { tau: p.get("time_constant") } })
    }
}

impl Block for TemperatureSensor {
    fn type_name(&self) -> &'static str {
        "temperature_sensor"
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
        out.fill(300.0);
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        self.lag.start_at(ctx.pneumatic[0].t, states);
    }
    fn flows(&self, _ctx: &Ctx, out: &mut [PortFlow]) {
        out[0] = PortFlow::default();
    }
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        self.lag.partials(phase, 0, &[(In::T(0), 1.0)], d);
        true
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.lag.output(ctx.pneumatic[0].t, ctx.states);
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        self.lag.derivative(ctx.pneumatic[0].t, ctx.states, out);
    }
}

/// Registry entry of `temperature_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "temperature_sensor",
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
    use gas::GasModel;

    #[test]
    fn lags_behind_a_temperature_step_by_its_time_constant() {
        let gas = gas::IdealGas::air();
        let s = TemperatureSensor { lag: Lag { tau: 0.05 } };
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
