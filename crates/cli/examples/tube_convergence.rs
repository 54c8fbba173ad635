//! Convergence of the lumped `tube` with its number of segments N, against
//! the step response of a transmission line (docs/blocks.md, "Tube").
//!
//! A 5 m line, inner diameter 6 mm, closed at its far end (a 0.01 cm³
//! end volume), initially at 1 bar and 20 °C, is connected at t = 0 to a
//! reservoir at 1.1 bar. Walls adiabatic (the wave passes in milliseconds).
//!
//! 1. A line at 0.1 of air's viscosity, against the exact solution of the
//!    lossless linear wave equation at the closed end, a square wave — p₀
//!    until the wave arrives at L/c, then p₀ + 2Δp until 3L/c, then p₀
//!    until 5L/c — with c = √(γRT) = 343.2 m/s. Reported: the arrival
//!    (first crossing of p₀ + Δp), the return (next crossing downwards) and
//!    the mean level of the plateau between 1.5 L/c and 2.5 L/c, against
//!    L/c, 3L/c and 2Δp. The flow is turbulent (Re ≈ 10⁵), where Blasius
//!    friction scales as μ^¼: at 0.1 of air's viscosity the line still
//!    loses a sixth of the plateau to friction, so the plateau converges to
//!    a level below 2Δp while the wave times converge to L/c and 3L/c.
//! 2. Air's viscosity (18.1 µPa s): friction damps the wave; reported are
//!    the same quantities against the finest line (N = 160, or the second
//!    argument).
//!
//! Run: `cargo run --release -p pneumo-cli --example tube_convergence -- out.csv [finest N]`
//! (the CSV holds the closed-end pressure of every N, for `pneumo plot`).
//! The time of every run is printed (the Jacobian is dense: the cost grows
//! quickly with N). `crates/cli/tests/page_quotes.rs` includes this file to
//! rerun the cheap rows (N = 2, 5; 10 at air's viscosity) and compare them
//! with docs/blocks.md; `crates/cli/tests/page_quotes_tube.rs` compares the
//! page's other rows with the committed output of `-- out.csv 40`
//! (docs/data/tube_convergence.txt), and its ignored test reruns the study
//! and compares that file with what the code gives now.

use std::path::Path;

struct NoFiles;
impl graph::Loader for NoFiles {
    fn read(&self, path: &Path) -> Result<String, String> {
        Err(format!("no file {}", path.display()))
    }
}

pub const L: f64 = 5.0;
pub const P0: f64 = 1e5;
pub const DP: f64 = 0.1e5;
/// Viscosity of the nearly lossless line, as a fraction of air's. Lower
/// values make the integration very slow (see the closing note of issue 18):
/// at 1e-3 of air's a 2-segment line does not finish in minutes.
pub const LOW: f64 = 0.1;

/// Closed-end pressure [Pa] on a fixed time grid, for N segments.
pub fn run(n: usize, viscosity: f64, t_end: f64, dt: f64) -> Vec<(f64, f64)> {
    let netlist = serde_json::json!({
        "name": format!("line_{n}"),
        "components": [
            { "id": "source", "type": "pressure_source", "params": { "p": P0 + DP, "T": 293.15 } },
            { "id": "line", "type": "tube",
              "params": { "length": L, "diameter": "6 mm", "segments": n, "inertia": "yes", "viscosity": viscosity, "tau_thermal": "inf" },
              "init": { "p0": P0, "T0": 293.15 } },
            { "id": "end", "type": "chamber", "params": { "dead_volume": "0.01 cm3", "tau_thermal": "inf" }, "init": { "p0": P0, "T0": 293.15 } }
        ],
        "connections": [["source.port", "line.a"], ["line.b", "end.port"]],
        "simulation": { "t_end": t_end, "sample_interval": dt, "max_step": dt, "rtol": 1e-7, "atol": 1e-8, "outputs": ["end.p"] }
    });
    let parsed = graph::expand::parse(&netlist.to_string(), "line.json").expect("netlist");
    let flat = graph::expand::flatten(&NoFiles, &parsed, Path::new(""), 0).expect("flatten");
    let circuit = graph::build(&flat).expect("circuit");
    let opts = solve::options_from(&circuit.simulation).expect("options");
    let mut model = solve::Model::new(circuit);
    let r = solve::simulate(&mut model, &opts).expect("simulation");
    r.series("end.p").expect("end.p")
}

/// Arrival (first upward crossing of p0 + Δp), return (next downward
/// crossing) and the mean level of the plateau between 1.5 and 2.5 L/c.
pub fn measures(p: &[(f64, f64)], tc: f64) -> (f64, f64, f64) {
    let level = P0 + DP;
    let cross = |from: f64, up: bool| {
        p.windows(2)
            .find(|w| w[0].0 >= from && if up { w[0].1 < level && w[1].1 >= level } else { w[0].1 >= level && w[1].1 < level })
            .map(|w| w[0].0 + (w[1].0 - w[0].0) * (level - w[0].1) / (w[1].1 - w[0].1))
            .unwrap_or(f64::NAN)
    };
    let arrival = cross(0.0, true);
    let back = cross(arrival + 0.5 * tc, false);
    let plateau: Vec<f64> = p.iter().filter(|s| s.0 > 1.5 * tc && s.0 < 2.5 * tc).map(|s| s.1).collect();
    let mean = plateau.iter().sum::<f64>() / plateau.len().max(1) as f64;
    (arrival, back, mean - P0)
}

