//! The discrepancy workflow on synthetic measurements with one hidden
//! effect (issue #5 acceptance tests).
//!
//! Truth: models/meter_out.json with 0.2 s dwells at both ends, four
//! operating points (4 and 7 bar × 26 and 52 L/(min·bar)), one catalogue
//! effect applied at a clearly visible size, simulated with rtol 1e-7 and
//! resampled at 1 kHz with pressure σ = 5 mbar plus a per-channel offset
//! (σ 2 mbar) and position σ = 20 µm ([`identify::synth`]). The fitted model
//! starts with friction k0, k2 and the valve and throttle conductances 10–20 %
//! away from the truth (random sign and size per seed) and integrates with
//! rtol 1e-6, atol 1e-5 on a 4 ms output grid.
//!
//! For each effect: the right name (and nothing else), its parameter within
//! the tolerance stated in [`CASES`], and after the fix a held-out RMSE
//! of at most 1.3 × the noise level or at least half of the baseline's
//! excess held-out error removed. With nothing hidden: nothing added.
//!
//! CI runs one seed per case with two cycles per experiment; the full matrix
//! (10 seeds per effect, 20 per null case, three cycles) runs with
//! `cargo test -p pneumo-identify --release --test discrepancy -- --ignored`
//! and prints the table recorded in docs/discrepancy.md.

use identify::synth::{draw_perturbation, standard_operating_points, Rng, Scenario, TruthSettings};
use identify::workflow::Outcome;

const L_MIN_BAR: f64 = 1e-3 / 60.0 / 1e5;

/// The nominal truth netlist.
fn base(adiabatic: bool) -> graph::FlatNetlist {
    let text = include_str!("../../../models/meter_out.json");
    let netlist = graph::expand::parse(text, "meter_out.json").expect("parse");
    let mut flat = graph::expand::flatten(&identify::netlist_edit::NoFiles, &netlist, std::path::Path::new("."), 0).expect("flatten");
    for s in ["controller.dwell_extended=0.2", "controller.dwell_retracted=0.2"] {
        graph::apply_set(&mut flat, s).expect("set");
    }
    if adiabatic {
        for id in ["head", "rod"] {
            identify::netlist_edit::set_param_si(&mut flat, id, "tau_thermal", f64::INFINITY).expect("adiabatic");
        }
    }
    flat
}

/// A hidden effect, its true values, and the tolerance on the fitted ones.
struct Case {
    effect: &'static str,
    values: fn() -> Vec<f64>,
    /// (parameter, relative tolerance) checked on the selected effect.
    tolerance: &'static [(&'static str, f64)],
    /// The fitted model lacks heat exchange (for `heat_transfer`).
    adiabatic: bool,
}

const CASES: &[Case] = &[
    Case { effect: "piston_seal_leak", values: || vec![0.3 * L_MIN_BAR], tolerance: &[("C", 0.10)], adiabatic: false },
    Case { effect: "dead_volume", values: || vec![30e-6, 0.0], tolerance: &[("extra_head", 0.10)], adiabatic: false },
    Case { effect: "valve_delay", values: || vec![0.010], tolerance: &[("T", 0.10)], adiabatic: false },
    Case {
        effect: "stribeck_friction",
        values: || vec![3.0, 0.02],
        tolerance: &[("breakaway_ratio", 0.05), ("stribeck_velocity", 0.5)],
        adiabatic: false,
    },
    Case { effect: "heat_transfer", values: || vec![1.0], tolerance: &[("rate", 0.10)], adiabatic: true },
    Case {
        effect: "supply_droop",
        values: || vec![200.0 * L_MIN_BAR, 0.5e-3],
        tolerance: &[("C_line", 0.10), ("V_line", 0.3)],
        adiabatic: false,
    },
    Case { effect: "real_gas", values: Vec::new, tolerance: &[], adiabatic: false },
];

