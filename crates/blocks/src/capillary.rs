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
    /// ṁ = k·c·(p_a² − p_b²)/2 with c = ρ_up/p_up (the integrated
    /// Hagen–Poiseuille law above): ∂ṁ/∂p_a = k c p_a, ∂ṁ/∂p_b = −k c p_b,
    /// plus (k/2)(p_a² − p_b²)·∂c of the upstream side, ∂c/∂p = (p ∂ρ/∂p − ρ)/p²,
    /// ∂c/∂T = (∂ρ/∂T)/p (gas-model slopes, [`crate::support::GasSlopes`]);
    /// Ė = ṁ·h_up with h_up moving with the upstream state.
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase != Phase::Flows {
            return true;
        }
        let (a, b) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        let up_port = if a.p >= b.p { 0 } else { 1 };
        let up = &ctx.pneumatic[up_port];
        let (f, da, db) = self.flow_slopes(a, b);
        let slopes = crate::support::GasSlopes::at(ctx.gas, up);
        let half = 0.5 * self.k * (a.p * a.p - b.p * b.p);
        let dc_dp = (up.p * slopes.drho_dp - up.rho) / (up.p * up.p);
        let dc_dt = slopes.drho_dt / up.p;
        // ∂ṁ by p_a, T_a, p_b, T_b
        let mut dm = [da, 0.0, db, 0.0];
        dm[2 * up_port] += half * dc_dp;
        dm[2 * up_port + 1] += half * dc_dt;
        let mut de = dm.map(|v| v * up.h);
        de[2 * up_port] += f.mdot * slopes.dh_dp;
        de[2 * up_port + 1] += f.mdot * slopes.dh_dt;
        let inputs = [In::P(0), In::T(0), In::P(1), In::T(1)];
        for (port, sign) in [(0, 1.0), (1, -1.0)] {
            for (i, &input) in inputs.iter().enumerate() {
                d.set(Out::Mdot(port), input, sign * dm[i]);
                d.set(Out::Edot(port), input, sign * de[i]);
            }
        }
        true
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

    #[test]
    fn partials_equal_central_differences() {
        use crate::partials_check::{build, point};
        let v = build(&TYPE, &[("k", "2 L/min/bar")]);
        // flow from a to b, then from b to a (the upstream side's density and enthalpy move)
        for ports in [[(5e5, 300.0), (1e5, 280.0)], [(2e5, 285.0), (2.5e5, 310.0)]] {
            point(&[], &ports, &[]).check(v.as_ref(), Phase::Flows);
        }
    }
}
