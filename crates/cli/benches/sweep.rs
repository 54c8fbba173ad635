//! Wall time of a typical study: the paper's Table 1 conductances (1.41,
//! 2.68, 13.2, 210 L/min/bar) × supply {4, 7} bar on the meter-out circuit,
//! 8 cases × 3 cycles, on 2 worker threads.
//!
//! pneumo-cli is a binary crate, so the benchmark times the release binary
//! itself (`pneumo sweep ... --jobs 2`, spawned with std::process::Command);
//! the figure includes process start-up, reading the netlist and writing the
//! CSV, i.e. what a user waits for. Run with
//! `cargo bench -p pneumo-cli --bench sweep`; criterion's median is in
//! target/criterion/sweep/table1_x2_jobs2/new/estimates.json.

use criterion::{criterion_group, criterion_main, Criterion};
use std::process::{Command, Stdio};
use std::time::Duration;

fn table1_sweep(c: &mut Criterion) {
    let exe = env!("CARGO_BIN_EXE_pneumo");
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/meter_out.json");
    let out = std::env::temp_dir().join(format!("pneumo-bench-sweep-{}.csv", std::process::id()));
    let out_arg = out.to_string_lossy().into_owned();
    let args = [
        "sweep",
        model,
        "--vary",
        "flow_control.C=1.41 L/min/bar,2.68 L/min/bar,13.2 L/min/bar,210 L/min/bar",
        "--vary",
        "supply.p=4 bar,7 bar",
        "--cycles",
        "3",
        "--jobs",
        "2",
        "--out",
        &out_arg,
    ];
    let mut group = c.benchmark_group("sweep");
    group.sample_size(10).measurement_time(Duration::from_secs(30)).warm_up_time(Duration::from_secs(3));
    group.bench_function("table1_x2_jobs2", |b| {
        b.iter(|| {
            let status = Command::new(exe).args(args).stdout(Stdio::null()).stderr(Stdio::null()).status();
            assert!(matches!(status, Ok(s) if s.success()), "pneumo sweep failed: {status:?}");
        })
    });
    group.finish();
    let _ = std::fs::remove_file(&out);
}

criterion_group!(benches, table1_sweep);
criterion_main!(benches);
