//! Conductance: a fixed pneumatic restriction characterised after ISO 6358
//! (orifice, fitting, throttle, one path of a valve).
//!
//! # Ports
//! - `a`, `b` — pneumatic, flow (conductance form: flows from the pressures).
//!
//! # Parameters (defaults in brackets)
//! - `C` [m³/(s Pa), required]: sonic conductance (e.g. "13.2 L/min/bar").
//! - `b` [-, required]: critical pressure ratio, in (0, 1).
//! - `m` [-, 0.5]: ISO 6358-1:2013 subsonic index (0.5 gives paper Eq. 33).
//! - `b_lam` [-, 0.999]: pressure ratio above which the flow is laminar
//!   (linear in Δp), which keeps the flow Lipschitz as r → 1.
//! - `T_ref` [K, 293.15 K], `rho_ref` [kg/m³, 1.185]: ISO 6358 ANR reference.
//! - `heat_conductance` [W/K, 0]: port conduction Q_c = G·(T_a − T_b) carried
//!   with the flow (paper Eq. 7, 9/10; the paper omits it in first approximation).
//!
//! # Equations
//! ṁ = C·ρ_ref·p_up·K_T·ω(r) with K_T = (T_ref/T_up)^½, r = p_down/p_up
//! (paper Eq. 33–35, see [`crate::iso6358`]). Flow runs from the higher to the
//! lower pressure; the energy flow is ṁ·h_up + Q_c (isenthalpic throttling:
//! the gas enters the downstream volume with the upstream enthalpy).
//!
//! # Assumptions
//! Quasi-steady flow (no inertia of the gas in the passage); the ISO
//! characteristic measured at steady flow holds in transients (but see paper
//! Eq. 36: C identified from a discharge can be smaller).

use crate::block::*;
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use gas::GasState;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[ParamSpec::quantity(
        "heat_conductance",
        dim::HEAT_CONDUCTANCE,
        Some(0.0),
        Range::NonNegative,
        "W/K",
        "port conduction G, Q_c = G (T_a - T_b)",
    )]
);
pub const PORTS: &[PortSpec] =
    &[PortSpec::new("a", PortKind::PneumaticFlow, "side a"), PortSpec::new("b", PortKind::PneumaticFlow, "side b")];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "mdot", unit: "kg/s" }];

/// Build a flow characteristic from the parameters named `c`, `b` and the shared ISO 6358 set.
pub use crate::iso6358::from_params as characteristic;

/// Flow from side a to side b of a restriction with an opening factor in [0, 1].
///
/// Returns the flow INTO the restriction at port a; the flow at port b is its negative.
/// [`restriction_flow`] with the derivatives of its mass flow with respect to
/// p_a and p_b (temperatures held): `(flow into a, ∂ṁ/∂p_a, ∂ṁ/∂p_b)`.
pub fn restriction_flow_slopes(fc: &FlowCharacteristic, opening: f64, a: &GasState, b: &GasState, g_heat: f64) -> (PortFlow, f64, f64) {
    if opening <= 0.0 {
        return (PortFlow { mdot: 0.0, edot: g_heat * (a.t - b.t) }, 0.0, 0.0);
    }
    // `restriction_flow`'s numbers, with the slopes from the same ω(r)
    let (m, da, db) = fc.mass_flow_and_derivatives(a.p, a.t, b.p, b.t);
    (carried(opening * m, a, b, g_heat), opening * da, opening * db)
}

/// Flow into port `port` (0 = a, 1 = b) of a two-port restriction carrying
/// `f` into a, with the derivative of its mass flow by that port's pressure.
pub fn at_port(port: usize, f: PortFlow, d_pa: f64, d_pb: f64) -> (PortFlow, f64) {
    if port == 0 {
        (f, d_pa)
    } else {
        (-f, -d_pb)
    }
}

/// Partial derivatives of [`restriction_flow`] (the flow into port a) with
/// respect to (p_a, T_a, p_b, T_b) and to the opening.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RestrictionPartials {
    pub mdot: [f64; 4],
    pub edot: [f64; 4],
    /// ∂(ṁ, Ė)/∂opening (the flow of the fully open path).
    pub opening: PortFlow,
}

/// The partials of [`restriction_flow`]: ṁ = opening·ṁ_ISO(p_a, T_a, p_b, T_b)
/// (gradient from [`FlowCharacteristic::mass_flow_gradient`]) and
/// Ė = ṁ·h_up + G·(T_a − T_b), where h_up(p, T) of the upstream side moves
/// with its state ([`crate::support::GasSlopes`]). At zero flow the mean of
/// both sides' enthalpies is taken (Ė has a kink there when they differ).
pub fn restriction_partials(
    fc: &FlowCharacteristic,
    opening: f64,
    a: &GasState,
    b: &GasState,
    g_heat: f64,
    gas: &dyn gas::GasModel,
) -> RestrictionPartials {
    let mut d = RestrictionPartials { edot: [0.0, g_heat, 0.0, -g_heat], ..Default::default() };
    let full = fc.mass_flow(a.p, a.t, b.p, b.t);
    let grad = fc.mass_flow_gradient(a.p, a.t, b.p, b.t);
    let (sa, sb) = (crate::support::GasSlopes::at(gas, a), crate::support::GasSlopes::at(gas, b));
    let (h_up, dh) = if full > 0.0 {
        (a.h, [sa.dh_dp, sa.dh_dt, 0.0, 0.0])
    } else if full < 0.0 {
        (b.h, [0.0, 0.0, sb.dh_dp, sb.dh_dt])
    } else {
        (0.5 * (a.h + b.h), [0.5 * sa.dh_dp, 0.5 * sa.dh_dt, 0.5 * sb.dh_dp, 0.5 * sb.dh_dt])
    };
    d.opening = PortFlow { mdot: full, edot: full * h_up };
    if opening <= 0.0 {
        return d;
    }
    let mdot = opening * full;
    for i in 0..4 {
        d.mdot[i] = opening * grad[i];
        d.edot[i] += h_up * d.mdot[i] + mdot * dh[i];
    }
    d
}

