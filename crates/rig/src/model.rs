//! The rig as a system of ODEs in one discrete mode: the chambers'
//! thermodynamics, the valves and the volume-less junction of the rod line,
//! and the piston's motion.
//!
//! ```text
//!   supply ──[line C, V_line]──┐ (optional supply droop)
//!                              P
//!                   ┌──────────┴──────────┐
//!   5/2 valve:      A  (extend: P→A, B→EB;  retract: P→B, A→EA)  B
//!                   │                                            │ junction j (no volume)
//!               head chamber 1                         speed-control valve:
//!                   │                                  throttle ⇄  ∥  check → (into rod)
//!               ═══ piston (x, v) ═══ rod ──▶                    │
//!                   │                                            │
//!               rod chamber 2 ─────────────────────────────────-─┘
//! ```
//!
//! # States
//! m₁, T₁, m₂, T₂, x, v, and with a supply line m_L, T_L; then four
//! quadrature accounts (not fed back): boundary mass in, boundary enthalpy
//! in, wall heat into the gas, boundary work done by the gas.
//!
//! # Chambers (paper Eq. 5, 6, 8, 12–17)
//! V₁ = V₀₁ + A₁x, V₂ = V₀₂ + A₂(L − x); ρ = m/V; p = p(ρ, T) from `gas`.
//! ṁ = Σ_k ṁ_k (positive into the chamber, Eq. 5). The temperature follows
//! from the energy balance U̇ = Q_w + Σ_in ṁ_k h_k + Σ_out ṁ_k h − pV̇
//! (Eq. 9/10: inflow carries the upstream enthalpy, outflow leaves at the
//! chamber state) with U = m u(ρ, T) (Eq. 11, 12):
//!
//! m c_v Ṫ = Q_w + Σ_in ṁ_k (h_k − h) + T(∂p/∂T)_ρ (ṁ/ρ − V̇)  (Eq. 13/14)
//!
//! which for the ideal gas is Eq. 16/17 (T(∂p/∂T)_ρ = p, h_k − h =
//! c_p(T_k − T)). Wall heat Q_w = m c_v (T_w − T)/τ_T (Eq. 8, with the
//! ideal-gas c_v; zero for τ_T = ∞).
//!
//! # Flows (paper Eq. 33–35 via `flow`)
//! Head port: one 5/2 path (supply or exhaust). Rod line: the 5/2 path from
//! supply or exhaust to the junction j, then the speed-control valve
//! (throttle in both directions, check valve into the rod chamber only).
//! The junction has no volume, so its pressure p_j is the root of the flow
//! balance q_valve(p_j) = q_scv(p_j), found by Brent's method on the
//! interval between the two end pressures (both flows are monotone in p_j;
//! the flow direction is the same through both and is known beforehand from
//! the end pressures). An exact check valve with a cracking pressure makes
//! q_scv jump; where the balance falls into the jump, the valve floats at
//! its cracking pressure and passes what the throttle does not
//! (`Plant::fill_junction`). Throttling is taken as isenthalpic and isothermal
//! (ideal gas): the junction passes on the upstream temperature and
//! enthalpy.
//!
//! # Piston (Newton; paper Eq. 37; Karnopp 1985)
//! F_a = p₁A₁ − p₂A₂ − p_atm(A₁ − A₂) + F_ext. Sliding in direction d:
//! M v̇ = F_a − d·F_dry(|v|) − c v, ẋ = v (see `friction`). Stuck: ẋ = v̇ = 0.

use crate::flow::{CheckLaw, LeakLaw, Restriction, SubsonicLaw};
use crate::friction::{Eq37, FrictionVariant};
use crate::gas::{Gas, GasLaw};
use crate::params::{Effects, ModelForm, Rig};
use crate::roots::brent;
use crate::sdirk::OdeSystem;

