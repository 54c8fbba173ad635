//! Sonic conductance `C` (and critical ratio `b`) of a restriction from a
//! discharge test: a rigid volume `V`, filled to `p0`, empties through the
//! restriction into the atmosphere while its pressure `p(t)` is recorded
//! (paper Eq. 36, after de las Heras 2001; ISO 6358-2:2013 describes a similar
//! discharge method).
//!
//! # (a) Unloading time, paper Eq. 36
//! For an ideal gas (constant γ) in an adiabatic rigid tank, the gas left in the
//! tank expands isentropically (Eq. 17 with V̇ = 0 and Q_w = 0), so
//! `ṗ = −γ·R·T·ṁ/V`. While the flow is choked (`p_atm/p ≤ b`) the ISO 6358 law
//! (Eq. 34/35) gives `ṁ = C·ρ_N·p·(T_N/T)^½`, hence
//! `ṗ/p = −(1/τ_U)·(T/T0)^½`, with the **unloading time**
//!
//! ```text
//! τ_U = K_T0·V / (γ·C·p_N),   K_T0 = (T_N/T0)^½,   p_N = ρ_N·R·T_N      (Eq. 36)
//! ```
//!
//! i.e. τ_U is the initial logarithmic decay time `−p/ṗ` at the start of the
//! discharge (it is the process time of Eq. 19, `V/(γ C p_N)`, corrected to the
//! initial temperature). With `T/T0 = (p/p0)^((γ−1)/γ)` the choked part of the
//! trace has the closed form
//!
//! ```text
//! p(t) = p0·[1 + (γ−1)/(2γ)·t/τ_U]^(−2γ/(γ−1))
//! ```
//!
//! which is fitted (unknowns `p0`, `τ_U`, by [`crate::lsq`]) to the samples from
//! the start of the trace down to `p = p_atm/b_w`, the end of choking; `b_w` is
//! `b` from method (b) unless given. `C` then follows from Eq. 36. Its standard
//! error is that of τ_U from the fit, whose residual scatter estimates the
//! measurement noise (`σ_C/C = σ_τ/τ_U`). `p_N = ρ_N R T_N` (99.72 kPa for air
//! with ρ_N = 1.185 kg/m³, T_N = 293.15 K) makes Eq. 36 exactly consistent with
//! the flow law of [`blocks::iso6358`]; the nominal ANR 100 kPa differs by 0.3 %.
//!
//! # (b) Model fit
//! `C`, `b` and `p0` are fitted by least squares to the whole trace, each
//! residual being the simulated minus the measured pressure. The simulation is
//! the real pneumo model of the test: a netlist (chamber with no piston, one
//! `conductance`, `atmosphere`, same ids as `models/tank_discharge.json`) built
//! through `graph::expand::parse` + `graph::build` and integrated by
//! `solve::simulate` (adiabatic chamber, ideal air; ISO 6358 law with the
//! block's defaults m = 0.5, b_lam = 0.999). Simulated pressures are linearly
//! interpolated at the sample times from a fine output grid. Standard errors
//! come from the fit covariance (`s²(JᵀJ)⁻¹`).
//!
//! # ISO 6358 values implied
//! For each estimate, the steady choked flow at the initial state:
//! `ṁ* = C·ρ_N·p0·K_T0` [kg/s] and its ANR volume flow `ṁ*/ρ_N` [m³/s].
//!
//! # Units, assumptions, validity
//! SI throughout (Pa absolute, K, m³, s, C in m³/(s·Pa)). The time axis starts
//! at the first sample, taken as the opening of the restriction, with the tank
//! at rest at `T0`. Adiabatic walls (fast discharges, paper §2.1: τ_T > τ);
//! ideal gas; uniform tank state; the line volume between tank and restriction
//! belongs to `V`. Method (a) needs a trace that starts choked
//! (`p0 > p_atm/b_w`); method (b) works for any `p0 > p_atm`.

use crate::lsq::{least_squares, Bounds, LsqError, LsqOptions};
use blocks::iso6358::{ANR_DENSITY, ANR_TEMPERATURE};
use gas::GasModel;
use serde::Serialize;
use std::path::Path;

