//! Convergence in the integration tolerance: cycle times change by less
//! than 1e-4 (relative) between rtol 1e-6 and 1e-8, with and without
//! hidden effects; the laminar end region tends to the pure ellipse as its
//! width goes to zero.

use rig::{
    simulate, CycleTimes, Effects, FrictionVariant, LeakLaw, ModelForm, Restriction, Rig, RunSpec, Stribeck, StribeckShape, SupplyLine,
};

fn cycles(rig: &Rig, form: &ModelForm, fx: &Effects, rtol: f64) -> Vec<CycleTimes> {
    let run = RunSpec { rtol, ..RunSpec::cycles(3, 1e-2) };
    simulate(rig, form, fx, &run).unwrap().cycles
}

fn max_rel_diff(a: &[CycleTimes], b: &[CycleTimes]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| ((x.total - y.total) / y.total).abs()).fold(0.0, f64::max)
}

#[test]
fn cycle_times_converge_with_the_tolerance() {
    let effects = Effects {
        seal_leak: Some(LeakLaw::Iso(Restriction::lpm_per_bar(0.3, 0.3))),
        friction: Some(FrictionVariant {
            breakaway_ratio: 1.5,
            stribeck: Some(Stribeck { velocity: 0.02, shape: StribeckShape::Gaussian }),
        }),
        supply_line: Some(SupplyLine { restriction: Restriction::lpm_per_bar(200.0, 0.3), volume: 0.5e-3, tau_thermal: 1.0 }),
        valve_delay: 0.01,
        ..Effects::default()
    };
    for (ps, c, fx) in
        [(4.0, 13.2, Effects::default()), (7.0, 1.41, Effects::default()), (4.0, 210.0, Effects::default()), (4.0, 13.2, effects)]
    {
        let rig = Rig::paper_bar_lpm(ps, c);
        let form = ModelForm::default();
        let coarse = cycles(&rig, &form, &fx, 1e-6);
        let fine = cycles(&rig, &form, &fx, 1e-8);
        let finer = cycles(&rig, &form, &fx, 1e-10);
        let d1 = max_rel_diff(&coarse, &finer);
        let d2 = max_rel_diff(&fine, &finer);
        println!("{ps} bar, C {c}, effects {}: rtol 1e-6 vs 1e-10: {d1:.1e}; 1e-8 vs 1e-10: {d2:.1e}", fx != Effects::default());
        assert!(max_rel_diff(&coarse, &fine) < 1e-4);
        assert!(d2 < 2e-5, "{d2}");
    }
}

#[test]
fn laminar_end_region_tends_to_the_ellipse() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let pure = cycles(&rig, &ModelForm::default(), &Effects::default(), 1e-8);
    let mut last = f64::INFINITY;
    for w in [1e-2, 1e-3, 1e-4] {
        let mut form = ModelForm::default();
        form.subsonic.laminar_width = Some(w);
        let c = cycles(&rig, &form, &Effects::default(), 1e-8);
        let d = max_rel_diff(&c, &pure);
        println!("laminar width {w:e}: cycle times differ from the ellipse by {d:.2e}");
        assert!(d < last);
        last = d;
    }
    assert!(last < 1e-4);
}
