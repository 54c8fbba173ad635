//! Prints the meter-out cycle times for the four throttle settings of the
//! paper's Table 1 at 4 and 7 bar, with the wall time of each run.
//!
//! `cargo run -p pneumo-rig --release --example cycle_table [rtol]`

use rig::{simulate, Effects, ModelForm, Rig, RunSpec};
use std::time::Instant;

fn main() {
    let rtol: f64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(1e-6);
    println!("rtol {rtol:e}, 3 cycles, no dwell, switch tolerance 10 µm");
    println!("| switch | C [L/min/bar] | p_s [bar] | cycle 1 (extend + retract) [s] | cycle 3 [s] | run [ms] | steps |");
    println!("|---|---|---|---|---|---|---|");
    for ps in [4.0, 7.0] {
        for (sw, c) in [(4, 1.41), (3, 2.68), (2, 13.2), (1, 210.0)] {
            let rig = Rig::paper_bar_lpm(ps, c);
            let run = RunSpec { rtol, ..RunSpec::cycles(3, 1e-3) };
            let t0 = Instant::now();
            let tr = simulate(&rig, &ModelForm::default(), &Effects::default(), &run);
            let ms = 1e3 * t0.elapsed().as_secs_f64();
            match tr {
                Ok(tr) => {
                    let (a, b) = (tr.cycles[0], tr.cycles[2]);
                    println!(
                        "| {sw} | {c} | {ps} | {:.4} ({:.4} + {:.4}) | {:.4} ({:.4} + {:.4}) | {ms:.0} | {} |",
                        a.total, a.extend, a.retract, b.total, b.extend, b.retract, tr.stats.steps
                    );
                }
                Err(e) => println!("| {sw} | {c} | {ps} | error: {e} | | {ms:.0} | |"),
            }
        }
    }
}