/// A recorded discharge: times [s] (strictly increasing), absolute pressures
/// [Pa] and optionally temperatures [K].
#[derive(Debug, Clone)]
pub struct DischargeData {
    pub t: Vec<f64>,
    pub p: Vec<f64>,
    pub temperature: Option<Vec<f64>>,
}

impl DischargeData {
    /// Check sizes, finiteness, positivity and increasing time.
    pub fn new(t: Vec<f64>, p: Vec<f64>, temperature: Option<Vec<f64>>) -> Result<Self, DischargeError> {
        if t.len() != p.len() || temperature.as_ref().is_some_and(|v| v.len() != t.len()) {
            return Err(DischargeError::BadData("columns of different lengths".into()));
        }
        if t.len() < MIN_SAMPLES {
            return Err(DischargeError::BadData(format!("{} samples, at least {MIN_SAMPLES} needed", t.len())));
        }
        for i in 0..t.len() {
            let p_ok = p[i].is_finite() && p[i] > 0.0;
            if !t[i].is_finite() || !p_ok {
                return Err(DischargeError::BadData(format!("sample {}: t = {}, p = {} (need finite t and p > 0)", i + 1, t[i], p[i])));
            }
            if i > 0 && t[i] <= t[i - 1] {
                return Err(DischargeError::BadData(format!("sample {}: time {} does not increase", i + 1, t[i])));
            }
            if let Some(tt) = &temperature {
                if !(tt[i].is_finite() && tt[i] > 0.0) {
                    return Err(DischargeError::BadData(format!("sample {}: T = {} K", i + 1, tt[i])));
                }
            }
        }
        Ok(DischargeData { t, p, temperature })
    }
}

/// Fewest samples accepted.
pub const MIN_SAMPLES: usize = 10;

/// The test rig.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct DischargeSetup {
    /// Tank (plus line) volume V [m³].
    pub volume: f64,
    /// Atmospheric (downstream) pressure [Pa].
    pub p_atm: f64,
    /// Initial gas temperature T0 [K].
    pub t0: f64,
}

/// What to run.
#[derive(Debug, Clone, Copy)]
pub struct AnalysisOptions {
    /// Critical ratio bounding the choked window of method (a); `None` = `b`
    /// from method (b) (0.528, the ideal-nozzle value, if (b) is not run).
    pub b_window: Option<f64>,
    /// Run method (b).
    pub fit_model: bool,
    /// Parallel Jacobian columns.
    pub parallel: bool,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        AnalysisOptions { b_window: None, fit_model: true, parallel: true }
    }
}

/// Result of method (a).
#[derive(Debug, Clone, Serialize)]
pub struct UnloadingEstimate {
    /// Unloading time τ_U [s] and its standard error.
    pub tau_u: f64,
    pub tau_u_std: f64,
    /// Fitted initial pressure [Pa].
    pub p0: f64,
    pub p0_std: f64,
    /// Sonic conductance from Eq. 36 [m³/(s Pa)] and its standard error.
    pub c: f64,
    pub c_std: f64,
    /// Critical ratio that bounded the window, and the window's lowest pressure [Pa].
    pub b_window: f64,
    pub p_window_min: f64,
    /// Samples used and the window's end time (from the start) [s].
    pub n_points: usize,
    pub t_window_end: f64,
    /// Root-mean-square residual [Pa].
    pub rms: f64,
}

/// Result of method (b).
#[derive(Debug, Clone, Serialize)]
pub struct ModelFitEstimate {
    /// Sonic conductance [m³/(s Pa)], critical ratio, initial pressure [Pa],
    /// each with its standard error.
    pub c: f64,
    pub c_std: f64,
    pub b: f64,
    pub b_std: f64,
    pub p0: f64,
    pub p0_std: f64,
    /// τ_U implied by the fitted C through Eq. 36 [s].
    pub tau_u: f64,
    /// Root-mean-square residual [Pa].
    pub rms: f64,
    pub n_points: usize,
    pub iterations: usize,
    pub simulations: usize,
    pub converged: bool,
}

