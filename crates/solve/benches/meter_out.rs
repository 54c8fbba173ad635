//! Benchmark: 20 meter-out cycles (switch 2, 4 bar) from models/meter_out.json,
//! at the model's own tolerances (rtol = atol = 1e-4, max_step 200 ms) and at
//! rtol = atol = 1e-3, the loosest setting whose periodic cycle time is within
//! 0.1 % of the converged one (docs/performance.md, where the whole-process
//! comparison with the C + CVODE anchor is made by `scripts/vs_cvode.py`).
//!
//! The model is parsed and built once per iteration batch outside the timed
//! region; each iteration simulates from the rest state through 20 cycles
//! with no trace sampled, and criterion reports time per simulated cycle.
//!
//! A second group times one simulation as `pneumo discrepancy`'s fits run
//! it: 3 cycles at the fits' settings (rtol 1e-6, atol 1e-5, max_step
//! 50 ms), a row every 1 ms, recording every column or only the three
//! measured channels (`SimOptions::record_only`, the same numbers).
//! Run: `cargo bench -p pneumo-solve --bench meter_out`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use std::path::{Path, PathBuf};

struct Fs;
impl graph::Loader for Fs {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

fn model_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/meter_out.json")
}

const CYCLES: u64 = 20;

/// The model with its own tolerances, or with rtol = atol = `rtol`.
fn build(rtol: Option<f64>) -> (solve::Model, solve::SimOptions) {
    let mut flat = graph::load(&Fs, &model_path()).expect("meter_out.json loads");
    if let Some(rtol) = rtol {
        graph::apply_set(&mut flat, &format!("simulation.rtol={rtol}")).expect("rtol");
        graph::apply_set(&mut flat, &format!("simulation.atol={rtol}")).expect("atol");
    }
    let circuit = graph::build(&flat).expect("meter_out.json builds");
    let mut opts = solve::options_from(&circuit.simulation).expect("settings");
    opts.cycles = Some(CYCLES);
    opts.sample_interval = 0.0;
    (solve::Model::new(circuit), opts)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("meter_out");
    group.sample_size(30);
    group.throughput(Throughput::Elements(CYCLES));
    for (name, rtol) in [("defaults", None), ("rtol_1e-3", Some(1e-3))] {
        group.bench_function(format!("twenty_cycles_{name}"), |b| {
            b.iter_batched(
                || build(rtol),
                |(mut model, opts)| {
                    let r = solve::simulate(&mut model, &opts).expect("simulates");
                    assert_eq!(r.cycles.len() as u64, CYCLES);
                    r.cycles[CYCLES as usize - 1].total
                },
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

/// One fit simulation (see the module header), recording `record_only`.
fn fit_run(record_only: Option<Vec<String>>) -> (solve::Model, solve::SimOptions) {
    let flat = graph::load(&Fs, &model_path()).expect("meter_out.json loads");
    let circuit = graph::build(&flat).expect("meter_out.json builds");
    let mut opts = solve::options_from(&circuit.simulation).expect("settings");
    opts.cycles = Some(3);
    opts.rtol = 1e-6;
    opts.atol = 1e-5;
    opts.max_step = opts.max_step.min(0.05);
    opts.sample_interval = 1e-3;
    opts.record_only = record_only;
    (solve::Model::new(circuit), opts)
}

fn bench_fit_run(c: &mut Criterion) {
    let mut group = c.benchmark_group("fit_run");
    group.sample_size(30);
    let channels = || Some(vec!["head.p".to_string(), "rod.p".to_string(), "piston.x".to_string()]);
    for (name, record_only) in [("every_column", None), ("three_channels", channels())] {
        group.bench_function(name, |b| {
            b.iter_batched(
                || fit_run(record_only.clone()),
                |(mut model, opts)| solve::simulate(&mut model, &opts).expect("simulates").rows.len(),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, bench, bench_fit_run);
criterion_main!(benches);