/// Index of the first quadrature account in the state vector, counted from
/// the end of the dynamic states.
pub(crate) const N_QUAD: usize = 4;
pub(crate) const I_M1: usize = 0;
pub(crate) const I_T1: usize = 1;
pub(crate) const I_M2: usize = 2;
pub(crate) const I_T2: usize = 3;
pub(crate) const I_X: usize = 4;
pub(crate) const I_V: usize = 5;
pub(crate) const I_ML: usize = 6;
pub(crate) const I_TL: usize = 7;

/// Position of the 5/2 valve spool.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValvePos {
    /// Supply → head, rod line → exhaust.
    Extend,
    /// Supply → rod line, head → exhaust (the un-actuated position).
    Retract,
}

/// Mechanical mode of the piston.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Mech {
    /// At rest, held by friction or an end stop.
    Stuck,
    /// Sliding in direction +1 (extend) or −1 (retract).
    Slide(f64),
}

/// The discrete mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Mode {
    pub valve: ValvePos,
    pub mech: Mech,
}

/// A gas end: pressure, temperature, specific enthalpy.
#[derive(Debug, Clone, Copy)]
struct End {
    p: f64,
    t: f64,
    h: f64,
}

/// Quantities at one instant, for output and event functions.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Eval {
    pub p1: f64,
    pub p2: f64,
    pub p_line: f64,
    pub p_junction: f64,
    pub f_applied: f64,
    pub f_break: f64,
}

/// Precomputed parameters of one run.
#[derive(Debug, Clone)]
pub(crate) struct Plant {
    pub gas: Gas,
    pub law: SubsonicLaw,
    pub check_law: CheckLaw,
    pub a1: f64,
    pub a2: f64,
    pub ar: f64,
    pub stroke: f64,
    pub mass: f64,
    pub v01: f64,
    pub v02: f64,
    pub f_ext: f64,
    supply: End,
    atm: End,
    pub p_atm: f64,
    pub t_wall: f64,
    /// 1/τ_T of the chambers (0 for adiabatic).
    pub inv_tau: f64,
    pub valve: Restriction,
    pub throttle: Restriction,
    pub check: Restriction,
    pub cracking: f64,
    pub friction: Eq37,
    pub variant: FrictionVariant,
    pub leak: Option<LeakLaw>,
    /// (restriction, volume, 1/τ_T) of the supply line.
    pub line: Option<(Restriction, f64, f64)>,
    pub n_dyn: usize,
}

fn inv(tau: f64) -> f64 {
    if tau.is_infinite() {
        0.0
    } else {
        1.0 / tau
    }
}

impl Plant {
    pub(crate) fn new(rig: &Rig, form: &ModelForm, fx: &Effects) -> Self {
        let mut gas = rig.gas;
        if fx.real_gas {
            gas.law = GasLaw::Virial;
        }
        let end = |p: f64, t: f64| {
            let rho = gas.density(p, t);
            End { p, t, h: gas.enthalpy(rho, t) }
        };
        Plant {
            gas,
            law: form.subsonic,
            check_law: form.check,
            a1: rig.area_head(),
            a2: rig.area_rod_side(),
            ar: rig.area_rod(),
            stroke: rig.stroke,
            mass: rig.mass,
            v01: rig.dead_volume_head + fx.extra_volume_head,
            v02: rig.dead_volume_rod + fx.extra_volume_rod,
            f_ext: rig.external_force,
            supply: end(rig.supply_pressure, rig.supply_temperature),
            atm: end(rig.atm_pressure, rig.atm_temperature),
            p_atm: rig.atm_pressure,
            t_wall: rig.wall_temperature,
            inv_tau: inv(fx.tau_thermal.unwrap_or(rig.tau_thermal)),
            valve: rig.valve,
            throttle: rig.throttle,
            check: rig.check,
            cracking: rig.check_cracking,
            friction: rig.friction,
            variant: fx.friction.unwrap_or(form.friction),
            leak: fx.seal_leak,
            line: fx.supply_line.map(|l| (l.restriction, l.volume, inv(l.tau_thermal))),
            n_dyn: if fx.supply_line.is_some() { 8 } else { 6 },
        }
    }

