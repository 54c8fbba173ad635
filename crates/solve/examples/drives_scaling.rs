//! How the cost of a run grows with the number of drives on one manifold:
//! wall time and the integrator's work (steps, rejected steps, model and
//! right-hand-side evaluations, Jacobians, LU factorisations, events, event
//! instants, root-function evaluations) of the circuit of `benches/drives.rs`
//! for the drive counts given on the command line.
//!
//! Run: `cargo run --release -p pneumo-solve --example drives_scaling -- [--in-step | --distinct] [--t-end S] [--repeat R] N...`
//! (default N = 32 64 128 256, staggered strokes (eight lengths, as in the
//! benchmark), 6 s simulated, best of R = 1 runs; `--in-step`: all strokes
//! alike; `--distinct`: every drive its own stroke; `--phases`: time one
//! evaluation and one Jacobian instead of runs). Prints one line per N, the fitted exponent k of time ∝ N^k
//! between the first and the last N and per doubling, and the same for the
//! time per unit of work (one model evaluation of one drive). Reported in
//! docs/performance.md.

#[path = "../tests/common/drives.rs"]
mod drives;

/// The figures of one run.
struct Run {
    n: usize,
    wall: f64,
    cpu: f64,
    evaluations: u64,
}

fn main() {
    let mut staggered = true;
    let mut t_end = 6.0;
    let mut repeat = 1usize;
    let mut phases = false;
    let mut distinct = false;
    let mut ns = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--in-step" => staggered = false,
            "--phases" => phases = true,
            "--distinct" => distinct = true,
            "--t-end" => t_end = args.next().and_then(|v| v.parse().ok()).expect("--t-end S"),
            "--repeat" => repeat = args.next().and_then(|v| v.parse().ok()).expect("--repeat R"),
            n => ns.push(n.parse::<usize>().expect("a drive count")),
        }
    }
    if ns.is_empty() {
        ns = vec![32, 64, 128, 256];
    }
    if phases {
        for &n in &ns {
            time_phases(n, staggered);
        }
        return;
    }
    let kind = match (distinct, staggered) {
        (true, _) => "distinct-stroke",
        (false, true) => "staggered",
        (false, false) => "in-step",
    };
    println!("{kind} drives, {t_end} s simulated, best of {repeat}");
    println!("| N | states | wall [s] | CPU [s] | steps | rejected | model evaluations | of them f | Jacobians | LU | events | event instants | root evaluations | CPU µs per evaluation and drive |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut runs = Vec::new();
    for &n in &ns {
        let netlist = if distinct {
            // every drive its own stroke, 310 … 450 mm: no two switch together
            drives::drives_with_strokes(n, |i| 310.0 + 140.0 * i as f64 / n as f64)
        } else {
            drives::drives(n, staggered)
        };
        let circuit = graph::build(&netlist).expect("the drives circuit builds");
        let mut opts = solve::options_from(&circuit.simulation).expect("settings");
        opts.sample_interval = 0.0;
        opts.t_end = t_end;
        let (mut best, mut best_cpu) = (f64::INFINITY, f64::INFINITY);
        let mut last = None;
        for _ in 0..repeat {
            let mut model = solve::Model::new(circuit.clone());
            let (start, cpu_start) = (std::time::Instant::now(), cpu_seconds());
            let r = solve::simulate(&mut model, &opts).expect("simulates");
            best = best.min(start.elapsed().as_secs_f64());
            best_cpu = best_cpu.min(cpu_seconds() - cpu_start);
            last = Some((model, r));
        }
        let (model, r) = last.expect("at least one run");
        let mut instants: Vec<f64> = r.events.iter().map(|e| e.t).collect();
        instants.dedup();
        println!(
            "| {n} | {} | {best:.3} | {best_cpu:.3} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |",
            model.n_states,
            r.stats.steps,
            r.stats.rejected,
            r.rhs_evaluations,
            r.stats.rhs_evals,
            r.stats.jacobians,
            r.stats.lu,
            r.events.len(),
            instants.len(),
            model.root_evaluations,
            best_cpu / (r.rhs_evaluations as f64 * n as f64) * 1e6,
        );
        runs.push(Run { n, wall: best, cpu: best_cpu, evaluations: r.rhs_evaluations });
    }
    if runs.len() > 1 {
        // exponent of time ∝ N^k: of the whole run (wall and CPU time) and of one model evaluation (CPU)
        let k = |a: &Run, b: &Run, cost: &dyn Fn(&Run) -> f64| (cost(b) / cost(a)).ln() / (b.n as f64 / a.n as f64).ln();
        let wall = |r: &Run| r.wall;
        let cpu = |r: &Run| r.cpu;
        let per_evaluation = |r: &Run| r.cpu / r.evaluations as f64;
        let line = |a: &Run, b: &Run| {
            format!(
                "k = {:.2} (wall), {:.2} (CPU), {:.2} (CPU per model evaluation)",
                k(a, b, &wall),
                k(a, b, &cpu),
                k(a, b, &per_evaluation)
            )
        };
        let (first, last) = (&runs[0], &runs[runs.len() - 1]);
        println!("{} between N = {} and N = {}", line(first, last), first.n, last.n);
        for w in runs.windows(2) {
            println!("  {} → {}: {}", w[0].n, w[1].n, line(&w[0], &w[1]));
        }
    }
}

