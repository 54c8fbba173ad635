//! Check valve: a one-way ISO 6358 restriction with a cracking pressure.
//!
//! # Ports
//! - `a` (inlet), `b` (outlet) — pneumatic, flow. Flow passes only from a to b.
//!
//! # Parameters (defaults in brackets)
//! - `C` [m³/(s Pa), required], `b` [-, required], `m` [0.5], `b_lam` [0.999],
//!   `T_ref`, `rho_ref`: the ISO 6358 characteristic of the open valve.
//! - `cracking_pressure` [Pa, 0]: pressure difference p_a − p_b at which the
//!   valve starts to open.
//! - `opening_range` [Pa, 1000 Pa]: further pressure difference over which it
//!   opens fully.
//!
//! # Equations
//! Opening s = clamp((p_a − p_b − p_crack)/Δp_open, 0, 1);
//! ṁ = s·ṁ_ISO(p_a, T_a → p_b) (Eq. 33–35). The linear opening keeps the flow
//! Lipschitz continuous in the pressures (no chattering at closing).
//!
//! # Assumptions
//! Massless poppet (opening follows Δp instantly); no reverse leakage.

use crate::block::*;
use crate::conductance::{characteristic, restriction_flow};
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("cracking_pressure", dim::PRESSURE, Some(0.0), Range::NonNegative, "bar", "opening pressure difference"),
        ParamSpec::quantity("opening_range", dim::PRESSURE, Some(1000.0), Range::Positive, "bar", "pressure rise from cracking to fully open"),
    ]
);
pub const PORTS: &[PortSpec] =
    &[PortSpec::new("a", PortKind::PneumaticFlow, "inlet"), PortSpec::new("b", PortKind::PneumaticFlow, "outlet")];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "mdot", unit: "kg/s" }];

/// One-way element shared by the check valve and the speed-control valve.
#[derive(Debug, Clone, PartialEq)]
pub struct OneWay {
    pub flow: FlowCharacteristic,
    pub cracking_pressure: f64,
    pub opening_range: f64,
}