    pub(crate) fn volumes(&self, x: f64) -> (f64, f64) {
        (self.v01 + self.a1 * x, self.v02 + self.a2 * (self.stroke - x))
    }

    /// Chamber pressures from the state.
    pub(crate) fn pressures(&self, y: &[f64]) -> (f64, f64) {
        let (v1, v2) = self.volumes(y[I_X]);
        (self.gas.pressure(y[I_M1] / v1, y[I_T1]), self.gas.pressure(y[I_M2] / v2, y[I_T2]))
    }

    /// Net pneumatic force and breakaway level at a state [N].
    pub(crate) fn forces(&self, y: &[f64], variant: &FrictionVariant) -> (f64, f64) {
        let (p1, p2) = self.pressures(y);
        (self.applied(p1, p2), variant.breakaway(&self.friction, p1, p2))
    }

    fn applied(&self, p1: f64, p2: f64) -> f64 {
        p1 * self.a1 - p2 * self.a2 - self.p_atm * self.ar + self.f_ext
    }

    /// Initial state vector (dynamic + quadrature) from the rig's initial state.
    pub(crate) fn initial_state(&self, rig: &Rig) -> Vec<f64> {
        let mut y = vec![0.0; self.n_dyn + N_QUAD];
        let ini = &rig.initial;
        let (v1, v2) = self.volumes(ini.x);
        y[I_M1] = self.gas.density(ini.p_head, ini.t_head) * v1;
        y[I_T1] = ini.t_head;
        y[I_M2] = self.gas.density(ini.p_rod, ini.t_rod) * v2;
        y[I_T2] = ini.t_rod;
        y[I_X] = ini.x;
        y[I_V] = 0.0;
        if let Some((_, vol, _)) = self.line {
            y[I_ML] = self.supply_density() * vol;
            y[I_TL] = self.supply.t;
        }
        y
    }

    pub(crate) fn supply_density(&self) -> f64 {
        self.gas.density(self.supply.p, self.supply.t)
    }

    /// Absolute parts of the error weights (per dynamic state), see `sdirk`.
    pub(crate) fn error_floors(&self) -> Vec<f64> {
        let rho_s = self.supply_density();
        let mut f = vec![
            1e-3 * rho_s * (self.v01 + self.a1 * self.stroke),
            1.0,
            1e-3 * rho_s * (self.v02 + self.a2 * self.stroke),
            1.0,
            1e-3 * self.stroke,
            1e-2,
        ];
        if let Some((_, vol, _)) = self.line {
            f.push(1e-3 * rho_s * vol);
            f.push(1.0);
        }
        f
    }

    /// Total internal energy of the gas [J] and total gas mass [kg].
    pub(crate) fn gas_totals(&self, y: &[f64]) -> (f64, f64) {
        let (v1, v2) = self.volumes(y[I_X]);
        let mut u = y[I_M1] * self.gas.internal_energy(y[I_M1] / v1, y[I_T1]) + y[I_M2] * self.gas.internal_energy(y[I_M2] / v2, y[I_T2]);
        let mut m = y[I_M1] + y[I_M2];
        if let Some((_, vol, _)) = self.line {
            u += y[I_ML] * self.gas.internal_energy(y[I_ML] / vol, y[I_TL]);
            m += y[I_ML];
        }
        (u, m)
    }

    fn iso_between(&self, r: &Restriction, a: &End, b: &End) -> (f64, f64) {
        if a.p >= b.p {
            (r.forward(&self.law, a.p, a.t, b.p), a.h)
        } else {
            (-r.forward(&self.law, b.p, b.t, a.p), b.h)
        }
    }

