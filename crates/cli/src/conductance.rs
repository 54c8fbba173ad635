//! `pneumo conductance`: sonic conductance C (and critical ratio b) of a
//! restriction from a recorded discharge of a known volume.
//!
//! Reads a CSV with a header naming the columns `t` [s] and `p` [Pa, absolute]
//! and optionally `T` [K] (any order, SI units, `#` comment lines allowed),
//! then runs the two estimates of [`identify::discharge`]:
//! (a) the unloading time τ_U of the choked part of the trace and paper
//! Eq. 36, C = K_T0·V/(γ·p_N·τ_U); (b) a least-squares fit of C, b and p0 of
//! the simulated discharge (pneumo chamber + ISO 6358 conductance, adiabatic,
//! Eq. 33–35) to the whole trace. Prints one block (or JSON with `--json`)
//! with standard errors and the ISO 6358 choked flow each estimate implies.
//!
//! T0 is taken from `--T0`, else from the first `T` sample, else 293.15 K.
//! Errors name the file and the line at fault.

use crate::error::CliError;
use identify::discharge::{analyse, AnalysisOptions, DischargeData, DischargeReport, DischargeSetup};
use std::path::{Path, PathBuf};
use units::dim;

#[derive(clap::Args, Debug)]
pub struct ConductanceArgs {
    /// Volume discharged (tank plus line), e.g. "1 L" (a bare number is m³).
    #[arg(long)]
    pub volume: String,
    /// CSV file with header t,p (optionally T), SI units: s, Pa absolute, K.
    #[arg(long, value_name = "FILE.csv")]
    pub data: PathBuf,
    /// Atmospheric pressure downstream of the restriction.
    #[arg(long = "p-atm", default_value = "1.01325 bar")]
    pub p_atm: String,
    /// Initial gas temperature (default: first T sample, else 293.15 K).
    #[arg(long = "T0")]
    pub t0: Option<String>,
    /// Critical ratio bounding the choked window of the unloading-time
    /// estimate (default: b from the model fit).
    #[arg(long = "b-window")]
    pub b_window: Option<f64>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

const LPMB: f64 = 1e-3 / 60.0 / 1e5;

pub fn run(a: &ConductanceArgs) -> Result<(), CliError> {
    let quantity =
        |text: &str, d, what: &str| units::parse_quantity(text, d).map_err(|e| CliError::Usage(format!("--{what} \"{text}\": {e}")));
    let volume = quantity(&a.volume, dim::VOLUME, "volume")?;
    let p_atm = quantity(&a.p_atm, dim::PRESSURE, "p-atm")?;
    if !(volume > 0.0 && p_atm > 0.0) {
        return Err(CliError::Usage("--volume and --p-atm must be > 0".into()));
    }
    if let Some(b) = a.b_window {
        if !(b > 0.0 && b < 1.0) {
            return Err(CliError::Usage(format!("--b-window must be in (0, 1), got {b}")));
        }
    }
    let data = read_discharge_csv(&a.data)?;
    let t0 = match (&a.t0, &data.temperature) {
        (Some(text), _) => quantity(text, dim::TEMPERATURE, "T0")?,
        (None, Some(t)) => t[0],
        (None, None) => 293.15,
    };
    if t0.is_nan() || t0 <= 0.0 {
        return Err(CliError::Usage(format!("--T0 must be > 0 K, got {t0}")));
    }
    let setup = DischargeSetup { volume, p_atm, t0 };
    let opts = AnalysisOptions { b_window: a.b_window, ..AnalysisOptions::default() };
    let report = analyse(&data, &setup, &opts).map_err(|e| CliError::Data(format!("{}: {e}", a.data.display())))?;
    if a.json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| CliError::Data(e.to_string()))?;
        println!("{text}");
    } else {
        print!("{}", render(&report, &a.data));
    }
    Ok(())
}

/// Read the discharge CSV; every error names the file and line.
pub fn read_discharge_csv(path: &Path) -> Result<DischargeData, CliError> {
    let text = std::fs::read_to_string(path).map_err(|e| CliError::io(path, e))?;
    parse_discharge_csv(&text, &path.display().to_string())
}

fn parse_discharge_csv(text: &str, origin: &str) -> Result<DischargeData, CliError> {
    // the table itself (header, comments, numbers, increasing t) is read by
    // the one CSV reader of measured data; the discharge test adds its own
    // requirements: a pressure column, every sample present, p and T > 0
    let table = identify::data::parse_csv(text, origin).map_err(|e| CliError::Data(e.to_string()))?;
    let p_col = table.channel("p").ok_or_else(|| {
        CliError::Data(format!("{origin}: header must name columns \"t\" and \"p\" (optionally \"T\"), found t,{}", table.names.join(",")))
    })?;
    let at = |i: usize| table.lines.get(i).copied().unwrap_or(0);
    let column = |c: usize, name: &str, unit: &str| -> Result<Vec<f64>, CliError> {
        table.values[c]
            .iter()
            .enumerate()
            .map(|(i, v)| match v {
                None => Err(CliError::Data(format!("{origin}:{}: column \"{name}\": the sample is missing", at(i)))),
                Some(v) if *v <= 0.0 => {
                    Err(CliError::Data(format!("{origin}:{}: {name} = {v} {unit}: absolute values must be > 0 (SI units: {unit})", at(i))))
                }
                Some(v) => Ok(*v),
            })
            .collect()
    };
    let p = column(p_col, "p", "Pa")?;
    let temperature = table.channel("T").map(|c| column(c, "T", "K")).transpose()?;
    DischargeData::new(table.times, p, temperature).map_err(|e| CliError::Data(format!("{origin}: {e}")))
}

