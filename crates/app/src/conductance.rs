//! `pneumo conductance`: sonic conductance C (and critical ratio b) of a
//! restriction from a recorded discharge of a known volume.
//!
//! Reads a CSV with a header naming the columns `t` [s] and `p` [Pa, absolute]
//! and optionally `T` [K] (any order, SI units, `#` comment lines allowed),
//! then runs the two estimates of [`identify::discharge`]:
//! (b) the estimate: a least-squares fit of C, b and p0 of the simulated
//! discharge (pneumo chamber with wall heat exchange, Eq. 8 and 17, and an
//! ISO 6358 conductance, Eq. 33–35) to the whole trace, with the thermal
//! model chosen by `--thermal` / `--tau-thermal` or, by default, fitted
//! (τ_T free, to p and to the `T` column when there is one) and reported;
//! (a) the unloading time τ_U of the choked part of the trace and paper
//! Eq. 36, C = K_T0·V/(γ·p_N·τ_U) — the adiabatic limit (n = 1 in place of γ
//! when (b) finds the discharge isothermal). Returns one block of text (or
//! JSON) with standard errors, the thermal model and the misfit, and the
//! ISO 6358 choked flow each estimate implies, and warnings (a misfit well
//! above the noise, τ_T not identifiable), one line each.
//!
//! T0 is taken from `--T0`, else from the first `T` sample, else 293.15 K.
//! p_atm from `--p-atm`, else fitted with C and b (started at 1.01325 bar,
//! or at the end of the trace when it ends lower). Errors name the file and
//! the line at fault.

use crate::error::AppError;
use identify::discharge::{
    analyse, p_atm_start, AnalysisOptions, DischargeData, DischargeReport, DischargeSetup, ThermalModel, ThermalOption,
};
use std::path::{Path, PathBuf};
use units::dim;

/// Thermal model of the tank as the user names it (`--thermal`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Thermal {
    /// Fit τ_T (to p, and to T when the data have it) and keep a limit unless the data reject it.
    #[default]
    Auto,
    /// τ_T = ∞ (the assumption of Eq. 36).
    Adiabatic,
    /// τ_T → 0: the gas stays at the wall temperature.
    Isothermal,
}

/// A discharge test to analyse (`pneumo conductance`). Quantities are text
/// with units, parsed here ("1 L", "1.013 bar", "20 degC", "1 s").
#[derive(Debug, Clone, Default)]
pub struct ConductanceOptions {
    /// Volume discharged (tank plus line), e.g. "1 L" (a bare number is m³).
    pub volume: String,
    /// CSV file with header t,p (optionally T), SI units: s, Pa absolute, K.
    pub data: PathBuf,
    /// Atmospheric pressure downstream of the restriction (None: fitted
    /// with C and b, started at 1.01325 bar or at the end of the trace).
    pub p_atm: Option<String>,
    /// Initial gas (and wall) temperature (None: first T sample, else 293.15 K).
    pub t0: Option<String>,
    /// Thermal model of the tank.
    pub thermal: Thermal,
    /// Thermal time constant τ_T of the tank, known beforehand, e.g. "1 s"
    /// ("inf": adiabatic, "0": isothermal); replaces the fitted one.
    pub tau_thermal: Option<String>,
    /// Fit the pressure trace only, even when the data have a T column (T
    /// still gives T0).
    pub pressure_only: bool,
    /// Critical ratio bounding the choked window of the unloading-time
    /// estimate (None: b from the model fit).
    pub b_window: Option<f64>,
    /// The report as JSON instead of text.
    pub json: bool,
    /// Column of the tank pressure (None: "p"); `tank.p` reads the CSV that
    /// `pneumo simulate --out` writes.
    pub p_column: Option<String>,
    /// Column of the gas temperature (None: "T" when there is one).
    pub t_column: Option<String>,
}

/// What the analysis reports: warnings (one line each, starting with the
/// data file's name) and the report, as text or JSON.
#[derive(Debug, Clone)]
pub struct ConductanceReport {
    pub warnings: Vec<String>,
    pub text: String,
}

const LPMB: f64 = 1e-3 / 60.0 / 1e5;