/// Add the partials of a restriction carrying flow from the block's
/// pneumatic port `pa` to port `pb` (flow phase): into `pa` with its sign,
/// out of `pb`; `opening` lists how the opening moves with the block's
/// inputs (a spool state, a pressure difference).
pub fn add_path(d: &mut Partials, pa: usize, pb: usize, r: &RestrictionPartials, opening: &[(In, f64)]) {
    let inputs = [In::P(pa), In::T(pa), In::P(pb), In::T(pb)];
    for (port, sign) in [(pa, 1.0), (pb, -1.0)] {
        for (i, &input) in inputs.iter().enumerate() {
            d.add(Out::Mdot(port), input, sign * r.mdot[i]);
            d.add(Out::Edot(port), input, sign * r.edot[i]);
        }
        for &(input, slope) in opening {
            d.add(Out::Mdot(port), input, sign * r.opening.mdot * slope);
            d.add(Out::Edot(port), input, sign * r.opening.edot * slope);
        }
    }
}

pub fn restriction_flow(fc: &FlowCharacteristic, opening: f64, a: &GasState, b: &GasState, g_heat: f64) -> PortFlow {
    if opening <= 0.0 {
        return PortFlow { mdot: 0.0, edot: g_heat * (a.t - b.t) };
    }
    carried(opening * fc.mass_flow(a.p, a.t, b.p, b.t), a, b, g_heat)
}

/// The flow into port a of a restriction passing `mdot` from a to b: the
/// mass flow with the upstream side's enthalpy and the port conduction
/// G·(T_a − T_b) (isenthalpic throttling, paper Eq. 7, 9/10).
fn carried(mdot: f64, a: &GasState, b: &GasState, g_heat: f64) -> PortFlow {
    let h_up = if mdot >= 0.0 { a.h } else { b.h };
    PortFlow { mdot, edot: mdot * h_up + g_heat * (a.t - b.t) }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Conductance {
    pub flow: FlowCharacteristic,
    pub heat_conductance: f64,
}

impl Conductance {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Conductance { flow: characteristic(p, "C", "b")?, heat_conductance: p.get("heat_conductance") })
    }
}

impl Block for Conductance {
    fn type_name(&self) -> &'static str {
        "conductance"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let f = restriction_flow(&self.flow, 1.0, &ctx.pneumatic[0], &ctx.pneumatic[1], self.heat_conductance);
        out[0] = f;
        out[1] = -f;
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        let (f, da, db) = restriction_flow_slopes(&self.flow, 1.0, &ctx.pneumatic[0], &ctx.pneumatic[1], self.heat_conductance);
        Some(at_port(port, f, da, db))
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Flows {
            let r = restriction_partials(&self.flow, 1.0, &ctx.pneumatic[0], &ctx.pneumatic[1], self.heat_conductance, ctx.gas);
            add_path(d, 0, 1, &r, &[]);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.flow.mass_flow(ctx.pneumatic[0].p, ctx.pneumatic[0].t, ctx.pneumatic[1].p, ctx.pneumatic[1].t));
    }
}

/// Registry entry of `conductance`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "conductance",
    family: crate::registry::Family::Restrictions,
    doc: "ISO 6358 restriction (Eq. 33-35)",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Conductance::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    #[test]
    fn energy_flow_carries_upstream_enthalpy_both_ways() {
        let gas = gas::IdealGas::air();
        let c = Conductance { flow: FlowCharacteristic::new(1e-8, 0.3).unwrap(), heat_conductance: 0.0 };
        let hi = gas.state_pt(4e5, 320.0);
        let lo = gas.state_pt(1e5, 280.0);
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[hi, lo], mechanical: &[], signals: &[] };
        let mut out = [PortFlow::default(); 2];
        c.flows(&ctx, &mut out);
        assert!(out[0].mdot > 0.0 && (out[0].mdot + out[1].mdot).abs() < 1e-18);
        assert!((out[0].edot / out[0].mdot - hi.h).abs() < 1e-6);
        let ctx = Ctx { pneumatic: &[lo, hi], ..ctx };
        c.flows(&ctx, &mut out);
        assert!(out[0].mdot < 0.0);
        assert!((out[0].edot / out[0].mdot - hi.h).abs() < 1e-6);
    }

    #[test]
    fn conduction_flows_from_hot_to_cold_without_mass_flow() {
        let gas = gas::IdealGas::air();
        let c = Conductance { flow: FlowCharacteristic::new(1e-8, 0.3).unwrap(), heat_conductance: 0.5 };
        let a = gas.state_pt(2e5, 330.0);
        let b = gas.state_pt(2e5, 300.0);
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[a, b], mechanical: &[], signals: &[] };
        let mut out = [PortFlow::default(); 2];
        c.flows(&ctx, &mut out);
        assert_eq!(out[0].mdot, 0.0);
        assert!((out[0].edot - 15.0).abs() < 1e-9 && (out[1].edot + 15.0).abs() < 1e-9);
    }
}
