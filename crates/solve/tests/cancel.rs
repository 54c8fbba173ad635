//! Cancelling a run (`SimOptions::cancel`): a raised flag stops the run with
//! `SolveError::Cancelled` at the simulated time it had reached, from before
//! the first step or from another thread in the middle of a long run; a flag
//! that is never raised changes nothing; a flag set for a thread
//! (`settings::set_thread_cancel`) reaches the options made on that thread.

mod common;

use common::*;
use solve::{Cancel, SolveError};
use std::time::{Duration, Instant};

fn build(flat: &graph::FlatNetlist) -> (solve::Model, solve::SimOptions) {
    let circuit = graph::build(flat).expect("build");
    let opts = solve::options_from(&circuit.simulation).expect("settings");
    (solve::Model::new(circuit), opts)
}

#[test]
fn a_flag_raised_before_the_run_stops_it_at_the_start() {
    let flat = flat_from_model("meter_out.json", &[]);
    let (mut model, mut opts) = build(&flat);
    let cancel = Cancel::new();
    cancel.cancel();
    opts.cancel = Some(cancel);
    match solve::simulate(&mut model, &opts) {
        Err(SolveError::Cancelled { t }) => assert_eq!(t, 0.0),
        other => panic!("expected a cancelled run, got {:?}", other.map(|r| r.t_final)),
    }
}

#[test]
fn a_flag_raised_from_another_thread_stops_a_long_run_promptly() {
    // ten minutes of simulated cycling: minutes of wall time if not stopped
    let flat = flat_from_model("meter_out.json", &[]);
    let (mut model, mut opts) = build(&flat);
    opts.cycles = None;
    opts.t_end = 600.0;
    let cancel = Cancel::new();
    opts.cancel = Some(cancel.clone());
    let started = Instant::now();
    let outcome = std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(Duration::from_millis(300));
            cancel.cancel();
        });
        solve::simulate(&mut model, &opts)
    });
    let waited = started.elapsed();
    match outcome {
        Err(e @ SolveError::Cancelled { t }) => {
            assert!(t > 0.0 && t < 600.0, "stopped at t = {t}");
            assert!(e.to_string().starts_with("cancelled at t = "), "{e}");
        }
        other => panic!("expected a cancelled run, got {:?}", other.map(|r| r.t_final)),
    }
    assert!(waited < Duration::from_secs(10), "the run went on for {waited:?} after the flag was raised");
}

#[test]
fn a_flag_never_raised_changes_nothing() {
    let flat = flat_from_model("meter_out.json", &["simulation.cycles=1"]);
    let plain = run(&flat);
    let flagged = run_with(&flat, |o| o.cancel = Some(Cancel::new()));
    assert_eq!(plain.times, flagged.times);
    assert_eq!(plain.rows, flagged.rows);
    assert_eq!(plain.cycles.len(), 1);
    assert_eq!(plain.cycles[0].total, flagged.cycles[0].total);
}

#[test]
fn a_flag_set_for_the_thread_reaches_options_made_on_it_only() {
    let flat = flat_from_model("meter_out.json", &[]);
    let circuit = graph::build(&flat).expect("build");
    let cancel = Cancel::new();
    solve::settings::set_thread_cancel(Some(cancel.clone()));
    let here = solve::options_from(&circuit.simulation).expect("settings");
    let elsewhere = std::thread::scope(|s| s.spawn(|| solve::options_from(&circuit.simulation).expect("settings")).join().expect("thread"));
    solve::settings::set_thread_cancel(None);
    let after = solve::options_from(&circuit.simulation).expect("settings");
    assert_eq!(here.cancel, Some(cancel));
    assert_eq!(elsewhere.cancel, None);
    assert_eq!(after.cancel, None);
}
