//! Proportional directional valve (5/3, flow control): the spool follows a
//! continuous command and meters P → A, B → EB on one side of centre and
//! P → B, A → EA on the other — the servo-pneumatic valve of a position
//! control loop.
//!
//! # Ports
//! - `P`, `A`, `B`, `EA`, `EB` — pneumatic, flow.
//! - `u` [1] — signal input: command in [−1, 1] (clipped): +1 fully open
//!   P → A, −1 fully open P → B, 0 centre.
//!
//! # Parameters (defaults in brackets)
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`:
//!   each path fully open.
//! - `C_leak` [m³/(s Pa), 0]: leakage of each land when closed (a
//!   zero-lapped spool leaks at centre, which holds both chambers between
//!   supply and exhaust pressure).
//! - spool response: `spool_order` [`first`], `time_constant` [5 ms] for
//!   first order; `natural_frequency` [50 Hz], `damping` [0.7] for second order.
//!
//! # Equations
//! Spool s: τ·ṡ = u − s, or s̈ = ω²(u − s) − 2ζω·ṡ (u clipped to [−1, 1]);
//! openings o_A = clamp(s, 0, 1) for P → A and B → EB, o_B = clamp(−s, 0, 1)
//! for P → B and A → EA; each path ṁ = o·ṁ_ISO + (1 − o)·ṁ_ISO,leak (paper
//! Eq. 33–35), energy with the upstream enthalpy. The effective area grows
//! linearly with the spool stroke (rectangular ports).
//!
//! # Assumptions
//! Zero lap; no flow forces on the spool; C and b do not change with the opening.

use crate::block::*;
use crate::spool_paths::{self, Opening};
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use crate::support::Spool;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[ParamSpec::quantity("C_leak", dim::CONDUCTANCE, Some(0.0), Range::NonNegative, "L/min/bar", "leakage of each closed land")],
    crate::support::SPOOL_DYNAMICS
);
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "working port A (u > 0: from P)"),
    PortSpec::new("B", PortKind::PneumaticFlow, "working port B (u < 0: from P)"),
    PortSpec::new("EA", PortKind::PneumaticFlow, "exhaust of A"),
    PortSpec::new("EB", PortKind::PneumaticFlow, "exhaust of B"),
    PortSpec::signal("u", PortKind::SignalIn, "1", "command in [-1, 1]"),
];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "spool", unit: "1" }];

/// (from, to, side: +1 opens with s > 0, −1 with s < 0)
const PATHS: [(usize, usize, f64); 4] = [(0, 1, 1.0), (2, 4, 1.0), (0, 2, -1.0), (1, 3, -1.0)];

#[derive(Debug, Clone, PartialEq)]
pub struct ProportionalValve {
    pub flow: FlowCharacteristic,
    pub leak: Option<FlowCharacteristic>,
    pub spool: Spool,
}

impl ProportionalValve {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let leak = if p.get("C_leak") > 0.0 { Some(crate::iso6358::with_shared(p, p.get("C_leak"), p.get("b"))?) } else { None };
        Ok(ProportionalValve { flow: crate::iso6358::from_params(p, "C", "b")?, leak, spool: Spool::from_params(p, 1.0) })
    }
    /// Each path's opening: max(±s, 0) on its side of centre, s the spool
    /// position clamped to [−1, 1].
    fn openings(&self, states: &[f64]) -> impl Iterator<Item = Opening<'_>> {
        let x = self.spool.position(states);
        let s = x.clamp(-1.0, 1.0);
        let ds = if (-1.0..=1.0).contains(&x) { 1.0 } else { 0.0 };
        PATHS.into_iter().map(move |(from, to, side)| Opening {
            from,
            to,
            flow: &self.flow,
            leak: self.leak.as_ref(),
            opening: (side * s).max(0.0),
            slope: if side * s > 0.0 { side * ds } else { 0.0 },
        })
    }
    fn command(ctx: &Ctx) -> f64 {
        ctx.signals[0].clamp(-1.0, 1.0)
    }
}

impl Block for ProportionalValve {
    fn type_name(&self) -> &'static str {
        "proportional_valve"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn states(&self) -> &[StateSpec] {
        self.spool.states()
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        self.spool.scales(out);
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        self.spool.start_at(Self::command(ctx), states);
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        spool_paths::flows(self.openings(ctx.states), ctx, out);
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        Some(spool_paths::port_flow(self.openings(ctx.states), ctx, port))
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        match phase {
            Phase::Flows => spool_paths::flow_partials(self.openings(ctx.states), ctx, d),
            Phase::Derivatives => {
                let u = ctx.signals[0];
                let du = if (-1.0..=1.0).contains(&u) { 1.0 } else { 0.0 };
                self.spool.partials(&[(In::Signal(0), du)], d);
            }
            _ => {}
        }
        true
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        self.spool.derivatives(Self::command(ctx), ctx.states, out);
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.spool.position(ctx.states));
    }
}

/// Registry entry of `proportional_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "proportional_valve",
    family: crate::registry::Family::ProportionalValves,
    doc: "proportional 5/3 flow valve: command u in [-1, 1], 1st/2nd-order spool",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(ProportionalValve::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;
    use gas::GasModel;

    fn valve(extra: &[(&str, &str)]) -> ProportionalValve {
        let mut raw = vec![("C", RawValue::Text("60 L/min/bar".into())), ("b", RawValue::Number(0.3))];
        raw.extend(extra.iter().map(|(k, v)| (*k, RawValue::Text(v.to_string()))));
        ProportionalValve::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).unwrap()
    }

    #[test]
    fn port_flow_slopes_match_finite_differences() {
        let gas = gas::IdealGas::air();
        let s = |p| gas.state_pt(p, 293.15);
        // P 6 bar, A 3 bar, B 5.99 bar, exhausts 1 bar
        let n = [s(6e5), s(3e5), s(5.99e5), s(1e5), s(1.0001e5)];
        let v = valve(&[("C_leak", "0.5 L/min/bar")]);
        let x0 = vec![0.0; v.spool.states().len()];
        for x in [-1.0, -0.4, 0.0, 0.3, 1.0] {
            let mut st = x0.clone();
            st[0] = x;
            crate::speed_control_valve::slope_tests::check_port_flow_slopes(&v, &st, &[x], &n);
        }
    }

    /// Step response of the spool to u = 1 from rest, by RK4.
    fn step(v: &ProportionalValve, t_end: f64) -> Vec<(f64, f64)> {
        let gas = gas::IdealGas::air();
        let n = v.spool.states().len();
        let mut x = vec![0.0; n];
        let dt = 1e-5;
        let f = |x: &[f64]| {
            let mut d = vec![0.0; n];
            v.derivatives(
                &Ctx { t: 0.0, gas: &gas, states: x, pneumatic: &[], mechanical: &[], signals: &[1.0] },
                &Balances { pneumatic: &[], mechanical: &[] },
                &mut d,
            );
            d
        };
        let mut out = Vec::new();
        let mut t = 0.0;
        while t < t_end {
            let k1 = f(&x);
            let x2: Vec<f64> = x.iter().zip(&k1).map(|(a, k)| a + 0.5 * dt * k).collect();
            let k2 = f(&x2);
            let x3: Vec<f64> = x.iter().zip(&k2).map(|(a, k)| a + 0.5 * dt * k).collect();
            let k3 = f(&x3);
            let x4: Vec<f64> = x.iter().zip(&k3).map(|(a, k)| a + dt * k).collect();
            let k4 = f(&x4);
            for i in 0..n {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += dt;
            out.push((t, x[0]));
        }
        out
    }

    #[test]
    fn second_order_spool_overshoots_as_the_closed_form() {
        // overshoot of an underdamped second-order step: exp(−ζπ/√(1−ζ²)); peak at π/(ω√(1−ζ²))
        let v = valve(&[("spool_order", "second"), ("natural_frequency", "80 Hz"), ("damping", "0.4")]);
        let (omega, zeta): (f64, f64) = (2.0 * std::f64::consts::PI * 80.0, 0.4);
        let r = step(&v, 0.05);
        let (t_peak, peak) = r.iter().copied().fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        let wd = omega * (1.0 - zeta * zeta).sqrt();
        assert!((peak - 1.0 - (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp()).abs() < 1e-4, "peak {peak}");
        assert!((t_peak - std::f64::consts::PI / wd).abs() < 2e-5, "t_peak {t_peak}");
        // first order: 63.2 % after one time constant
        let v = valve(&[("time_constant", "4 ms")]);
        let r = step(&v, 0.004);
        assert!((r.last().unwrap().1 - (1.0 - (-1.0f64).exp())).abs() < 1e-3);
    }

    #[test]
    fn opening_meters_the_flow_linearly_and_centre_leaks() {
        let gas = gas::IdealGas::air();
        let s = |p| gas.state_pt(p, 293.15);
        let n = [s(6e5), s(3e5), s(3e5), s(1e5), s(1e5)];
        let v = valve(&[("C_leak", "0.6 L/min/bar")]);
        let full = v.flow.mass_flow(6e5, 293.15, 3e5, 293.15);
        let leak = v.leak.unwrap().mass_flow(6e5, 293.15, 3e5, 293.15);
        for spool in [0.25, 0.5, 1.0] {
            let mut out = [PortFlow::default(); 5];
            v.flows(&Ctx { t: 0.0, gas: &gas, states: &[spool], pneumatic: &n, mechanical: &[], signals: &[spool] }, &mut out);
            // P passes the metered flow into A plus the leak into B
            assert!((out[0].mdot - (spool * full + (1.0 - spool) * leak + leak)).abs() < 1e-15, "spool {spool}");
        }
        let mut out = [PortFlow::default(); 5];
        v.flows(&Ctx { t: 0.0, gas: &gas, states: &[0.0], pneumatic: &n, mechanical: &[], signals: &[0.0] }, &mut out);
        assert!((out[0].mdot - 2.0 * leak).abs() < 1e-15, "centre: P leaks into A and B");
    }
}
