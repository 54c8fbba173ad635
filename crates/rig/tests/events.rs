//! Event handling: stick–slip, end stops, limit switches and valve timing.
//!
//! The central property: a piston is never held while the applied force
//! exceeds the breakaway level by more than the integration tolerance, over
//! a grid of breakaway ratios, Stribeck laws and tolerances.

use rig::{simulate, Effects, EventKind, FrictionVariant, ModelForm, Rig, RunSpec, Sampling, Stribeck, StribeckShape, Trace, ValvePos};

fn run(rig: &Rig, form: &ModelForm, fx: &Effects, rtol: f64, dt: f64) -> Trace {
    let spec = RunSpec { rtol, ..RunSpec::cycles(3, dt) };
    simulate(rig, form, fx, &spec).unwrap()
}

/// Force tolerance that corresponds to the integration tolerance: rtol of
/// the supply pressure on the piston area [N].
fn force_tol(rig: &Rig, rtol: f64) -> f64 {
    rtol * rig.supply_pressure * rig.area_head()
}

fn check_holds(rig: &Rig, tr: &Trace, rtol: f64, label: &str) {
    assert_eq!(tr.cycles.len(), 3, "{label}");
    // at every integration point
    assert!(tr.max_hold_excess <= 5.0 * force_tol(rig, rtol) + 1e-6, "{label}: held {} N above breakaway", tr.max_hold_excess);
    // at the (interpolated) samples, and a held piston does not move
    let mut held_x: Option<(f64, f64)> = None;
    let releases: Vec<f64> = tr.events.iter().filter(|e| matches!(e.kind, EventKind::Breakaway(_))).map(|e| e.t).collect();
    for i in 0..tr.t.len() {
        assert!(tr.x[i] >= -1e-12 && tr.x[i] <= rig.stroke + 1e-12, "{label}: x = {} outside the stroke", tr.x[i]);
        if tr.stuck[i] {
            assert_eq!(tr.v[i], 0.0);
            let at_lower = tr.x[i] <= 1e-9;
            let at_upper = tr.x[i] >= rig.stroke - 1e-9;
            let mut excess = f64::NEG_INFINITY;
            if !at_upper {
                excess = excess.max(tr.f_applied[i] - tr.f_breakaway[i]);
            }
            if !at_lower {
                excess = excess.max(-tr.f_applied[i] - tr.f_breakaway[i]);
            }
            assert!(excess <= 20.0 * force_tol(rig, rtol) + 1e-6, "{label}: sample at t = {} held {excess} N above breakaway", tr.t[i]);
            // unless it slipped and stuck again between the two samples
            if let Some((t0, x0)) = held_x {
                if !releases.iter().any(|&tb| tb > t0 && tb <= tr.t[i]) {
                    assert!((tr.x[i] - x0).abs() < 1e-12, "{label}: held piston moved at t = {}", tr.t[i]);
                }
            }
            held_x = Some((tr.t[i], tr.x[i]));
        } else {
            held_x = None;
        }
    }
}

#[test]
fn never_held_above_breakaway_over_a_grid() {
    let stribecks = [
        None,
        Some(Stribeck { velocity: 5e-3, shape: StribeckShape::Exponential }),
        Some(Stribeck { velocity: 5e-3, shape: StribeckShape::Gaussian }),
    ];
    let mut runs = 0;
    for (ps, c) in [(4.0, 13.2), (7.0, 2.68)] {
        let rig = Rig::paper_bar_lpm(ps, c);
        for ratio in [1.0, 1.5, 2.0, 3.0] {
            for stribeck in stribecks {
                for rtol in [1e-5, 1e-6, 1e-7] {
                    let form = ModelForm { friction: FrictionVariant { breakaway_ratio: ratio, stribeck }, ..ModelForm::default() };
                    let tr = run(&rig, &form, &Effects::default(), rtol, 2e-3);
                    let label = format!("{ps} bar, C {c}, ratio {ratio}, {stribeck:?}, rtol {rtol:e}");
                    check_holds(&rig, &tr, rtol, &label);
                    runs += 1;
                }
            }
        }
    }
    assert_eq!(runs, 72);
}

#[test]
fn breakaway_happens_when_the_force_reaches_the_breakaway_level() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let form = ModelForm { friction: FrictionVariant { breakaway_ratio: 2.0, stribeck: None }, ..ModelForm::default() };
    let first = run(&rig, &form, &Effects::default(), 1e-8, 1e-2);
    let tb = first.events.iter().find(|e| matches!(e.kind, EventKind::Breakaway(_))).unwrap().t;
    // the same (deterministic) run, sampled every µs around the breakaway
    let times: Vec<f64> = (-20..=20).map(|k| tb + k as f64 * 1e-6).collect();
    let spec = RunSpec { rtol: 1e-8, sampling: Sampling::At(times), ..RunSpec::cycles(1, 1.0) };
    let tr = simulate(&rig, &form, &Effects::default(), &spec).unwrap();
    assert_eq!(tr.t.len(), 41);
    let g: Vec<f64> = (0..41).map(|i| tr.f_applied[i] - tr.f_breakaway[i]).collect();
    let slope = (g[19] - g[18]) / 1e-6;
    assert!(slope > 0.0);
    for (i, gi) in g.iter().enumerate() {
        if tr.t[i] <= tb {
            assert!(tr.stuck[i], "{i}");
            assert!(*gi <= 1e-6, "held above breakaway at sample {i}: {gi}");
        } else {
            assert!(!tr.stuck[i], "{i}");
        }
    }
    // released within a few nanoseconds of the crossing: the linear
    // extrapolation of F_a − F_s from the held samples vanishes at t_b
    let at_tb = g[20];
    assert!(at_tb.abs() < slope * 1e-8 + 1e-6, "F_a − F_s at breakaway {at_tb}, slope {slope} N/s");
    assert!(tr.v[21] > 0.0 && tr.x[21] > 0.0);
}