/// The readable report.
fn render(r: &DischargeReport, data: &Path) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let s_ = &mut s;
    let _ = writeln!(
        s_,
        "Discharge test {}: {} samples over {:.4} s; V = {:.4} L, p_atm = {:.4} bar, T0 = {:.2} K, gamma = {:.4}, p_N = rho_N R T_N = {:.1} Pa",
        data.display(),
        r.n_samples,
        r.duration,
        r.setup.volume * 1e3,
        r.setup.p_atm / 1e5,
        r.setup.t0,
        r.gamma,
        r.p_n
    );
    match (&r.unloading, &r.unloading_note) {
        (Some(u), _) => {
            let _ = writeln!(
                s_,
                "(a) unloading time, Eq. 36 (closed-form choked fit on {} samples, p >= p_atm/{:.3} = {:.4} bar, t <= {:.4} s):",
                u.n_points,
                u.b_window,
                u.p_window_min / 1e5,
                u.t_window_end
            );
            let _ = writeln!(
                s_,
                "    tau_U = {:.5} ± {:.5} s   p0 = {:.5} ± {:.5} bar   rms residual {:.2} mbar",
                u.tau_u,
                u.tau_u_std,
                u.p0 / 1e5,
                u.p0_std / 1e5,
                u.rms / 100.0
            );
            let _ = writeln!(s_, "    C = {:.4} ± {:.4} L/min/bar  ({:.4e} m3/(s Pa))", u.c / LPMB, u.c_std / LPMB, u.c);
        }
        (None, Some(note)) => {
            let _ = writeln!(s_, "(a) unloading time, Eq. 36: not applicable: {note}");
        }
        (None, None) => {}
    }
    if let Some(m) = &r.model_fit {
        let _ = writeln!(
            s_,
            "(b) model fit (pneumo chamber + ISO 6358 conductance, adiabatic) on all {} samples: {} simulations, {}",
            m.n_points,
            m.simulations,
            if m.converged { "converged" } else { "NOT converged (iteration limit)" }
        );
        let _ = writeln!(
            s_,
            "    C = {:.4} ± {:.4} L/min/bar  ({:.4e} m3/(s Pa))   b = {:.4} ± {:.4}",
            m.c / LPMB,
            m.c_std / LPMB,
            m.c,
            m.b,
            m.b_std
        );
        let _ = writeln!(
            s_,
            "    p0 = {:.5} ± {:.5} bar   tau_U (Eq. 36) = {:.5} s   rms residual {:.2} mbar",
            m.p0 / 1e5,
            m.p0_std / 1e5,
            m.tau_u,
            m.rms / 100.0
        );
    }
    for f in &r.iso {
        let _ = writeln!(
            s_,
            "ISO 6358 steady flow from {}: choked at p0 = {:.4} bar, T0 = {:.2} K: {:.4} g/s = {:.1} L/min (ANR)",
            if f.method == "model_fit" { "(b)" } else { "(a)" },
            f.p_up / 1e5,
            f.t_up,
            f.choked_mass_flow * 1e3,
            f.choked_anr_flow * 6e4
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_errors_name_file_and_line() {
        let e = parse_discharge_csv("t,p\n0,7e5\n0.001,abc\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:3:") && e.contains("abc"), "{e}");
        let e = parse_discharge_csv("time,pressure\n0,1\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:1:") && e.contains("\"t\""), "{e}");
        let e = parse_discharge_csv("t,p\n0,7e5\n0,6e5\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:3:") && e.contains("increase"), "{e}");
        let e = parse_discharge_csv("t,p\n0,7e5\n1,6e5,3\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:3:"), "{e}");
        let e = parse_discharge_csv("t,p\n# comment\n0,7e5\n1,-6e5\n2,5e5\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:4:") && e.contains("> 0"), "{e}");
        let e = parse_discharge_csv("t,p,T\n0,7e5,293\n1,6e5,0\n2,5e5,290\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:3:") && e.contains("T = 0 K"), "{e}");
        let e = parse_discharge_csv("t,p\n0,7e5\n1,\n2,5e5\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:3:") && e.contains("missing"), "{e}");
        let e = parse_discharge_csv("t,q\n0,7e5\n1,6e5\n2,5e5\n", "d.csv").unwrap_err().to_string();
        assert!(e.starts_with("d.csv:") && e.contains("\"p\"") && e.contains("t,q"), "{e}");
    }

    #[test]
    fn csv_with_columns_in_any_order_and_temperature() {
        let mut text = String::from("p, T, t\n");
        for i in 0..12 {
            text.push_str(&format!("{}, {}, {}\n", 7e5 - 1e4 * i as f64, 293.0 - i as f64, 0.01 * i as f64));
        }
        let d = parse_discharge_csv(&text, "x.csv").expect("parse");
        assert_eq!(d.t.len(), 12);
        assert_eq!(d.p[1], 6.9e5);
        assert_eq!(d.t[11], 0.11);
        assert_eq!(d.temperature.as_ref().map(|v| v[2]), Some(291.0));
    }
}
