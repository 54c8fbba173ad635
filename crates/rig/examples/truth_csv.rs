//! Writes a measured-like CSV of the meter-out rig with a hidden effect:
//! the truth generator in one command.
//!
//! `cargo run -p pneumo-rig --release --example truth_csv -- OUT.csv [seed]`
//!
//! The example hides a piston seal leak of 0.3 L/(min·bar) in the paper's
//! rig (4 bar, switch 2) and logs three cycles with the default sensors
//! (5 mbar / 20 µm noise, 10 mbar pressure offsets, 10 µm position
//! quantum, 1 kHz with 20 µs jitter).

use rig::sensors::{acquire, write_csv, SensorSpec};
use rig::{Effects, LeakLaw, ModelForm, Restriction, Rig, RigError, RunSpec};

fn main() -> Result<(), RigError> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "truth.csv".to_string());
    let seed = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let effects = Effects { seal_leak: Some(LeakLaw::Iso(Restriction::lpm_per_bar(0.3, 0.3))), ..Effects::default() };
    let run = RunSpec { t_end: 20.0, ..RunSpec::cycles(3, 1e-3) };
    let (trace, m) = acquire(&rig, &ModelForm::default(), &effects, &run, &SensorSpec::default(), seed)?;
    let file = std::fs::File::create(&path).map_err(|e| RigError::Io(format!("{path}: {e}")))?;
    write_csv(&m, std::io::BufWriter::new(file))?;
    let cycles: Vec<String> = trace.cycles.iter().map(|c| format!("{:.4}", c.total)).collect();
    println!(
        "{path}: {} samples, cycles {} s, offsets p1 {:.0} Pa, p2 {:.0} Pa",
        m.t.len(),
        cycles.join(", "),
        m.draws.offset[0],
        m.draws.offset[1]
    );
    Ok(())
}
