//! `pneumo conductance` end to end on discharge traces with heat exchange,
//! written as CSV files by an independent generator (not pneumo): a rigid
//! tank emptying through an ISO 6358 restriction (paper Eq. 33–35, elliptic
//! law up to r = 1), energy balance Eq. 17 with V̇ = 0 and wall heat Eq. 8,
//! textbook air (R = 287.0, γ = 1.4), fixed-step RK4 (10 µs), 1 kHz samples,
//! σ = 5 mbar on p and 0.3 K on T, a 20 ms pre-trigger, p_atm = 1.013 bar
//! (left for the command to fit).
//!
//! Checked: C within 2 %, b within 0.05 and the thermal model named, with a
//! temperature column and without; a forced adiabatic reading of an
//! isothermal trace warns on stderr; `--tau-thermal` is used as given; bad
//! options and a T column in °C end with one error line.

mod common;

use common::Scratch;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

const LPMB: f64 = 1e-3 / 60.0 / 1e5;

/// A discharge trace: C [L/min/bar], b, V [m³], τ_T [s] (None = isothermal,
/// ∞ = adiabatic); returns the CSV text (with a T column if asked).
fn discharge_csv(c: f64, b: f64, volume: f64, tau: Option<f64>, with_t: bool, seed: u64) -> String {
    let (r, gamma, rho_n, t_n, p_atm, t_w, p0) = (287.0, 1.4, 1.185, 293.15, 1.013e5, 293.15, 7e5);
    let cv = r / (gamma - 1.0);
    let rates = |m: f64, temp: f64| -> (f64, f64) {
        let temp = if tau.is_none() { t_w } else { temp };
        let p = m * r * temp / volume;
        let ratio = p_atm / p;
        let omega = if ratio >= 1.0 {
            0.0
        } else if ratio <= b {
            1.0
        } else {
            let x = (ratio - b) / (1.0 - b);
            (1.0 - x * x).max(0.0).sqrt()
        };
        let mdot = -c * LPMB * rho_n * p * (t_n / temp).sqrt() * omega;
        let dtemp = match tau {
            None => 0.0,
            Some(tt) => (if tt.is_finite() { (t_w - temp) / tt } else { 0.0 }) + r * temp * mdot / (cv * m),
        };
        (mdot, dtemp)
    };
    let mut state = 0x2545_F491_4F6C_DD1D_u64 ^ seed;
    let mut normal = || {
        let mut u = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 + 0.5 / (1u64 << 53) as f64
        };
        let (u1, u2) = (u(), u());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    };
    let mut text = String::from(if with_t { "t,p,T\n" } else { "t,p\n" });
    let mut row = |t: f64, p: f64, temp: f64, text: &mut String| {
        let (pn, tn) = (p + 500.0 * normal(), temp + 0.3 * normal());
        if with_t {
            text.push_str(&format!("{t:.3},{pn:.1},{tn:.3}\n"));
        } else {
            text.push_str(&format!("{t:.3},{pn:.1}\n"));
        }
    };
    let pre = 20;
    for i in 0..pre {
        row(i as f64 * 1e-3, p0, t_w, &mut text);
    }
    let (mut m, mut temp, h) = (p0 * volume / (r * t_w), t_w, 1e-5);
    let mut k = 0usize;
    let mut t_stop = f64::INFINITY;
    while (k as f64) * h < t_stop {
        let (a1, b1) = rates(m, temp);
        let (a2, b2) = rates(m + 0.5 * h * a1, temp + 0.5 * h * b1);
        let (a3, b3) = rates(m + 0.5 * h * a2, temp + 0.5 * h * b2);
        let (a4, b4) = rates(m + h * a3, temp + h * b3);
        m += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
        temp += h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4);
        k += 1;
        if k.is_multiple_of(100) {
            let t = k as f64 * h;
            let gas_t = if tau.is_none() { t_w } else { temp };
            let p = m * r * gas_t / volume;
            row((pre + k / 100) as f64 * 1e-3, p, gas_t, &mut text);
            if t_stop.is_infinite() && p - p_atm < 2e-3 * (p0 - p_atm) {
                t_stop = 1.2 * t;
            }
        }
    }
    text
}