/// The wave's travel time along the line, L/c with c = √(γRT) at 20 °C [s].
pub fn travel_time() -> f64 {
    L / (1.4f64 * 287.05 * 293.15).sqrt()
}

/// The run's end time and output interval for the travel time `tc` [s].
pub fn grid(tc: f64) -> (f64, f64) {
    (6.0 * tc, tc / 400.0)
}

/// A run's name and its closed-end pressure: (t [s], p [Pa]).
pub type Trace = (String, Vec<(f64, f64)>);

/// The study: both tables, as printed (the lines of docs/data/tube_convergence.txt
/// for `finest` = 40), and the closed-end pressure of every run, named. The
/// time of each run goes to stderr.
pub fn study(finest: usize) -> (Vec<String>, Vec<Trace>) {
    let tc = travel_time();
    let (t_end, dt) = grid(tc);
    let ns: Vec<usize> = [2usize, 5, 10, 20, 40, 80, 160].into_iter().filter(|&n| n < finest).chain([finest]).collect();
    let mut lines = Vec::new();
    let mut columns: Vec<Trace> = Vec::new();
    lines.push(format!(
        "Line at {LOW} of air's viscosity against the lossless wave, L/c = {:.3} ms, exact: arrival {:.3} ms, return {:.3} ms, plateau 2Δp = {:.3} bar",
        tc * 1e3,
        tc * 1e3,
        3.0 * tc * 1e3,
        2.0 * DP / 1e5
    ));
    lines.push("| N | arrival [ms] | error | return [ms] | error | plateau [bar] | error |".into());
    lines.push("|---|---|---|---|---|---|---|".into());
    for &n in &ns[..ns.len() - 1] {
        let clock = std::time::Instant::now();
        let p = run(n, 18.1e-6 * LOW, t_end, dt);
        eprintln!("low viscosity N = {n}: {:.1} s", clock.elapsed().as_secs_f64());
        let (a, b, m) = measures(&p, tc);
        lines.push(format!(
            "| {n} | {:.3} | {:+.1} % | {:.3} | {:+.1} % | {:.4} | {:+.1} % |",
            a * 1e3,
            100.0 * (a / tc - 1.0),
            b * 1e3,
            100.0 * (b / (3.0 * tc) - 1.0),
            m / 1e5,
            100.0 * (m / (2.0 * DP) - 1.0)
        ));
        columns.push((format!("low_viscosity_N{n}"), p));
    }
    let reference = run(finest, 18.1e-6, t_end, dt);
    let (ra, rb, rm) = measures(&reference, tc);
    lines.push(String::new());
    lines.push(format!(
        "Air's viscosity (18.1 µPa s), against N = {finest}: arrival {:.3} ms, return {:.3} ms, plateau {:.4} bar",
        ra * 1e3,
        rb * 1e3,
        rm / 1e5
    ));
    lines.push("| N | arrival [ms] | error | return [ms] | error | plateau [bar] | error |".into());
    lines.push("|---|---|---|---|---|---|---|".into());
    for &n in &ns[..ns.len() - 1] {
        let clock = std::time::Instant::now();
        let p = run(n, 18.1e-6, t_end, dt);
        eprintln!("air N = {n}: {:.1} s", clock.elapsed().as_secs_f64());
        let (a, b, m) = measures(&p, tc);
        lines.push(format!(
            "| {n} | {:.3} | {:+.1} % | {:.3} | {:+.1} % | {:.4} | {:+.1} % |",
            a * 1e3,
            100.0 * (a / ra - 1.0),
            b * 1e3,
            100.0 * (b / rb - 1.0),
            m / 1e5,
            100.0 * (m / rm - 1.0)
        ));
        columns.push((format!("air_N{n}"), p));
    }
    columns.push((format!("air_N{finest}"), reference));
    (lines, columns)
}

fn main() {
    let out = std::env::args().nth(1);
    let tc = travel_time();
    // the finest line (the viscous reference) is the second argument, 160 by default
    let finest: usize = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(160);
    let (lines, columns) = study(finest);
    for line in &lines {
        println!("{line}");
    }
    if let Some(path) = out {
        // the exact lossless square wave and every run, on the common grid
        let grid: Vec<f64> = columns[0].1.iter().map(|s| s.0).collect();
        let mut text = String::from("t,exact");
        for (name, _) in &columns {
            text.push_str(&format!(",{name}"));
        }
        text.push('\n');
        for (k, &t) in grid.iter().enumerate() {
            let phase = ((t / tc - 1.0) / 4.0).rem_euclid(1.0);
            let exact = if t < tc || phase >= 0.5 { P0 } else { P0 + 2.0 * DP };
            text.push_str(&format!("{t},{exact}"));
            for (_, s) in &columns {
                let v = s.iter().find(|p| (p.0 - t).abs() < 1e-12).or_else(|| s.get(k)).map(|p| p.1).unwrap_or(f64::NAN);
                text.push_str(&format!(",{v}"));
            }
            text.push('\n');
        }
        std::fs::write(&path, text).expect("write the CSV");
        println!("\nwrote {path}");
    }
}
