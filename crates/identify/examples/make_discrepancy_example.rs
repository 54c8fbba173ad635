//! Writes the shipped example of `pneumo discrepancy`:
//! models/examples/discrepancy/{experiments.json, run1.csv … run4.csv}.
//!
//! The "measurements" are the meter-out circuit of models/meter_out.json
//! with one hidden effect — a piston seal leak of 0.3 L/(min·bar) between
//! the chambers — and "true" parameters that differ from the netlist's by
//! 10–20 % (friction k0 = 12 N, k2 = 42 N s/m, valve C = 430 L/(min·bar),
//! throttle C = 23.5 and 57 L/(min·bar) where the operator set 26 and 52).
//! Four operating points (4 and 7 bar × two throttle settings), three cycles
//! each with 0.2 s dwells, simulated with rtol 1e-7 and resampled at 1 kHz
//! with sensor noise (pressure σ = 5 mbar plus a constant offset of a few
//! mbar, position σ = 20 µm) by [`identify::synth`]. Column names are those
//! of a data logger (p1_Pa, p2_Pa, x_m); run2 has a short sensor dropout
//! (empty cells); run3 starts 0.25 s before the valve command on a logger
//! clock (time_origin 100 s).
//!
//! Usage (from the repository root): `cargo run --release -p pneumo-identify --example make_discrepancy_example`

use identify::synth::{measure, simulate_fine, Rng, TruthSettings};
use std::fmt::Write as _;
use std::path::Path;

struct Fs;
impl graph::Loader for Fs {
    fn read(&self, p: &Path) -> Result<String, String> {
        std::fs::read_to_string(p).map_err(|e| e.to_string())
    }
}

const L_MIN_BAR: f64 = 1e-3 / 60.0 / 1e5;

fn main() -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = root.join("models/examples/discrepancy");
    std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
    let model = graph::load(&Fs, &root.join("models/meter_out.json")).map_err(|e| e.to_string())?;
    let leak = identify::effects::by_name("piston_seal_leak").ok_or("no leak effect")?;
    // (supply, nominal throttle as marked, true throttle)
    let points = [
        ("4 bar", "26 L/min/bar", 23.5),
        ("4 bar", "52 L/min/bar", 57.0),
        ("7 bar", "26 L/min/bar", 23.5),
        ("7 bar", "52 L/min/bar", 57.0),
    ];
    let settings = TruthSettings { cycles: Some(3), duration: 120.0, ..TruthSettings::default() };
    let mut rng = Rng::new(2024);
    let mut manifest = String::from("{\n  \"description\": \"Synthetic measurements of the meter-out circuit with a hidden piston seal leak (written by crates/identify/examples/make_discrepancy_example.rs).\",\n  \"experiments\": [\n");
    for (k, (supply, marked, c_true)) in points.iter().enumerate() {
        let mut truth = model.clone();
        for s in [
            format!("supply.p={supply}"),
            format!("flow_control.C={}", c_true * L_MIN_BAR),
            "controller.dwell_extended=0.2".to_string(),
            "controller.dwell_retracted=0.2".to_string(),
            "friction.k0=12".to_string(),
            "friction.k2=42".to_string(),
            format!("dcv.C={}", 430.0 * L_MIN_BAR),
        ] {
            graph::apply_set(&mut truth, &s).map_err(|e| e.to_string())?;
        }
        leak.apply(&mut truth, &[0.3 * L_MIN_BAR]).map_err(|e| e.to_string())?;
        let fine = simulate_fine(&truth, &settings)?;
        let data = measure(&fine, &settings, 0.0, &mut rng)?;
        // logger clock and a pre-trigger stretch for run3
        let (clock, pre) = if k == 2 { (100.0, 250) } else { (0.0, 0) };
        let mut csv = String::from("t,p1_Pa,p2_Pa,x_m\n");
        for i in 0..pre {
            let t = clock - (pre - i) as f64 * 1e-3;
            let p1 = 0.98e5 + 500.0 * rng.normal();
            let p2 = data.values[1][0].unwrap_or(0.0) + 500.0 * rng.normal();
            let x = 20e-6 * rng.normal();
            let _ = writeln!(csv, "{t:.3},{p1:.1},{p2:.1},{x:.7}");
        }
        for (i, t) in data.times.iter().enumerate() {
            let cell = |c: usize, digits: usize| -> String {
                // a 40 ms dropout of the pressure sensors in run2
                if k == 1 && (1500..1540).contains(&i) && c < 2 {
                    return String::new();
                }
                data.values[c][i].map(|v| format!("{v:.digits$}")).unwrap_or_default()
            };
            let _ = writeln!(csv, "{:.3},{},{},{}", t + clock, cell(0, 1), cell(1, 1), cell(2, 7));
        }
        let file = format!("run{}.csv", k + 1);
        std::fs::write(out.join(&file), csv).map_err(|e| e.to_string())?;
        let origin = if k == 2 { ", \"time_origin\": \"100 s\"" } else { "" };
        let _ = write!(
            manifest,
            "    {{ \"name\": \"{}_{}\", \"data\": \"{file}\"{origin},\n      \"set\": {{ \"supply.p\": \"{supply}\", \"flow_control.C\": \"{marked}\", \"controller.dwell_extended\": \"0.2 s\", \"controller.dwell_retracted\": \"0.2 s\" }},\n      \"columns\": {{ \"p1_Pa\": \"head.p\", \"p2_Pa\": \"rod.p\", \"x_m\": \"piston.x\" }} }}{}\n",
            supply.replace(' ', ""),
            marked.split(' ').next().unwrap_or(""),
            if k + 1 < points.len() { "," } else { "" }
        );
        println!("wrote {} ({} samples, {} cycles)", file, data.times.len() + pre, fine.cycles.len());
    }
    manifest.push_str("  ]\n}\n");
    std::fs::write(out.join("experiments.json"), manifest).map_err(|e| e.to_string())?;
    println!("wrote {}", out.join("experiments.json").display());
    Ok(())
}
