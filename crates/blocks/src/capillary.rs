//! Capillary: a laminar restriction — a long, narrow passage such as the
//! gap past a worn piston seal, a bleed hole or a capillary tube.
//!
//! # Ports
//! - `a`, `b` — pneumatic, flow (conductance form: flows from the pressures).
//!
//! # Parameters
//! - `k` [m³/(s Pa), required]: laminar coefficient, k = π d⁴/(128 μ ℓ) for a
//!   round passage of diameter d and length ℓ in a gas of viscosity μ (the
//!   same dimension as an ISO 6358 conductance, so it may be given in
//!   "L/min/bar").
//!
//! # Equations
//! Hagen–Poiseuille flow dp/dx = −128 μ ṁ/(π d⁴ ρ) integrated along the
//! passage at constant temperature with ρ = p/(R T) gives
//! ṁ = k·(p_up² − p_down²)/(2 R T_up); with a real-gas model the factor
//! 1/(R T_up) is ρ_up/p_up. Unlike an orifice (ISO 6358, `conductance`) the
//! flow grows with the mean pressure and never chokes: at a small drop it is
//! ṁ ≈ k·ρ_up·Δp. Flow runs from the higher to the lower pressure; the
//! energy flow is ṁ·h_up (isenthalpic throttling, as for `conductance`).
//!
//! # Assumptions
//! Fully developed laminar flow (Reynolds number well below 2000), the gas
//! at the upstream temperature along the whole passage, no gas stored in
//! it, quasi-steady.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use gas::GasState;
use units::dim;

pub const PARAMS: &[ParamSpec] = &[ParamSpec::quantity(
    "k",
    dim::CONDUCTANCE,
    None,
    Range::Positive,
    "L/min/bar",
    "laminar coefficient k = pi d^4/(128 mu l)",
)];
pub const PORTS: &[PortSpec] =
    &[PortSpec::new("a", PortKind::PneumaticFlow, "side a"), PortSpec::new("b", PortKind::PneumaticFlow, "side b")];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "mdot", unit: "kg/s" }];

#[derive(Debug, Clone, PartialEq)]
pub struct Capillary {
    /// Laminar coefficient [m³/(s Pa)].
    pub k: f64,
}

impl Capillary {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Capillary { k: p.get("k") })
    }

    /// Flow into port a with ∂ṁ/∂p_a and ∂ṁ/∂p_b (temperatures held).
    pub fn flow_slopes(&self, a: &GasState, b: &GasState) -> (PortFlow, f64, f64) {
        let up = if a.p >= b.p { a } else { b };
        // 1/(R T_up) of an ideal gas; ρ/p of any gas model
        let c = up.rho / up.p;
        let mdot = 0.5 * self.k * c * (a.p * a.p - b.p * b.p);
        (PortFlow { mdot, edot: mdot * up.h }, self.k * c * a.p, -self.k * c * b.p)
    }
}

impl Block for Capillary {
    fn type_name(&self) -> &'static str {
        "capillary"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let (f, _, _) = self.flow_slopes(&ctx.pneumatic[0], &ctx.pneumatic[1]);
        out[0] = f;
        out[1] = -f;
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        let (f, da, db) = self.flow_slopes(&ctx.pneumatic[0], &ctx.pneumatic[1]);
        Some(crate::conductance::at_port(port, f, da, db))
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.flow_slopes(&ctx.pneumatic[0], &ctx.pneumatic[1]).0.mdot);
    }
}

/// Registry entry of `capillary`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "capillary",
    family: crate::registry::Family::Restrictions,
    doc: "laminar restriction (Hagen-Poiseuille, compressible): leak gap, bleed",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Capillary::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    #[test]
    fn the_flow_is_the_integrated_hagen_poiseuille_law() {
        let gas = gas::IdealGas::air();
        let cap = Capillary { k: 1e-11 };
        let (hi, lo) = (gas.state_pt(5e5, 300.0), gas.state_pt(1e5, 280.0));
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[hi, lo], mechanical: &[], signals: &[] };
        let mut out = [PortFlow::default(); 2];
        cap.flows(&ctx, &mut out);
        // k (p_a² − p_b²)/(2 R T_a), R of air from the gas model
        let r = hi.p / (hi.rho * hi.t);
        let expected = 1e-11 * (25e10 - 1e10) / (2.0 * r * 300.0);
        assert!((out[0].mdot / expected - 1.0).abs() < 1e-12, "{} vs {expected}", out[0].mdot);
        assert!((out[0].edot / out[0].mdot - hi.h).abs() < 1e-9);
        assert_eq!(out[1].mdot, -out[0].mdot);
        // reversed: the same magnitude the other way, with the upstream (now b) enthalpy
        let ctx = Ctx { pneumatic: &[lo, hi], ..ctx };
        cap.flows(&ctx, &mut out);
        assert!((out[0].mdot / expected + 1.0).abs() < 1e-12);
        assert!((out[0].edot / out[0].mdot - hi.h).abs() < 1e-9);
    }

    #[test]
    fn slopes_match_differences_and_the_flow_never_chokes() {
        let gas = gas::IdealGas::air();
        let cap = Capillary { k: 2e-11 };
        let (a, b) = (gas.state_pt(3e5, 293.15), gas.state_pt(2e5, 293.15));
        let (f, da, db) = cap.flow_slopes(&a, &b);
        let h = 1.0;
        let fa = cap.flow_slopes(&gas.state_pt(a.p + h, a.t), &b).0.mdot;
        let fb = cap.flow_slopes(&a, &gas.state_pt(b.p + h, b.t)).0.mdot;
        assert!(((fa - f.mdot) / h / da - 1.0).abs() < 1e-5);
        assert!(((fb - f.mdot) / h / db - 1.0).abs() < 1e-5);
        // a lower downstream pressure always passes more (no choking)
        let vacuum = cap.flow_slopes(&a, &gas.state_pt(0.1e5, 293.15)).0.mdot;
        let half = cap.flow_slopes(&a, &gas.state_pt(1.5e5, 293.15)).0.mdot;
        assert!(vacuum > half && half > f.mdot);
    }
}