    /// Flow through the speed-control valve from the junction (pressure
    /// `pj`, gas temperature `t_u`) into the rod chamber at `p2`, for pj ≥ p2.
    fn scv_in(&self, pj: f64, t_u: f64, p2: f64) -> f64 {
        let thr = self.throttle.forward(&self.law, pj, t_u, p2);
        let s = self.check_law.opening(pj - p2, self.cracking);
        if s > 0.0 {
            thr + s * self.check.forward(&self.law, pj, t_u, p2)
        } else {
            thr
        }
    }

    /// The junction while the rod line fills the rod chamber (s.p > r.p):
    /// its pressure p_j and the flow into the rod chamber, given the flow
    /// q₁(p_j) through the 5/2 valve from `s`.
    ///
    /// With the linear check-valve law (and the exact law at zero cracking
    /// pressure) the speed-control valve's flow is continuous in p_j and
    /// the balance q₁ = q_scv has one root between the end pressures.
    /// The exact law with a cracking pressure Δp_cr jumps at
    /// p_c = p_rod + Δp_cr from the throttle's flow to the throttle's plus
    /// the whole check valve's, and the balance may have no root at all:
    /// closed, the valve would let the junction rise above p_c; fully open,
    /// it would pull it below. The ideal valve's law is then the one an
    /// ideal spring-loaded poppet obeys — at Δp = Δp_cr any opening between
    /// closed and open — and the poppet floats at p_j = p_c, passing what
    /// the throttle does not (a maximal monotone law, Filippov's convention;
    /// the flow is then continuous in the state). Handing that band to
    /// Brent's method instead made it converge onto the jump and return
    /// one side or the other at random, a right-hand side that chattered by
    /// the check valve's whole flow: the integrator's step collapsed there
    /// (issue 23: a varied truth draw with Δp_cr = 0.2 bar never finished).
    fn fill_junction(&self, q1: &dyn Fn(f64) -> f64, s: &End, r: &End, xtol: f64) -> (f64, f64) {
        let thr = |pj: f64| self.throttle.forward(&self.law, pj, s.t, r.p);
        let p_c = r.p + self.cracking;
        if self.check_law == CheckLaw::Exact && p_c < s.p {
            let closed = q1(p_c) - thr(p_c);
            if closed <= 0.0 {
                // the check valve stays shut: the root lies at or below p_c
                let pj = brent(|pj| q1(pj) - thr(pj), r.p, p_c, q1(r.p), closed, xtol);
                return (thr(pj), pj);
            }
            let open = closed - self.check.forward(&self.law, p_c, s.t, r.p);
            if open < 0.0 {
                // floating at the cracking pressure
                return (q1(p_c), p_c);
            }
            // fully open: the root lies at or above p_c
            let q2 = |pj: f64| thr(pj) + self.check.forward(&self.law, pj, s.t, r.p);
            let pj = brent(|pj| q1(pj) - q2(pj), p_c, s.p, open, -q2(s.p), xtol);
            return (q2(pj), pj);
        }
        let q2 = |pj: f64| self.scv_in(pj, s.t, r.p);
        let pj = brent(|pj| q1(pj) - q2(pj), r.p, s.p, q1(r.p), -q2(s.p), xtol);
        (q2(pj), pj)
    }

    /// The rod line between the 5/2 end `s` (supply node or exhaust) and the
    /// rod chamber `r`. Returns (ṁ into the rod chamber, ṁ leaving `s`
    /// towards the junction, enthalpy carried, junction pressure).
    fn rod_line(&self, s: &End, r: &End) -> (f64, f64, f64, f64) {
        let span = (s.p - r.p).abs();
        if span <= 1e-12 * s.p.max(r.p) {
            return (0.0, 0.0, r.h, 0.5 * (s.p + r.p));
        }
        let xtol = 1e-14 * s.p.max(r.p);
        if s.p > r.p {
            // s → j (5/2 valve) → rod (speed-control valve), gas at s.t
            let q1 = |pj: f64| self.valve.forward(&self.law, s.p, s.t, pj);
            let (q, pj) = self.fill_junction(&q1, s, r, xtol);
            (q, q1(pj), s.h, pj)
        } else {
            // rod → j (throttle; the check valve is closed) → s (5/2 valve), gas at r.t
            let q1 = |pj: f64| self.throttle.forward(&self.law, r.p, r.t, pj);
            let q2 = |pj: f64| self.valve.forward(&self.law, pj, r.t, s.p);
            let res = |pj: f64| q1(pj) - q2(pj);
            let (lo, hi) = (s.p, r.p);
            let pj = brent(res, lo, hi, q1(lo), -q2(hi), xtol);
            (-q1(pj), -q2(pj), r.h, pj)
        }
    }

