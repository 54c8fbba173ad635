//! Closed-form checks of the rig's physics: the reference vessels (which use
//! the rig's own chamber equation, flow law, gas and integrator) against
//! analytic solutions, and the throttled stroke of the rig against a hand
//! calculation.

use rig::tank::{run_vessels, Reservoir, Vessel, VesselSystem};
use rig::{simulate, Effects, Gas, ModelForm, Restriction, Rig, RunSpec, SubsonicLaw, LPM_PER_BAR};

const RHO_N: f64 = 1.185;
const T_N: f64 = 293.15;

fn gas() -> Gas {
    Gas::default()
}

/// Adiabatic choked discharge of a rigid tank (isentropic in the tank):
/// p(t) = p0 [1 + (γ−1)/(2γ) t/τ]^(−2γ/(γ−1)), τ = V/(γ C ρ_N R √(T_N T0)),
/// T = T0 (p/p0)^((γ−1)/γ), valid while p ≥ p_atm/b.
#[test]
fn adiabatic_choked_discharge_follows_the_closed_form() {
    let g = gas();
    let gamma = g.gamma();
    let (v, p0, t0, p_atm, b) = (1e-3, 7e5, 292.0, 1.013e5, 0.3);
    let c = 100.0 * LPM_PER_BAR;
    let sys = VesselSystem {
        convection: None,
        gas: g,
        law: SubsonicLaw::default(),
        t_wall: 292.0,
        vessels: vec![Vessel { volume: v, p0, t0, tau_thermal: f64::INFINITY }],
        reservoir: Some(Reservoir { p: p_atm, t: 292.0, restriction: Restriction { c, b } }),
        link: None,
    };
    let tau = v / (gamma * c * RHO_N * g.r * (T_N * t0).sqrt());
    let k = (gamma - 1.0) / (2.0 * gamma);
    let p_exact = |t: f64| p0 * (1.0 + k * t / tau).powf(-1.0 / k);
    // end of the choked phase
    let t_choke = tau / k * ((p0 * b / p_atm).powf(k) - 1.0);
    assert!(t_choke > 0.3 && t_choke < 0.35, "{t_choke}");
    let tr = run_vessels(&sys, t_choke, 1e-3, 1e-9).unwrap();
    let mut worst_p: f64 = 0.0;
    let mut worst_t: f64 = 0.0;
    for i in 0..tr.t.len() {
        let pe = p_exact(tr.t[i]);
        worst_p = worst_p.max((tr.p[0][i] - pe).abs() / pe);
        let te = t0 * (tr.p[0][i] / p0).powf((gamma - 1.0) / gamma);
        worst_t = worst_t.max((tr.temp[0][i] - te).abs() / te);
    }
    println!("choked discharge: τ = {tau:.6} s, worst relative error p {worst_p:.2e}, T {worst_t:.2e}");
    assert!(worst_p < 1e-7, "{worst_p}");
    assert!(worst_t < 1e-7, "{worst_t}");
    // the closed form itself reaches p_atm/b at t_choke
    assert!((p_exact(t_choke) - p_atm / b).abs() < 1e-6);
    assert!(*tr.t.last().unwrap() > t_choke - 1e-3);
}

/// Adiabatic filling of a rigid, nearly empty tank from a reservoir at T_s:
/// the energy balance m c_v T = m0 c_v T0 + (m − m0) c_p T_s holds at every
/// instant, so T → γ T_s as m/m0 → ∞.
#[test]
fn adiabatic_filling_tends_to_gamma_times_supply_temperature() {
    let g = gas();
    let (v, p0, t0, ps, ts) = (1e-3, 1e3, 292.0, 7e5, 292.0);
    let sys = VesselSystem {
        convection: None,
        gas: g,
        law: SubsonicLaw::default(),
        t_wall: 292.0,
        vessels: vec![Vessel { volume: v, p0, t0, tau_thermal: f64::INFINITY }],
        reservoir: Some(Reservoir { p: ps, t: ts, restriction: Restriction { c: 50.0 * LPM_PER_BAR, b: 0.3 } }),
        link: None,
    };
    let tr = run_vessels(&sys, 1.5, 1e-3, 1e-9).unwrap();
    let m0 = tr.m[0][0];
    let mut worst: f64 = 0.0;
    // the filling proper: up to 0.9999 p_s. (At rest at p_s the pure
    // ellipse's cusp lets tolerance-level flows go back and forth, carrying
    // c_p T_s in and c_p T out, so the invariant then drifts slowly; see the
    // crate documentation, "Limitations".)
    let n = tr.p[0].iter().position(|&p| p > 0.9999 * ps).unwrap();
    for i in 0..=n {
        let (m, t) = (tr.m[0][i], tr.temp[0][i]);
        let lhs = m * g.cv * t;
        let rhs = m0 * g.cv * t0 + (m - m0) * g.cp() * ts;
        worst = worst.max((lhs - rhs).abs() / lhs);
    }
    let (mf, tf, pf) = (tr.m[0][n], tr.temp[0][n], tr.p[0][n]);
    let tf_exact = (m0 * g.cv * t0 + (mf - m0) * g.cp() * ts) / (mf * g.cv);
    println!(
        "adiabatic filling: T_final = {tf:.6} K (γT_s = {:.6} K), p_final = {pf:.3} Pa, worst energy error {worst:.2e}",
        g.gamma() * ts
    );
    assert!(worst < 1e-7, "{worst}");
    assert!((tf - tf_exact).abs() / tf_exact < 1e-7);
    let p_end = *tr.p[0].last().unwrap();
    assert!((p_end - ps).abs() / ps < 1e-6, "{p_end}");
    // m0/mf ≈ 1/1000, so T_final is within 0.1 % of γ T_s
    assert!((tf - g.gamma() * ts).abs() / (g.gamma() * ts) < 1e-3, "{tf}");
}

