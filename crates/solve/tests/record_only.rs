//! Recording only some columns (`SimOptions::record_only`), as the fits of
//! `pneumo discrepancy` do: on every shipped model, a run that records only
//! the block signals gives the same times and the same signal values, bit
//! for bit, as a run that records every column — whether the model takes
//! the short path (no evaluation per output row) or records in full; a
//! block output among the names records in full; a name the model does not
//! have is refused, quoted safely.

mod common;

use common::{flat_from_model, run_with};
use solve::SimOptions;

/// At most 3 s of each model (its own settings otherwise).
fn short(o: &mut SimOptions) {
    o.t_end = o.t_end.min(3.0);
}

#[test]
fn recording_only_signals_changes_no_number_on_any_shipped_model() {
    let mut short_path = Vec::new();
    let mut files: Vec<String> = std::fs::read_dir(common::models_dir())
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".json"))
        .collect();
    files.sort();
    assert!(files.len() >= 10, "shipped models: {files:?}");
    for file in &files {
        let flat = flat_from_model(file, &[]);
        let signals = solve::Model::new(graph::build(&flat).unwrap()).signal_columns();
        let names: Vec<String> = signals.iter().map(|(n, ..)| n.clone()).collect();
        let full = run_with(&flat, short);
        let part = run_with(&flat, |o| {
            short(o);
            o.record_only = Some(names.clone());
        });
        assert_eq!(full.times, part.times, "{file}: output times");
        assert_eq!(full.t_final.to_bits(), part.t_final.to_bits(), "{file}: end time");
        assert_eq!(full.events.len(), part.events.len(), "{file}: events");
        for (name, column, _) in &signals {
            for (i, (a, b)) in full.rows.iter().zip(&part.rows).enumerate() {
                assert_eq!(a[*column].map(f64::to_bits), b[*column].map(f64::to_bits), "{file}: {name} at t = {} s", full.times[i]);
            }
        }
        // the short path leaves the block outputs (a chamber's n, a piston's a) empty
        let others: Vec<usize> = (0..full.columns.len()).filter(|c| !signals.iter().any(|s| s.1 == *c)).collect();
        assert!(!others.is_empty(), "{file} has block outputs");
        if part.rows.iter().all(|r| others.iter().all(|&c| r[c].is_none())) {
            short_path.push(file.as_str());
        } else {
            assert_eq!(full.rows, part.rows, "{file}: a full recording is every column");
        }
    }
    // the fits' circuits take the short path
    for file in ["meter_out.json", "meter_in.json", "tank_discharge.json"] {
        assert!(short_path.contains(&file), "{file} should record its signals alone (short path: {short_path:?})");
    }
    // and both paths are checked: a model with junctions that a sensor or a
    // tube's sweep reads records in full
    assert!(short_path.len() < files.len(), "every model took the short path: {short_path:?}");
}

#[test]
fn a_block_output_among_the_names_records_every_column() {
    let flat = flat_from_model("meter_out.json", &[]);
    let full = run_with(&flat, short);
    let part = run_with(&flat, |o| {
        short(o);
        o.record_only = Some(vec!["head.p".into(), "head.n".into()]);
    });
    assert_eq!(full.times, part.times);
    assert_eq!(full.rows, part.rows);
    assert!(part.series("head.n").is_some_and(|s| !s.is_empty()));
}

#[test]
fn a_name_the_model_does_not_have_is_refused_and_quoted_safely() {
    let flat = flat_from_model("meter_out.json", &[]);
    let circuit = graph::build(&flat).unwrap();
    let mut opts = solve::options_from(&circuit.simulation).unwrap();
    opts.record_only = Some(vec!["head.p".into(), "head.\u{1b}[31mq".into()]);
    let err = solve::simulate(&mut solve::Model::new(circuit), &opts).unwrap_err().to_string();
    assert!(err.contains("record_only") && err.contains(r"head.\u{1b}[31mq"), "{err}");
    assert!(!err.contains('\u{1b}'), "{err}");
}