fn pneumo(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pneumo")).args(args).current_dir(dir).output().expect("run pneumo")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Run with `--json`, expect success; the report and stderr.
fn json_report(dir: &Path, args: &[&str]) -> (Value, String) {
    let mut all = vec!["conductance", "--json"];
    all.extend_from_slice(args);
    let out = pneumo(dir, &all);
    assert!(out.status.success(), "pneumo {all:?}: {}", text(&out.stderr));
    (serde_json::from_slice(&out.stdout).expect("json report"), text(&out.stderr))
}

fn c_and_b(rep: &Value) -> (f64, f64) {
    (rep["model_fit"]["c"].as_f64().expect("c") / LPMB, rep["model_fit"]["b"].as_f64().expect("b"))
}

#[test]
fn conductance_reads_heat_exchanging_discharges_with_and_without_temperature() {
    let dir = Scratch::new("conductance-thermal");
    // τ_T = 1 s, with a temperature column: fitted to p and T.
    dir.write("tau.csv", &discharge_csv(60.0, 0.4, 1e-3, Some(1.0), true, 1));
    let (rep, err) = json_report(&dir.0, &["--volume", "1 L", "--data", "tau.csv"]);
    let (c, b) = c_and_b(&rep);
    eprintln!("tau_T = 1 s, T column: C = {c:.3} L/min/bar, b = {b:.4}, {}", rep["thermal"]["decision"]);
    assert!((c / 60.0 - 1.0).abs() < 0.02 && (b - 0.4).abs() < 0.05, "C {c} b {b}");
    assert_eq!(rep["thermal"]["model"], "finite_tau");
    assert_eq!(rep["thermal"]["source"], "fitted_pressure_temperature");
    assert_eq!(rep["model_fit"]["thermal_model"], "finite_tau");
    let tau = rep["thermal"]["tau_thermal"].as_f64().expect("tau_T");
    assert!((tau - 1.0).abs() < 0.1, "tau_T {tau}");
    assert!(rep["model_fit"]["tau_thermal_std"].as_f64().is_some_and(|s| s > 0.0));
    assert!((rep["model_fit"]["p_atm"].as_f64().expect("p_atm") - 1.013e5).abs() < 300.0);
    assert_eq!(rep["p_atm_source"], "fitted");
    assert_eq!(rep["opening"]["samples_dropped"].as_u64().map(|k| k.abs_diff(20) <= 1), Some(true), "{}", rep["opening"]);
    let rms = rep["model_fit"]["rms"].as_f64().expect("rms");
    assert!(rms < 600.0, "misfit {rms} Pa");
    assert!(err.is_empty(), "{err}");

    // Isothermal, no temperature column: fitted to p alone.
    dir.write("iso.csv", &discharge_csv(100.0, 0.3, 1e-3, None, false, 2));
    let (rep, err) = json_report(&dir.0, &["--volume", "1 L", "--data", "iso.csv", "--p-atm", "1.013 bar"]);
    let (c, b) = c_and_b(&rep);
    eprintln!("isothermal, no T column: C = {c:.3} L/min/bar, b = {b:.4}");
    assert!((c / 100.0 - 1.0).abs() < 0.02 && (b - 0.3).abs() < 0.05, "C {c} b {b}");
    assert_eq!((&rep["thermal"]["model"], &rep["thermal"]["source"]), (&Value::from("isothermal"), &Value::from("fitted_pressure")));
    assert_eq!(rep["p_atm_source"], "given");
    assert!(err.is_empty(), "{err}");
    // the readable report says it first
    let out = pneumo(&dir.0, &["conductance", "--volume", "1 L", "--data", "iso.csv"]);
    let s = text(&out.stdout);
    assert!(out.status.success() && s.contains("Thermal model: isothermal") && s.contains("Result: C = "), "{s}");
    assert!(s.contains("tau_U") && s.contains("(b) model fit") && s.contains("L/min (ANR)"), "{s}");

    // Adiabatic, with a temperature column.
    dir.write("adi.csv", &discharge_csv(100.0, 0.3, 0.5e-3, Some(f64::INFINITY), true, 3));
    let (rep, _) = json_report(&dir.0, &["--volume", "0.5 L", "--data", "adi.csv"]);
    let (c, b) = c_and_b(&rep);
    assert!((c / 100.0 - 1.0).abs() < 0.02 && (b - 0.3).abs() < 0.05, "C {c} b {b}");
    assert_eq!(rep["thermal"]["model"], "adiabatic");
    assert!(rep["thermal"]["tau_thermal"].is_null());
}

#[test]
fn conductance_thermal_options_and_warnings() {
    let dir = Scratch::new("conductance-options");
    dir.write("iso.csv", &discharge_csv(100.0, 0.3, 1e-3, None, false, 4));
    // The reading: an adiabatic fit of an isothermal trace is biased
    // and now says so on stderr, in one line.
    let (rep, err) = json_report(&dir.0, &["--volume", "1 L", "--data", "iso.csv", "--thermal", "adiabatic"]);
    let (c, _) = c_and_b(&rep);
    assert!(c < 90.0, "{c}");
    assert_eq!((&rep["thermal"]["model"], &rep["thermal"]["source"]), (&Value::from("adiabatic"), &Value::from("forced")));
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("warning: iso.csv: the adiabatic fit leaves") && err.contains("mbar"), "{err}");
    // docs/conductance.md quotes this warning, word for word, numbers by the shared rule:
    // "*"the adiabatic fit leaves 26.28 mbar RMS against 4.91 mbar noise (residual lag-1
    // autocorrelation 0.96): systematic misfit; …"*"
    let warning = err.trim().trim_start_matches("warning: iso.csv: ");
    let page = common::quotes::Page::read("docs/conductance.md");
    // (its numbers: the RMS, the noise, the 1 of "lag-1", the autocorrelation)
    let quoted = page.numbers_after("for an imposed adiabatic model: *\"", 4);
    let said: Vec<Option<f64>> = common::numbers::pieces(warning)
        .into_iter()
        .filter_map(|p| match p {
            common::numbers::Piece::Number(x, _) => Some(Some(x)),
            common::numbers::Piece::Text(_) => None,
        })
        .take(quoted.len())
        .collect();
    page.says("for an imposed adiabatic model: *\"", &said);
    let words = |t: &str| t.split(|c: char| !c.is_alphabetic()).filter(|w| !w.is_empty()).map(str::to_string).collect::<Vec<_>>();
    let markdown = std::fs::read_to_string(common::repo().join("docs/conductance.md")).expect("docs/conductance.md");
    let joined = markdown.split_whitespace().collect::<Vec<_>>().join(" ");
    let from =
        joined.find("for an imposed adiabatic model: *\"").expect("the quoted warning") + "for an imposed adiabatic model: *\"".len();
    let shown = &joined[from..from + joined[from..].find("\"*").expect("the quote's end")];
    assert_eq!(words(shown), words(warning), "docs/conductance.md quotes the warning in other words: {shown:?} / {warning:?}");
    // τ_T given with a unit: used as given.
    let (rep, err) = json_report(&dir.0, &["--volume", "1 L", "--data", "iso.csv", "--tau-thermal", "0.1 ms"]);
    let (c, b) = c_and_b(&rep);
    assert!((c / 100.0 - 1.0).abs() < 0.02 && (b - 0.3).abs() < 0.05, "C {c} b {b}");
    assert_eq!(rep["thermal"]["source"], "given");
    assert!((rep["thermal"]["tau_thermal"].as_f64().expect("tau") - 1e-4).abs() < 1e-12);
    assert!(err.is_empty(), "{err}");
    // "inf" and "0" name the limits.
    let (rep, _) = json_report(&dir.0, &["--volume", "1 L", "--data", "iso.csv", "--tau-thermal", "0"]);
    assert_eq!(rep["thermal"]["model"], "isothermal");

    // Errors: one line, non-zero exit.
    for (args, needle) in [
        (vec!["--tau-thermal=-1 s"], "--tau-thermal"),
        (vec!["--tau-thermal", "1 bar"], "--tau-thermal"),
        (vec!["--tau-thermal", "1 s", "--thermal", "adiabatic"], "not both"),
        (vec!["--thermal", "polytropic"], "polytropic"),
    ] {
        let mut all = vec!["conductance", "--volume", "1 L", "--data", "iso.csv"];
        all.extend_from_slice(&args);
        let out = pneumo(&dir.0, &all);
        let err = text(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(needle), "{args:?}: {err}");
        if needle != "polytropic" {
            assert_eq!(err.lines().count(), 1, "{err}");
        }
    }
    // A temperature column in °C is refused with the file named.
    let celsius: String = (0..12).map(|i| format!("{},{},{}\n", i as f64 * 1e-3, 7e5 - 1e4 * i as f64, 20.0 - 0.5 * i as f64)).collect();
    dir.write("celsius.csv", &format!("t,p,T\n{celsius}"));
    let out = pneumo(&dir.0, &["conductance", "--volume", "1 L", "--data", "celsius.csv"]);
    let err = text(&out.stderr);
    assert!(!out.status.success() && err.lines().count() == 1, "{err}");
    assert!(err.contains("celsius.csv") && err.contains("in K"), "{err}");
}

