//! Benchmark: one meter-out cycle (switch 2, 4 bar) from models/meter_out.json.
//!
//! The model is parsed and built once per iteration batch outside the timed
//! region; each iteration simulates from the initial state through the first
//! two cycles and reports time per simulated cycle via criterion's throughput.
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

fn build(rtol: f64) -> (solve::Model, solve::SimOptions) {
    let mut flat = graph::load(&Fs, &model_path()).expect("meter_out.json loads");
    graph::apply_set(&mut flat, &format!("simulation.rtol={rtol}")).expect("rtol");
    graph::apply_set(&mut flat, &format!("simulation.atol={rtol}")).expect("atol");
    let circuit = graph::build(&flat).expect("meter_out.json builds");
    let mut opts = solve::options_from(&circuit.simulation).expect("settings");
    opts.cycles = Some(2);
    opts.sample_interval = 0.0;
    (solve::Model::new(circuit), opts)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("meter_out");
    group.sample_size(30);
    group.throughput(Throughput::Elements(2));
    for rtol in [1e-4, 1e-6] {
        group.bench_function(format!("two_cycles_rtol_{rtol:e}"), |b| {
            b.iter_batched(
                || build(rtol),
                |(mut model, opts)| {
                    let r = solve::simulate(&mut model, &opts).expect("simulates");
                    assert_eq!(r.cycles.len(), 2);
                    r.cycles[1].total
                },
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