/// ISO 6358 steady-flow values implied by one estimate.
#[derive(Debug, Clone, Serialize)]
pub struct IsoFlow {
    /// Which estimate ("unloading_time" or "model_fit").
    pub method: String,
    pub c: f64,
    pub b: Option<f64>,
    /// Upstream state [Pa], [K].
    pub p_up: f64,
    pub t_up: f64,
    /// Choked mass flow C ρ_N p K_T [kg/s] and its ANR volume flow [m³/s].
    pub choked_mass_flow: f64,
    pub choked_anr_flow: f64,
}

/// Everything `pneumo conductance` reports.
#[derive(Debug, Clone, Serialize)]
pub struct DischargeReport {
    pub setup: DischargeSetup,
    pub n_samples: usize,
    /// Duration of the trace [s].
    pub duration: f64,
    /// γ at T0 and p_N = ρ_N R T_N [Pa] used in Eq. 36.
    pub gamma: f64,
    pub p_n: f64,
    pub unloading: Option<UnloadingEstimate>,
    /// Why method (a) was not applicable, if it was not.
    pub unloading_note: Option<String>,
    pub model_fit: Option<ModelFitEstimate>,
    pub iso: Vec<IsoFlow>,
}

/// Why an analysis failed.
#[derive(Debug, thiserror::Error)]
pub enum DischargeError {
    #[error("bad discharge data: {0}")]
    BadData(String),
    #[error("bad setup: {0}")]
    BadSetup(String),
    #[error("unloading-time method not applicable: {0}")]
    NotChoked(String),
    #[error("least-squares fit failed: {0}")]
    Fit(#[from] LsqError),
    #[error("simulation of the discharge failed: {0}")]
    Simulation(String),
}

/// Ideal air, as in the simulation model.
fn air() -> gas::IdealGas {
    gas::IdealGas::air()
}

/// γ of ideal air at temperature `t0` (constant for the ideal model).
pub fn gamma_air(t0: f64) -> f64 {
    let g = air();
    g.gamma(g.density(ANR_DENSITY * g.r() * ANR_TEMPERATURE, t0), t0)
}

/// p_N = ρ_N·R·T_N [Pa], the reference pressure that makes Eq. 36 exact for
/// the ISO 6358 flow law with reference density ρ_N.
pub fn reference_pressure() -> f64 {
    ANR_DENSITY * air().r() * ANR_TEMPERATURE
}

/// Eq. 36: C = K_T0·V/(γ·p_N·τ_U) [m³/(s Pa)].
pub fn conductance_from_unloading_time(tau_u: f64, volume: f64, gamma: f64, t0: f64) -> f64 {
    (ANR_TEMPERATURE / t0).sqrt() * volume / (gamma * reference_pressure() * tau_u)
}

/// Eq. 36 solved for τ_U [s].
pub fn unloading_time_from_conductance(c: f64, volume: f64, gamma: f64, t0: f64) -> f64 {
    (ANR_TEMPERATURE / t0).sqrt() * volume / (gamma * reference_pressure() * c)
}

/// Closed form of adiabatic choked discharge:
/// p(t) = p0·[1 + (γ−1)/(2γ)·t/τ_U]^(−2γ/(γ−1)).
pub fn choked_pressure(t: f64, p0: f64, tau_u: f64, gamma: f64) -> f64 {
    let k = (gamma - 1.0) / (2.0 * gamma);
    p0 * (1.0 + k * t / tau_u).powf(-1.0 / k)
}

fn check_setup(s: &DischargeSetup) -> Result<(), DischargeError> {
    let ok = |x: f64| x.is_finite() && x > 0.0;
    if !ok(s.volume) || !ok(s.p_atm) || !ok(s.t0) {
        return Err(DischargeError::BadSetup(format!(
            "V = {} m3, p_atm = {} Pa, T0 = {} K must be finite and > 0",
            s.volume, s.p_atm, s.t0
        )));
    }
    Ok(())
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

/// Rough τ from the first 20 % of the pressure excess lost, for start values.
fn rough_tau(data: &DischargeData, p_atm: f64) -> f64 {
    let (t0, p0) = (data.t[0], data.p[0]);
    let target = p0 - 0.2 * (p0 - p_atm).max(0.0);
    let i = data.p.iter().position(|&p| p <= target).unwrap_or(data.p.len() - 1).max(1);
    let ratio = (data.p[i] / p0).clamp(1e-6, 1.0 - 1e-9);
    let tau = -(data.t[i] - t0) / ratio.ln();
    if tau.is_finite() && tau > 0.0 {
        tau
    } else {
        (data.t[data.t.len() - 1] - t0) / 3.0
    }
}

/// Method (a): fit the choked closed form to the samples with p ≥ p_atm/b_window.
pub fn estimate_unloading(data: &DischargeData, setup: &DischargeSetup, b_window: f64) -> Result<UnloadingEstimate, DischargeError> {
    check_setup(setup)?;
    if !(b_window > 0.0 && b_window < 1.0) {
        return Err(DischargeError::BadSetup(format!("choked-window critical ratio {b_window} not in (0, 1)")));
    }
    let gamma = gamma_air(setup.t0);
    let p_min = setup.p_atm / b_window;
    let n = data.p.iter().position(|&p| p < p_min).unwrap_or(data.p.len());
    if n < 5 {
        return Err(DischargeError::NotChoked(format!(
            "only {n} samples above p_atm/b = {:.4} bar (the trace must start choked: p0 > p_atm/b)",
            p_min / 1e5
        )));
    }
    let t: Vec<f64> = data.t[..n].iter().map(|v| v - data.t[0]).collect();
    let p = &data.p[..n];
    let p_scale = data.p[0];
    let tau_scale = rough_tau(data, setup.p_atm);
    let f = |x: &[f64]| -> Result<Vec<f64>, String> {
        let (p0, tau) = (x[0] * p_scale, x[1] * tau_scale);
        Ok(t.iter().zip(p).map(|(&ti, &pi)| choked_pressure(ti, p0, tau, gamma) - pi).collect())
    };
    let bounds = Bounds::new(vec![0.5, 1e-4], vec![2.0, 1e4]);
    let opts = LsqOptions { parallel: false, ..LsqOptions::default() };
    let res = least_squares(f, &[1.0, 1.0], &bounds, &opts)?;
    let se = res.std_errors.clone().unwrap_or_else(|| vec![f64::NAN; 2]);
    let tau_u = res.x[1] * tau_scale;
    let tau_u_std = se[1] * tau_scale;
    let c = conductance_from_unloading_time(tau_u, setup.volume, gamma, setup.t0);
    Ok(UnloadingEstimate {
        tau_u,
        tau_u_std,
        p0: res.x[0] * p_scale,
        p0_std: se[0] * p_scale,
        c,
        c_std: c * tau_u_std / tau_u,
        b_window,
        p_window_min: p_min,
        n_points: n,
        t_window_end: t[n - 1],
        rms: rms(&res.residuals),
    })
}

/// The discharge netlist (same ids as `models/tank_discharge.json`) for a
/// conductance `c`, critical ratio `b` and initial pressure `p0`, all SI.
pub fn discharge_netlist(setup: &DischargeSetup, c: f64, b: f64, p0: f64, t_end: f64) -> serde_json::Value {
    serde_json::json!({
        "name": "discharge_fit",
        "gas": { "model": "ideal", "species": "air" },
        "components": [
            { "id": "tank", "type": "chamber",
              "params": { "dead_volume": setup.volume, "area": 0.0, "tau_thermal": "inf", "T_wall": setup.t0 },
              "init": { "p0": p0, "T0": setup.t0 } },
            { "id": "orifice", "type": "conductance", "params": { "C": c, "b": b } },
            { "id": "atmosphere", "type": "atmosphere", "params": { "p": setup.p_atm, "T": setup.t0 } }
        ],
        "connections": [["tank.port", "orifice.a"], ["orifice.b", "atmosphere.port"]],
        "simulation": { "t_end": t_end }
    })
}

/// Simulate the discharge and return the tank pressure at `times` (seconds
/// from the opening, increasing, ≥ 0).
pub fn simulate_discharge(setup: &DischargeSetup, c: f64, b: f64, p0: f64, times: &[f64]) -> Result<Vec<f64>, String> {
    let t_last = times.last().copied().unwrap_or(0.0);
    let t_end = t_last.max(1e-9);
    let text = discharge_netlist(setup, c, b, p0, t_end).to_string();
    let netlist = graph::expand::parse(&text, "discharge_fit").map_err(|e| e.to_string())?;
    let flat = graph::expand::flatten(&crate::netlist_edit::NoFiles, &netlist, Path::new(""), 0).map_err(|e| e.to_string())?;
    let circuit = graph::build(&flat).map_err(|e| e.to_string())?;
    let mut model = solve::Model::new(circuit);
    let mut spacing: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    spacing.sort_by(f64::total_cmp);
    let median = spacing.get(spacing.len() / 2).copied().unwrap_or(t_end);
    let opts = solve::SimOptions {
        t_end,
        cycles: None,
        rtol: 1e-10,
        atol: 1e-10,
        sample_interval: median.min(t_end / 2000.0),
        max_step: t_end / 50.0,
        max_events: 1000,
    };
    let result = solve::simulate(&mut model, &opts).map_err(|e| e.to_string())?;
    let series = result.series("tank.p").ok_or("no tank.p in the results")?;
    if series.is_empty() {
        return Err("empty simulation result".into());
    }
    Ok(interpolate(&series, times))
}

/// Interpolation of a sorted (t, v) series at sorted `times` (clamped at the
/// ends): cubic Lagrange through the two samples either side (error O(Δt⁴)),
/// linear where the series has fewer than four samples or nearly coincident
/// ones (event instants).
fn interpolate(series: &[(f64, f64)], times: &[f64]) -> Vec<f64> {
    let n = series.len();
    let mut out = Vec::with_capacity(times.len());
    let mut k = 0;
    for &t in times {
        while k + 2 < n && series[k + 1].0 < t {
            k += 1;
        }
        if n == 1 || t <= series[0].0 {
            out.push(series[0].1);
            continue;
        }
        if t >= series[n - 1].0 {
            out.push(series[n - 1].1);
            continue;
        }
        let (t0, v0) = series[k];
        let (t1, v1) = series[k + 1];
        let linear = v0 + (v1 - v0) * (t - t0) / (t1 - t0);
        if n < 4 {
            out.push(linear);
            continue;
        }
        let lo = k.saturating_sub(1).min(n - 4);
        let nodes = &series[lo..lo + 4];
        let min_gap = nodes.windows(2).map(|w| w[1].0 - w[0].0).fold(f64::INFINITY, f64::min);
        if min_gap <= 1e-6 * (t1 - t0) {
            out.push(linear);
            continue;
        }
        let mut v = 0.0;
        for (a, &(ta, va)) in nodes.iter().enumerate() {
            let mut w = 1.0;
            for (c, &(tc, _)) in nodes.iter().enumerate() {
                if c != a {
                    w *= (t - tc) / (ta - tc);
                }
            }
            v += w * va;
        }
        out.push(v);
    }
    out
}

/// Method (b): fit C, b and p0 of the simulated discharge to the whole trace.
pub fn fit_discharge_model(data: &DischargeData, setup: &DischargeSetup, parallel: bool) -> Result<ModelFitEstimate, DischargeError> {
    check_setup(setup)?;
    if data.p[0] <= setup.p_atm {
        return Err(DischargeError::BadData(format!(
            "the trace starts at {:.4} bar, not above p_atm = {:.4} bar",
            data.p[0] / 1e5,
            setup.p_atm / 1e5
        )));
    }
    let gamma = gamma_air(setup.t0);
    let times: Vec<f64> = data.t.iter().map(|v| v - data.t[0]).collect();
    let c_scale = conductance_from_unloading_time(rough_tau(data, setup.p_atm), setup.volume, gamma, setup.t0);
    let p_scale = data.p[0];
    let f = |x: &[f64]| -> Result<Vec<f64>, String> {
        let sim = simulate_discharge(setup, x[0] * c_scale, x[1], x[2] * p_scale, &times)?;
        Ok(sim.iter().zip(&data.p).map(|(s, m)| s - m).collect())
    };
    let p0_lo = (setup.p_atm * (1.0 + 1e-6) / p_scale).max(0.5);
    let bounds = Bounds::new(vec![1e-3, 0.02, p0_lo], vec![1e3, 0.95, 2.0_f64.max(p0_lo)]);
    let opts = LsqOptions { max_iter: 100, ftol: 1e-10, xtol: 1e-9, gtol: 1e-8, fd_rel_step: 1e-6, parallel };
    let res = least_squares(f, &[1.0, 0.3, 1.0], &bounds, &opts)?;
    let se = res.std_errors.clone().unwrap_or_else(|| vec![f64::NAN; 3]);
    let c = res.x[0] * c_scale;
    Ok(ModelFitEstimate {
        c,
        c_std: se[0] * c_scale,
        b: res.x[1],
        b_std: se[1],
        p0: res.x[2] * p_scale,
        p0_std: se[2] * p_scale,
        tau_u: unloading_time_from_conductance(c, setup.volume, gamma, setup.t0),
        rms: rms(&res.residuals),
        n_points: data.p.len(),
        iterations: res.iterations,
        simulations: res.evaluations,
        converged: res.converged,
    })
}

/// ISO 6358 choked flow of conductance `c` at upstream `p_up`, `t_up`.
pub fn iso_flow(method: &str, c: f64, b: Option<f64>, p_up: f64, t_up: f64) -> IsoFlow {
    let mdot = c * ANR_DENSITY * p_up * (ANR_TEMPERATURE / t_up).sqrt();
    IsoFlow { method: method.to_string(), c, b, p_up, t_up, choked_mass_flow: mdot, choked_anr_flow: mdot / ANR_DENSITY }
}

/// Run both methods and collect the report. Method (a) failing for lack of a
/// choked phase is reported as a note, not an error.
pub fn analyse(data: &DischargeData, setup: &DischargeSetup, opts: &AnalysisOptions) -> Result<DischargeReport, DischargeError> {
    check_setup(setup)?;
    let model_fit = if opts.fit_model { Some(fit_discharge_model(data, setup, opts.parallel)?) } else { None };
    let b_window = opts.b_window.or(model_fit.as_ref().map(|m| m.b)).unwrap_or(0.528);
    let (unloading, unloading_note) = match estimate_unloading(data, setup, b_window) {
        Ok(u) => (Some(u), None),
        Err(DischargeError::NotChoked(m)) => (None, Some(m)),
        Err(e) => return Err(e),
    };
    let mut iso = Vec::new();
    if let Some(u) = &unloading {
        iso.push(iso_flow("unloading_time", u.c, None, u.p0, setup.t0));
    }
    if let Some(m) = &model_fit {
        iso.push(iso_flow("model_fit", m.c, Some(m.b), m.p0, setup.t0));
    }
    Ok(DischargeReport {
        setup: *setup,
        n_samples: data.t.len(),
        duration: data.t[data.t.len() - 1] - data.t[0],
        gamma: gamma_air(setup.t0),
        p_n: reference_pressure(),
        unloading,
        unloading_note,
        model_fit,
        iso,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LPMB: f64 = 1e-3 / 60.0 / 1e5; // 1 L/min/bar in m³/(s Pa)

    use crate::synth::Rng as Normal;

    struct Fs;
    impl graph::Loader for Fs {
        fn read(&self, path: &Path) -> Result<String, String> {
            std::fs::read_to_string(path).map_err(|e| e.to_string())
        }
    }

    fn models_dir() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
    }

    /// Simulate models/tank_discharge.json with the given C, b and add noise.
    fn synthetic(c_lpmb: f64, b: f64, sigma: f64, seed: u64) -> DischargeData {
        let mut flat = graph::load(&Fs, &models_dir().join("tank_discharge.json")).expect("load model");
        graph::apply_set(&mut flat, &format!("orifice.C={c_lpmb} L/min/bar")).expect("set C");
        graph::apply_set(&mut flat, &format!("orifice.b={b}")).expect("set b");
        let circuit = graph::build(&flat).expect("build");
        let opts = solve::options_from(&circuit.simulation).expect("options");
        let mut model = solve::Model::new(circuit);
        let res = solve::simulate(&mut model, &opts).expect("simulate");
        let s = res.series("tank.p").expect("tank.p");
        let mut rng = Normal::new(seed);
        let t = s.iter().map(|x| x.0).collect();
        let p = s.iter().map(|x| x.1 + sigma * rng.normal()).collect();
        DischargeData::new(t, p, None).expect("data")
    }

    /// The rig of models/tank_discharge.json.
    fn setup() -> DischargeSetup {
        DischargeSetup { volume: 1e-3, p_atm: 1.013e5, t0: 293.15 }
    }

    #[test]
    fn eq36_round_trip_and_closed_form_matches_simulation() {
        let g = gamma_air(293.15);
        assert!((g - 1004.85 / 717.8).abs() < 1e-12);
        let c = 100.0 * LPMB;
        let tau = unloading_time_from_conductance(c, 1e-3, g, 293.15);
        // Hand value: 1e-3 / (1.39993 · 99 716.7 · 1.6667e-7) = 0.42980 s.
        assert!((tau - 0.42980).abs() < 1e-4, "{tau}");
        assert!((conductance_from_unloading_time(tau, 1e-3, g, 293.15) / c - 1.0).abs() < 1e-14);
        // Colder gas: K_T0 > 1, longer τ_U.
        assert!(unloading_time_from_conductance(c, 1e-3, g, 250.0) > tau);
        // The closed form reproduces the simulated choked phase (no noise).
        let d = synthetic(100.0, 0.3, 0.0, 1);
        let s = setup();
        for (t, p) in d.t.iter().zip(&d.p) {
            if s.p_atm / p > 0.3 {
                break;
            }
            let pc = choked_pressure(*t, 7e5, tau, g);
            assert!((pc - p).abs() < 1e-6 * p, "t = {t}: {pc} vs {p}");
        }
        // and the library's own simulation matches the model file's.
        let own = simulate_discharge(&s, c, 0.3, 7e5, &d.t).expect("sim");
        // (the model file integrates with rtol 1e-8; global error a few 1e-8·p)
        for (a, b) in own.iter().zip(&d.p) {
            assert!((a - b).abs() < 1e-7 * b, "{a} vs {b}");
        }
    }

    #[test]
    fn cubic_interpolation_is_exact_for_cubics() {
        let f = |t: f64| 2.0 - t + 0.5 * t * t - 0.25 * t * t * t;
        let grid: Vec<(f64, f64)> = [0.0, 0.1, 0.25, 0.3, 0.5, 0.8, 1.0].iter().map(|&t| (t, f(t))).collect();
        let times = [-0.5, 0.0, 0.05, 0.26, 0.31, 0.79, 0.999, 1.0, 2.0];
        let v = interpolate(&grid, &times);
        for (t, vi) in times.iter().zip(&v) {
            let expect = f(t.clamp(0.0, 1.0));
            assert!((vi - expect).abs() < 1e-12, "t = {t}: {vi} vs {expect}");
        }
        // Two points: linear.
        let v = interpolate(&[(0.0, 1.0), (1.0, 3.0)], &[0.25]);
        assert!((v[0] - 1.5).abs() < 1e-15);
    }

    #[test]
    fn noise_free_trace_gives_exact_values() {
        let d = synthetic(100.0, 0.3, 0.0, 1);
        let u = estimate_unloading(&d, &setup(), 0.3).expect("tau");
        assert!((u.c / (100.0 * LPMB) - 1.0).abs() < 1e-5, "{}", u.c / LPMB);
        assert!((u.p0 / 7e5 - 1.0).abs() < 1e-7);
        let m = fit_discharge_model(&d, &setup(), true).expect("fit");
        assert!(m.converged);
        assert!((m.c / (100.0 * LPMB) - 1.0).abs() < 1e-4, "{}", m.c / LPMB);
        assert!((m.b - 0.3).abs() < 1e-3, "{}", m.b);
        assert!(m.rms < 1.0, "rms {} Pa", m.rms);
    }

    #[test]
    fn noisy_traces_recover_c_and_b() {
        // σ = 5 mbar; several conductances, critical ratios and seeds.
        let sigma = 500.0;
        for (c, b, seed) in [(100.0, 0.3, 11), (100.0, 0.3, 12), (60.0, 0.45, 13), (150.0, 0.2, 14)] {
            let d = synthetic(c, b, sigma, seed);
            let rep = analyse(&d, &setup(), &AnalysisOptions::default()).expect("analyse");
            let u = rep.unloading.as_ref().expect("unloading estimate");
            let m = rep.model_fit.as_ref().expect("model fit");
            let ea = u.c / (c * LPMB) - 1.0;
            let eb = m.c / (c * LPMB) - 1.0;
            eprintln!(
                "C = {c} L/min/bar, b = {b}, seed {seed}: (a) C error {:+.3} % (±{:.3} %), (b) C error {:+.3} % (±{:.3} %), b error {:+.4} (±{:.4}), {} simulations",
                100.0 * ea,
                100.0 * u.c_std / u.c,
                100.0 * eb,
                100.0 * m.c_std / m.c,
                m.b - b,
                m.b_std,
                m.simulations
            );
            assert!(ea.abs() < 0.03, "C={c} b={b} seed {seed}: method a error {ea}");
            assert!(eb.abs() < 0.03, "C={c} b={b} seed {seed}: method b error {eb}");
            assert!((m.b - b).abs() < 0.05, "b {} vs {b}", m.b);
            // The residual scatter matches the noise, and the reported
            // uncertainties cover the errors.
            assert!((m.rms / sigma - 1.0).abs() < 0.1, "rms {}", m.rms);
            assert!((u.rms / sigma - 1.0).abs() < 0.2, "rms {}", u.rms);
            assert!((m.c - c * LPMB).abs() < 4.0 * m.c_std);
            assert!((u.c - c * LPMB).abs() < 4.0 * u.c_std);
            assert!((m.b - b).abs() < 4.0 * m.b_std);
            // ISO 6358 choked flow at p0 follows from C.
            let iso = &rep.iso[1];
            assert!((iso.choked_mass_flow - m.c * ANR_DENSITY * m.p0).abs() < 1e-12);
        }
    }

    #[test]
    fn unchoked_trace_is_a_note_not_an_error() {
        // Starting at 1.6 bar into 1.013 bar: never choked for b = 0.3.
        let s = setup();
        let t: Vec<f64> = (0..400).map(|i| i as f64 * 2e-3).collect();
        let p = simulate_discharge(&s, 100.0 * LPMB, 0.3, 1.6e5, &t).expect("sim");
        let d = DischargeData::new(t, p, None).expect("data");
        let rep = analyse(&d, &s, &AnalysisOptions::default()).expect("analyse");
        assert!(rep.unloading.is_none());
        assert!(rep.unloading_note.as_deref().unwrap_or("").contains("choked"));
        let m = rep.model_fit.expect("fit");
        assert!((m.c / (100.0 * LPMB) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn bad_data_is_rejected() {
        let t = (0..20).map(|i| i as f64).collect::<Vec<_>>();
        let mut p = vec![2e5; 20];
        p[3] = -1.0;
        assert!(matches!(DischargeData::new(t.clone(), p, None), Err(DischargeError::BadData(_))));
        let mut t2 = t.clone();
        t2[5] = t2[4];
        assert!(DischargeData::new(t2, vec![2e5; 20], None).unwrap_err().to_string().contains("sample 6"));
        assert!(DischargeData::new(t[..5].to_vec(), vec![2e5; 5], None).is_err());
        let d = DischargeData::new(t, vec![2e5; 20], None).expect("data");
        let bad = DischargeSetup { volume: 0.0, ..setup() };
        assert!(matches!(analyse(&d, &bad, &AnalysisOptions::default()), Err(DischargeError::BadSetup(_))));
    }
}