/// Generate the data of one seed and run the workflow.
fn run(hidden: Option<(&str, Vec<f64>)>, adiabatic: bool, perturb: bool, seed: u64, cycles: u64) -> (Outcome, Vec<(String, f64)>) {
    let mut rng = Rng::new(seed.wrapping_mul(7919).wrapping_add(17));
    let perturbation =
        if perturb { draw_perturbation(&["friction.k0", "friction.k2", "flow_control.C", "dcv.C"], &mut rng) } else { Vec::new() };
    let settings = TruthSettings { cycles: Some(cycles), duration: 60.0, ..TruthSettings::default() };
    let scenario = Scenario {
        hidden: hidden.map(|(n, v)| (n.to_string(), v)),
        operating_points: standard_operating_points(),
        perturb: perturbation.clone(),
        truth_only: vec![],
        settings,
        seed,
    };
    let (model, experiments) = scenario.generate(&base(adiabatic)).expect("truth generation");
    let calibrate = identify::problem::default_calibration(&model);
    let options = identify::Options { report: true, ..identify::Options::default() };
    let outcome = identify::run(&model, &experiments, &calibrate, &options).expect("workflow");
    (outcome, perturbation)
}

/// What one seed of one case gave.
#[derive(Debug)]
struct Assessment {
    named: bool,
    params_ok: bool,
    heldout_ok: bool,
    verdict: String,
    detail: String,
}

fn assess(case: &Case, o: &Outcome) -> Assessment {
    let s = &o.summary;
    let named = s.selected.len() == 1 && s.selected[0].effect == case.effect && s.ambiguous.is_empty();
    let truth = (case.values)();
    let names: Vec<&str> = identify::effects::by_name(case.effect).map(|e| e.params().iter().map(|p| p.name).collect()).unwrap_or_default();
    let mut params_ok = named;
    let mut detail = String::new();
    if named {
        for (p, tol) in case.tolerance {
            let k = names.iter().position(|n| n == p).expect("tolerance names a parameter");
            let fitted = s.selected[0].params.get(*p).copied().unwrap_or(f64::NAN);
            let rel = (fitted - truth[k]).abs() / truth[k].abs();
            detail += &format!("{p} {fitted:.4e} (truth {:.4e}, {:+.1} %) ", truth[k], 100.0 * (fitted - truth[k]) / truth[k]);
            params_ok &= rel <= *tol;
        }
    }
    let (h0, h1) = (s.baseline.heldout_rmse, s.after.heldout_rmse);
    let heldout_ok = h1 <= 1.3 || (h0 - h1) >= 0.5 * (h0 - 1.0);
    detail += &format!("held-out {h0:.3} -> {h1:.3}");
    Assessment { named, params_ok, heldout_ok, verdict: s.verdict.clone(), detail }
}

fn check_case(case: &Case, seed: u64, cycles: u64) {
    let (o, perturbation) = run(Some((case.effect, (case.values)())), case.adiabatic, true, seed, cycles);
    let a = assess(case, &o);
    let report =
        format!("{}: seed {seed}: {} | {} | perturbation {perturbation:?} | {:.1} s", case.effect, a.verdict, a.detail, o.summary.seconds);
    eprintln!("{report}");
    assert!(a.named, "{report}");
    assert!(a.params_ok, "{report}");
    assert!(a.heldout_ok, "{report}");
    // the gap shrinks: the augmented netlist is what the report writes
    assert_eq!(o.augmented.len(), 1);
    assert!(o.augmented[0].1.components.len() >= base(case.adiabatic).components.len());
    assert!(o.summary.after.chi2 < o.summary.baseline.chi2);
}

fn case(name: &str) -> &'static Case {
    CASES.iter().find(|c| c.effect == name).expect("case")
}

// ---------------------------------------------------------------- CI set

#[test]
fn hidden_piston_seal_leak_is_named() {
    check_case(case("piston_seal_leak"), 1, 2);
}

#[test]
fn hidden_dead_volume_is_named() {
    check_case(case("dead_volume"), 1, 2);
}

#[test]
fn hidden_valve_delay_is_named() {
    check_case(case("valve_delay"), 1, 2);
}

#[test]
fn hidden_stribeck_friction_is_named() {
    check_case(case("stribeck_friction"), 1, 2);
}

