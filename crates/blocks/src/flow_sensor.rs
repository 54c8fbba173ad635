//! Flow sensor: an in-line flow meter. Gas passes through it as through a
//! restriction (its pressure drop is part of the circuit), and it reads the
//! mass flow and the free-air (ANR) volume flow with a first-order lag.
//!
//! # Ports
//! - `a`, `b` — pneumatic, flow: positive reading for gas passing a → b.
//! - `mdot` [kg/s], `Q` [m³/s ANR] — signal outputs: the readings.
//!
//! # Parameters (defaults in brackets)
//! - `C` [m³/(s Pa), 1000 L/min/bar], `b` [-, 0.5], and the shared ISO 6358
//!   set (`m`, `b_lam`, `T_ref`, `rho_ref`): the meter's passage.
//! - `time_constant` [s, 10 ms, ≥ 0]: τ of the reading; 0 = ideal.
//!
//! # Equations
//! ṁ through the passage after ISO 6358 (paper Eq. 33–35); reading
//! τ·ẏ = ṁ − y (first-order instrument, Doebelin, *Measurement Systems*,
//! §3.3); Q = y/ρ_ANR with ρ_ANR = 1.185 kg/m³ (ISO 8778 standard
//! reference atmosphere: 20 °C, 100 kPa, 65 % relative humidity).

use crate::block::*;
use crate::conductance::restriction_flow;
use crate::iso6358::{FlowCharacteristic, ANR_DENSITY};
use crate::params::{ParamSpec, Params, Range};
use crate::support::Lag;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    &[
        ParamSpec::quantity("C", dim::CONDUCTANCE, Some(1000e-3 / 60.0 / 1e5), Range::Positive, "L/min/bar", "sonic conductance of the passage"),
        ParamSpec::quantity("b", dim::DIMENSIONLESS, Some(0.5), Range::OpenUnit, "", "critical pressure ratio of the passage"),
    ],
    crate::iso6358::SHARED,
    &[ParamSpec::quantity("time_constant", dim::TIME, Some(0.01), Range::NonNegative, "ms", "response time constant (0 = ideal)")]
);
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("a", PortKind::PneumaticFlow, "inlet (positive reading for flow a -> b)"),
    PortSpec::new("b", PortKind::PneumaticFlow, "outlet"),
    PortSpec::signal("mdot", PortKind::SignalOut, "kg/s", "mass flow reading"),
    PortSpec::signal("Q", PortKind::SignalOut, "m3/s", "free-air volume flow reading (ANR, ISO 8778)"),
];

#[derive(Debug, Clone, PartialEq)]
pub struct FlowSensor {
    pub flow: FlowCharacteristic,
    pub lag: Lag,
}

impl FlowSensor {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(FlowSensor { flow: crate::iso6358::from_params(p, "C", "b")?, lag: Lag { tau: p.get("time_constant") } })
    }
    fn mdot(&self, ctx: &Ctx) -> f64 {
        let (a, b) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        self.flow.mass_flow(a.p, a.t, b.p, b.t)
    }
}

impl Block for FlowSensor {
    fn type_name(&self) -> &'static str {
        "flow_sensor"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn states(&self) -> &[StateSpec] {
        self.lag.states()
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out.fill(1e-3);
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        self.lag.start_at(self.mdot(ctx), states);
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let f = restriction_flow(&self.flow, 1.0, &ctx.pneumatic[0], &ctx.pneumatic[1], 0.0);
        out[0] = f;
        out[1] = -f;
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        let (a, b) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        let r = crate::conductance::restriction_partials(&self.flow, 1.0, a, b, 0.0, ctx.gas);
        if phase == Phase::Flows {
            crate::conductance::add_path(d, 0, 1, &r, &[]);
        }
        let du = [(In::P(0), r.mdot[0]), (In::T(0), r.mdot[1]), (In::P(1), r.mdot[2]), (In::T(1), r.mdot[3])];
        self.lag.partials(phase, 0, &du, d);
        let scaled = du.map(|(i, v)| (i, v / ANR_DENSITY));
        if phase == Phase::Signals {
            if self.lag.tau > 0.0 {
                d.set(Out::Signal(1), In::State(0), 1.0 / ANR_DENSITY);
            } else {
                for (i, v) in scaled {
                    d.add(Out::Signal(1), i, v);
                }
            }
        }
        true
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        let y = self.lag.output(self.mdot(ctx), ctx.states);
        out[0] = y;
        out[1] = y / ANR_DENSITY;
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        self.lag.derivative(self.mdot(ctx), ctx.states, out);
    }
}

/// Registry entry of `flow_sensor`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "flow_sensor",
    family: crate::registry::Family::Sensors,
    doc: "in-line flow meter: mass flow and ANR volume flow, first-order lag",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(FlowSensor::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    #[test]
    fn reads_the_iso_flow_it_passes_in_anr_litres() {
        let gas = gas::IdealGas::air();
        let c = 1000e-3 / 60.0 / 1e5;
        let s = FlowSensor { flow: FlowCharacteristic::new(c, 0.5).unwrap(), lag: Lag { tau: 0.0 } };
        // choked at 6 bar → 1 bar (r < b): ṁ = C ρ_ANR p1 K_T, K_T = 1 at 20 °C
        let nodes = [gas.state_pt(6e5, 293.15), gas.state_pt(1e5, 293.15)];
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &nodes, mechanical: &[], signals: &[] };
        let mut out = [0.0; 2];
        s.signal_outputs(&ctx, &mut out);
        let mdot = c * ANR_DENSITY * 6e5;
        assert!((out[0] - mdot).abs() < 1e-12 * mdot);
        // in free air: Q = C p1 = 6000 L/min
        assert!((out[1] * 60e3 - 6000.0).abs() < 1e-9, "{} L/min", out[1] * 60e3);
        let mut f = [PortFlow::default(); 2];
        s.flows(&ctx, &mut f);
        assert!((f[0].mdot - mdot).abs() < 1e-12 * mdot && f[0].mdot + f[1].mdot == 0.0);
    }
}
