//! Quick-exhaust valve: mounted at a cylinder port, it lets air in from the
//! valve line (P → A) and, when the line is vented, exhausts the cylinder
//! straight to the atmosphere (A → E) instead of back through the line and
//! the directional valve.
//!
//! ```text
//!   P ──[ lip seal, opens when p_P > p_A ]── A ──[ exhaust seat, opens when p_A > p_P ]── E
//! ```
//!
//! # Ports
//! - `P` (from the directional valve), `A` (to the cylinder), `E` (exhaust) —
//!   pneumatic, flow.
//!
//! # Parameters (defaults in brackets)
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`: the
//!   inflow passage P → A.
//! - `C_exhaust` [m³/(s Pa), required], `b_exhaust` [-, = b]: the exhaust
//!   passage A → E (usually the larger one: that is the point of the valve).
//! - `cracking_pressure` [Pa, 0.1 bar]: pressure difference that moves the
//!   disc off either seat; `opening_range` [Pa, 0.1 bar]: further difference
//!   to fully open.
//!
//! # Equations
//! With Δp = p_P − p_A, the inflow passage opens
//! x_in = clamp((Δp − p_crack)/Δp_open, 0, 1) and the exhaust passage
//! x_ex = clamp((−Δp − p_crack)/Δp_open, 0, 1); each passes
//! x·ṁ_ISO (paper Eq. 33–35). The disc cannot open both: x_in·x_ex = 0.
//!
//! # Assumptions
//! Massless disc following Δp; no leakage across the closed seat.

use crate::block::*;
use crate::conductance::restriction_flow;
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use crate::support::ramp;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("C_exhaust", dim::CONDUCTANCE, None, Range::Positive, "L/min/bar", "exhaust passage A -> E"),
        ParamSpec::quantity("b_exhaust", dim::DIMENSIONLESS, Some(0.0), Range::Closed(0.0, 0.999), "", "exhaust passage (default: b)"),
        ParamSpec::quantity("cracking_pressure", dim::PRESSURE, Some(0.1e5), Range::NonNegative, "bar", "pressure difference to lift the disc"),
        ParamSpec::quantity("opening_range", dim::PRESSURE, Some(0.1e5), Range::Positive, "bar", "further difference to open fully"),
    ]
);
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "from the directional valve"),
    PortSpec::new("A", PortKind::PneumaticFlow, "to the cylinder"),
    PortSpec::new("E", PortKind::PneumaticFlow, "exhaust"),
];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "mdot_in", unit: "kg/s" }, OutputSpec { name: "mdot_exhaust", unit: "kg/s" }];

#[derive(Debug, Clone, PartialEq)]
pub struct QuickExhaust {
    pub inflow: FlowCharacteristic,
    pub exhaust: FlowCharacteristic,
    pub cracking: f64,
    pub range: f64,
}

impl QuickExhaust {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let b_ex = if p.was_given("b_exhaust") { p.get("b_exhaust") } else { p.get("b") };
        Ok(QuickExhaust {
            inflow: crate::iso6358::from_params(p, "C", "b")?,
            exhaust: crate::iso6358::with_shared(p, p.get("C_exhaust"), b_ex)?,
            cracking: p.get("cracking_pressure"),
            range: p.get("opening_range"),
        })
    }
    /// Flows (P → A, A → E) as port flows of the two passages.
    fn passages(&self, ctx: &Ctx) -> (PortFlow, PortFlow) {
        let (p, a, e) = (&ctx.pneumatic[0], &ctx.pneumatic[1], &ctx.pneumatic[2]);
        let dp = p.p - a.p;
        let x_in = ramp(dp, self.cracking, self.range);
        let x_ex = ramp(-dp, self.cracking, self.range);
        (restriction_flow(&self.inflow, x_in, p, a, 0.0), restriction_flow(&self.exhaust, x_ex, a, e, 0.0))
    }
}

impl Block for QuickExhaust {
    fn type_name(&self) -> &'static str {
        "quick_exhaust_valve"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let (pa, ae) = self.passages(ctx);
        out[0] = pa;
        out[1] = -pa;
        out[1] += ae;
        out[2] = -ae;
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Flows {
            let (p, a, e) = (&ctx.pneumatic[0], &ctx.pneumatic[1], &ctx.pneumatic[2]);
            let dp = p.p - a.p;
            let (s_in, s_ex) = (crate::support::ramp_slope(dp, self.cracking, self.range), crate::support::ramp_slope(-dp, self.cracking, self.range));
            let inflow = crate::conductance::restriction_partials(&self.inflow, ramp(dp, self.cracking, self.range), p, a, 0.0, ctx.gas);
            crate::conductance::add_path(d, 0, 1, &inflow, &[(In::P(0), s_in), (In::P(1), -s_in)]);
            let exhaust = crate::conductance::restriction_partials(&self.exhaust, ramp(-dp, self.cracking, self.range), a, e, 0.0, ctx.gas);
            crate::conductance::add_path(d, 1, 2, &exhaust, &[(In::P(0), -s_ex), (In::P(1), s_ex)]);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let (pa, ae) = self.passages(ctx);
        out[0] = Some(pa.mdot);
        out[1] = Some(ae.mdot);
    }
}

/// Registry entry of `quick_exhaust_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "quick_exhaust_valve",
    family: crate::registry::Family::LogicValves,
    doc: "quick-exhaust valve: fills through P, exhausts A straight to E",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(QuickExhaust::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    fn flows(q: &QuickExhaust, pp: f64, pa: f64) -> [PortFlow; 3] {
        let gas = gas::IdealGas::air();
        let n = [gas.state_pt(pp, 293.15), gas.state_pt(pa, 293.15), gas.state_pt(1.01325e5, 293.15)];
        let mut out = [PortFlow::default(); 3];
        q.flows(&Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &n, mechanical: &[], signals: &[] }, &mut out);
        assert!(out.iter().map(|f| f.mdot).sum::<f64>().abs() < 1e-15);
        out
    }

    #[test]
    fn fills_through_p_and_exhausts_through_e() {
        let (c, ce) = (50e-3 / 60.0 / 1e5, 400e-3 / 60.0 / 1e5);
        let q = QuickExhaust {
            inflow: FlowCharacteristic::new(c, 0.3).unwrap(),
            exhaust: FlowCharacteristic::new(ce, 0.3).unwrap(),
            cracking: 0.1e5,
            range: 0.1e5,
        };
        // filling: supply on P, cylinder at 2 bar: all of it goes P → A, E is shut
        let f = flows(&q, 6e5, 2e5);
        assert!(f[0].mdot > 0.0 && f[2].mdot == 0.0);
        assert!((f[0].mdot - FlowCharacteristic::new(c, 0.3).unwrap().mass_flow(6e5, 293.15, 2e5, 293.15)).abs() < 1e-15);
        // venting: line at atmosphere, cylinder at 6 bar: A exhausts to E at the
        // choked flow of the exhaust passage, nothing goes back into the line
        let f = flows(&q, 1.01325e5, 6e5);
        assert_eq!(f[0].mdot, 0.0);
        let choked = ce * crate::iso6358::ANR_DENSITY * 6e5;
        assert!((f[1].mdot - choked).abs() < 1e-12 * choked, "{} vs {choked}", f[1].mdot);
        // within the cracking band nothing moves
        let f = flows(&q, 3.05e5, 3e5);
        assert!(f.iter().all(|x| x.mdot == 0.0));
    }
}
