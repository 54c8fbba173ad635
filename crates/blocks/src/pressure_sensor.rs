//! Pressure sensor: reads the pressure of a pneumatic node with a
//! first-order lag.
//!
//! # Ports
//! - `port` — pneumatic, flow: reads the node, passes no gas.
//! - `p` [Pa] — signal output: the reading (absolute, or gauge with `gauge`).
//!
//! # Parameters (defaults in brackets)
//! - `time_constant` [s, 1 ms, ≥ 0]: τ of the sensor's response; 0 = ideal.
//! - `reading` [`absolute`]: `absolute` or `gauge` (p − p_atm).
//! - `p_atm` [Pa, 101 325 Pa]: reference of a gauge reading.
//!
//! # Equations
//! τ·ẏ = p − y (first-order instrument, Doebelin, *Measurement Systems*,
//! §3.3); the step response is y = p·(1 − e^(−t/τ)). The reading starts at
//! the initial pressure (no start-up transient).
//!
//! # Assumptions
//! No dead volume and no flow into the sensor (its volume belongs to the
//! node's capacity).
//!
//! The lag, states and partials are the shared [`crate::lagged_sensor`]
//! pattern; this file says only what is read.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::lagged_sensor::{LaggedSensor, Reading};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("time_constant", dim::TIME, Some(1e-3), Range::NonNegative, "ms", "response time constant (0 = ideal)"),
    ParamSpec::choice("reading", &["absolute", "gauge"], 0, "absolute pressure, or gauge (p - p_atm)"),
    ParamSpec::quantity("p_atm", dim::PRESSURE, Some(101_325.0), Range::AbsolutePressure, "bar", "reference of a gauge reading"),
];
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("port", PortKind::PneumaticFlow, "the node whose pressure is read (no flow)"),
    PortSpec::signal("p", PortKind::SignalOut, "Pa", "pressure reading"),
];

/// What a pressure sensor reads: the node's absolute pressure less `offset`.
#[derive(Debug, Clone, PartialEq)]
pub struct Pressure {
    /// Subtracted from the absolute pressure (0, or p_atm for a gauge reading) [Pa].
    pub offset: f64,
}

impl Reading for Pressure {
    const TYPE_NAME: &'static str = "pressure_sensor";
    const PORTS: &'static [PortSpec] = PORTS;
    const SCALE: f64 = 1e5;
    const INPUT: In = In::P(0);
    fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let offset = if p.choice("reading") == 1 { p.get("p_atm") } else { 0.0 };
        Ok(Pressure { offset })
    }
    fn value(&self, ctx: &Ctx) -> f64 {
        ctx.pneumatic[0].p - self.offset
    }
}

/// The pressure sensor: [`Pressure`] behind a first-order lag.
pub type PressureSensor = LaggedSensor<Pressure>;

/// Registry entry of `pressure_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: <Pressure as Reading>::TYPE_NAME,
    family: crate::registry::Family::Sensors,
    doc: "pressure of a node with a first-order lag",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(PressureSensor::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::Lag;
    use gas::GasModel;

    #[test]
    fn step_response_is_the_first_order_closed_form() {
        let gas = gas::IdealGas::air();
        let s = PressureSensor { lag: Lag { tau: 0.01 }, reading: Pressure { offset: 0.0 } };
        let node = [gas.state_pt(5e5, 293.15)];
        // start at 1 bar, the node steps to 5 bar: y(τ) = 1 + 4(1 − 1/e) bar
        let (mut y, dt) = (1e5, 1e-6);
        let mut d = [0.0];
        for _ in 0..10_000 {
            let ctx = Ctx { t: 0.0, gas: &gas, states: &[y], pneumatic: &node, mechanical: &[], signals: &[] };
            s.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
            y += dt * d[0];
        }
        let exact = 1e5 + 4e5 * (1.0 - (-1.0f64).exp());
        assert!((y - exact).abs() < 1e-4 * exact, "{y} vs {exact}");
        // no gas flows into it
        let mut f = [PortFlow { mdot: 1.0, edot: 1.0 }];
        s.flows(&Ctx { t: 0.0, gas: &gas, states: &[y], pneumatic: &node, mechanical: &[], signals: &[] }, &mut f);
        assert_eq!(f[0], PortFlow::default());
    }

    #[test]
    fn ideal_gauge_reading_subtracts_the_atmosphere() {
        let gas = gas::IdealGas::air();
        let s = PressureSensor { lag: Lag { tau: 0.0 }, reading: Pressure { offset: 101_325.0 } };
        assert!(s.states().is_empty());
        let node = [gas.state_pt(6e5, 293.15)];
        let mut out = [0.0];
        s.signal_outputs(&Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &node, mechanical: &[], signals: &[] }, &mut out);
        assert_eq!(out[0], 6e5 - 101_325.0);
    }
}
