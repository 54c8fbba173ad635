//! Scratch timing of one meter-out simulation (development aid).
use std::path::Path;
struct Fs;
impl graph::Loader for Fs {
    fn read(&self, p: &Path) -> Result<String, String> {
        std::fs::read_to_string(p).map_err(|e| e.to_string())
    }
}
fn main() {
    let flat0 = graph::load(&Fs, Path::new("models/meter_out.json")).unwrap();
    for (rtol, si) in [(1e-6, 1e-3), (1e-5, 1e-3), (1e-4, 1e-3), (1e-4, 5e-3), (1e-3, 1e-3), (1e-4, 0.0)] {
        for sup in ["4e5", "7e5"] {
            let mut flat = flat0.clone();
            graph::apply_set(&mut flat, &format!("supply.p={sup}")).unwrap();
            let c = graph::build(&flat).unwrap();
            let mut opts = solve::options_from(&c.simulation).unwrap();
            opts.rtol = rtol;
            opts.sample_interval = si;
            opts.cycles = None;
            opts.t_end = 6.0;
            let mut m = solve::Model::new(c);
            let t0 = std::time::Instant::now();
            let r = solve::simulate(&mut m, &opts).unwrap();
            let el = t0.elapsed();
            let x = r.series("piston.x").unwrap();
            println!(
                "rtol {rtol:e} si {si} p {sup}: {:.1} ms, {} rows, {} evals, steps {:?}, cycles {}, x_end {:.4}",
                el.as_secs_f64() * 1e3,
                r.times.len(),
                r.rhs_evaluations,
                r.stats,
                r.cycles.len(),
                x.last().unwrap().1
            );
        }
    }
}