    /// Evaluates the derivatives (if `dy` is given) and the diagnostic
    /// quantities. `None` if the state is outside the physical domain.
    pub(crate) fn evaluate(&self, mode: &Mode, y: &[f64], dy: Option<&mut [f64]>) -> Option<Eval> {
        let g = &self.gas;
        let (m1, t1, m2, t2, x) = (y[I_M1], y[I_T1], y[I_M2], y[I_T2], y[I_X]);
        let (v1, v2) = self.volumes(x);
        if !(m1 > 0.0 && m2 > 0.0 && t1 > 0.0 && t2 > 0.0 && v1 > 0.0 && v2 > 0.0) {
            return None;
        }
        let (rho1, rho2) = (m1 / v1, m2 / v2);
        let p1 = g.pressure(rho1, t1);
        let p2 = g.pressure(rho2, t2);
        let head = End { p: p1, t: t1, h: g.enthalpy(rho1, t1) };
        let rod = End { p: p2, t: t2, h: g.enthalpy(rho2, t2) };
        let line = match self.line {
            Some((_, vol, _)) => {
                let (ml, tl) = (y[I_ML], y[I_TL]);
                if !(ml > 0.0 && tl > 0.0) {
                    return None;
                }
                let rho = ml / vol;
                Some(End { p: g.pressure(rho, tl), t: tl, h: g.enthalpy(rho, tl) })
            }
            None => None,
        };
        let p_node = line.unwrap_or(self.supply);

        // flows: (ṁ, h_up) positive into the named chamber
        let (mut md1, mut ex1) = (0.0, 0.0); // ṁ and Σ_in ṁ(h_in − h)
        let (mut md2, mut ex2) = (0.0, 0.0);
        let (mut mdl, mut exl) = (0.0, 0.0);
        let (mut bm, mut bh) = (0.0, 0.0); // boundary mass and enthalpy in
        let add = |md: &mut f64, ex: &mut f64, q: f64, h_up: f64, h_self: f64| {
            *md += q;
            if q > 0.0 {
                *ex += q * (h_up - h_self);
            }
        };

        let (head_from, rodline_from) = match mode.valve {
            ValvePos::Extend => (p_node, self.atm),
            ValvePos::Retract => (self.atm, p_node),
        };
        let (q_head, h_head) = self.iso_between(&self.valve, &head_from, &head);
        add(&mut md1, &mut ex1, q_head, h_head, head.h);
        let (q_rod, q_from, h_rod, pj) = self.rod_line(&rodline_from, &rod);
        add(&mut md2, &mut ex2, q_rod, h_rod, rod.h);
        // what left the supply node / the atmosphere
        let head_from_node = mode.valve == ValvePos::Extend;
        let (q_node, q_atm, h_node_flow, h_atm_flow) =
            if head_from_node { (q_head, q_from, h_head, h_rod) } else { (q_from, q_head, h_rod, h_head) };
        bm += q_atm;
        bh += q_atm * h_atm_flow;
        match (self.line, line) {
            (Some((lr, _, _)), Some(l)) => {
                // the line volume feeds the valve and is fed by the supply
                add(&mut mdl, &mut exl, -q_node, h_node_flow, l.h);
                let (q_in, h_in) = self.iso_between(&lr, &self.supply, &l);
                add(&mut mdl, &mut exl, q_in, h_in, l.h);
                bm += q_in;
                bh += q_in * h_in;
            }
            _ => {
                bm += q_node;
                bh += q_node * h_node_flow;
            }
        }
        if let Some(leak) = self.leak {
            // positive from head to rod
            let q = if p1 >= p2 { leak.forward(&self.law, g.r, p1, t1, p2) } else { -leak.forward(&self.law, g.r, p2, t2, p1) };
            let h_up = if q >= 0.0 { head.h } else { rod.h };
            add(&mut md1, &mut ex1, -q, h_up, head.h);
            add(&mut md2, &mut ex2, q, h_up, rod.h);
        }

        // mechanics
        let f_applied = self.applied(p1, p2);
        let f_break = self.variant.breakaway(&self.friction, p1, p2);
        let (xdot, vdot) = match mode.mech {
            Mech::Stuck => (0.0, 0.0),
            Mech::Slide(dir) => {
                let v = y[I_V];
                let dry = self.variant.dry(&self.friction, p1, p2, dir * v);
                let c = self.friction.viscous(p1, p2);
                (v, (f_applied - dir * dry - c * v) / self.mass)
            }
        };
        let ev = Eval { p1, p2, p_line: p_node.p, p_junction: pj, f_applied, f_break };
        let Some(dy) = dy else {
            return Some(ev);
        };
        let vd1 = self.a1 * xdot;
        let vd2 = -self.a2 * xdot;
        let tdot = |m: f64, t: f64, rho: f64, md: f64, ex: f64, vdot: f64, inv_tau: f64| {
            temperature_rate(g, m, t, rho, Inflow { mdot: md, excess: ex }, vdot, self.t_wall, inv_tau)
        };
        dy[I_M1] = md1;
        dy[I_T1] = tdot(m1, t1, rho1, md1, ex1, vd1, self.inv_tau);
        dy[I_M2] = md2;
        dy[I_T2] = tdot(m2, t2, rho2, md2, ex2, vd2, self.inv_tau);
        dy[I_X] = xdot;
        dy[I_V] = vdot;
        let mut qwall = g.cv * self.inv_tau * (m1 * (self.t_wall - t1) + m2 * (self.t_wall - t2));
        let mut q0 = 6;
        if let (Some((_, vol, inv_tau_l)), Some(l)) = (self.line, line) {
            let (ml, tl) = (y[I_ML], y[I_TL]);
            let rho = ml / vol;
            dy[I_ML] = mdl;
            dy[I_TL] = tdot(ml, tl, rho, mdl, exl, 0.0, inv_tau_l);
            qwall += g.cv * inv_tau_l * ml * (self.t_wall - l.t);
            q0 = 8;
        }
        dy[q0] = bm;
        dy[q0 + 1] = bh;
        dy[q0 + 2] = qwall;
        dy[q0 + 3] = p1 * vd1 + p2 * vd2;
        Some(ev)
    }
}

