//! Pressure-relief valve: opens from a line to the exhaust when the line
//! pressure exceeds the exhaust by the cracking pressure.
//!
//! # Ports
//! - `P` (protected line), `E` (exhaust) — pneumatic, flow.
//!
//! # Parameters (defaults in brackets)
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`: the
//!   valve fully open.
//! - `p_crack` [Pa, required, > 0]: pressure difference p_P − p_E at which
//!   it starts to open (write "6 bar": a difference, not an absolute value).
//! - `band` [Pa, 0.5 bar, > 0]: further rise to fully open (the override
//!   of the valve's flow characteristic).
//!
//! # Equations
//! x = clamp((p_P − p_E − p_crack)/Δp_band, 0, 1), ṁ = x·ṁ_ISO(p_P, p_E)
//! (paper Eq. 33–35). A line fed with ṁ settles where x·ṁ_ISO = ṁ; with the
//! valve choked, p_P² − (p_E + p_crack)·p_P − Δp_band·ṁ/(C ρ_ref K_T) = 0.
//!
//! # Assumptions
//! Massless poppet, no hysteresis between opening and reseating, no leak.

use crate::block::*;
use crate::conductance::restriction_flow;
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use crate::support::ramp;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("p_crack", dim::PRESSURE, None, Range::Positive, "bar", "opening pressure difference P - E"),
        ParamSpec::quantity("band", dim::PRESSURE, Some(0.5e5), Range::Positive, "bar", "pressure rise from cracking to fully open"),
    ]
);
pub const PORTS: &[PortSpec] =
    &[PortSpec::new("P", PortKind::PneumaticFlow, "protected line"), PortSpec::new("E", PortKind::PneumaticFlow, "exhaust")];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "mdot", unit: "kg/s" }, OutputSpec { name: "opening", unit: "1" }];

#[derive(Debug, Clone, PartialEq)]
pub struct ReliefValve {
    pub flow: FlowCharacteristic,
    pub p_crack: f64,
    pub band: f64,
}

impl ReliefValve {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(ReliefValve { flow: crate::iso6358::from_params(p, "C", "b")?, p_crack: p.get("p_crack"), band: p.get("band") })
    }
    pub fn opening(&self, p_line: f64, p_exhaust: f64) -> f64 {
        ramp(p_line - p_exhaust, self.p_crack, self.band)
    }
}

impl Block for ReliefValve {
    fn type_name(&self) -> &'static str {
        "relief_valve"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let (a, e) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        let f = restriction_flow(&self.flow, self.opening(a.p, e.p), a, e, 0.0);
        out[0] = f;
        out[1] = -f;
    }
    /// ṁ = x·ṁ_ISO(p_P, p_E) (paper Eq. 33–35) with x = clamp((p_P − p_E −
    /// p_crack)/Δp_band, 0, 1): the ISO 6358 partials plus ṁ_ISO·∂x/∂p
    /// (±1/Δp_band inside the band).
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Flows {
            let (a, e) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
            let s = crate::support::ramp_slope(a.p - e.p, self.p_crack, self.band);
            let r = crate::conductance::restriction_partials(&self.flow, self.opening(a.p, e.p), a, e, 0.0, ctx.gas);
            crate::conductance::add_path(d, 0, 1, &r, &[(In::P(0), s), (In::P(1), -s)]);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let (a, e) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        let x = self.opening(a.p, e.p);
        out[0] = Some(x * self.flow.mass_flow(a.p, a.t, e.p, e.t));
        out[1] = Some(x);
    }
}

/// Registry entry of `relief_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "relief_valve",
    family: crate::registry::Family::PressureValves,
    doc: "pressure-relief valve with cracking pressure",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(ReliefValve::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::iso6358::ANR_DENSITY;
    use gas::GasModel;

    #[test]
    fn steady_line_pressure_is_the_closed_form() {
        let c = 20e-3 / 60.0 / 1e5;
        let v = ReliefValve { flow: FlowCharacteristic::new(c, 0.3).unwrap(), p_crack: 6e5, band: 0.5e5 };
        let gas = gas::IdealGas::air();
        let pe = 1.01325e5;
        for mdot in [1e-4, 5e-4, 1e-3] {
            // p² − (p_E + p_crack) p − band ṁ/(C ρ K_T) = 0, K_T = 1 at 20 °C
            let k = v.band * mdot / (c * ANR_DENSITY);
            let s = pe + v.p_crack;
            let p = 0.5 * (s + (s * s + 4.0 * k).sqrt());
            let n = [gas.state_pt(p, 293.15), gas.state_pt(pe, 293.15)];
            let mut out = [PortFlow::default(); 2];
            v.flows(&Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &n, mechanical: &[], signals: &[] }, &mut out);
            assert!(pe / p < 0.3, "choked");
            assert!((out[0].mdot - mdot).abs() < 1e-12 * mdot, "{} vs {mdot} at {p} Pa", out[0].mdot);
        }
        // closed below the cracking pressure
        let n = [gas.state_pt(6.9e5, 293.15), gas.state_pt(pe, 293.15)];
        let mut out = [PortFlow::default(); 2];
        v.flows(&Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &n, mechanical: &[], signals: &[] }, &mut out);
        assert_eq!(out[0].mdot, 0.0);
    }

    #[test]
    fn partials_equal_central_differences() {
        use crate::partials_check::{build, point};
        let v = build(&TYPE, &[("C", "20 L/min/bar"), ("b", "0.3"), ("p_crack", "6 bar")]);
        // (line, exhaust): opening and choked, fully open and choked, opening and subsonic, closed
        for (p, e) in [(7.2e5, 1e5), (8e5, 1e5), (10.4e5, 4e5), (6.5e5, 1e5)] {
            point(&[], &[(p, 300.0), (e, 290.0)], &[]).check(v.as_ref(), Phase::Flows);
        }
    }
}
