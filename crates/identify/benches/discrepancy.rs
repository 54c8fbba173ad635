//! Benchmark of one discrepancy workflow run on the shipped example:
//! models/meter_out.json against models/examples/discrepancy (4 experiments
//! × 3 cycles at 1 kHz, hidden piston seal leak), full catalogue.
//!
//! `cargo bench -p pneumo-identify --bench discrepancy` (release profile).
//! Prints the wall time of each run (default 3 runs; `BENCH_RUNS=n`), the
//! number of simulations, the per-step timing and the verdict. The issue's
//! budget is 60 s wall on 2 cores.

use std::path::Path;

struct Fs;
impl graph::Loader for Fs {
    fn read(&self, p: &Path) -> Result<String, String> {
        std::fs::read_to_string(p).map_err(|e| e.to_string())
    }
}

fn main() -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let flat = graph::load(&Fs, &root.join("models/meter_out.json")).map_err(|e| e.to_string())?;
    let dir = root.join("models/examples/discrepancy");
    let text = std::fs::read_to_string(dir.join("experiments.json")).map_err(|e| e.to_string())?;
    let manifest = identify::manifest::parse(&text, "experiments.json").map_err(|e| e.to_string())?;
    let read = |name: &str| -> Result<(String, String), String> {
        let p = dir.join(name);
        std::fs::read_to_string(&p).map(|t| (t, p.display().to_string())).map_err(|e| e.to_string())
    };
    let mut resolved = identify::manifest::resolve(&manifest, &flat, &read)?;
    // LSQ_JACOBIAN=broyden: Broyden updates between finite-difference Jacobians (a study)
    if std::env::var("LSQ_JACOBIAN").is_ok_and(|s| s == "broyden") {
        resolved.options.fit.jacobian = identify::lsq::JacobianUpdate::BROYDEN;
    }
    let samples: usize = resolved.experiments.iter().map(|e| e.times.len()).sum();
    let runs: usize = std::env::var("BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    println!(
        "discrepancy workflow: {} experiments, {} samples, {} threads",
        resolved.experiments.len(),
        samples,
        rayon::current_num_threads()
    );
    let mut times = Vec::new();
    for run in 1..=runs {
        let t0 = std::time::Instant::now();
        let l0 = identify::lsq::counts();
        let o = identify::run(&flat, &resolved.experiments, &resolved.calibrate, &resolved.options).map_err(|e| e.to_string())?;
        let dt = t0.elapsed().as_secs_f64();
        let l1 = identify::lsq::counts();
        times.push(dt);
        println!("run {run}: {dt:.1} s wall, {} simulations, {:?}; {}", o.summary.evaluations, o.summary.timing, o.summary.verdict);
        println!(
            "  least squares: {} runs, {} evaluations at start and trial points, {} for {} finite-difference Jacobians, {} Broyden updates",
            l1.runs - l0.runs,
            l1.trials - l0.trials,
            l1.columns - l0.columns,
            l1.jacobians - l0.jacobians,
            l1.updates - l0.updates
        );
        for c in &o.summary.candidates {
            println!("  r{} {:<18} {:>5} simulations, dIC {:.1}, {:?}", c.round, c.effect, c.evaluations, c.delta_ic, c.params);
        }
    }
    times.sort_by(|a, b| a.total_cmp(b));
    println!("median {:.1} s, best {:.1} s", times[times.len() / 2], times[0]);
    Ok(())
}