/// The net mass flow into a chamber and the enthalpy its inflows bring
/// above the chamber's own, Σ_in ṁ_k (h_k − h).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Inflow {
    pub mdot: f64,
    pub excess: f64,
}

/// Temperature rate of a chamber (paper Eq. 13/14 with Eq. 8; Eq. 16/17 for
/// the ideal gas): m c_v Ṫ = Q_w + Σ_in ṁ_k (h_k − h) + T(∂p/∂T)_ρ (ṁ/ρ − V̇),
/// Q_w = m c_v⁰ (T_w − T)/τ_T. Shared by the rig and the reference vessels.
#[allow(clippy::too_many_arguments)]
pub(crate) fn temperature_rate(g: &Gas, m: f64, t: f64, rho: f64, flow: Inflow, vdot: f64, t_wall: f64, inv_tau: f64) -> f64 {
    let qw = m * g.cv * (t_wall - t) * inv_tau;
    (qw + flow.excess + g.t_dp_dt(rho, t) * (flow.mdot / rho - vdot)) / (m * g.cv_real(rho, t))
}

/// The plant in a fixed mode, as seen by the integrator.
pub(crate) struct ModeSystem<'a> {
    pub plant: &'a Plant,
    pub mode: Mode,
}

impl OdeSystem for ModeSystem<'_> {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) -> bool {
        self.plant.evaluate(&self.mode, y, Some(dy)).is_some() && dy.iter().all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_overpressure_flows_back_and_cools() {
        let rig = Rig::paper_bar_lpm(4.0, 13.2);
        let plant = Plant::new(&rig, &ModelForm::default(), &Effects::default());
        let mut y = plant.initial_state(&rig);
        let (v1, _) = plant.volumes(0.2);
        y[I_X] = 0.2;
        y[I_V] = 0.5;
        y[I_M1] = 5e5 * v1 / (287.05 * 330.0);
        y[I_T1] = 330.0;
        let mut dy = vec![0.0; y.len()];
        let mode = Mode { valve: ValvePos::Extend, mech: Mech::Slide(1.0) };
        let ev = plant.evaluate(&mode, &y, Some(&mut dy)).unwrap();
        assert!(ev.p1 > ev.p_line);
        assert!(dy[I_M1] < 0.0);
        assert!(dy[I_T1] < 0.0);
    }
}