#[test]
fn hidden_heat_transfer_is_named() {
    check_case(case("heat_transfer"), 1, 2);
}

#[test]
fn hidden_supply_droop_is_named() {
    check_case(case("supply_droop"), 1, 2);
}

#[test]
fn hidden_real_gas_is_named() {
    // At 4–7 bar the virial departure changes the piston speed by 0.1–0.2 %,
    // hundreds of 20 µm position-noise levels over a stroke: visible here
    // (see docs/discrepancy.md), so the workflow must name it.
    check_case(case("real_gas"), 1, 2);
}

#[test]
fn nothing_hidden_nothing_added() {
    for (perturb, seed) in [(false, 1), (true, 2)] {
        let (o, p) = run(None, false, perturb, seed, 2);
        eprintln!("nothing hidden, perturbation {p:?}: {} ({:.1} s)", o.summary.verdict, o.summary.seconds);
        assert!(o.summary.selected.is_empty() && o.summary.ambiguous.is_empty(), "{}", o.summary.verdict);
        assert_eq!(o.summary.verdict, "no missing effect found");
        // the calibration recovers the truth: normalised RMSE near the noise level
        for (ch, r) in &o.summary.baseline.rmse_normalized {
            assert!(*r < 1.3, "{ch}: {r}");
        }
        let k0 = o.summary.baseline.params.iter().find(|e| e.name == "friction.k0").expect("k0").value;
        assert!((k0 - 10.0).abs() < 0.5, "k0 = {k0}");
    }
}

// ---------------------------------------------------------------- full matrix

/// The full matrix, or part of it: `PNEUMO_MATRIX_CYCLES` (default 3) sets
/// the cycles per experiment, `PNEUMO_MATRIX_CASES` a comma-separated list of
/// effects and/or `none` (default: every case).
#[test]
#[ignore = "full matrix: about 100 minutes on 2 cores; run with --release -- --ignored"]
fn full_matrix() {
    let cycles: u64 = std::env::var("PNEUMO_MATRIX_CYCLES").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let only: Option<Vec<String>> = std::env::var("PNEUMO_MATRIX_CASES").ok().map(|v| v.split(',').map(|s| s.trim().to_string()).collect());
    let wanted = |name: &str| only.as_ref().is_none_or(|o| o.iter().any(|x| x == name));
    eprintln!("full matrix: {cycles} cycles per experiment");
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for c in CASES.iter().filter(|c| wanted(c.effect)) {
        let (mut named, mut params, mut held) = (0, 0, 0);
        for seed in 1..=10 {
            let (o, _) = run(Some((c.effect, (c.values)())), c.adiabatic, true, seed, cycles);
            let a = assess(c, &o);
            eprintln!("{} seed {seed}: {} | {} | {:.1} s", c.effect, a.verdict, a.detail, o.summary.seconds);
            named += usize::from(a.named);
            params += usize::from(a.params_ok);
            held += usize::from(a.heldout_ok);
        }
        rows.push(format!("| {} | {named}/10 | {params}/10 | {held}/10 |", c.effect));
        if named < 9 || params < 9 || held < 9 {
            failures.push(c.effect.to_string());
        }
    }
    let null_cases = if wanted("none") { vec![("nothing hidden", false), ("nothing hidden, baseline perturbed", true)] } else { vec![] };
    for (label, perturb) in null_cases {
        let mut clean = 0;
        for seed in 1..=20 {
            let (o, _) = run(None, false, perturb, 100 + seed, cycles);
            eprintln!("{label} seed {seed}: {} ({:.1} s)", o.summary.verdict, o.summary.seconds);
            clean += usize::from(o.summary.selected.is_empty() && o.summary.ambiguous.is_empty());
        }
        rows.push(format!("| {label} | nothing added {clean}/20 | | |"));
        if clean < 19 {
            failures.push(label.to_string());
        }
    }
    eprintln!("| case | right name | parameters | held-out |\n|---|---|---|---|\n{}", rows.join("\n"));
    assert!(failures.is_empty(), "failed: {failures:?}");
}
