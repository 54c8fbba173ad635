//! The discrepancy workflow on data it did not make (issue 15).
//!
//! The measurements come from `pneumo-rig`, a second implementation of the
//! meter-out rig that shares no code with pneumo (its own SDIRK integrator,
//! junction solver, event handling, friction and sensors; see
//! `tests/truth/mod.rs` for every difference). The model handed to the
//! workflow is `models/meter_out.json` with only `supply.p` and the throttle
//! set per experiment, as a user's manifest would.
//!
//! CI set (the release build of README's test command, a few minutes on 2
//! cores): one seed of the nominal setting for six cases, two cycles per
//! experiment unless said, the whole catalogue:
//! - nothing hidden → nothing named (no false alarm);
//! - extra dead volume in one chamber → `dead_volume` named first and alone,
//!   its volume within ±30 % of the truth;
//! - a valve delay of 10–20 ms → `valve_delay` named first and alone, the
//!   delay within ±30 % of the truth;
//! - wall heat exchange in the data, an adiabatic model (seed 3, three
//!   cycles as in the matrix) → `heat_transfer` named first and alone, its
//!   rate 1/τ_T within ±30 % of the truth (missed there before the
//!   recentred starts were on by default: the calibrated form parameters
//!   imitated part of it; named with two cycles either way);
//! - a real gas in the data, an ideal gas in the model (seed 2) →
//!   `real_gas` named first and alone (missed before its screen lost the
//!   early stop, docs/discrepancy.md "Recentred starts on by default");
//! - a seal leak and a valve delay together (seed 5, three cycles as in the
//!   matrix) → both named, the delay first (half there — the delay only —
//!   while the candidates started from the round's recentred reference:
//!   docs/discrepancy.md "Candidates start from the calibration, not from
//!   the round's reference").
//!
//! The ±30 % tolerance is stated up front, not read off a run: the truth's
//! model form differs (exact check valve, no laminar region, exact
//! stick–slip) so a biased estimate is expected, but an effect "recovered"
//! outside ±30 % would be the wrong size for an engineer's purposes.
//!
//! The long matrix (every case, several seeds, nominal and varied model
//! forms, three cycles) is `full_matrix`, ignored here:
//! `cargo test --release -p pneumo-identify --test independent -- --ignored --nocapture`
//! (its table is in docs/discrepancy.md; `SEEDS=n` seeds per case,
//! `VARIATION=nominal` or `varied` one half only, `CASES=a,b` some cases,
//! `FIRST_SEED=n` the first seed, `TABLE=1` every candidate's figures).

mod truth;

use identify::report::Outcome;
use truth::{Case, Variation};

/// Run the workflow on one case and seed.
fn run(case: Case, seed: u64, variation: Variation, cycles: usize) -> (truth::Truth, Outcome) {
    let t = truth::draw(case, seed, variation);
    let records = truth::records(&t, seed, cycles).expect("the rig simulates");
    let experiments = truth::experiments(&records).expect("the records are experiments");
    let model = truth::model(case);
    let calibrate = identify::params::default_calibration(&model);
    let mut options = identify::Options { report: false, ..identify::Options::default() };
    // studies of the defaults (not used by the CI set): SCREEN_PREPARE=n turns
    // the projected scan on, SENSORS=offset fits offsets only, no gain or skew
    if let Some(n) = std::env::var("SCREEN_PREPARE").ok().and_then(|s| s.parse().ok()) {
        options.screen_prepare = n;
    }
    // PROGRESS=1 prints the workflow's progress with the time since the start
    if std::env::var("PROGRESS").is_ok_and(|s| s == "1") {
        let clock = std::time::Instant::now();
        options.progress = identify::options::Progress::to(move |m| {
            let (n, _, _) = identify::problem::simulation_count();
            eprintln!("[{:7.1} s, {n:6} sims] {m}", clock.elapsed().as_secs_f64())
        });
    }
    // LSQ_JACOBIAN=broyden: Broyden updates between finite-difference
    // Jacobians in every fit (identify::lsq::JacobianUpdate; a study)
    if std::env::var("LSQ_JACOBIAN").is_ok_and(|s| s == "broyden") {
        options.fit.jacobian = identify::lsq::JacobianUpdate::BROYDEN;
    }
    if std::env::var("SENSORS").is_ok_and(|s| s == "offset") {
        options.sensors.gain = false;
        options.sensors.skew = 0.0;
    }
    let o = identify::run(&model, &experiments, &calibrate, &options).expect("the workflow runs");
    (t, o)
}

