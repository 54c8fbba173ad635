//! A user-declared effect (manifest `user_effects`) on data pneumo did not
//! make: the independent rig (`tests/truth`) with a hidden piston-seal leak
//! following ISO 6358 (b = 0.5), and the same rig with nothing hidden.
//!
//! The user writes the leak as a `conductance` between the two chambers with
//! its C free — the physics of the built-in `piston_seal_leak` at its
//! orifice law, which is left out of the pool here (two effects with the
//! same physics would tie, and the verdict would rightly be "ambiguous").
//! Every other built-in is tried alongside it, so it has to win the same
//! screen, fit, held-out and floor tests a built-in wins.
//!
//! Stated up front: the fitted C within ±30 % of the truth (the tolerance of
//! tests/independent.rs: the rig's exact check valve, missing laminar
//! region and exact stick–slip bias the estimate).

mod truth;

use identify::effects::user::{UserEffect, UserEffectSpec};
use identify::report::Outcome;
use truth::{Case, Variation};

/// The workflow on one case with the declared effect; `builtins` = the
/// built-in effects tried beside it.
fn run(case: Case, seed: u64, builtins: Vec<String>) -> (truth::Truth, Outcome) {
    let t = truth::draw(case, seed, Variation::Nominal);
    let records = truth::records(&t, seed, 2).expect("the rig simulates");
    let experiments = truth::experiments(&records).expect("the records are experiments");
    let model = truth::model(case);
    let spec: UserEffectSpec = serde_json::from_str(truth::SEAL_ORIFICE).expect("the declaration parses");
    let effect = UserEffect::declare(&spec, &model).expect("the declaration is valid");
    let signals: Vec<String> = experiments[0].channels.iter().map(|c| c.signal.clone()).collect();
    effect.check_nested(&model, 1.0, &signals).expect("the declared effect nests");
    let options = identify::Options { report: false, effects: Some(builtins), user_effects: vec![effect], ..identify::Options::default() };
    let calibrate = identify::params::default_calibration(&model);
    let o = identify::run(&model, &experiments, &calibrate, &options).expect("the workflow runs");
    (t, o)
}

fn named(o: &Outcome) -> Vec<String> {
    o.summary.selected.iter().map(|s| s.effect.clone()).collect()
}

fn table(o: &Outcome) -> String {
    let mut out = format!("verdict: {}\n", o.summary.verdict);
    for c in &o.summary.candidates {
        out +=
            &format!("  r{} {:<18} dIC {:>10.1} {} {:?} {}\n", c.round, c.effect, c.delta_ic, c.accepted, c.params, c.reasons.join("; "));
    }
    out
}

/// Named alone, with C within ±30 % of the truth, beside `builtins`.
fn leak_case(builtins: Vec<String>) {
    // seed 4: the rig's leak is an ISO 6358 orifice with b = 0.5 (truth::draw_effects)
    let (t, o) = run(Case::Leak, 4, builtins);
    assert_eq!(named(&o), vec!["seal_orifice"], "{}\n{}", t.description, table(&o));
    let Some(rig::LeakLaw::Iso(r)) = t.effects.seal_leak else { panic!("seed 4 draws an ISO leak: {}", t.description) };
    let fitted = o.summary.selected[0].params["seal.C"];
    let lpm = 1e-3 / 60.0 / 1e5;
    eprintln!("seal.C fitted {:.4} L/min/bar, truth {:.4} L/min/bar", fitted / lpm, r.c / lpm);
    assert!((fitted - r.c).abs() <= 0.3 * r.c, "C {:.3} L/min/bar, truth {:.3} L/min/bar\n{}", fitted / lpm, r.c / lpm, table(&o));
    // reported like a built-in: a candidate with an estimate in the declared unit
    let c = o.summary.candidates.iter().find(|c| c.effect == "seal_orifice" && c.accepted).expect("an accepted candidate");
    assert_eq!(c.estimates[0].unit, "L/min/bar");
}

/// CI: beside the two built-ins that most often compete with a leak.
#[test]
fn a_declared_seal_leak_is_named_and_sized_on_rig_data() {
    leak_case(vec!["dead_volume".into(), "valve_delay".into()]);
}

/// Beside every other built-in (about 2 minutes on a loaded 2-core machine).
#[test]
#[ignore = "long: run with --release -- --ignored --nocapture"]
fn a_declared_seal_leak_wins_against_the_whole_catalogue() {
    leak_case(identify::effects::names().into_iter().filter(|n| n != "piston_seal_leak").collect());
}

#[test]
fn a_declared_seal_leak_is_not_named_on_null_data() {
    let (t, o) = run(Case::Null, 1, vec![]);
    assert!(named(&o).is_empty() && o.summary.ambiguous.is_empty(), "{}\nfalse alarm:\n{}", t.description, table(&o));
    assert!(o.summary.candidates.iter().any(|c| c.effect == "seal_orifice"), "the declared effect was tried\n{}", table(&o));
}