/// The thermal option from `--thermal` and `--tau-thermal`.
fn thermal_option(a: &ConductanceOptions) -> Result<ThermalOption, AppError> {
    let Some(text) = &a.tau_thermal else {
        return Ok(match a.thermal {
            Thermal::Auto => ThermalOption::Auto,
            Thermal::Adiabatic => ThermalOption::Adiabatic,
            Thermal::Isothermal => ThermalOption::Isothermal,
        });
    };
    if a.thermal != Thermal::Auto {
        return Err(AppError::Usage("give either --thermal or --tau-thermal, not both".into()));
    }
    if matches!(text.trim(), "inf" | "infinity" | "∞") {
        return Ok(ThermalOption::Adiabatic);
    }
    let shown = units::show::text(text);
    let tau = units::parse_quantity(text, dim::TIME).map_err(|e| AppError::Usage(format!("--tau-thermal \"{shown}\": {e}")))?;
    if tau == 0.0 {
        Ok(ThermalOption::Isothermal)
    } else if tau > 0.0 {
        Ok(ThermalOption::Given(tau))
    } else {
        Err(AppError::Usage(format!("--tau-thermal \"{shown}\": the thermal time constant must be >= 0 s (or \"inf\")")))
    }
}

/// Estimate C and b from the discharge test of `a`.
pub fn conductance(a: &ConductanceOptions) -> Result<ConductanceReport, AppError> {
    let quantity = |text: &str, d, what: &str| {
        units::parse_quantity(text, d).map_err(|e| AppError::Usage(format!("--{what} \"{}\": {e}", units::show::text(text))))
    };
    let volume = quantity(&a.volume, dim::VOLUME, "volume")?;
    if volume.is_nan() || volume <= 0.0 {
        return Err(AppError::Usage(format!("--volume \"{}\": the volume must be positive (e.g. \"1 L\")", units::show::text(&a.volume))));
    }
    if let Some(b) = a.b_window {
        if !(b > 0.0 && b < 1.0) {
            return Err(AppError::Usage(format!("--b-window must be in (0, 1), got {}", units::show::num(b))));
        }
    }
    let thermal = thermal_option(a)?;
    let given_p_atm = a.p_atm.as_deref().map(|text| quantity(text, dim::PRESSURE, "p-atm")).transpose()?;
    if given_p_atm.is_some_and(|p| p.is_nan() || p <= 0.0) {
        return Err(AppError::Usage("--p-atm: the atmospheric pressure must be positive (absolute, e.g. \"1.013 bar\")".into()));
    }
    let given_t0 = a.t0.as_deref().map(|text| quantity(text, dim::TEMPERATURE, "T0")).transpose()?;
    let data = read_discharge_csv(&a.data, a.p_column.as_deref(), a.t_column.as_deref())?;
    let t0 = match (given_t0, &data.temperature) {
        (Some(t0), _) => t0,
        (None, Some(t)) => {
            if !(150.0..=600.0).contains(&t[0]) {
                return Err(AppError::Data(format!(
                    "{}: first T sample {} K is not a plausible absolute gas temperature (the T column must be in K; or give --T0)",
                    crate::error::shown_path(&a.data),
                    units::show::num(t[0])
                )));
            }
            t[0]
        }
        (None, None) => 293.15,
    };
    if t0.is_nan() || t0 <= 0.0 {
        return Err(AppError::Usage(format!("--T0 must be > 0 K, got {}", units::show::num(t0))));
    }
    // p_atm: given, or fitted from a start the trace does not end below
    let p_atm = given_p_atm.unwrap_or_else(|| p_atm_start(&data));
    let setup = DischargeSetup { volume, p_atm, t0 };
    let opts = AnalysisOptions {
        b_window: a.b_window,
        thermal,
        use_temperature: !a.pressure_only,
        fit_p_atm: given_p_atm.is_none(),
        ..AnalysisOptions::default()
    };
    let p_atm_source = if given_p_atm.is_some() { "given" } else { "fitted" };
    let report = analyse(&data, &setup, &opts).map_err(|e| AppError::Data(format!("{}: {e}", crate::error::shown_path(&a.data))))?;
    let warnings = report.warnings.iter().map(|w| format!("{}: {w}", a.data.display())).collect();
    let text = if a.json {
        let mut value = serde_json::to_value(&report).map_err(|e| AppError::Data(e.to_string()))?;
        if let Some(obj) = value.as_object_mut() {
            obj.insert("p_atm_source".into(), p_atm_source.into());
        }
        serde_json::to_string_pretty(&value).map_err(|e| AppError::Data(e.to_string()))? + "\n"
    } else {
        render(&report, &a.data, p_atm_source)
    };
    Ok(ConductanceReport { warnings, text })
}

/// Read the discharge CSV, its pressure and temperature from the named
/// columns (None: "p" and "T"); every error names the file and line.
pub fn read_discharge_csv(path: &Path, p_column: Option<&str>, t_column: Option<&str>) -> Result<DischargeData, AppError> {
    let text = crate::load::read_input_text(path, "data").map_err(|e| AppError::io(path, e))?;
    parse_columns(&text, &crate::error::shown_path(path), p_column, t_column)
}