/// CPU time of this thread so far [s] (from /proc/thread-self/schedstat: the
/// time it ran, not the time it waited for a core on a loaded machine); NaN
/// where that file does not exist.
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|ns| ns.parse::<f64>().ok()))
        .map_or(f64::NAN, |ns| ns * 1e-9)
}

/// Time one model evaluation and one Jacobian (grouped differences) of N
/// drives at their rest state, each repeated for about 0.3 s, and print the
/// time per drive: what a step costs, apart from the linear algebra.
fn time_phases(n: usize, staggered: bool) {
    let circuit = graph::build(&drives::drives(n, staggered)).expect("the drives circuit builds");
    let mut model = solve::Model::new(circuit);
    solve::rest::apply(&mut model).expect("rest state");
    let y = model.initial_state();
    let mut dy = vec![0.0; model.dim()];
    let structure = solve::jacobian::Structure::new(&model).expect("structure");
    let mut work = solve::jacobian::Workspace::default();
    let deltas: Vec<f64> = y.iter().map(|v| 1e-7 * v.abs().max(1e-3)).collect();
    let mut values = vec![0.0; structure.pattern().nnz()];
    let per = |what: &str, f: &mut dyn FnMut()| {
        f();
        let start = std::time::Instant::now();
        let mut reps = 0u32;
        while start.elapsed().as_secs_f64() < 0.3 {
            f();
            reps += 1;
        }
        let each = start.elapsed().as_secs_f64() / f64::from(reps);
        println!("N = {n:4}: {what:>10} {:9.1} µs, {:6.3} µs per drive ({} repetitions)", each * 1e6, each * 1e6 / n as f64, reps + 1);
    };
    per("evaluation", &mut || model.eval(0.0, &y, Some(&mut dy), None).expect("evaluates"));
    per("Jacobian", &mut || structure.fill(&mut model, &mut work, 0.0, &y, &deltas, &mut values).expect("fills"));
    // bit pattern of the grouped-difference Jacobian (to check that a change of the code leaves it alone)
    let bits = values.iter().fold(0u64, |h, v| h.rotate_left(7) ^ v.to_bits());
    println!("N = {n:4}: Jacobian bits {bits:016x}");
    let mut exact = solve::exact::Exact::new(&model, structure.pattern().clone());
    per("exact", &mut || exact.fill(&mut model, 0.0, &y, &mut values).expect("fills"));
}