#[test]
fn conductance_reads_pneumo_simulates_own_csv_by_column() {
    let dir = Scratch::new("conductance-columns");
    let model = common::repo().join("models/tank_discharge.json");
    let out = pneumo(&dir.0, &["simulate", model.to_str().expect("utf-8"), "--out", "r.csv"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // the model: 1 L at 7 bar through C = 100 L/min/bar, b = 0.3, adiabatic
    let (rep, _) = json_report(
        &dir.0,
        &["--volume", "1 L", "--data", "r.csv", "--p-column", "tank.p", "--T-column", "tank.T", "--p-atm", "1.013 bar"],
    );
    let (c, b) = c_and_b(&rep);
    assert!((c / 100.0 - 1.0).abs() < 0.02 && (b - 0.3).abs() < 0.05, "C {c} b {b}");
    // the text report prints every number readably: the rejected isothermal
    // limit's dchi2 (~7e17 on noise-free data) once printed 18 digits
    let args =
        ["conductance", "--volume", "1 L", "--data", "r.csv", "--p-column", "tank.p", "--T-column", "tank.T", "--p-atm", "1.013 bar"];
    let out = pneumo(&dir.0, &args);
    let report = text(&out.stdout);
    assert!(out.status.success() && report.contains("isothermal limit rejected"), "{report}");
    let longest_digits = report.split(|c: char| !c.is_ascii_digit()).map(str::len).max().unwrap_or(0);
    assert!(longest_digits <= 10, "a number printed with {longest_digits} digits in a row:\n{report}");
    // without the option, the message says which option reads this file
    let out = pneumo(&dir.0, &["conductance", "--volume", "1 L", "--data", "r.csv"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--p-column tank.p"), "{err}");
    // a misspelt column is named, with the nearest
    let out = pneumo(&dir.0, &["conductance", "--volume", "1 L", "--data", "r.csv", "--p-column", "tank.pp"]);
    let err = text(&out.stderr);
    assert!(err.contains("\"tank.pp\"") && err.contains("did you mean \"tank.p\""), "{err}");
}
