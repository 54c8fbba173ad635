//! How the cost of a run grows with the number of drives on one manifold:
//! wall time, steps, model evaluations and events of the circuit of
//! `benches/drives.rs` for the drive counts given on the command line.
//!
//! Run: `cargo run --release -p pneumo-solve --example drives_scaling -- [--in-step] [--t-end S] N...`
//! (default N = 32 64 128 256, staggered strokes, 6 s simulated). Prints one
//! line per N and the fitted exponent k of time ∝ N^k between the first and
//! the last N. Reported in docs/performance.md.

#[path = "../tests/common/drives.rs"]
mod drives;

fn main() {
    let mut staggered = true;
    let mut t_end = 6.0;
    let mut ns = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--in-step" => staggered = false,
            "--t-end" => t_end = args.next().and_then(|v| v.parse().ok()).expect("--t-end S"),
            n => ns.push(n.parse::<usize>().expect("a drive count")),
        }
    }
    if ns.is_empty() {
        ns = vec![32, 64, 128, 256];
    }
    println!("{} drives, {t_end} s simulated", if staggered { "staggered" } else { "in-step" });
    println!("| N | states | wall [s] | steps | rejected | evaluations | events | Jacobians |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut times = Vec::new();
    for &n in &ns {
        let circuit = graph::build(&drives::drives(n, staggered)).expect("the drives circuit builds");
        let mut opts = solve::options_from(&circuit.simulation).expect("settings");
        opts.sample_interval = 0.0;
        opts.t_end = t_end;
        let mut model = solve::Model::new(circuit);
        let start = std::time::Instant::now();
        let r = solve::simulate(&mut model, &opts).expect("simulates");
        let wall = start.elapsed().as_secs_f64();
        times.push(wall);
        println!(
            "| {n} | {} | {wall:.3} | {} | {} | {} | {} | {} |",
            model.n_states,
            r.stats.steps,
            r.stats.rejected,
            r.rhs_evaluations,
            r.events.len(),
            r.stats.jacobians
        );
    }
    if ns.len() > 1 {
        let (n0, n1) = (ns[0] as f64, ns[ns.len() - 1] as f64);
        let k = (times[times.len() - 1] / times[0]).ln() / (n1 / n0).ln();
        println!("k = {k:.2} between N = {} and N = {}", ns[0], ns[ns.len() - 1]);
    }
}
