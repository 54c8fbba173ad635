//! The hidden effects of the truth generator: at their null values they
//! leave the run unchanged (bit for bit), and switched on they act in the
//! direction physics says.

use rig::{
    simulate, Effects, EventKind, FrictionVariant, LeakLaw, ModelForm, Restriction, Rig, RunSpec, Stribeck, StribeckShape, SupplyLine,
    Trace,
};

fn run(fx: &Effects) -> Trace {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    simulate(&rig, &ModelForm::default(), fx, &RunSpec::cycles(3, 1e-3)).unwrap()
}

fn totals(t: &Trace) -> Vec<f64> {
    t.cycles.iter().map(|c| c.total).collect()
}

#[test]
fn null_effects_change_nothing() {
    let base = run(&Effects::default());
    let nulls = [
        Effects { seal_leak: Some(LeakLaw::Iso(Restriction { c: 0.0, b: 0.3 })), ..Effects::default() },
        Effects { seal_leak: Some(LeakLaw::Laminar { k: 0.0 }), ..Effects::default() },
        Effects { valve_delay: 0.0, extra_volume_head: 0.0, extra_volume_rod: 0.0, ..Effects::default() },
        Effects { friction: Some(FrictionVariant::default()), ..Effects::default() },
        Effects { tau_thermal: Some(5.0), ..Effects::default() },
    ];
    for fx in nulls {
        let tr = run(&fx);
        assert_eq!(totals(&tr), totals(&base), "{fx:?}");
        assert_eq!(tr.p1, base.p1, "{fx:?}");
        assert_eq!(tr.x, base.x, "{fx:?}");
    }
}

#[test]
fn each_effect_acts_in_the_expected_direction() {
    let base = run(&Effects::default());
    let tb = totals(&base);
    let first_breakaway = |t: &Trace| t.events.iter().find(|e| matches!(e.kind, EventKind::Breakaway(_))).unwrap().t;

    // seal leak: head → rod during the stroke; the rod chamber gains mass,
    // p2 rises and the head pressure must follow: the cycle changes
    let leak = run(&Effects { seal_leak: Some(LeakLaw::Iso(Restriction::lpm_per_bar(0.3, 0.3))), ..Effects::default() });
    assert!((totals(&leak)[2] / tb[2] - 1.0).abs() > 1e-3);

    // valve delay: the spool follows the command late: first breakaway
    // later by the delay, and a rest at each end (the rod chamber refills
    // before the next stroke, so the periodic cycle gets much longer)
    let td = 0.03;
    let delay = run(&Effects { valve_delay: td, ..Effects::default() });
    assert!((first_breakaway(&delay) - first_breakaway(&base) - td).abs() < 1e-6);
    assert!(totals(&delay)[2] > tb[2] + 2.0 * td);

    // supply droop: the valve's supply port sags below the source
    let droop = run(&Effects {
        supply_line: Some(SupplyLine { restriction: Restriction::lpm_per_bar(200.0, 0.3), volume: 1e-3, tau_thermal: 1.0 }),
        ..Effects::default()
    });
    let min_ps = droop.p_supply.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(min_ps < 3.5e5, "{min_ps}");
    assert!(base.p_supply.iter().all(|&p| p == 4e5));

    // extra dead volume: more air to fill before breakaway
    let vol = run(&Effects { extra_volume_head: 50e-6, ..Effects::default() });
    assert!(first_breakaway(&vol) > first_breakaway(&base) * 1.5);

    // Stribeck friction with a breakaway ratio: later breakaway
    let stribeck = run(&Effects {
        friction: Some(FrictionVariant {
            breakaway_ratio: 2.5,
            stribeck: Some(Stribeck { velocity: 0.02, shape: StribeckShape::Gaussian }),
        }),
        ..Effects::default()
    });
    assert!(first_breakaway(&stribeck) > first_breakaway(&base));

    // adiabatic chambers: the head gets colder on the fast return
    let adiabatic = run(&Effects { tau_thermal: Some(f64::INFINITY), ..Effects::default() });
    let tmin = |t: &Trace| t.temp1.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(tmin(&adiabatic) < tmin(&base));
    let fast_exchange = run(&Effects { tau_thermal: Some(0.05), ..Effects::default() });
    assert!(tmin(&fast_exchange) > tmin(&base) + 10.0);

    // real gas: B < 0 lowers the pressure at a given density; the initial
    // states are set by pressure, so the masses differ by the compressibility
    let real = run(&Effects { real_gas: true, ..Effects::default() });
    let z = base.m2[0] / real.m2[0];
    assert!(z < 1.0 && z > 0.995, "{z}");
    assert!((totals(&real)[2] / tb[2] - 1.0).abs() > 1e-4);
}