#[test]
fn each_cycle_has_the_expected_event_sequence() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let tr = run(&rig, &ModelForm::default(), &Effects::default(), 1e-6, 1e-2);
    let kinds: Vec<EventKind> = tr.events.iter().map(|e| e.kind).collect();
    assert_eq!(kinds[0], EventKind::ValveSwitch(ValvePos::Extend));
    assert_eq!(kinds.iter().filter(|k| **k == EventKind::SwitchRetracted).count(), 3);
    assert_eq!(kinds.iter().filter(|k| **k == EventKind::SwitchExtended).count(), 3);
    assert_eq!(kinds.iter().filter(|k| **k == EventKind::EndStop(true)).count(), 3);
    // every extend switch is followed by the retract command, the upper stop
    // and a backward breakaway, then the retract switch
    for (i, e) in tr.events.iter().enumerate() {
        if e.kind == EventKind::SwitchExtended {
            let rest: Vec<EventKind> = tr.events[i + 1..].iter().map(|e| e.kind).take(4).collect();
            assert_eq!(
                rest,
                vec![
                    EventKind::ValveSwitch(ValvePos::Retract),
                    EventKind::EndStop(true),
                    EventKind::Breakaway(-1.0),
                    EventKind::SwitchRetracted
                ]
            );
            assert_eq!(tr.events[i + 1].t, e.t);
        }
    }
    // times are non-decreasing and the cycles add up
    assert!(tr.events.windows(2).all(|w| w[1].t >= w[0].t));
    let total: f64 = tr.cycles.iter().map(|c| c.total).sum();
    assert!((total - tr.t_final).abs() < 1e-12);
    for c in &tr.cycles {
        assert!((c.extend + c.retract - c.total).abs() < 1e-12);
    }
}

#[test]
fn switch_at_the_stop_with_zero_tolerance() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let mut form = ModelForm::default();
    form.switches.tolerance = 0.0;
    let tr = run(&rig, &form, &Effects::default(), 1e-6, 1e-2);
    assert_eq!(tr.cycles.len(), 3);
    let stop = tr.events.iter().find(|e| e.kind == EventKind::EndStop(true)).unwrap().t;
    let trip = tr.events.iter().find(|e| e.kind == EventKind::SwitchExtended).unwrap().t;
    assert_eq!(stop, trip);
    // 10 µm earlier with the default tolerance: ~64 µs at 0.156 m/s
    let base = run(&rig, &ModelForm::default(), &Effects::default(), 1e-6, 1e-2);
    let d = tr.cycles[0].extend - base.cycles[0].extend;
    assert!(d > 5e-5 && d < 8e-5, "{d}");
}

#[test]
fn latency_and_valve_delay_shift_the_valve_exactly() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let (lat, td) = (5e-3, 20e-3);
    let mut form = ModelForm::default();
    form.switches.latency = lat;
    let fx = Effects { valve_delay: td, ..Effects::default() };
    let tr = run(&rig, &form, &fx, 1e-6, 1e-2);
    // first extend: the command at t = 0 has no latency, the valve follows td later
    assert_eq!(tr.events[0].kind, EventKind::ValveSwitch(ValvePos::Extend));
    assert!((tr.events[0].t - td).abs() < 1e-12);
    for (i, e) in tr.events.iter().enumerate() {
        if e.kind == EventKind::SwitchExtended || e.kind == EventKind::SwitchRetracted {
            let want = if e.kind == EventKind::SwitchExtended { ValvePos::Retract } else { ValvePos::Extend };
            if let Some(v) = tr.events[i + 1..].iter().find(|v| matches!(v.kind, EventKind::ValveSwitch(_))) {
                assert_eq!(v.kind, EventKind::ValveSwitch(want));
                assert!((v.t - e.t - lat - td).abs() < 1e-9, "{} {}", v.t, e.t);
            }
        }
    }
    // before the valve moves nothing changes (the rig is at rest in
    // equilibrium), so the first breakaway is delayed by exactly td
    let base = run(&rig, &ModelForm::default(), &Effects::default(), 1e-6, 1e-2);
    let tb = |t: &Trace| t.events.iter().find(|e| matches!(e.kind, EventKind::Breakaway(_))).unwrap().t;
    assert!((tb(&tr) - tb(&base) - td).abs() < 1e-7, "{} {}", tb(&tr), tb(&base));
}

#[test]
fn dwell_holds_the_piston_at_the_stop() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let mut form = ModelForm::default();
    form.switches.dwell_extended = 0.2;
    form.switches.dwell_retracted = 0.2;
    let tr = run(&rig, &form, &Effects::default(), 1e-6, 1e-3);
    assert_eq!(tr.cycles.len(), 3);
    // during the dwell at the extended end the piston sits at the stop
    let trip = tr.events.iter().find(|e| e.kind == EventKind::SwitchExtended).unwrap().t;
    for i in 0..tr.t.len() {
        if tr.t[i] > trip + 0.01 && tr.t[i] < trip + 0.2 {
            assert_eq!(tr.x[i], rig.stroke);
            assert!(tr.stuck[i]);
        }
    }
    // the retract phase contains the dwell
    assert!(tr.cycles[1].retract > 0.2 + 0.14);
    check_holds(&rig, &tr, 1e-6, "dwell");
}