/// A closed rigid tank relaxes to the wall temperature with the thermal time
/// constant (paper Eq. 8): T = T_w + (T0 − T_w) e^(−t/τ_T); p ∝ T.
#[test]
fn wall_heat_relaxes_with_the_thermal_time_constant() {
    let (tw, t0, tau) = (292.0, 350.0, 2.0);
    let sys = VesselSystem {
        convection: None,
        gas: gas(),
        law: SubsonicLaw::default(),
        t_wall: tw,
        vessels: vec![Vessel { volume: 1e-3, p0: 5e5, t0, tau_thermal: tau }],
        reservoir: None,
        link: None,
    };
    let tr = run_vessels(&sys, 6.0, 1e-2, 1e-9).unwrap();
    let mut worst: f64 = 0.0;
    for i in 0..tr.t.len() {
        let te = tw + (t0 - tw) * (-tr.t[i] / tau).exp();
        worst = worst.max((tr.temp[0][i] - te).abs() / te);
        let pe = 5e5 * tr.temp[0][i] / t0;
        assert!((tr.p[0][i] - pe).abs() / pe < 1e-12);
    }
    println!("τ_T relaxation: worst relative error in T {worst:.2e}");
    assert!(worst < 1e-7, "{worst}");
    // the wall heat account equals the change of internal energy
    let n = tr.t.len() - 1;
    let du = tr.energy[n] - tr.energy[0];
    assert!((du - tr.wall_heat[n]).abs() < 1e-8 * du.abs(), "{du} {}", tr.wall_heat[n]);
}

/// The throttled extend stroke of the meter-out rig at 4 bar, switch 2:
/// the rod chamber's gas leaves through the choked throttle at the rate
/// C ρ_N p₂ √(T_N/T₂) (paper Eq. 34, 35); at steady speed the chamber's
/// density is constant, so A₂ v = ṁ/ρ₂ = C ρ_N R √(T_N T₂), independent of
/// p₂ — about 0.16 m/s.
#[test]
fn steady_throttled_speed_matches_the_hand_calculation() {
    let c_lpm = 13.2;
    let rig = Rig::paper_bar_lpm(4.0, c_lpm);
    let run = RunSpec::cycles(1, 1e-3);
    let tr = simulate(&rig, &ModelForm::default(), &Effects::default(), &run).unwrap();
    let c = c_lpm * LPM_PER_BAR;
    let a2 = rig.area_rod_side();
    let mut n = 0;
    let mut worst: f64 = 0.0;
    for i in 0..tr.t.len() {
        if tr.v[i] > 0.0 && tr.x[i] > 0.15 && tr.x[i] < 0.35 {
            let v_hand = c * RHO_N * rig.gas.r * (T_N * tr.temp2[i]).sqrt() / a2;
            worst = worst.max((tr.v[i] - v_hand).abs() / v_hand);
            // choked: junction (exhaust side) below b times the rod pressure
            assert!(tr.p_junction[i] < 0.3 * tr.p2[i]);
            n += 1;
        }
    }
    assert!(n > 1000, "{n}");
    // by hand at the rod temperature of 292 K: 0.1548 m/s
    let v292 = c * RHO_N * rig.gas.r * (T_N * 292.0f64).sqrt() / a2;
    assert!((v292 - 0.1548).abs() < 5e-4, "{v292}");
    let mid = tr.x.iter().position(|&x| x > 0.25).unwrap();
    println!(
        "steady speed: simulated {:.5} m/s at x = 0.25 m (T2 = {:.2} K, p2 = {:.0} Pa); hand {:.5} m/s; worst deviation over 0.15–0.35 m {worst:.2e}",
        tr.v[mid],
        tr.temp2[mid],
        tr.p2[mid],
        c * RHO_N * rig.gas.r * (T_N * tr.temp2[mid]).sqrt() / a2
    );
    assert!(worst < 5e-3, "{worst}");
    assert!(tr.v[mid] > 0.15 && tr.v[mid] < 0.165);
    // force balance at steady speed: p1 A1 − p2 A2 − p_atm A_rod = F_c + c v
    let (p1, p2, v) = (tr.p1[mid], tr.p2[mid], tr.v[mid]);
    let f = rig.friction;
    let lhs = p1 * rig.area_head() - p2 * a2 - rig.atm_pressure * rig.area_rod();
    let rhs = f.coulomb(p1, p2) + f.viscous(p1, p2) * v;
    assert!((lhs - rhs).abs() < 0.05, "{lhs} {rhs}");
}