/// Names of the selected effects, sorted.
fn named(o: &Outcome) -> Vec<String> {
    let mut v: Vec<String> = o.summary.selected.iter().map(|s| s.effect.clone()).collect();
    v.sort();
    v
}

/// A table of the candidates, for failure messages.
fn table(o: &Outcome) -> String {
    let s = &o.summary;
    let mut out = format!("verdict: {}\n", s.verdict);
    for c in &s.candidates {
        out += &format!(
            "  r{} {:<18} dIC {:>10.1} sham {:>9.1} held {:>7.3} gain {:>5.1} % floor {:>6.2} gap {:>4.0} % {} {:?} {}\n",
            c.round,
            c.effect,
            c.delta_ic,
            c.sham_delta_ic,
            c.heldout_rmse,
            100.0 * c.heldout_relative,
            c.floor_ratio,
            100.0 * c.gap_explained,
            if c.accepted { "PASS" } else { "fail" },
            c.params,
            c.reasons.join("; ")
        );
    }
    out
}

/// The one fitted value of `effect` whose parameter name satisfies `key`.
fn fitted(o: &Outcome, effect: &str, key: impl Fn(&str) -> bool) -> f64 {
    let s = o.summary.selected.iter().find(|s| s.effect == effect).unwrap_or_else(|| panic!("{effect} not selected\n{}", table(o)));
    let hits: Vec<f64> = s.params.iter().filter(|(k, _)| key(k)).map(|(_, v)| *v).collect();
    assert_eq!(hits.len(), 1, "parameters of {effect}: {:?}", s.params);
    hits[0]
}

fn within(value: f64, truth: f64, rel: f64) -> bool {
    (value - truth).abs() <= rel * truth.abs()
}

#[test]
fn independent_null_data_name_nothing() {
    let (t, o) = run(Case::Null, 1, Variation::Nominal, 2);
    assert!(named(&o).is_empty() && o.summary.ambiguous.is_empty(), "{}\nfalse alarm:\n{}", t.description, table(&o));
}

#[test]
fn independent_dead_volume_is_named_and_sized() {
    let (t, o) = run(Case::DeadVolume, 1, Variation::Nominal, 2);
    assert_eq!(named(&o), vec!["dead_volume"], "{}\n{}", t.description, table(&o));
    let (head, rod) = (t.effects.extra_volume_head, t.effects.extra_volume_rod);
    let (side, truth) = if head > 0.0 { ("head", head) } else { ("rod", rod) };
    let v = fitted(&o, "dead_volume", |k| k.contains(side));
    assert!(within(v, truth, 0.3), "{side} volume {:.2} cm3, truth {:.2} cm3\n{}", v * 1e6, truth * 1e6, table(&o));
}

#[test]
fn independent_valve_delay_is_named_and_sized() {
    let (t, o) = run(Case::ValveDelay, 1, Variation::Nominal, 2);
    assert_eq!(named(&o), vec!["valve_delay"], "{}\n{}", t.description, table(&o));
    let d = fitted(&o, "valve_delay", |k| k == "T");
    assert!(within(d, t.effects.valve_delay, 0.3), "delay {:.2} ms, truth {:.2} ms\n{}", d * 1e3, t.effects.valve_delay * 1e3, table(&o));
}

#[test]
fn independent_heat_transfer_is_named_and_sized() {
    let (t, o) = run(Case::HeatTransfer, 3, Variation::Nominal, 3);
    assert_eq!(named(&o), vec!["heat_transfer"], "{}\n{}", t.description, table(&o));
    let rate = fitted(&o, "heat_transfer", |k| k == "rate");
    let truth = 1.0 / t.tau_thermal;
    assert!(within(rate, truth, 0.3), "rate {rate:.4} 1/s, truth {truth:.4} 1/s\n{}", table(&o));
}

#[test]
fn independent_real_gas_is_named() {
    let (t, o) = run(Case::RealGas, 2, Variation::Nominal, 2);
    assert_eq!(named(&o), vec!["real_gas"], "{}\n{}", t.description, table(&o));
}

#[test]
fn independent_leak_behind_a_delay_is_named() {
    let (t, o) = run(Case::LeakAndDelay, 5, Variation::Nominal, 3);
    let order: Vec<&str> = o.summary.selected.iter().map(|s| s.effect.as_str()).collect();
    assert_eq!(order, vec!["valve_delay", "piston_seal_leak"], "{}\n{}", t.description, table(&o));
}