#[cfg(test)]
mod junction_tests {
    use super::*;

    /// The rod line filling the rod chamber through an exact check valve
    /// with a cracking pressure: across the band where neither a shut nor
    /// a fully open valve balances the junction, the valve floats at the
    /// cracking pressure — the junction sits at p_rod + Δp_cr, what enters
    /// the rod chamber is what leaves the supply, and the flow is
    /// continuous in the rod pressure (it jumped by the check valve's whole
    /// flow before, issue 23).
    #[test]
    fn an_exact_check_valve_floats_at_its_cracking_pressure() {
        let cracking = 0.134e5;
        let rig = Rig { check_cracking: cracking, ..Rig::paper_bar_lpm(4.0, 26.0) };
        let plant = Plant::new(&rig, &ModelForm::default(), &Effects::default());
        let supply = plant.supply;
        let rod_end = |p: f64| End { p, t: 292.0, h: plant.gas.enthalpy(plant.gas.density(p, 292.0), 292.0) };
        let mut floating = 0;
        let mut last: Option<f64> = None;
        let mut largest_jump: f64 = 0.0;
        let mut largest_flow: f64 = 0.0;
        let n = 20_000;
        for k in 0..n {
            // rod pressure from 3.5 bar up to just below the supply
            let p2 = 3.5e5 + (supply.p - 3.5e5) * k as f64 / n as f64;
            let (q_rod, q_from, _, pj) = plant.rod_line(&supply, &rod_end(p2));
            assert!(
                (q_rod - q_from).abs() <= 1e-6 * q_from.abs(),
                "p_rod {p2} Pa: into the rod {q_rod} kg/s, out of the supply {q_from} kg/s"
            );
            assert!(pj >= p2 && pj <= supply.p, "p_rod {p2}: junction {pj}");
            let throttle_only = plant.throttle.forward(&plant.law, pj, supply.t, p2);
            if q_rod > throttle_only * (1.0 + 1e-9) && pj - p2 < cracking * (1.0 + 1e-9) {
                // the check valve passes flow: the junction is at (not below) the cracking pressure
                assert!((pj - p2 - cracking).abs() <= 1e-6 * cracking, "p_rod {p2}: junction {pj}, Δp {} Pa", pj - p2);
                floating += 1;
            }
            if let Some(q) = last {
                largest_jump = largest_jump.max((q_rod - q).abs());
            }
            largest_flow = largest_flow.max(q_rod);
            last = Some(q_rod);
        }
        assert!(floating > 100, "the band was crossed: {floating} points floating");
        // a grid step of 2.5 Pa moves a continuous flow by far less than 1 % of its range
        assert!(largest_jump < 0.01 * largest_flow, "largest jump {largest_jump} kg/s of {largest_flow} kg/s");
    }
}