#[cfg(test)]
fn parse_discharge_csv(text: &str, origin: &str) -> Result<DischargeData, AppError> {
    parse_columns(text, origin, None, None)
}

fn parse_columns(text: &str, origin: &str, p_column: Option<&str>, t_column: Option<&str>) -> Result<DischargeData, AppError> {
    // the table itself (header, comments, numbers, increasing t) is read by
    // the one CSV reader of measured data; the discharge test adds its own
    // requirements: a pressure column, every sample present, p and T > 0
    let table = identify::data::parse_csv(text, origin).map_err(|e| AppError::Data(e.to_string()))?;
    let shown = |names: &[String]| crate::error::one_line(&names.join(","));
    let p_col = match p_column {
        Some(name) => table.channel(name).ok_or_else(|| {
            let hint = blocks::suggest::did_you_mean(name, table.names.iter().map(String::as_str));
            AppError::Data(format!(
                "{origin}: no column \"{}\" (--p-column){hint}; found t,{}",
                units::show::text(name),
                shown(&table.names)
            ))
        })?,
        None => table.channel("p").ok_or_else(|| {
            // pneumo simulate's CSV names its columns id.signal: point at the option that reads them
            let pressures: Vec<&str> = table.names.iter().map(String::as_str).filter(|n| n.ends_with(".p")).collect();
            let hint = match pressures.first() {
                Some(first) => format!(" (a pneumo simulate result? give --p-column {first}; pressure columns: {})", pressures.join(", ")),
                None => " (or name the pressure column with --p-column)".to_string(),
            };
            AppError::Data(format!(
                "{origin}: header must name columns \"t\" and \"p\" (optionally \"T\"), found t,{}{hint}",
                shown(&table.names)
            ))
        })?,
    };
    let t_col = match t_column {
        Some(name) => Some(table.channel(name).ok_or_else(|| {
            let hint = blocks::suggest::did_you_mean(name, table.names.iter().map(String::as_str));
            AppError::Data(format!(
                "{origin}: no column \"{}\" (--T-column){hint}; found t,{}",
                units::show::text(name),
                shown(&table.names)
            ))
        })?),
        None => table.channel("T"),
    };
    let at = |i: usize| table.lines.get(i).copied().unwrap_or(0);
    let column = |c: usize, name: &str, unit: &str| -> Result<Vec<f64>, AppError> {
        table.values[c]
            .iter()
            .enumerate()
            .map(|(i, v)| match v {
                None => Err(AppError::Data(format!("{origin}:{}: column \"{name}\": the sample is missing", at(i)))),
                Some(v) if *v <= 0.0 => Err(AppError::Data(format!(
                    "{origin}:{}: {name} = {} {unit}: absolute values must be > 0 (SI units: {unit})",
                    at(i),
                    units::show::num(*v)
                ))),
                Some(v) => Ok(*v),
            })
            .collect()
    };
    let p = column(p_col, p_column.unwrap_or("p"), "Pa")?;
    let t_name = t_column.unwrap_or("T");
    let temperature = t_col.map(|c| column(c, t_name, "K")).transpose()?;
    DischargeData::new(table.times, p, temperature).map_err(|e| AppError::Data(format!("{origin}: {e}")))
}

/// "finite tau_T = 1.002 ± 0.012 s" etc.
fn thermal_text(model: ThermalModel, tau: Option<f64>, tau_std: Option<f64>) -> String {
    match (model, tau) {
        (ThermalModel::Adiabatic, _) => "adiabatic (tau_T = inf)".into(),
        (ThermalModel::Isothermal, _) => "isothermal (tau_T -> 0)".into(),
        (ThermalModel::FiniteTau, Some(t)) => match tau_std.filter(|v| v.is_finite()) {
            Some(e) => format!("finite tau_T = {t:.4} ± {e:.4} s"),
            None => format!("finite tau_T = {t:.4} s"),
        },
        (ThermalModel::FiniteTau, None) => "finite tau_T".into(),
    }
}

