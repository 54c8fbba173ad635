//! Shuttle valve (OR function): the ball seals the inlet with the lower
//! pressure, so the outlet A is fed by whichever of P1, P2 is pressurised.
//!
//! ```text
//!   P1 ──[ seat 1, opening w ]──┬── A
//!   P2 ──[ seat 2, opening 1−w ]┘
//! ```
//!
//! # Ports
//! - `P1`, `P2` (inlets), `A` (outlet) — pneumatic, flow.
//!
//! # Parameters (defaults in brackets)
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`: each
//!   inlet-to-outlet passage fully open.
//! - `shift_pressure` [Pa, 0.1 bar, > 0]: pressure difference between the
//!   inlets that moves the ball fully across.
//! - `ball_time` [s, 2 ms, > 0]: time constant of the ball's travel.
//!
//! # Equations
//! Ball position target w* = clamp(½ + (p₁ − p₂)/Δp_shift, 0, 1) (w = 1:
//! seat 2 closed); τ·ẇ = w* − w. Passages: ṁ_1 = w·ṁ_ISO(P1 ↔ A),
//! ṁ_2 = (1 − w)·ṁ_ISO(P2 ↔ A) (paper Eq. 33–35), in either direction, so
//! the outlet exhausts back through the inlet that fed it.
//!
//! # Assumptions
//! The ball's travel is a first-order lag (its mass and the flow forces on
//! it are lumped into τ). Being a state, it keeps each port's flow
//! non-decreasing in that port's pressure, as the junction solve requires.

use crate::block::*;
use crate::conductance::restriction_flow;
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

/// Parameters of a ball-seat logic valve (shuttle and two-pressure valves).
pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("shift_pressure", dim::PRESSURE, Some(0.1e5), Range::Positive, "bar", "inlet difference that moves the ball across"),
        ParamSpec::quantity("ball_time", dim::TIME, Some(2e-3), Range::Positive, "ms", "time constant of the ball's travel"),
    ]
);
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("P1", PortKind::PneumaticFlow, "inlet 1"),
    PortSpec::new("P2", PortKind::PneumaticFlow, "inlet 2"),
    PortSpec::new("A", PortKind::PneumaticFlow, "outlet"),
];
const STATES: &[StateSpec] = &[StateSpec { name: "ball", unit: "1" }];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "ball", unit: "1" }];

/// A ball between two seats: P1 passes with opening w, P2 with 1 − w.
#[derive(Debug, Clone, PartialEq)]
pub struct BallSeat {
    pub type_name: &'static str,
    pub flow: FlowCharacteristic,
    pub shift: f64,
    pub tau: f64,
    /// true: the higher inlet passes (OR, shuttle); false: the lower (AND).
    pub higher_passes: bool,
}

impl BallSeat {
    pub fn from_params(p: &Params, type_name: &'static str, higher_passes: bool) -> Result<Self, crate::BlockError> {
        Ok(BallSeat {
            type_name,
            flow: crate::iso6358::from_params(p, "C", "b")?,
            shift: p.get("shift_pressure"),
            tau: p.get("ball_time"),
            higher_passes,
        })
    }
    /// Ball position the inlet pressures push towards.
    pub fn target(&self, p1: f64, p2: f64) -> f64 {
        let d = if self.higher_passes { p1 - p2 } else { p2 - p1 };
        (0.5 + d / self.shift).clamp(0.0, 1.0)
    }
    /// ∂w*/∂p₁ of [`BallSeat::target`] (∂w*/∂p₂ is its negative): ±1/Δp_shift
    /// inside the clamp, 0 outside.
    fn target_slope(&self, p1: f64, p2: f64) -> f64 {
        let d = if self.higher_passes { p1 - p2 } else { p2 - p1 };
        let u = 0.5 + d / self.shift;
        if u > 0.0 && u < 1.0 {
            if self.higher_passes {
                1.0 / self.shift
            } else {
                -1.0 / self.shift
            }
        } else {
            0.0
        }
    }
}

impl Block for BallSeat {
    fn type_name(&self) -> &'static str {
        self.type_name
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn states(&self) -> &[StateSpec] {
        STATES
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out.fill(1.0);
    }
    fn initial_states(&self, _ctx: &InitCtx, out: &mut [f64]) {
        out[0] = 0.5;
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        states[0] = self.target(ctx.pneumatic[0].p, ctx.pneumatic[1].p);
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let w = ctx.states[0].clamp(0.0, 1.0);
        let a = &ctx.pneumatic[2];
        let f1 = restriction_flow(&self.flow, w, &ctx.pneumatic[0], a, 0.0);
        let f2 = restriction_flow(&self.flow, 1.0 - w, &ctx.pneumatic[1], a, 0.0);
        out[0] = f1;
        out[1] = f2;
        out[2] = -f1;
        out[2] += -f2;
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        out[0] = (self.target(ctx.pneumatic[0].p, ctx.pneumatic[1].p) - ctx.states[0]) / self.tau;
    }
    /// Flows: the two ISO 6358 passages (paper Eq. 33–35) with openings w and
    /// 1 − w ([`crate::conductance::restriction_partials`]), the opening moving
    /// with the ball state while it lies in [0, 1]. Derivatives: τ·ẇ = w* − w
    /// with w* = clamp(½ ± (p₁ − p₂)/Δp_shift).
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        match phase {
            Phase::Flows => {
                let raw = ctx.states[0];
                let w = raw.clamp(0.0, 1.0);
                let moves = raw > 0.0 && raw < 1.0;
                let a = &ctx.pneumatic[2];
                for (port, opening, slope) in [(0, w, 1.0), (1, 1.0 - w, -1.0)] {
                    let r = crate::conductance::restriction_partials(&self.flow, opening, &ctx.pneumatic[port], a, 0.0, ctx.gas);
                    let by_ball: &[(In, f64)] = if moves { &[(In::State(0), slope)] } else { &[] };
                    crate::conductance::add_path(d, port, 2, &r, by_ball);
                }
            }
            Phase::Derivatives => {
                let s = self.target_slope(ctx.pneumatic[0].p, ctx.pneumatic[1].p) / self.tau;
                d.set(Out::Rate(0), In::State(0), -1.0 / self.tau);
                d.set(Out::Rate(0), In::P(0), s);
                d.set(Out::Rate(0), In::P(1), -s);
            }
            _ => {}
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(ctx.states[0]);
    }
}

/// Registry entry of `shuttle_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "shuttle_valve",
    family: crate::registry::Family::LogicValves,
    doc: "shuttle valve (OR): the higher inlet feeds the outlet",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(BallSeat::from_params(p, "shuttle_valve", true)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    pub(crate) fn steady(v: &BallSeat, p1: f64, p2: f64, pa: f64) -> [f64; 3] {
        let gas = gas::IdealGas::air();
        let n = [gas.state_pt(p1, 293.15), gas.state_pt(p2, 293.15), gas.state_pt(pa, 293.15)];
        let w = [v.target(p1, p2)];
        let mut out = [PortFlow::default(); 3];
        v.flows(&Ctx { t: 0.0, gas: &gas, states: &w, pneumatic: &n, mechanical: &[], signals: &[] }, &mut out);
        [out[0].mdot, out[1].mdot, out[2].mdot]
    }

    #[test]
    fn the_higher_inlet_feeds_the_outlet_and_the_other_is_sealed() {
        let v = BallSeat { type_name: "shuttle_valve", flow: FlowCharacteristic::new(1e-8, 0.3).unwrap(), shift: 0.1e5, tau: 2e-3, higher_passes: true };
        let f = steady(&v, 6e5, 1e5, 3e5);
        let iso = v.flow.mass_flow(6e5, 293.15, 3e5, 293.15);
        assert!((f[0] - iso).abs() < 1e-15 && f[1] == 0.0 && (f[2] + iso).abs() < 1e-15);
        let f = steady(&v, 1e5, 6e5, 3e5);
        assert!(f[0] == 0.0 && f[1] > 0.0);
        // vented inlet: the outlet exhausts back through the inlet that fed it (both inlets at 1 bar: ball centred)
        let f = steady(&v, 1e5, 1e5, 3e5);
        assert!(f[0] < 0.0 && f[1] < 0.0 && (f[0] - f[1]).abs() < 1e-18);
    }

    #[test]
    fn partials_equal_central_differences() {
        use crate::partials_check::{build, point};
        for ty in [&TYPE, &crate::two_pressure_valve::TYPE] {
            let v = build(ty, &[("C", "10 L/min/bar"), ("b", "0.3")]);
            // ball between the seats, inlets within the shift band; outlet subsonic, then choked
            for a in [3e5, 1.2e5] {
                let at = point(&[0.3], &[(5.02e5, 293.0), (5.0e5, 300.0), (a, 290.0)], &[]);
                at.check(v.as_ref(), Phase::Flows);
                at.check(v.as_ref(), Phase::Derivatives);
            }
            // ball nearly across, target clamped by a large inlet difference; the outlet exhausting
            let at = point(&[0.99], &[(6e5, 293.0), (1e5, 293.0), (3e5, 293.0)], &[]);
            at.check(v.as_ref(), Phase::Flows);
            at.check(v.as_ref(), Phase::Derivatives);
        }
    }
}