#[cfg(test)]
mod energy_tests {
    use super::*;
    use crate::flow::LeakLaw;
    use crate::params::SupplyLine;

    /// dU/dt computed from the state derivatives equals the accounts'
    /// derivative H_in + Q − W at arbitrary states, in every mode: the
    /// temperature equation is consistent with u(ρ, T).
    #[test]
    fn temperature_equation_is_consistent_with_the_energy_accounts() {
        let rig = Rig::paper_bar_lpm(5.0, 13.2);
        for real in [false, true] {
            for line in [false, true] {
                let fx = Effects {
                    real_gas: real,
                    seal_leak: Some(LeakLaw::Iso(Restriction::lpm_per_bar(2.0, 0.3))),
                    supply_line: line.then_some(SupplyLine {
                        restriction: Restriction::lpm_per_bar(100.0, 0.3),
                        volume: 1e-3,
                        tau_thermal: 2.0,
                    }),
                    ..Effects::default()
                };
                let plant = Plant::new(&rig, &ModelForm::default(), &fx);
                let g = plant.gas;
                for (p1, t1, p2, t2, x, v) in [
                    (3e5, 250.0, 4.5e5, 320.0, 0.1, 0.3),
                    (1.2e5, 310.0, 2e5, 280.0, 0.3, -2.0),
                    (6e5, 300.0, 1.5e5, 300.0, 0.44, 1.0),
                    (0.9e5, 240.0, 5.2e5, 330.0, 0.02, -0.5),
                ] {
                    for valve in [ValvePos::Extend, ValvePos::Retract] {
                        let mut y = plant.initial_state(&rig);
                        let (v1, v2) = plant.volumes(x);
                        y[I_M1] = g.density(p1, t1) * v1;
                        y[I_T1] = t1;
                        y[I_M2] = g.density(p2, t2) * v2;
                        y[I_T2] = t2;
                        y[I_X] = x;
                        y[I_V] = v;
                        if line {
                            y[I_ML] = g.density(4.2e5, 300.0) * 1e-3;
                            y[I_TL] = 300.0;
                        }
                        let mode = Mode { valve, mech: Mech::Slide(v.signum()) };
                        let mut dy = vec![0.0; y.len()];
                        plant.evaluate(&mode, &y, Some(&mut dy)).unwrap();
                        // dU/dt by the chain rule
                        let du = |m: f64, t: f64, vol: f64, dm: f64, dt: f64, dvol: f64| {
                            let rho = m / vol;
                            let drho = (dm - rho * dvol) / vol;
                            let eps_t = 1e-4;
                            let eps_r = 1e-6 * rho;
                            let u_t = (g.internal_energy(rho, t + eps_t) - g.internal_energy(rho, t - eps_t)) / (2.0 * eps_t);
                            let u_r = (g.internal_energy(rho + eps_r, t) - g.internal_energy(rho - eps_r, t)) / (2.0 * eps_r);
                            dm * g.internal_energy(rho, t) + m * (u_t * dt + u_r * drho)
                        };
                        let mut dudt =
                            du(y[I_M1], t1, v1, dy[I_M1], dy[I_T1], plant.a1 * v) + du(y[I_M2], t2, v2, dy[I_M2], dy[I_T2], -plant.a2 * v);
                        let q0 = plant.n_dyn;
                        if line {
                            dudt += du(y[I_ML], y[I_TL], 1e-3, dy[I_ML], dy[I_TL], 0.0);
                        }
                        let accounts = dy[q0 + 1] + dy[q0 + 2] - dy[q0 + 3];
                        let scale = dy[q0 + 1].abs() + dy[q0 + 2].abs() + dy[q0 + 3].abs();
                        assert!(
                            (dudt - accounts).abs() < 1e-6 * scale,
                            "real {real} line {line} {valve:?} state {:?}: dU/dt {dudt} accounts {accounts}",
                            (p1, t1, p2, t2, x, v)
                        );
                    }
                }
            }
        }
    }
}
