//! The Jacobian from the circuit's structure (`solve::jacobian`) against
//! plain one-column-at-a-time finite differences, and whole runs with and
//! without it.
//!
//! The structured Jacobian perturbs several states at once (one column group
//! per model evaluation) and reads each block's share back from the rows
//! that state can reach. If the dependency sets missed a path (a state that
//! moves a junction pressure two blocks away, a signal that feeds a valve),
//! an entry would be dropped or credited to the wrong column; comparing every
//! entry with the plain difference quotient, taken with the same increments,
//! catches both. Entries outside the declared pattern must be zero in the
//! plain quotient too (the pattern is a superset of the true structure).

mod common;

use common::*;
use serde_json::{json, Value};
use solve::jacobian::{Structure, Workspace};
use solve::{Model, SimOptions};

/// `n` meter-out drives (5/2 valve, speed-control valve, cylinder, cycler)
/// on one supply line and manifold: the circuit of docs/performance.md's
/// scaling study. Each drive has its own cycler with a different stroke, so
/// that the drives fall out of step.
fn drives(n: usize) -> graph::FlatNetlist {
    let cylinder = models_dir().join("lib/cylinder.json");
    let mut components = vec![
        json!({"id": "supply", "type": "pressure_source", "params": {"p": "6 bar", "T": "292 K"}}),
        json!({"id": "line", "type": "conductance", "params": {"C": "2000 L/min/bar", "b": 0.3}}),
        json!({"id": "manifold", "type": "chamber", "params": {"dead_volume": "2 L", "T_wall": "292 K"}}),
        json!({"id": "exhaust", "type": "atmosphere", "params": {"p": "0.98 bar", "T": "292 K"}}),
    ];
    let mut connections = vec![json!(["supply.port", "line.a"]), json!(["line.b", "manifold.port"])];
    for i in 0..n {
        let d = format!("d{i}");
        let stroke = format!("{} mm", 450 - 20 * i);
        components.extend([
            json!({"id": format!("{d}_dcv"), "type": "valve_5_2", "params": {"C": "490 L/min/bar", "b": 0.3}}),
            json!({"id": format!("{d}_fc"), "type": "speed_control_valve",
                   "params": {"C": "13.2 L/min/bar", "b": 0.3, "check_C": "490 L/min/bar", "check_b": 0.3}}),
            json!({"id": format!("{d}_cyl"), "type": "subsystem", "file": cylinder.to_str().unwrap()}),
            json!({"id": format!("{d}_ctl"), "type": "cycler", "params": {"stroke": stroke}}),
        ]);
        connections.extend([
            json!(["manifold.port", format!("{d}_dcv.P")]),
            json!([format!("{d}_dcv.A"), format!("{d}_cyl.head_port")]),
            json!([format!("{d}_dcv.B"), format!("{d}_fc.a")]),
            json!([format!("{d}_fc.b"), format!("{d}_cyl.rod_port")]),
            json!([format!("{d}_dcv.EA"), "exhaust.port"]),
            json!([format!("{d}_dcv.EB"), "exhaust.port"]),
            json!({"from": format!("{d}_cyl.x"), "to": format!("{d}_ctl.x")}),
            json!({"from": format!("{d}_ctl.command"), "to": format!("{d}_dcv.command")}),
        ]);
    }
    let net: Value = json!({
        "name": format!("drives_{n}"), "components": components, "connections": connections,
        "simulation": {"t_end": "3 s", "rtol": 1e-4, "atol": 1e-4, "max_step": "250 ms", "initial": "rest"}
    });
    let dir = std::env::temp_dir().join(format!("pneumo-jacobian-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("drives.json");
    std::fs::write(&file, serde_json::to_string_pretty(&net).unwrap()).unwrap();
    let flat = graph::load(&FsLoader, &file).unwrap_or_else(|e| panic!("load: {e}"));
    let _ = std::fs::remove_dir_all(&dir);
    flat
}

fn model_of(flat: &graph::FlatNetlist) -> (Model, SimOptions) {
    let circuit = graph::build(flat).unwrap_or_else(|e| panic!("build: {e}"));
    let opts = solve::options_from(&circuit.simulation).unwrap_or_else(|e| panic!("settings: {e}"));
    (Model::new(circuit), opts)
}

/// Models as runs of a few lengths leave them (pistons at stops and in
/// mid-stroke, valves switched either way, friction modes as they are),
/// with the state each run ended in.
fn visited(flat: &graph::FlatNetlist) -> Vec<(Model, Vec<f64>)> {
    [0.35, 0.9, 1.6, 2.4]
        .iter()
        .map(|&t_end| {
            let (mut model, mut opts) = model_of(flat);
            opts.t_end = t_end;
            let mut last = Vec::new();
            solve::simulate_observed(&mut model, &opts, &mut |c| last = c.y.to_vec())
                .unwrap_or_else(|e| panic!("simulate to {t_end}: {e}"));
            (model, last)
        })
        .collect()
}

/// Compare every structured entry with the plain quotient at state `y`.
fn compare(model: &mut Model, y: &[f64], label: &str) -> usize {
    let structure = Structure::new(model).expect("a circuit with states has a structure");
    let ns = model.n_states;
    let n = model.dim();
    assert_eq!(y.len(), n);
    let t = 0.1;
    // increments as an integrator would take them: relative, with a floor
    let deltas: Vec<f64> = y[..ns].iter().map(|v| 1e-7 * v.abs().max(1e-3)).collect();
    let pattern = structure.pattern();
    assert_eq!((pattern.n_rows(), pattern.n_columns()), (n, ns), "{label}: pattern shape");
    let mut values = vec![0.0; pattern.nnz()];
    let mut work = Workspace::default();
    structure.fill(model, &mut work, t, y, &deltas, &mut values).unwrap_or_else(|e| panic!("{label}: fill: {e}"));

    // plain differences, one column at a time, with the same increments
    let mut f0 = vec![0.0; n];
    model.eval_detached(t, y, Some(&mut f0), None).unwrap();
    let mut checked = 0;
    for j in 0..ns {
        let mut yp = y.to_vec();
        yp[j] += deltas[j];
        let mut f1 = vec![0.0; n];
        let sign = if model.eval_detached(t, &yp, Some(&mut f1), None).is_ok() {
            1.0
        } else {
            yp[j] = y[j] - deltas[j];
            model.eval_detached(t, &yp, Some(&mut f1), None).unwrap();
            -1.0
        };
        let plain: Vec<f64> = (0..n).map(|i| sign * (f1[i] - f0[i]) / deltas[j]).collect();
        let scale = plain.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        let range = pattern.column_range(j);
        let rows = &pattern.rows()[range.clone()];
        for (i, p) in plain.iter().enumerate() {
            let structured = rows.iter().position(|&r| r == i).map_or(0.0, |k| values[range.start + k]);
            // the junction pressures are solved iteratively to a relative
            // tolerance far below this; a dropped or misplaced entry is O(1)
            let err = (structured - p).abs() / scale;
            assert!(
                err < 1e-5,
                "{label}: ∂f{i}/∂y{j}: structured {structured:e}, plain {p:e} (column scale {scale:e}, in pattern: {})",
                rows.contains(&i)
            );
            checked += 1;
        }
    }
    checked
}

#[test]
fn structured_jacobian_equals_plain_differences_on_the_meter_out_circuit() {
    let flat = flat_from_model("meter_out.json", &[]);
    let mut total = 0;
    for (k, (mut model, y)) in visited(&flat).into_iter().enumerate() {
        total += compare(&mut model, &y, &format!("meter_out state {k}"));
    }
    assert!(total > 0);
}

#[test]
fn structured_jacobian_equals_plain_differences_on_four_drives() {
    let flat = drives(4);
    let (model, _) = model_of(&flat);
    let s = Structure::new(&model).unwrap();
    // four independent drives share one manifold: far fewer groups than columns
    assert!(
        2 * s.evaluations_per_jacobian() <= model.n_states,
        "{} evaluations for {} states",
        s.evaluations_per_jacobian(),
        model.n_states
    );
    for (k, (mut model, y)) in visited(&flat).into_iter().enumerate() {
        compare(&mut model, &y, &format!("drives(4) state {k}"));
    }
}

/// Columns per group do not grow with the number of drives: the evaluations
/// per Jacobian stay bounded while the states grow linearly.
#[test]
fn evaluations_per_jacobian_do_not_grow_with_the_circuit() {
    let small = model_of(&drives(2)).0;
    let large = model_of(&drives(12)).0;
    let (es, el) = (Structure::new(&small).unwrap().evaluations_per_jacobian(), Structure::new(&large).unwrap().evaluations_per_jacobian());
    assert!(large.n_states >= 5 * small.n_states, "{} vs {}", large.n_states, small.n_states);
    assert!(el <= es + 2, "evaluations per Jacobian grew from {es} to {el}");
}

/// The same run with the structured Jacobian and with plain differences:
/// both are approximations of the same Jacobian, so the cycle times agree to
/// the integration tolerance, and the structured run is the one that uses a
/// structured (or, when large, sparse) linear algebra.
#[test]
fn runs_with_and_without_the_structure_agree() {
    for (label, flat, expect) in [("drives(3)", drives(3), "structured"), ("drives(12)", drives(12), "sparse")] {
        let (mut m1, opts) = model_of(&flat);
        let with = solve::simulate(&mut m1, &opts).unwrap();
        let (mut m2, mut plain_opts) = model_of(&flat);
        plain_opts.structured_jacobian = false;
        let without = solve::simulate(&mut m2, &plain_opts).unwrap();
        assert_eq!(without.linear_algebra, "dense", "{label}");
        assert_eq!(with.linear_algebra, expect, "{label}");
        assert!(!with.cycles.is_empty(), "{label}: no cycle completed");
        assert_eq!(with.cycles.len(), without.cycles.len(), "{label}: cycles");
        for (a, b) in with.cycles.iter().zip(&without.cycles) {
            let rel = (a.total - b.total).abs() / b.total;
            assert!(rel < 1e-3, "{label}: cycle {} s vs {} s", a.total, b.total);
        }
        assert!(
            with.rhs_evaluations < without.rhs_evaluations,
            "{label}: {} vs {} evaluations",
            with.rhs_evaluations,
            without.rhs_evaluations
        );
    }
}

/// Sampling the outputs evaluates the model between steps; that must leave
/// no trace in the run (the junction warm starts are restored), so a run
/// sampled every millisecond, one sampled every 50 ms and one not sampled
/// at all take identical steps.
#[test]
fn sampling_does_not_change_the_run() {
    let flat = flat_from_model("meter_out.json", &["simulation.cycles=2"]);
    let runs: Vec<_> = [1e-3, 5e-2, 0.0]
        .iter()
        .map(|&dt| {
            let (mut m, mut opts) = model_of(&flat);
            opts.sample_interval = dt;
            solve::simulate(&mut m, &opts).unwrap()
        })
        .collect();
    for r in &runs[1..] {
        assert_eq!(r.stats.steps, runs[0].stats.steps);
        assert_eq!(r.rhs_evaluations, runs[0].rhs_evaluations);
        let totals = |x: &solve::SimResult| x.cycles.iter().map(|c| c.total).collect::<Vec<_>>();
        assert_eq!(totals(r), totals(&runs[0]));
    }
}
