//! Meter-out, 20 cycles (switch 2, 4 bar, the model's own tolerances), once
//! per way of forming the Jacobian: model evaluations, steps, Jacobians,
//! median wall time of a few runs and the last cycle time. The figures in
//! docs/performance.md ("Exact Jacobians") come from
//! `cargo run --release -p pneumo-solve --example jacobian_methods`; an
//! argument (`exact`, `grouped` or `plain`) runs that method alone, and a
//! second the number of rounds (7 by default; the best and the median are
//! printed), e.g. to profile one method under `perf record`.

use solve::JacobianMethod;
use std::path::{Path, PathBuf};
use std::time::Instant;

struct Fs;
impl graph::Loader for Fs {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

fn model_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/meter_out.json")
}

fn main() {
    let flat = graph::load(&Fs, &model_path()).expect("meter_out.json loads");
    let args: Vec<String> = std::env::args().skip(1).collect();
    let methods: Vec<JacobianMethod> = match args.first().map(String::as_str) {
        None | Some("all") => vec![JacobianMethod::Exact, JacobianMethod::GroupedDifferences, JacobianMethod::PlainDifferences],
        Some("exact") => vec![JacobianMethod::Exact],
        Some("grouped") => vec![JacobianMethod::GroupedDifferences],
        Some("plain") => vec![JacobianMethod::PlainDifferences],
        Some(other) => {
            eprintln!("unknown method {other:?}: exact, grouped, plain or all");
            std::process::exit(2)
        }
    };
    let rounds: usize = args.get(1).and_then(|r| r.parse().ok()).unwrap_or(7).max(1);
    println!(
        "| Jacobian | evaluations | per Jacobian | steps | Jacobians | best wall | median wall | last cycle | blocks by differences |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for method in methods {
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..rounds {
            let circuit = graph::build(&flat).expect("meter_out.json builds");
            let mut opts = solve::options_from(&circuit.simulation).expect("settings");
            opts.cycles = Some(20);
            opts.sample_interval = 0.0;
            opts.jacobian = method;
            let mut model = solve::Model::new(circuit);
            let start = Instant::now();
            let result = solve::simulate(&mut model, &opts).expect("the run");
            times.push(start.elapsed().as_secs_f64());
            last = Some(result);
        }
        times.sort_by(f64::total_cmp);
        let r = last.expect("at least one round");
        println!(
            "| {} ({}) | {} | {} | {} | {} | {:.1} ms | {:.1} ms | {:.6} s | {:?} |",
            r.jacobian,
            r.linear_algebra,
            r.rhs_evaluations,
            r.evaluations_per_jacobian,
            r.stats.steps,
            r.stats.jacobians,
            1e3 * times[0],
            1e3 * times[rounds / 2],
            r.cycles.last().map_or(f64::NAN, |c| c.total),
            r.finite_difference_blocks
        );
    }
}
