//! Conservation: a closed pair of tanks keeps its mass to rounding and its
//! energy to the integration tolerance; the open rig's gas mass changes by
//! exactly what crossed the boundary, its energy by H_in + Q − W.
//!
//! Mass is a linear function of the states, which a Runge–Kutta method
//! conserves exactly; internal energy m·u(ρ, T) is not, so its balance
//! closes only to the accumulated integration error, roughly (number of
//! steps) × rtol relative to U, and shrinks with the tolerance.

use rig::tank::{run_vessels, Vessel, VesselSystem};
use rig::{
    simulate, Effects, FrictionVariant, Gas, GasLaw, LeakLaw, ModelForm, Restriction, Rig, RunSpec, SubsonicLaw, SupplyLine, LPM_PER_BAR,
};

fn pair(tau: f64, law: GasLaw) -> VesselSystem {
    VesselSystem {
        convection: None,
        gas: Gas { law, ..Gas::default() },
        law: SubsonicLaw::default(),
        t_wall: 292.0,
        vessels: vec![
            Vessel { volume: 0.5e-3, p0: 7e5, t0: 320.0, tau_thermal: tau },
            Vessel { volume: 2e-3, p0: 1e5, t0: 280.0, tau_thermal: tau },
        ],
        reservoir: None,
        link: Some(Restriction { c: 20.0 * LPM_PER_BAR, b: 0.3 }),
    }
}

#[test]
fn closed_pair_keeps_mass_exactly_and_energy_to_tolerance() {
    for law in [GasLaw::Ideal, GasLaw::Virial] {
        let sys = pair(f64::INFINITY, law);
        let tr = run_vessels(&sys, 2.0, 1e-2, 1e-8).unwrap();
        let m0 = tr.m[0][0] + tr.m[1][0];
        let mut worst_m: f64 = 0.0;
        let mut worst_u: f64 = 0.0;
        for i in 0..tr.t.len() {
            worst_m = worst_m.max((tr.m[0][i] + tr.m[1][i] - m0).abs() / m0);
            worst_u = worst_u.max((tr.energy[i] - tr.energy[0]).abs() / tr.energy[0]);
        }
        println!("{law:?}: closed pair, mass drift {worst_m:.1e}, energy drift {worst_u:.1e}");
        assert!(worst_m < 1e-14, "{law:?} {worst_m}");
        assert!(worst_u < 2e-6, "{law:?} {worst_u}");
        // the pressures have equalised; for the ideal gas at the volume-
        // weighted mean, since U = pV/(γ−1) is conserved
        let n = tr.t.len() - 1;
        assert!((tr.p[0][n] - tr.p[1][n]).abs() < 1e-3 * tr.p[1][n]);
        if law == GasLaw::Ideal {
            let pf = (7e5 * 0.5e-3 + 1e5 * 2e-3) / 2.5e-3;
            assert!((tr.p[1][n] - pf).abs() / pf < 1e-6, "{}", tr.p[1][n]);
        }
    }
}

#[test]
fn closed_pair_with_wall_heat_changes_energy_by_the_heat() {
    for law in [GasLaw::Ideal, GasLaw::Virial] {
        let sys = pair(1.0, law);
        let tr = run_vessels(&sys, 5.0, 1e-2, 1e-8).unwrap();
        let n = tr.t.len() - 1;
        let du = tr.energy[n] - tr.energy[0];
        let q = tr.wall_heat[n];
        println!("{law:?}: ΔU = {du:.6} J, wall heat {q:.6} J");
        assert!(q.abs() > 10.0);
        assert!((du - q).abs() < 2e-6 * tr.energy[0], "{du} {q}");
        assert_eq!(tr.mass_in[n], 0.0);
    }
}

fn rig_balance(fx: &Effects, rtol: f64) -> rig::Balance {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let run = RunSpec { rtol, ..RunSpec::cycles(3, 1e-2) };
    let tr = simulate(&rig, &ModelForm::default(), fx, &run).unwrap();
    assert_eq!(tr.cycles.len(), 3);
    tr.balance
}

#[test]
fn rig_mass_balance_is_exact() {
    let all = Effects {
        seal_leak: Some(LeakLaw::Iso(Restriction::lpm_per_bar(0.5, 0.3))),
        valve_delay: 0.02,
        extra_volume_head: 30e-6,
        extra_volume_rod: 10e-6,
        friction: Some(FrictionVariant { breakaway_ratio: 1.5, stribeck: None }),
        supply_line: Some(SupplyLine { restriction: Restriction::lpm_per_bar(300.0, 0.3), volume: 0.5e-3, tau_thermal: 1.0 }),
        tau_thermal: Some(3.0),
        real_gas: true,
    };
    for fx in [Effects::default(), all] {
        let b = rig_balance(&fx, 1e-6);
        println!("mass in {:.6e} kg, change {:.6e} kg, residual {:.1e} kg", b.mass_in, b.mass_change, b.mass_residual);
        // the boundary flows are ~1e-3 kg/s over ~8 s; rounding only
        assert!(b.mass_residual.abs() < 1e-12, "{b:?}");
        assert!(b.mass_in.abs() > 1e-5);
    }
}

#[test]
fn rig_energy_balance_closes_with_the_tolerance() {
    let mut last = f64::INFINITY;
    for (rtol, bound) in [(1e-6, 3e-4), (1e-8, 5e-5)] {
        let b = rig_balance(&Effects::default(), rtol);
        println!(
            "rtol {rtol:e}: ΔU {:.4} J = H_in {:.4} + Q {:.4} − W {:.4} + residual {:.2e} J (relative {:.1e})",
            b.energy_change, b.enthalpy_in, b.wall_heat, b.work, b.energy_residual, b.energy_residual_rel
        );
        assert!(b.energy_residual_rel < bound, "{b:?}");
        assert!(b.energy_residual_rel < last / 3.0);
        last = b.energy_residual_rel;
    }
    // real gas: the same balance with u(ρ, T) from the virial equation
    let b = rig_balance(&Effects { real_gas: true, ..Effects::default() }, 1e-8);
    assert!(b.energy_residual_rel < 5e-5, "{b:?}");
}