/// Seeds per case of the long matrix (environment `SEEDS`, default 5).
fn seeds() -> u64 {
    std::env::var("SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5)
}

/// The first seed of the long matrix (environment `FIRST_SEED`, default 1).
fn first_seed() -> u64 {
    std::env::var("FIRST_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1)
}

#[test]
#[ignore = "long matrix: run with --release -- --ignored --nocapture"]
fn full_matrix() {
    let mut lines = Vec::new();
    // VARIATION=nominal or varied runs one half of the matrix
    let wanted = std::env::var("VARIATION").unwrap_or_default();
    let variations = [Variation::Nominal, Variation::Varied];
    for variation in variations.into_iter().filter(|v| wanted.is_empty() || format!("{v:?}").eq_ignore_ascii_case(&wanted)) {
        // CASES=a,b runs some cases only
        let cases = std::env::var("CASES").unwrap_or_default();
        for case in Case::ALL.into_iter().filter(|c| cases.is_empty() || cases.split(',').any(|n| n == c.name())) {
            let (mut exact, mut total) = (0, 0);
            let mut confusions = std::collections::BTreeMap::<String, usize>::new();
            for seed in first_seed()..first_seed() + seeds() {
                let clock = std::time::Instant::now();
                let (_, o) = run(case, seed, variation, 3);
                let seconds = clock.elapsed().as_secs_f64();
                let got = named(&o).join("+");
                let want = case.expected().join("+");
                total += 1;
                if got == want && o.summary.ambiguous.is_empty() {
                    exact += 1;
                }
                let key = if o.summary.ambiguous.is_empty() { got } else { format!("ambiguous {}", o.summary.ambiguous.join("/")) };
                *confusions.entry(if key.is_empty() { "none".into() } else { key }).or_default() += 1;
                eprintln!("{variation:?} {} seed {seed} ({seconds:.0} s): {}", case.name(), o.summary.verdict);
                // TABLE=1 prints every candidate's figures too
                if std::env::var("TABLE").is_ok_and(|s| s == "1") {
                    eprintln!("{}", table(&o));
                }
            }
            let line = format!("| {variation:?} | {} | {exact}/{total} | {confusions:?} |", case.name());
            eprintln!("{line}");
            lines.push(line);
        }
    }
    println!("| truth | hidden | named exactly | outcomes |\n|---|---|---|---|\n{}", lines.join("\n"));
}

/// Where the time of one run goes (docs/discrepancy.md, "Run time"):
/// `CASES=<case> VARIATION=nominal SEEDS=1 cargo test --release -p pneumo-identify --test independent profile_run -- --ignored --nocapture`
/// (first case and seed of the selection; three cycles as in the matrix).
#[test]
#[ignore = "study: run with --release -- --ignored --nocapture"]
fn profile_run() {
    let case = std::env::var("CASES").ok().and_then(|c| Case::ALL.into_iter().find(|k| k.name() == c)).unwrap_or(Case::Null);
    let variation = if std::env::var("VARIATION").is_ok_and(|v| v == "varied") { Variation::Varied } else { Variation::Nominal };
    let (s0, w0, _) = identify::problem::simulation_count();
    let l0 = identify::lsq::counts();
    let clock = std::time::Instant::now();
    let (t, o) = run(case, first_seed(), variation, 3);
    let l1 = identify::lsq::counts();
    let seconds = clock.elapsed().as_secs_f64();
    let (s1, w1, d1) = identify::problem::simulation_count();
    eprintln!("{}\n{}", t.description, table(&o));
    eprintln!(
        "{variation:?} {} seed {}: {seconds:.1} s wall, {} simulations of one experiment ({:.1} s simulated in all, {:.1} ms each on average, {:.1} s summed over threads), workflow evaluations {}",
        case.name(),
        first_seed(),
        s1 - s0,
        d1,
        1e3 * (w1 - w0) / (s1 - s0).max(1) as f64,
        w1 - w0,
        o.summary.evaluations
    );
    eprintln!(
        "least squares: {} runs, {} evaluations at start and trial points, {} for {} finite-difference Jacobians, {} Broyden updates",
        l1.runs - l0.runs,
        l1.trials - l0.trials,
        l1.columns - l0.columns,
        l1.jacobians - l0.jacobians,
        l1.updates - l0.updates
    );
    eprintln!("stages: {:?}", o.summary.timing);
    for c in &o.summary.candidates {
        eprintln!("  r{} {:<18} {:>6} simulations (of all experiments) {}", c.round, c.effect, c.evaluations, c.fit_message);
    }
}
