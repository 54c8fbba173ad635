//! Two-pressure valve (AND function): the outlet A receives air only when
//! both inlets P1 and P2 are pressurised — the higher inlet pushes the
//! shuttle against its own seat, so A is fed by the lower one.
//!
//! # Ports
//! - `P1`, `P2` (inlets), `A` (outlet) — pneumatic, flow.
//!
//! # Parameters (defaults in brackets)
//! As the shuttle valve ([`crate::shuttle_valve`]): ISO 6358 set `C`, `b`
//! (required), `m`, `b_lam`, `T_ref`, `rho_ref`; `shift_pressure` [0.1 bar];
//! `ball_time` [2 ms].
//!
//! # Equations
//! Shuttle position target w* = clamp(½ + (p₂ − p₁)/Δp_shift, 0, 1) (w = 1:
//! P1 passes, i.e. P1 is the lower inlet); τ·ẇ = w* − w;
//! ṁ_1 = w·ṁ_ISO(P1 ↔ A), ṁ_2 = (1 − w)·ṁ_ISO(P2 ↔ A) (paper Eq. 33–35).
//! The outlet pressure therefore follows min(p₁, p₂).
//!
//! # Assumptions
//! As the shuttle valve: the shuttle's travel is a first-order lag.

use crate::shuttle_valve::{BallSeat, OUTPUTS, PARAMS, PORTS};

/// Registry entry of `two_pressure_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "two_pressure_valve",
    family: crate::registry::Family::LogicValves,
    doc: "two-pressure valve (AND): the outlet gets the lower inlet",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(BallSeat::from_params(p, "two_pressure_valve", false)),
};

#[cfg(test)]
mod tests {
    use crate::block::*;
    use crate::iso6358::FlowCharacteristic;
    use crate::shuttle_valve::BallSeat;
    use gas::GasModel;

    fn steady(v: &BallSeat, p1: f64, p2: f64, pa: f64) -> [f64; 3] {
        let gas = gas::IdealGas::air();
        let n = [gas.state_pt(p1, 293.15), gas.state_pt(p2, 293.15), gas.state_pt(pa, 293.15)];
        let w = [v.target(p1, p2)];
        let mut out = [PortFlow::default(); 3];
        v.flows(&Ctx { t: 0.0, gas: &gas, states: &w, pneumatic: &n, mechanical: &[], signals: &[] }, &mut out);
        [out[0].mdot, out[1].mdot, out[2].mdot]
    }

    #[test]
    fn output_only_when_both_inlets_are_pressurised() {
        let v = BallSeat { type_name: "two_pressure_valve", flow: FlowCharacteristic::new(1e-8, 0.3).unwrap(), shift: 0.1e5, tau: 2e-3, higher_passes: false };
        // only P1 pressurised: it seals itself, A is connected to the vented P2 (and vents)
        let f = steady(&v, 6e5, 1e5, 1e5);
        assert_eq!(f[0], 0.0);
        assert_eq!(f[2], 0.0);
        // both pressurised, P2 lower: A is fed from P2
        let f = steady(&v, 6e5, 5e5, 2e5);
        assert!(f[0] == 0.0 && f[1] > 0.0);
        // equal inlets: both half open, each passes half the flow
        let f = steady(&v, 6e5, 6e5, 2e5);
        let iso = v.flow.mass_flow(6e5, 293.15, 2e5, 293.15);
        assert!((f[0] - 0.5 * iso).abs() < 1e-15 && (f[1] - 0.5 * iso).abs() < 1e-15);
    }
}