impl OneWay {
    /// Opening fraction for a pressure difference p_a − p_b.
    pub fn opening(&self, dp: f64) -> f64 {
        ((dp - self.cracking_pressure) / self.opening_range).clamp(0.0, 1.0)
    }
    /// Flow into the element at port a (from a to b).
    pub fn flow(&self, a: &gas::GasState, b: &gas::GasState) -> PortFlow {
        restriction_flow(&self.flow, self.opening(a.p - b.p), a, b, 0.0)
    }
    /// Add the partials of [`OneWay::flow`] between the block's pneumatic
    /// ports `pa` and `pb` to `d` (the opening moves with p_a − p_b inside
    /// the opening range).
    pub fn add_partials(&self, d: &mut Partials, pa: usize, pb: usize, ctx: &Ctx) {
        let (a, b) = (&ctx.pneumatic[pa], &ctx.pneumatic[pb]);
        let x = (a.p - b.p - self.cracking_pressure) / self.opening_range;
        let r = crate::conductance::restriction_partials(&self.flow, self.opening(a.p - b.p), a, b, 0.0, ctx.gas);
        let k = 1.0 / self.opening_range;
        let moves: &[(In, f64)] = if x > 0.0 && x < 1.0 { &[(In::P(pa), k), (In::P(pb), -k)] } else { &[] };
        crate::conductance::add_path(d, pa, pb, &r, moves);
    }
    /// [`OneWay::flow`] with the derivatives of its mass flow by p_a and p_b
    /// (the opening moves with p_a − p_b inside the opening range).
    pub fn flow_slopes(&self, a: &gas::GasState, b: &gas::GasState) -> (PortFlow, f64, f64) {
        let dp = a.p - b.p;
        let opening = self.opening(dp);
        let (f, da, db) = crate::conductance::restriction_flow_slopes(&self.flow, opening, a, b, 0.0);
        let x = (dp - self.cracking_pressure) / self.opening_range;
        if x > 0.0 && x < 1.0 {
            // ṁ = opening·ṁ_ISO: the opening's own slope ±1/range adds ṁ_ISO/range
            let full = self.flow.mass_flow(a.p, a.t, b.p, b.t);
            let d = full / self.opening_range;
            (f, da + d, db - d)
        } else {
            (f, da, db)
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct CheckValve {
    pub valve: OneWay,
}

impl CheckValve {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(CheckValve {
            valve: OneWay {
                flow: characteristic(p, "C", "b")?,
                cracking_pressure: p.get("cracking_pressure"),
                opening_range: p.get("opening_range"),
            },
        })
    }
}

impl Block for CheckValve {
    fn type_name(&self) -> &'static str {
        "check_valve"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let f = self.valve.flow(&ctx.pneumatic[0], &ctx.pneumatic[1]);
        out[0] = f;
        out[1] = -f;
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        let (f, da, db) = self.valve.flow_slopes(&ctx.pneumatic[0], &ctx.pneumatic[1]);
        Some(crate::conductance::at_port(port, f, da, db))
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Flows {
            self.valve.add_partials(d, 0, 1, ctx);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.valve.flow(&ctx.pneumatic[0], &ctx.pneumatic[1]).mdot);
    }
}

/// Registry entry of `check_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "check_valve",
    family: crate::registry::Family::Restrictions,
    doc: "one-way restriction with cracking pressure",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(CheckValve::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    fn valve(crack: f64) -> OneWay {
        OneWay { flow: FlowCharacteristic::new(1e-8, 0.3).unwrap(), cracking_pressure: crack, opening_range: 1000.0 }
    }

    #[test]
    fn blocks_reverse_flow_and_opens_above_cracking() {
        let gas = gas::IdealGas::air();
        let v = valve(20_000.0);
        let lo = gas.state_pt(2e5, 293.0);
        assert_eq!(v.flow(&lo, &gas.state_pt(5e5, 293.0)).mdot, 0.0); // reverse
        assert_eq!(v.flow(&gas.state_pt(2.19e5, 293.0), &lo).mdot, 0.0); // below cracking
        let open = v.flow(&gas.state_pt(3e5, 293.0), &lo).mdot;
        let free = v.flow.mass_flow(3e5, 293.0, 2e5, 293.0);
        assert!((open - free).abs() < 1e-15 && open > 0.0);
        // partly open inside the opening range
        let part = v.flow(&gas.state_pt(2.205e5, 293.0), &lo).mdot;
        let full = v.flow.mass_flow(2.205e5, 293.0, 2e5, 293.0);
        assert!((part - 0.5 * full).abs() < 1e-9 * full);
    }

    #[test]
    fn flow_is_continuous_through_cracking() {
        // ṁ = s(Δp)·ṁ_ISO is Lipschitz: d/dΔp ≤ ṁ_ISO/Δp_open + dṁ_ISO/dp. Bound both by
        // their largest values over the range (laminar slope C ρ_ref K_T ω(b_lam)/(1 − b_lam))
        // and check no 1 Pa step exceeds it; a jump to the open flow (~1e-3 kg/s) would.
        let gas = gas::IdealGas::air();
        let v = valve(10_000.0);
        let lo = gas.state_pt(2e5, 293.0);
        let fc = &v.flow;
        let laminar_slope = fc.c() * fc.rho_ref() * (fc.t_ref() / 293.0).sqrt() * fc.omega(fc.b_lam()) / (1.0 - fc.b_lam());
        let open_max = fc.mass_flow(2.13e5, 293.0, 2e5, 293.0);
        let lipschitz = open_max / v.opening_range + laminar_slope;
        let mut prev = v.flow(&gas.state_pt(2.09e5, 293.0), &lo).mdot;
        assert_eq!(prev, 0.0);
        for i in 1..=4000 {
            let pa = 2.09e5 + i as f64;
            let f = v.flow(&gas.state_pt(pa, 293.0), &lo).mdot;
            assert!(f >= prev, "not monotone at {pa}");
            assert!(f - prev <= lipschitz * 1.0001, "jump of {} at {pa} (bound {lipschitz})", f - prev);
            prev = f;
        }
        // just above cracking the flow is tiny
        let eps = v.flow(&gas.state_pt(2.1e5 + 1e-3, 293.0), &lo).mdot;
        assert!(eps < 1e-3 * lipschitz, "{eps}");
    }
}