/// The readable report.
fn render(r: &DischargeReport, data: &Path, p_atm_source: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let s_ = &mut s;
    let opening = if r.opening.samples_dropped > 0 {
        format!(
            " from the opening found at t = {:.4} s ({} pre-trigger samples at {:.4} bar left out)",
            r.opening.t_open,
            r.opening.samples_dropped,
            r.opening.p_hold / 1e5
        )
    } else {
        String::new()
    };
    let p_atm = match r.model_fit.as_ref().and_then(|m| m.p_atm_std.map(|e| (m.p_atm, e))) {
        Some((v, e)) => format!("{:.5} ± {:.5} bar ({p_atm_source})", v / 1e5, e / 1e5),
        None => format!("{:.5} bar ({p_atm_source})", r.setup.p_atm / 1e5),
    };
    let t0 = match r.model_fit.as_ref().and_then(|m| m.t0_std.map(|e| (m.t0, e))) {
        Some((v, e)) => format!("{v:.2} ± {e:.2} K (fitted to the T column)"),
        None => format!("{:.2} K", r.setup.t0),
    };
    let _ = writeln!(
        s_,
        "Discharge test {}: {} samples, {:.4} s{opening}; V = {:.4} L, p_atm = {p_atm}, T0 = {t0}, gamma = {:.4}, p_N = rho_N R T_N = {:.1} Pa",
        data.display(),
        r.n_samples,
        r.duration,
        r.setup.volume * 1e3,
        r.gamma,
        r.p_n
    );
    let noise_t = r.noise_temperature.map(|v| format!(", temperature {v:.3} K")).unwrap_or_default();
    let _ = writeln!(s_, "Noise estimated from the data: pressure {:.2} mbar{noise_t}", r.noise_p.unwrap_or(f64::NAN) / 100.0);
    if let (Some(m), Some(th)) = (&r.model_fit, &r.thermal) {
        let ratio =
            th.tau_ratio.filter(|_| th.model == ThermalModel::FiniteTau).map(|x| format!(", tau_T/tau = {x:.3}")).unwrap_or_default();
        let _ = writeln!(
            s_,
            "Thermal model: {} ({}{ratio}; process time tau = V/(gamma C p_N) = {:.4} s, Eq. 19)",
            thermal_text(th.model, th.tau_thermal, th.tau_thermal_std),
            th.source.describe(),
            th.process_time
        );
        for c in &th.candidates {
            let rt = c.rms_temperature.map(|v| format!(", T misfit {v:.3} K")).unwrap_or_default();
            let _ = writeln!(
                s_,
                "    tried {:<28} C = {:>9.4} L/min/bar  b = {:.4}  misfit {:>8.2} mbar{rt}  dchi2 = {}{}",
                thermal_text(c.model, c.tau_thermal, None),
                c.c / LPMB,
                c.b,
                c.rms / 100.0,
                units::show::fixed(c.delta_chi2, 4),
                if c.rejected { "  rejected" } else { "" }
            );
        }
        let _ = writeln!(s_, "    decision: {}", th.decision);
        let _ = writeln!(
            s_,
            "Result: C = {:.4} ± {:.4} L/min/bar, b = {:.4} ± {:.4}, thermal model {}, misfit {:.2} mbar RMS",
            m.c / LPMB,
            m.c_std / LPMB,
            m.b,
            m.b_std,
            m.thermal_model.name(),
            m.rms / 100.0
        );
    }
    match (&r.unloading, &r.unloading_note) {
        (Some(u), _) => {
            let law = if u.polytropic_index == 1.0 { "isothermal closed form, Eq. 36 with n = 1" } else { "adiabatic closed form" };
            let _ = writeln!(
                s_,
                "(a) unloading time, Eq. 36 ({law}, choked fit on {} samples, p >= p_atm/{:.3} = {:.4} bar, t <= {:.4} s):",
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
            if let Some(c) = &u.caveat {
                let _ = writeln!(s_, "    note: {c}");
            }
        }
        (None, Some(note)) => {
            let _ = writeln!(s_, "(a) unloading time, Eq. 36: not applicable: {note}");
        }
        (None, None) => {}
    }
    if let Some(m) = &r.model_fit {
        let _ = writeln!(
            s_,
            "(b) model fit (pneumo chamber + ISO 6358 conductance, {}) on all {} samples: {} simulations, {}",
            m.thermal_model.name(),
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
            "    p0 = {:.5} ± {:.5} bar   tau_U (Eq. 36) = {:.5} s   rms residual {:.2} mbar (lag-1 autocorrelation {:.2})",
            m.p0 / 1e5,
            m.p0_std / 1e5,
            m.tau_u,
            m.rms / 100.0,
            m.residual_lag1
        );
        if let Some(rt) = m.rms_temperature {
            let pm = |v: Option<f64>| v.filter(|x| x.is_finite()).map(|x| format!(" ± {x:.4}")).unwrap_or_default();
            let _ = writeln!(
                s_,
                "    T0 = {:.3}{} K   sensor lag = {:.4}{} s   rms temperature residual {:.3} K",
                m.t0,
                pm(m.t0_std),
                m.sensor_lag.unwrap_or(0.0),
                pm(m.sensor_lag_std),
                rt
            );
        }
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
