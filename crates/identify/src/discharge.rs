//! Sonic conductance `C` (and critical ratio `b`) of a restriction from a
//! discharge test: a rigid volume `V`, filled to `p0`, empties through the
//! restriction into the atmosphere while its pressure `p(t)` (and perhaps a
//! temperature `T(t)`) is recorded (paper Eq. 36, after de las Heras 2001;
//! ISO 6358-2:2013 describes a similar discharge method). The tank exchanges
//! heat with its wall; how much is the thermal model of the test.
//!
//! # The energy balance of the discharge (paper Eq. 36 generalised)
//! Rigid tank (V̇ = 0), ideal gas (Eq. 15), outflow only, uniform state; the
//! wall, at T_w = T0 (the tank is at rest before the opening), exchanges
//! Q_w = m·c_v·(T_w − T)/τ_T (Eq. 8). The ISO 6358 law (Eq. 33–35) gives
//! `ṁ = −C·ρ_N·p·(T_N/T)^½·ω(p_atm/p)`, and Eq. 17 with V̇ = 0 gives
//! `Ṫ = (T_w − T)/τ_T + R·T·ṁ/(c_v·m)`. With p = m·R·T/V, R/c_v = γ − 1 and
//! m = p·V/(R·T):
//!
//! ```text
//! ṁ/m = −(1/(γ τ_U))·(T/T0)^½·ω,     τ_U = K_T0·V/(γ·C·p_N)   (Eq. 36)
//! ṗ/p = ṁ/m + Ṫ/T = −(1/τ_U)·(T/T0)^½·ω + (T_w − T)/(T·τ_T)
//! Ṫ/T = −((γ−1)/γ)·(1/τ_U)·(T/T0)^½·ω + (T_w − T)/(T·τ_T)
//! ```
//!
//! with K_T0 = (T_N/T0)^½ and p_N = ρ_N·R·T_N (99.72 kPa for air with
//! ρ_N = 1.185 kg/m³, T_N = 293.15 K; it makes Eq. 36 exactly consistent with
//! [`blocks::iso6358`]; the nominal ANR 100 kPa differs by 0.3 %). At the
//! opening T = T_w, so the initial decay rate is 1/τ_U whatever τ_T: the
//! thermal time constant only sets how soon, and how far, the curve leaves
//! the adiabatic one. Limits:
//!
//! - **adiabatic**, τ_T → ∞: Ṫ/T = ((γ−1)/γ)·ṗ/p, so T/T0 = (p/p0)^((γ−1)/γ)
//!   and, while choked (ω = 1), ṗ/p = −(1/τ_U)·(p/p0)^((γ−1)/(2γ)), whose
//!   solution is the closed form of method (a),
//!   `p(t) = p0·[1 + (γ−1)/(2γ)·t/τ_U]^(−2γ/(γ−1))`: Eq. 36 is this limit;
//! - **isothermal**, τ_T → 0: T = T_w, the wall supplies the flow work,
//!   Q_w → −R·T·ṁ = p·|ṁ|/ρ (finite while T_w − T → 0), and ṗ/p = ṁ/m =
//!   −1/(γ τ_U): `p(t) = p0·exp(−t/(γ τ_U))`, i.e. Eq. 36 with γ replaced by
//!   n = 1. Along any polytrope of index n the same steps give
//!   `p = p0·[1 + (n−1)/(2n)·t/τ_n]^(−2n/(n−1))`, C = K_T0·V/(n·p_N·τ_n)
//!   ([`choked_pressure_polytropic`]); only n = γ and n = 1 are exact for a
//!   wall heat of Eq. 8;
//! - **finite τ_T**: no closed form; the trace is simulated.
//!
//! Read against these, an adiabatic fit of an isothermal trace sees a decay
//! slower than its model allows for the true C and returns too small a C
//! (77.7 L/min/bar for 100, with b = 0.63 for 0.3 and a misfit of 27 mbar
//! against 5 mbar of noise: the curve shapes differ).
//!
//! # (a) Unloading time, paper Eq. 36
//! The choked closed form above (unknowns `p0`, `τ`) is fitted by
//! [`crate::lsq`] to the samples from the opening down to `p = p_atm/b_w`,
//! the end of choking (`b_w` = `b` from method (b) unless given), with
//! n = γ, or n = 1 when method (b) finds the discharge isothermal; C follows
//! from Eq. 36. When (b) finds a finite τ_T, (a) is still the adiabatic
//! limit and carries a caveat: its C is biased low. σ_C/C = σ_τ/τ from the
//! fit's residual scatter.
//!
//! # (b) Model fit, with the thermal model
//! `C`, `b` and `p0` are fitted by least squares to the whole trace, each
//! residual the simulated minus the measured pressure divided by the
//! pressure noise. The simulation is the real pneumo model of the test: a
//! netlist (chamber with no piston and `tau_thermal` = τ_T, `T_wall` = T0,
//! one `conductance`, `atmosphere`, same ids as `models/tank_discharge.json`)
//! built through `graph::expand::parse` + `graph::build` and integrated by
//! `solve::simulate` (ideal air; ISO 6358 law with the block's defaults
//! m = 0.5, b_lam = 0.999), output on 4000 steps and interpolated (cubic) at
//! the sample times. Standard errors come from the fit covariance
//! (`s²(JᵀJ)⁻¹`). The thermal model ([`ThermalOption`]):
//!
//! - imposed: adiabatic (τ_T = ∞), isothermal (τ_T = [`ISOTHERMAL_FRACTION`]·τ,
//!   T stays within 0.1 K of the wall), or a τ_T given by the caller;
//! - **automatic** (default): three fits — adiabatic, isothermal, and τ_T
//!   free (started from three points; parameter s = τ/(τ + τ_T) ∈ [0, 1],
//!   which keeps both limits at finite distance) — then a limit is kept when
//!   the data do not reject it: Δχ² = 2·(cost_limit − cost_best)/s² ≤ 10.83
//!   (likelihood-ratio test at 0.1 %, one degree of freedom; s² the residual
//!   variance of the best fit), or when the free τ_T lies beyond
//!   [0.01, 100]·τ (τ = V/(γ C p_N), Eq. 19: there the limit's C differs from
//!   the free one by < 0.2 % and b by < 0.02, measured on noise-free traces,
//!   so a noise-free trace is not called "finite τ_T = 400 s"). Neither limit
//!   rejected: τ_T is not identifiable and the adiabatic limit (the Eq. 36
//!   assumption) is kept, with a warning giving the isothermal C. Both
//!   rejected: the free fit. Adiabatic and isothermal traces have different
//!   shapes (the choked phase is a power law in one, an exponential in the
//!   other, and b moves the subsonic tail), so at 1 kHz and 5 mbar the
//!   choice is clear-cut on full traces.
//! - **measured temperature**: when the data have a `T` column, the automatic
//!   fits are joint fits of p and T (T residuals divided by the T noise),
//!   with two more parameters: T0 (= T_w; a noisy first sample would
//!   otherwise bias the whole T channel) and the time constant of a
//!   first-order sensor, T_s' = (T − T_s)/τ_s (exact for the piecewise-linear
//!   simulated T). The T column is *not* used to drive the mass balance
//!   (m = pV/(RT_measured)): real sensors lag, and a lag of 50 ms already
//!   biases such a C by +4 % on a 0.43 s discharge (+14 % at 0.2 s), while
//!   the joint fit finds the lag and keeps C within 0.1 %.
//!
//! The downstream pressure is the caller's p_atm, or fitted too
//! ([`AnalysisOptions::fit_p_atm`]) from [`p_atm_start`]. A pre-trigger
//! segment before the opening is found and left out ([`find_opening`]).
//!
//! # Diagnostics
//! The report carries the noise levels estimated from the data
//! ([`crate::data::noise_sigma`]), the misfit (RMS, lag-1 autocorrelation of
//! the residuals) and one-line warnings: a fit leaving an RMS above 1.5×
//! the noise (at least 1 mbar) with residuals correlated from sample to
//! sample (lag-1 > 0.5) — for an imposed adiabatic model, "the discharge is
//! not adiabatic"; a temperature misfit above 3× its noise; no convergence;
//! τ_T not identifiable.
//!
//! # ISO 6358 values implied
//! For each estimate, the steady choked flow at the initial state:
//! `ṁ* = C·ρ_N·p0·K_T0` [kg/s] and its ANR volume flow `ṁ*/ρ_N` [m³/s].
//!
//! # Units, assumptions, validity
//! SI throughout (Pa absolute, K, m³, s, C in m³/(s·Pa)). The tank is at
//! rest at T0 = T_w when the restriction opens; ideal gas; uniform tank
//! state; the line volume between tank and restriction belongs to `V`; the
//! wall temperature stays T_w; one τ_T for the whole test (Eq. 8). Method
//! (a) needs a trace that starts choked (`p0 > p_atm/b_w`); method (b)
//! works for any `p0 > p_atm`, but τ_T and b need the trace to go well into
//! the subsonic phase.

use crate::data::noise_sigma;
use crate::lsq::{least_squares, Bounds, JacobianUpdate, LsqError, LsqOptions};
use crate::stats::autocorrelation;
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
                return Err(DischargeError::BadData(format!(
                    "sample {}: t = {}, p = {} (need finite t and p > 0)",
                    i + 1,
                    units::show::num(t[i]),
                    units::show::num(p[i])
                )));
            }
            if i > 0 && t[i] <= t[i - 1] {
                return Err(DischargeError::BadData(format!("sample {}: time {} does not increase", i + 1, units::show::num(t[i]))));
            }
            if let Some(tt) = &temperature {
                if !(tt[i].is_finite() && tt[i] > 0.0) {
                    return Err(DischargeError::BadData(format!("sample {}: T = {} K", i + 1, units::show::num(tt[i]))));
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
    /// Initial gas temperature T0 [K], also the wall temperature T_w.
    pub t0: f64,
}

/// How the heat exchange with the tank wall is treated (see the module
/// header, "(b) Model fit").
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ThermalOption {
    /// Fit τ_T with C, b and p0 (to the pressure trace, and to the
    /// temperature trace when there is one and it is used), then keep a
    /// limit (adiabatic or isothermal) unless the data reject it.
    #[default]
    Auto,
    /// τ_T = ∞ (the assumption of paper Eq. 36).
    Adiabatic,
    /// τ_T → 0: the gas stays at the wall temperature.
    Isothermal,
    /// A finite τ_T [s] known beforehand.
    Given(f64),
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
    /// Thermal model of method (b).
    pub thermal: ThermalOption,
    /// With [`ThermalOption::Auto`], fit the temperature column too when the
    /// data have one.
    pub use_temperature: bool,
    /// Fit the downstream pressure too, started at the setup's `p_atm`
    /// (for a barometric pressure not measured: it varies by ±3 kPa with the
    /// weather and falls by 1.2 kPa per 100 m of altitude).
    pub fit_p_atm: bool,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        AnalysisOptions {
            b_window: None,
            fit_model: true,
            parallel: true,
            thermal: ThermalOption::Auto,
            use_temperature: true,
            fit_p_atm: false,
        }
    }
}

/// The thermal behaviour of a fitted model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ThermalModel {
    /// τ_T = ∞.
    Adiabatic,
    /// τ_T → 0 (simulated with τ_T = [`ISOTHERMAL_FRACTION`]·τ).
    Isothermal,
    /// A finite τ_T.
    FiniteTau,
}

impl ThermalModel {
    /// Human-readable name.
    pub fn name(self) -> &'static str {
        match self {
            ThermalModel::Adiabatic => "adiabatic",
            ThermalModel::Isothermal => "isothermal",
            ThermalModel::FiniteTau => "finite tau_T",
        }
    }
}

/// Where the thermal model came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ThermalSource {
    /// Imposed by the caller (adiabatic or isothermal).
    Forced,
    /// τ_T given by the caller.
    Given,
    /// Chosen from fits to the pressure trace.
    FittedPressure,
    /// Chosen from joint fits to the pressure and (measured) temperature traces.
    FittedPressureTemperature,
}

impl ThermalSource {
    /// Human-readable description.
    pub fn describe(self) -> &'static str {
        match self {
            ThermalSource::Forced => "imposed",
            ThermalSource::Given => "tau_T given",
            ThermalSource::FittedPressure => "fitted to the pressure trace",
            ThermalSource::FittedPressureTemperature => "fitted to the pressure and measured temperature traces",
        }
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
    /// Exponent n of the closed form: γ (adiabatic, Eq. 36 itself) or 1
    /// (isothermal limit).
    pub polytropic_index: f64,
    /// Why this estimate is biased for the thermal model found by (b), if it is.
    pub caveat: Option<String>,
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
    /// Initial (and wall) temperature of the simulation [K]: the setup's T0,
    /// or fitted with its standard error when a temperature column is fitted.
    pub t0: f64,
    pub t0_std: Option<f64>,
    /// Downstream pressure of the simulation [Pa]: the setup's, or fitted
    /// with its standard error ([`AnalysisOptions::fit_p_atm`]).
    pub p_atm: f64,
    pub p_atm_std: Option<f64>,
    /// Thermal model of this fit.
    pub thermal_model: ThermalModel,
    /// τ_T [s]: `None` = ∞ (adiabatic), 0 = isothermal; standard error when fitted.
    pub tau_thermal: Option<f64>,
    pub tau_thermal_std: Option<f64>,
    /// Time constant of the first-order temperature sensor [s] (joint fits
    /// with a temperature column) and its standard error.
    pub sensor_lag: Option<f64>,
    pub sensor_lag_std: Option<f64>,
    /// τ_U implied by the fitted C through Eq. 36 [s].
    pub tau_u: f64,
    /// Root-mean-square pressure residual [Pa].
    pub rms: f64,
    /// Root-mean-square temperature residual [K] (joint fits).
    pub rms_temperature: Option<f64>,
    /// Lag-1 autocorrelation of the pressure residuals (≈ 0 for a model
    /// that leaves white noise, → 1 for a systematic misfit).
    pub residual_lag1: f64,
    pub n_points: usize,
    pub iterations: usize,
    pub simulations: usize,
    pub converged: bool,
}

/// One thermal model tried by the automatic choice.
#[derive(Debug, Clone, Serialize)]
pub struct ThermalCandidate {
    pub model: ThermalModel,
    pub c: f64,
    pub b: f64,
    pub tau_thermal: Option<f64>,
    /// Pressure misfit [Pa] and temperature misfit [K].
    pub rms: f64,
    pub rms_temperature: Option<f64>,
    /// Increase of the noise-normalised χ² over the best fit.
    pub delta_chi2: f64,
    /// Rejected by the likelihood-ratio test (limits only).
    pub rejected: bool,
}

/// The thermal model used by method (b), and why.
#[derive(Debug, Clone, Serialize)]
pub struct ThermalSelection {
    pub model: ThermalModel,
    pub source: ThermalSource,
    /// τ_T [s] (`None` = ∞) and its standard error when fitted.
    pub tau_thermal: Option<f64>,
    pub tau_thermal_std: Option<f64>,
    /// Process time O(τ) = V/(γ C p_N) of the fitted C (paper Eq. 19) [s],
    /// and τ_T/τ.
    pub process_time: f64,
    pub tau_ratio: Option<f64>,
    /// Δχ² above which a limit is rejected.
    pub threshold: f64,
    /// Fits compared (automatic choice only).
    pub candidates: Vec<ThermalCandidate>,
    /// One sentence: what was compared and what was kept.
    pub decision: String,
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
    /// Samples in the file.
    pub n_samples: usize,
    /// The opening found in the trace ([`find_opening`]); the analyses use
    /// the samples from it on.
    pub opening: Opening,
    /// Duration of the trace from the opening [s].
    pub duration: f64,
    /// γ at T0 and p_N = ρ_N R T_N [Pa] used in Eq. 36.
    pub gamma: f64,
    pub p_n: f64,
    /// White-noise level of the pressure [Pa] and temperature [K] columns,
    /// estimated from the data ([`crate::data::noise_sigma`]).
    pub noise_p: Option<f64>,
    pub noise_temperature: Option<f64>,
    pub unloading: Option<UnloadingEstimate>,
    /// Why method (a) was not applicable, if it was not.
    pub unloading_note: Option<String>,
    /// Method (b) with the thermal model of `thermal`: the estimate.
    pub model_fit: Option<ModelFitEstimate>,
    pub thermal: Option<ThermalSelection>,
    pub iso: Vec<IsoFlow>,
    /// One line each: misfits well above the noise, fits that did not
    /// converge, a thermal time constant the data cannot pin down.
    pub warnings: Vec<String>,
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

/// Eq. 36: C = K_T0·V/(γ·p_N·τ_U) [m³/(s Pa)]. With `gamma` = n it is the
/// polytropic form (n = 1: isothermal limit).
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
    choked_pressure_polytropic(t, p0, tau_u, gamma)
}

/// Closed form of choked discharge along a polytrope of index n ≥ 1:
/// p(t) = p0·[1 + (n−1)/(2n)·t/τ]^(−2n/(n−1)), and its limit
/// p0·exp(−t/τ) for n = 1 (isothermal), with τ = K_T0·V/(n·C·p_N).
pub fn choked_pressure_polytropic(t: f64, p0: f64, tau: f64, n: f64) -> f64 {
    let k = (n - 1.0) / (2.0 * n);
    if k.abs() < 1e-12 {
        p0 * (-t / tau).exp()
    } else {
        p0 * (1.0 + k * t / tau).powf(-1.0 / k)
    }
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

/// Method (a): fit the adiabatic choked closed form (Eq. 36) to the samples
/// with p ≥ p_atm/b_window.
pub fn estimate_unloading(data: &DischargeData, setup: &DischargeSetup, b_window: f64) -> Result<UnloadingEstimate, DischargeError> {
    estimate_unloading_polytropic(data, setup, b_window, gamma_air(setup.t0))
}

/// Method (a) along a polytrope of index `n` (γ: adiabatic, Eq. 36; 1:
/// isothermal limit): fit [`choked_pressure_polytropic`] to the samples with
/// p ≥ p_atm/b_window, then C = K_T0·V/(n·p_N·τ).
pub fn estimate_unloading_polytropic(
    data: &DischargeData,
    setup: &DischargeSetup,
    b_window: f64,
    n: f64,
) -> Result<UnloadingEstimate, DischargeError> {
    check_setup(setup)?;
    if !(b_window > 0.0 && b_window < 1.0) {
        return Err(DischargeError::BadSetup(format!("choked-window critical ratio {b_window} not in (0, 1)")));
    }
    if !(n >= 1.0 && n.is_finite()) {
        return Err(DischargeError::BadSetup(format!("polytropic index {n} must be >= 1")));
    }
    let p_min = setup.p_atm / b_window;
    let count = data.p.iter().position(|&p| p < p_min).unwrap_or(data.p.len());
    if count < 5 {
        return Err(DischargeError::NotChoked(format!(
            "only {count} samples above p_atm/b = {:.4} bar (the trace must start choked: p0 > p_atm/b)",
            p_min / 1e5
        )));
    }
    let t: Vec<f64> = data.t[..count].iter().map(|v| v - data.t[0]).collect();
    let p = &data.p[..count];
    let p_scale = data.p[0];
    let tau_scale = rough_tau(data, setup.p_atm);
    let f = |x: &[f64]| -> Result<Vec<f64>, String> {
        let (p0, tau) = (x[0] * p_scale, x[1] * tau_scale);
        Ok(t.iter().zip(p).map(|(&ti, &pi)| choked_pressure_polytropic(ti, p0, tau, n) - pi).collect())
    };
    let bounds = Bounds::new(vec![0.5, 1e-4], vec![2.0, 1e4]);
    let opts = LsqOptions { parallel: false, jacobian: JacobianUpdate::FiniteDifference, ..LsqOptions::default() };
    let res = least_squares(f, &[1.0, 1.0], &bounds, &opts)?;
    let se = res.std_errors.clone().unwrap_or_else(|| vec![f64::NAN; 2]);
    let tau_u = res.x[1] * tau_scale;
    let tau_u_std = se[1] * tau_scale;
    let c = conductance_from_unloading_time(tau_u, setup.volume, n, setup.t0);
    Ok(UnloadingEstimate {
        tau_u,
        tau_u_std,
        p0: res.x[0] * p_scale,
        p0_std: se[0] * p_scale,
        c,
        c_std: c * tau_u_std / tau_u,
        b_window,
        p_window_min: p_min,
        n_points: count,
        t_window_end: t[count - 1],
        rms: rms(&res.residuals),
        polytropic_index: n,
        caveat: None,
    })
}

/// The discharge netlist (same ids as `models/tank_discharge.json`) for a
/// conductance `c`, critical ratio `b`, initial pressure `p0` and thermal
/// time constant `tau_thermal` (∞ = adiabatic), all SI. The wall is at T0.
pub fn discharge_netlist_thermal(setup: &DischargeSetup, c: f64, b: f64, p0: f64, tau_thermal: f64, t_end: f64) -> serde_json::Value {
    let tau = if tau_thermal.is_finite() { serde_json::json!(tau_thermal) } else { serde_json::json!("inf") };
    serde_json::json!({
        "name": "discharge_fit",
        "gas": { "model": "ideal", "species": "air" },
        "components": [
            { "id": "tank", "type": "chamber",
              "params": { "dead_volume": setup.volume, "area": 0.0, "tau_thermal": tau, "T_wall": setup.t0 },
              "init": { "p0": p0, "T0": setup.t0 } },
            { "id": "orifice", "type": "conductance", "params": { "C": c, "b": b } },
            { "id": "atmosphere", "type": "atmosphere", "params": { "p": setup.p_atm, "T": setup.t0 } }
        ],
        "connections": [["tank.port", "orifice.a"], ["orifice.b", "atmosphere.port"]],
        "simulation": { "t_end": t_end }
    })
}

/// The adiabatic discharge netlist ([`discharge_netlist_thermal`] with τ_T = ∞).
pub fn discharge_netlist(setup: &DischargeSetup, c: f64, b: f64, p0: f64, t_end: f64) -> serde_json::Value {
    discharge_netlist_thermal(setup, c, b, p0, f64::INFINITY, t_end)
}

/// Simulated tank pressure [Pa] and sensed temperature [K] at the sample times.
#[derive(Debug, Clone)]
pub struct SimulatedTraces {
    pub p: Vec<f64>,
    /// Gas temperature seen through a first-order sensor of time constant
    /// `sensor_lag` (the gas temperature itself when the lag is 0).
    pub temperature: Vec<f64>,
}

/// Simulate the adiabatic discharge and return the tank pressure at `times`
/// (seconds from the opening, increasing, ≥ 0).
pub fn simulate_discharge(setup: &DischargeSetup, c: f64, b: f64, p0: f64, times: &[f64]) -> Result<Vec<f64>, String> {
    Ok(simulate_discharge_thermal(setup, c, b, p0, f64::INFINITY, 0.0, times)?.p)
}

/// Simulate the discharge with wall heat exchange (τ_T, ∞ = adiabatic) and
/// return pressure and sensed temperature (sensor lag `sensor_lag` ≥ 0 [s])
/// at `times` (seconds from the opening, increasing, ≥ 0).
pub fn simulate_discharge_thermal(
    setup: &DischargeSetup,
    c: f64,
    b: f64,
    p0: f64,
    tau_thermal: f64,
    sensor_lag: f64,
    times: &[f64],
) -> Result<SimulatedTraces, String> {
    let t_last = times.last().copied().unwrap_or(0.0);
    let t_end = t_last.max(1e-9);
    let text = discharge_netlist_thermal(setup, c, b, p0, tau_thermal, t_end).to_string();
    let netlist = graph::expand::parse(&text, "discharge_fit").map_err(|e| e.to_string())?;
    let flat = graph::expand::flatten(&crate::netlist_edit::NoFiles, &netlist, Path::new(""), 0).map_err(|e| e.to_string())?;
    let circuit = graph::build(&flat).map_err(|e| e.to_string())?;
    let mut model = solve::Model::new(circuit);
    let opts = solve::SimOptions {
        t_end,
        cycles: None,
        rtol: 1e-10,
        atol: 1e-10,
        // a grid independent of the data rate: the cubic interpolation
        // below is exact to O(Δt⁴), far below any sensor noise
        sample_interval: t_end / 4000.0,
        max_step: t_end / 50.0,
        max_events: 1000,
        ..solve::SimOptions::default()
    };
    let result = solve::simulate(&mut model, &opts).map_err(|e| e.to_string())?;
    let p = result.series("tank.p").ok_or("no tank.p in the results")?;
    let temperature = result.series("tank.T").ok_or("no tank.T in the results")?;
    if p.is_empty() || temperature.is_empty() {
        return Err("empty simulation result".into());
    }
    let sensed = first_order_lag(&temperature, sensor_lag);
    Ok(SimulatedTraces { p: interpolate(&p, times), temperature: interpolate(&sensed, times) })
}

/// Output of a first-order sensor y' = (x − y)/τ, y(t₀) = x(t₀), driven by
/// the piecewise-linear interpolant of the series x (exact on each interval:
/// with slope a, y₁ = x₁ − aτ + (y₀ − x₀ + aτ)·e^(−h/τ)). τ ≤ 0: y = x.
fn first_order_lag(series: &[(f64, f64)], tau: f64) -> Vec<(f64, f64)> {
    if tau.is_nan() || tau <= 0.0 || series.is_empty() {
        return series.to_vec();
    }
    let mut out = Vec::with_capacity(series.len());
    let mut y = series[0].1;
    out.push(series[0]);
    for w in series.windows(2) {
        let ((t0, x0), (t1, x1)) = (w[0], w[1]);
        let h = t1 - t0;
        if h > 0.0 {
            let a = (x1 - x0) / h;
            y = x1 - a * tau + (y - x0 + a * tau) * (-h / tau).exp();
        }
        out.push((t1, y));
    }
    out
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

/// τ_T of the isothermal limit, as a fraction of the trace's time scale.
pub const ISOTHERMAL_FRACTION: f64 = 1e-4;
/// Largest heat-exchange parameter s (τ_T = τ·(1 − s)/s = ISOTHERMAL_FRACTION·τ).
const S_MAX: f64 = 1.0 / (1.0 + ISOTHERMAL_FRACTION);
/// Largest sensor parameter u (τ_sensor = τ·u/(1 − u) ≤ 99·τ).
const U_MAX: f64 = 0.99;
/// Largest correction of T0 fitted to a temperature trace [K].
const T0_RANGE: f64 = 30.0;
/// Δχ² above which a thermal limit is rejected: the 99.9 % quantile of χ²
/// with one degree of freedom (a likelihood-ratio test at the 0.1 % level).
pub const LIMIT_REJECTION_CHI2: f64 = 10.83;
/// τ_T/τ beyond which a fitted τ_T is read as its limit (τ the process time
/// of Eq. 19): there the limit's C differs from the free fit's by less than
/// 0.2 % and its b by less than 0.02 (module header, "(b) Model fit").
pub const ADIABATIC_RATIO: f64 = 100.0;
pub const ISOTHERMAL_RATIO: f64 = 0.01;
/// Floors of the noise levels used to weight a joint p–T fit: 0.1 mbar and
/// 0.05 K (a noise-free trace must not get an infinite weight).
const NOISE_FLOOR_P: f64 = 10.0;
const NOISE_FLOOR_T: f64 = 0.05;
/// Noise floor of the misfit warning: 1 mbar (a systematic misfit below it
/// is below the accuracy of pressure transducers).
const WARN_FLOOR_P: f64 = 100.0;
/// A misfit is flagged when its RMS exceeds this multiple of the noise level
/// and its residuals are this correlated from sample to sample.
const MISFIT_RATIO: f64 = 1.5;
const MISFIT_LAG1: f64 = 0.5;

/// How the heat exchange enters one fit.
#[derive(Debug, Clone, Copy)]
enum Heat {
    /// τ_T fixed [s] (∞ = adiabatic).
    Fixed(f64),
    /// τ_T fitted through s ∈ [0, S_MAX].
    Free,
}

/// Scales and data shared by the fits of method (b).
struct FitContext<'a> {
    data: &'a DischargeData,
    setup: &'a DischargeSetup,
    times: Vec<f64>,
    c_scale: f64,
    p_scale: f64,
    tau_scale: f64,
    sigma_p: f64,
    /// The measured temperature and its noise level, when fitted.
    temperature: Option<(&'a [f64], f64)>,
    /// Fit p_atm (started at the setup's value).
    fit_p_atm: bool,
    parallel: bool,
}

/// Start values in fit units: C/c_scale, b, p0/p_scale, s, u, and the
/// offset of T0 from the setup's value [K].
#[derive(Debug, Clone, Copy)]
struct Start {
    c: f64,
    b: f64,
    p0: f64,
    s: f64,
    u: f64,
    dt0: f64,
    /// p_atm over the setup's value.
    p_atm: f64,
}

/// One fit of method (b): the estimate, its final parameters and cost.
struct Fitted {
    est: ModelFitEstimate,
    start: Start,
    /// ½ Σ (residual/σ)².
    cost: f64,
    m: usize,
    n: usize,
}

fn tau_from_s(s: f64, scale: f64) -> f64 {
    if s <= 0.0 {
        f64::INFINITY
    } else {
        scale * (1.0 - s) / s
    }
}

fn s_from_tau(tau: f64, scale: f64) -> f64 {
    if tau.is_finite() {
        scale / (scale + tau.max(0.0))
    } else {
        0.0
    }
}

fn lag_from_u(u: f64, scale: f64) -> f64 {
    scale * u / (1.0 - u)
}

impl FitContext<'_> {
    fn new<'a>(
        data: &'a DischargeData,
        setup: &'a DischargeSetup,
        temperature: Option<(&'a [f64], f64)>,
        fit_p_atm: bool,
        parallel: bool,
    ) -> FitContext<'a> {
        let gamma = gamma_air(setup.t0);
        let tau_scale = rough_tau(data, setup.p_atm);
        let p: Vec<Option<f64>> = data.p.iter().map(|&v| Some(v)).collect();
        FitContext {
            data,
            setup,
            times: data.t.iter().map(|v| v - data.t[0]).collect(),
            c_scale: conductance_from_unloading_time(tau_scale, setup.volume, gamma, setup.t0),
            p_scale: data.p[0],
            tau_scale,
            sigma_p: noise_sigma(&data.t, &p).unwrap_or(0.0).max(NOISE_FLOOR_P),
            temperature,
            fit_p_atm,
            parallel,
        }
    }

    /// Fit C, b, p0 (and s when `heat` is free; T0 when a temperature trace
    /// is fitted, with the sensor lag when `sensor`).
    fn fit(&self, heat: Heat, model: ThermalModel, sensor: bool, start: Start) -> Result<Fitted, DischargeError> {
        let setup = self.setup;
        let (c_scale, p_scale, tau_scale, sigma_p) = (self.c_scale, self.p_scale, self.tau_scale, self.sigma_p);
        // parameters: C/c_scale, b, p0/p_scale, then those that apply
        let p_atm_hi = (1.2 * setup.p_atm).min(0.9 * p_scale) / setup.p_atm;
        let p0_lo = (setup.p_atm * (1.0 + 1e-6) / p_scale * if self.fit_p_atm { p_atm_hi } else { 1.0 }).max(0.5);
        let mut lo = vec![1e-3, 0.02, p0_lo];
        let mut hi = vec![1e3, 0.95, 2.0_f64.max(p0_lo)];
        let mut x0 = vec![start.c, start.b, start.p0];
        let mut add = |on: bool, l: f64, h: f64, x: f64| {
            on.then(|| {
                lo.push(l);
                hi.push(h);
                x0.push(x.clamp(l, h));
                x0.len() - 1
            })
        };
        let fit_t0 = self.temperature.is_some();
        let i_s = add(matches!(heat, Heat::Free), 0.0, S_MAX, start.s);
        let i_u = add(sensor && fit_t0, 0.0, U_MAX, start.u);
        let i_t0 = add(fit_t0, -T0_RANGE, T0_RANGE, start.dt0);
        let i_pa = add(self.fit_p_atm, 0.8, p_atm_hi.max(0.8), start.p_atm);
        let setup_of = |x: &[f64]| DischargeSetup {
            t0: setup.t0 + i_t0.map_or(0.0, |k| x[k]),
            p_atm: setup.p_atm * i_pa.map_or(1.0, |k| x[k]),
            ..*setup
        };
        let measured_p = &self.data.p;
        let measured_t = self.temperature;
        let times = &self.times;
        let tau_of = |x: &[f64]| match (heat, i_s) {
            (Heat::Free, Some(k)) => tau_from_s(x[k], tau_scale),
            (Heat::Fixed(t), _) => t,
            (Heat::Free, None) => f64::INFINITY,
        };
        let lag_of = |x: &[f64]| i_u.map_or(0.0, |k| lag_from_u(x[k], tau_scale));
        let f = |x: &[f64]| -> Result<Vec<f64>, String> {
            let sim = simulate_discharge_thermal(&setup_of(x), x[0] * c_scale, x[1], x[2] * p_scale, tau_of(x), lag_of(x), times)?;
            let mut r: Vec<f64> = sim.p.iter().zip(measured_p).map(|(s, m)| (s - m) / sigma_p).collect();
            if let Some((t_meas, sigma_t)) = measured_t {
                r.extend(sim.temperature.iter().zip(t_meas).map(|(s, m)| (s - m) / sigma_t));
            }
            Ok(r)
        };
        let opts = LsqOptions {
            max_iter: 100,
            ftol: 1e-10,
            xtol: 1e-9,
            gtol: 1e-8,
            fd_rel_step: 1e-6,
            parallel: self.parallel,
            final_jacobian: true,
            jacobian: JacobianUpdate::FiniteDifference,
        };
        let res = least_squares(f, &x0, &Bounds::new(lo, hi), &opts)?;
        let se = res.std_errors.clone().unwrap_or_else(|| vec![f64::NAN; x0.len()]);
        let np = measured_p.len();
        let rp: Vec<f64> = res.residuals[..np].iter().map(|v| v * sigma_p).collect();
        let rms_temperature = measured_t.map(|(_, sigma_t)| rms(&res.residuals[np..]) * sigma_t);
        let tau = tau_of(&res.x);
        let (tau_thermal, tau_thermal_std) = match (model, i_s) {
            (ThermalModel::Adiabatic, _) => (None, None),
            (ThermalModel::Isothermal, _) => (Some(0.0), None),
            (ThermalModel::FiniteTau, Some(k)) => (Some(tau), Some(tau_scale * se[k] / (res.x[k] * res.x[k]))),
            (ThermalModel::FiniteTau, None) => (Some(tau), None),
        };
        let (sensor_lag, sensor_lag_std) = match i_u {
            Some(k) => (Some(lag_of(&res.x)), Some(tau_scale * se[k] / ((1.0 - res.x[k]) * (1.0 - res.x[k])))),
            None => (None, None),
        };
        let c = res.x[0] * c_scale;
        let fitted_setup = setup_of(&res.x);
        let t0 = fitted_setup.t0;
        let est = ModelFitEstimate {
            c,
            c_std: se[0] * c_scale,
            b: res.x[1],
            b_std: se[1],
            p0: res.x[2] * p_scale,
            p0_std: se[2] * p_scale,
            t0,
            t0_std: i_t0.map(|k| se[k]),
            p_atm: fitted_setup.p_atm,
            p_atm_std: i_pa.map(|k| se[k] * setup.p_atm),
            thermal_model: model,
            tau_thermal,
            tau_thermal_std,
            sensor_lag,
            sensor_lag_std,
            tau_u: unloading_time_from_conductance(c, setup.volume, gamma_air(t0), t0),
            rms: rms(&rp),
            rms_temperature,
            residual_lag1: autocorrelation(&rp, 1),
            n_points: np,
            iterations: res.iterations,
            simulations: res.evaluations,
            converged: res.converged,
        };
        let start = Start {
            c: res.x[0],
            b: res.x[1],
            p0: res.x[2],
            s: i_s.map_or(s_from_tau(tau, tau_scale), |k| res.x[k]),
            u: i_u.map_or(start.u, |k| res.x[k]),
            dt0: i_t0.map_or(start.dt0, |k| res.x[k]),
            p_atm: i_pa.map_or(start.p_atm, |k| res.x[k]),
        };
        Ok(Fitted { est, start, cost: res.cost, m: res.residuals.len(), n: x0.len() })
    }
}

fn check_starts_above_atmosphere(data: &DischargeData, setup: &DischargeSetup) -> Result<(), DischargeError> {
    if data.p[0] <= setup.p_atm {
        return Err(DischargeError::BadData(format!(
            "the trace starts at {:.4} bar, not above p_atm = {:.4} bar",
            data.p[0] / 1e5,
            setup.p_atm / 1e5
        )));
    }
    Ok(())
}

/// Method (b) with an adiabatic tank: fit C, b and p0 of the simulated
/// discharge to the whole pressure trace.
pub fn fit_discharge_model(data: &DischargeData, setup: &DischargeSetup, parallel: bool) -> Result<ModelFitEstimate, DischargeError> {
    check_setup(setup)?;
    check_starts_above_atmosphere(data, setup)?;
    let ctx = FitContext::new(data, setup, None, false, parallel);
    let start = Start { c: 1.0, b: 0.3, p0: 1.0, s: 0.0, u: 0.0, dt0: 0.0, p_atm: 1.0 };
    Ok(ctx.fit(Heat::Fixed(f64::INFINITY), ThermalModel::Adiabatic, false, start)?.est)
}

/// Method (b) with the thermal model of `opts.thermal`: the estimate and the
/// account of how its thermal model was chosen.
pub fn fit_discharge_thermal(
    data: &DischargeData,
    setup: &DischargeSetup,
    opts: &AnalysisOptions,
) -> Result<(ModelFitEstimate, ThermalSelection), DischargeError> {
    check_setup(setup)?;
    check_starts_above_atmosphere(data, setup)?;
    let gamma = gamma_air(setup.t0);
    let temperature = match (opts.thermal, opts.use_temperature, &data.temperature) {
        (ThermalOption::Auto, true, Some(t)) => {
            let tv: Vec<Option<f64>> = t.iter().map(|&v| Some(v)).collect();
            Some((t.as_slice(), noise_sigma(&data.t, &tv).unwrap_or(0.0).max(NOISE_FLOOR_T)))
        }
        _ => None,
    };
    let ctx = FitContext::new(data, setup, temperature, opts.fit_p_atm, opts.parallel);
    let adiabatic_start = Start { c: 1.0, b: 0.3, p0: 1.0, s: 0.0, u: 0.05, dt0: 0.0, p_atm: 1.0 };
    let isothermal_tau = ISOTHERMAL_FRACTION * ctx.tau_scale;
    let single = |heat: Heat, model: ThermalModel, source: ThermalSource, start: Start, why: String| {
        let fit = ctx.fit(heat, model, false, start)?;
        let sel = selection(&fit, setup.volume, source, Vec::new(), why);
        Ok::<_, DischargeError>((fit.est, sel))
    };
    match opts.thermal {
        ThermalOption::Adiabatic => single(
            Heat::Fixed(f64::INFINITY),
            ThermalModel::Adiabatic,
            ThermalSource::Forced,
            adiabatic_start,
            "adiabatic tank imposed (tau_T = inf, the assumption of Eq. 36)".into(),
        ),
        ThermalOption::Isothermal => single(
            Heat::Fixed(isothermal_tau),
            ThermalModel::Isothermal,
            ThermalSource::Forced,
            Start { c: gamma, ..adiabatic_start },
            "isothermal tank imposed (gas held at the wall temperature)".into(),
        ),
        ThermalOption::Given(tau) => {
            if !tau.is_finite() || tau <= 0.0 {
                return Err(DischargeError::BadSetup(format!("tau_T = {tau} s must be finite and > 0 (infinite: the adiabatic model)")));
            }
            let s = s_from_tau(tau, ctx.tau_scale);
            let start = Start { c: 1.0 + (gamma - 1.0) * s, ..adiabatic_start };
            single(Heat::Fixed(tau), ThermalModel::FiniteTau, ThermalSource::Given, start, format!("tau_T = {tau} s given"))
        }
        ThermalOption::Auto => auto_select(&ctx, gamma, adiabatic_start, isothermal_tau),
    }
}

/// The account of a chosen fit: its thermal model, τ_T and τ_T/τ, τ the
/// process time V/(γ C p_N) of Eq. 19.
fn selection(fit: &Fitted, volume: f64, source: ThermalSource, candidates: Vec<ThermalCandidate>, decision: String) -> ThermalSelection {
    let process_time = volume / (gamma_air(fit.est.t0) * reference_pressure() * fit.est.c);
    ThermalSelection {
        model: fit.est.thermal_model,
        source,
        tau_thermal: fit.est.tau_thermal,
        tau_thermal_std: fit.est.tau_thermal_std,
        process_time,
        tau_ratio: fit.est.tau_thermal.map(|t| t / process_time),
        threshold: LIMIT_REJECTION_CHI2,
        candidates,
        decision,
    }
}

/// The automatic choice (module header, "(b) Model fit"): fit both limits and
/// τ_T free, keep a limit unless the likelihood-ratio test rejects it.
fn auto_select(
    ctx: &FitContext<'_>,
    gamma: f64,
    adiabatic_start: Start,
    isothermal_tau: f64,
) -> Result<(ModelFitEstimate, ThermalSelection), DischargeError> {
    let source = if ctx.temperature.is_some() { ThermalSource::FittedPressureTemperature } else { ThermalSource::FittedPressure };
    let adiabatic = ctx.fit(Heat::Fixed(f64::INFINITY), ThermalModel::Adiabatic, true, adiabatic_start)?;
    let iso_start = Start { c: adiabatic.start.c * gamma, ..adiabatic.start };
    let isothermal = ctx.fit(Heat::Fixed(isothermal_tau), ThermalModel::Isothermal, false, iso_start)?;
    // τ_T free, started just inside each limit and half-way (τ_T = τ, C the
    // geometric mean of the limits'), with a fast sensor: a limit's own
    // sensor lag may have run away to flatten a temperature it cannot follow.
    // The best end point is kept.
    let (better, u0) = (if adiabatic.cost <= isothermal.cost { &adiabatic } else { &isothermal }, 0.02);
    let starts = [
        Start { s: 0.05, u: u0, dt0: 0.0, ..adiabatic.start },
        Start { s: 0.95, u: u0, dt0: 0.0, ..isothermal.start },
        Start { s: 0.5, u: u0, dt0: 0.0, c: (adiabatic.start.c * isothermal.start.c).sqrt(), ..better.start },
    ];
    let free: Vec<Fitted> = starts.iter().filter_map(|&st| ctx.fit(Heat::Free, ThermalModel::FiniteTau, true, st).ok()).collect();
    let free = free.into_iter().min_by(|a, b| a.cost.total_cmp(&b.cost));
    let best_cost =
        [Some(adiabatic.cost), Some(isothermal.cost), free.as_ref().map(|f| f.cost)].into_iter().flatten().fold(f64::INFINITY, f64::min);
    let (m, n) = free.as_ref().map_or((adiabatic.m, adiabatic.n + 1), |f| (f.m, f.n));
    // noise variance of the normalised residuals, from the best fit
    let s2 = (2.0 * best_cost / (m.saturating_sub(n).max(1)) as f64).max(f64::MIN_POSITIVE);
    let delta = |f: &Fitted| 2.0 * (f.cost - best_cost) / s2;
    let (d_ad, d_iso) = (delta(&adiabatic), delta(&isothermal));
    // τ_T/τ of the free fit, τ = V/(γ C p_N) the process time of Eq. 19
    let ratio = free.as_ref().and_then(|f| {
        let process_time = ctx.setup.volume / (gamma * reference_pressure() * f.est.c);
        f.est.tau_thermal.map(|t| t / process_time)
    });
    let ad_stat = d_ad <= LIMIT_REJECTION_CHI2;
    let iso_stat = d_iso <= LIMIT_REJECTION_CHI2;
    let ad_ok = ad_stat || ratio.is_some_and(|r| r >= ADIABATIC_RATIO) || free.as_ref().is_some_and(|f| f.est.tau_thermal.is_none());
    let iso_ok = iso_stat || ratio.is_some_and(|r| r <= ISOTHERMAL_RATIO);
    let candidate = |f: &Fitted, rejected: bool| ThermalCandidate {
        model: f.est.thermal_model,
        c: f.est.c,
        b: f.est.b,
        tau_thermal: f.est.tau_thermal,
        rms: f.est.rms,
        rms_temperature: f.est.rms_temperature,
        delta_chi2: delta(f),
        rejected,
    };
    let mut candidates = vec![candidate(&adiabatic, !ad_ok), candidate(&isothermal, !iso_ok)];
    if let Some(f) = &free {
        candidates.push(candidate(f, false));
    }
    let verdict = |stat: bool, ok: bool| match (stat, ok) {
        (true, _) => "accepted",
        (false, true) => "accepted in effect",
        (false, false) => "rejected",
    };
    let free_text = match (&free, ratio) {
        (Some(f), Some(r)) => format!("tau_T free: {:.4} s = {:.3e} tau", f.est.tau_thermal.unwrap_or(f64::INFINITY), r),
        (Some(_), None) => "tau_T free: inf".to_string(),
        (None, _) => "tau_T free: fit failed".to_string(),
    };
    let tests = format!(
        "{free_text}; adiabatic limit {} (dchi2 = {}), isothermal limit {} (dchi2 = {}); a limit is kept when dchi2 <= {LIMIT_REJECTION_CHI2} or tau_T/tau lies beyond [{ISOTHERMAL_RATIO}, {ADIABATIC_RATIO}]",
        verdict(ad_stat, ad_ok),
        units::show::fixed(d_ad, 4),
        verdict(iso_stat, iso_ok),
        units::show::fixed(d_iso, 4)
    );
    let (chosen, decision) = match (ad_ok, iso_ok, free) {
        (true, true, _) => {
            (adiabatic, format!("tau_T not identifiable from this trace, adiabatic limit kept (Eq. 36 assumption): {tests}"))
        }
        (true, false, _) => (adiabatic, format!("adiabatic: {tests}")),
        (false, true, _) => (isothermal, format!("isothermal: {tests}")),
        (false, false, Some(f)) => (f, format!("finite tau_T: {tests}")),
        (false, false, None) => {
            let best = if d_ad <= d_iso { adiabatic } else { isothermal };
            (best, format!("both limits rejected but the fit with tau_T free failed, the better limit kept: {tests}"))
        }
    };
    let sel = selection(&chosen, ctx.setup.volume, source, candidates, decision);
    Ok((chosen.est, sel))
}

/// The instant the restriction opened, found in the trace.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Opening {
    /// Estimated opening time [s, in the file's time axis].
    pub t_open: f64,
    /// Pressure held before the opening [Pa] (the first sample when the trace
    /// starts at the opening).
    pub p_hold: f64,
    /// Samples recorded before the opening and left out of the fits.
    pub samples_dropped: usize,
}

/// Find the opening of the restriction in a trace that may begin with a
/// pre-trigger segment at constant pressure. The first sample below
/// p[0] − δ (δ = max(8σ, 0.2 % of p[0] − p_atm), σ the noise level) marks the
/// fall; the samples up to 2 % of the excess pressure lost are fitted by a
/// hinge, constant until t_o and straight after it, for every sample time
/// t_o up to the fall. The opening is the best hinge when it beats the
/// straight line through all those samples (t_o = the first sample) by more
/// than 25 σ² in the sum of squares and lies more than one sample interval
/// after the start. Samples before it are dropped; the sub-sample remainder
/// is absorbed by the fitted p0.
pub fn find_opening(data: &DischargeData, p_atm: f64) -> Opening {
    let (t, p) = (&data.t, &data.p);
    let none = Opening { t_open: t[0], p_hold: p[0], samples_dropped: 0 };
    let column: Vec<Option<f64>> = p.iter().map(|&v| Some(v)).collect();
    let sigma = noise_sigma(t, &column).unwrap_or(0.0).max(NOISE_FLOOR_P);
    let delta = (8.0 * sigma).max(2e-3 * (p[0] - p_atm).max(0.0));
    let Some(j) = p.iter().position(|&v| v < p[0] - delta) else {
        return none;
    };
    if j < 3 {
        return none;
    }
    let stop = p[0] - 0.02 * (p[0] - p_atm).max(0.0);
    let mut k = j;
    while k + 1 < p.len() && (k < j + 5 || (p[k + 1] >= stop && k < j + 2000)) {
        k += 1;
    }
    // the hinge through samples 0..=k for a given opening t_o: constant a
    // before it, a + s·(t − t_o) after it; linear least squares in (a, s)
    let hinge = |t_o: f64| -> (f64, f64, f64) {
        let x: Vec<f64> = t[..=k].iter().map(|&ti| (ti - t_o).max(0.0)).collect();
        let n = x.len() as f64;
        let (mx, my) = (x.iter().sum::<f64>() / n, p[..=k].iter().sum::<f64>() / n);
        let sxx: f64 = x.iter().map(|v| (v - mx) * (v - mx)).sum();
        let sxy: f64 = x.iter().zip(&p[..=k]).map(|(v, y)| (v - mx) * (y - my)).sum();
        let s = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        let a = my - s * mx;
        let sse = x.iter().zip(&p[..=k]).map(|(v, y)| (a + s * v - y).powi(2)).sum();
        (sse, a, s)
    };
    let (line_sse, _, _) = hinge(t[0]);
    let best = (1..=j).map(|i| (i, hinge(t[i]))).min_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
    let Some((i, (sse, a, s))) = best else {
        return none;
    };
    if !(line_sse - sse > 25.0 * sigma * sigma && s < 0.0) {
        return none;
    }
    let dt = (t[j] - t[0]) / j as f64;
    if t[i] - t[0] <= dt {
        return none;
    }
    let dropped = t.iter().take_while(|&&ti| ti < t[i]).count();
    Opening { t_open: t[i], p_hold: a, samples_dropped: dropped }
}

/// The trace from the opening on (the samples before `opening` left out).
fn from_opening(data: &DischargeData, opening: &Opening) -> Result<DischargeData, DischargeError> {
    let k = opening.samples_dropped;
    if k == 0 {
        return Ok(data.clone());
    }
    DischargeData::new(data.t[k..].to_vec(), data.p[k..].to_vec(), data.temperature.as_ref().map(|t| t[k..].to_vec()))
        .map_err(|e| DischargeError::BadData(format!("after the opening found at t = {} s: {e}", opening.t_open)))
}

/// Start value of a fitted p_atm [Pa]: the standard atmosphere, or the mean
/// of the last samples (2 % of them, 5 to 50) when the trace ends below it.
pub fn p_atm_start(data: &DischargeData) -> f64 {
    let n = data.p.len();
    let k = (n / 50).clamp(5, 50).min(n);
    let tail = data.p[n - k..].iter().sum::<f64>() / k as f64;
    tail.min(units::STANDARD_ATMOSPHERE)
}

/// ISO 6358 choked flow of conductance `c` at upstream `p_up`, `t_up`.
pub fn iso_flow(method: &str, c: f64, b: Option<f64>, p_up: f64, t_up: f64) -> IsoFlow {
    let mdot = c * ANR_DENSITY * p_up * (ANR_TEMPERATURE / t_up).sqrt();
    IsoFlow { method: method.to_string(), c, b, p_up, t_up, choked_mass_flow: mdot, choked_anr_flow: mdot / ANR_DENSITY }
}

/// One-line warnings about the fit of method (b).
fn fit_warnings(m: &ModelFitEstimate, sel: &ThermalSelection, noise_p: Option<f64>, noise_t: Option<f64>) -> Vec<String> {
    let mut w = Vec::new();
    let sigma_p = noise_p.unwrap_or(0.0).max(WARN_FLOOR_P);
    if m.rms > MISFIT_RATIO * sigma_p && m.residual_lag1 > MISFIT_LAG1 {
        let hint = match (m.thermal_model, sel.source) {
            (ThermalModel::Adiabatic, ThermalSource::Forced) => "the discharge is not adiabatic: let tau_T be fitted, or give it",
            (_, ThermalSource::Forced | ThermalSource::Given) => {
                "the imposed thermal model does not describe this discharge: let tau_T be fitted"
            }
            _ => "the tank model misses something (leak, valve opening time, volume, p_atm, sensor offset?)",
        };
        w.push(format!(
            "the {} fit leaves {:.2} mbar RMS against {:.2} mbar noise (residual lag-1 autocorrelation {:.2}): systematic misfit; {hint}",
            m.thermal_model.name(),
            m.rms / 100.0,
            sigma_p / 100.0,
            m.residual_lag1
        ));
    }
    if let (Some(rt), Some(st)) = (m.rms_temperature, noise_t) {
        let st = st.max(NOISE_FLOOR_T);
        if rt > 3.0 * st {
            w.push(format!(
                "the temperature column is fitted to {rt:.3} K RMS against {st:.3} K noise: it is not the tank gas seen through a first-order sensor; consider fitting the pressure only"
            ));
        }
    }
    if !m.converged {
        w.push("the model fit stopped at the iteration limit without converging".into());
    }
    if sel.decision.starts_with("tau_T not identifiable") {
        let iso_c = sel.candidates.iter().find(|c| c.model == ThermalModel::Isothermal).map(|c| c.c);
        w.push(match iso_c {
            Some(ci) => format!(
                "tau_T cannot be identified from this trace: the adiabatic limit is reported; the isothermal reading would give C = {:.4} L/min/bar",
                ci / (1e-3 / 60.0 / 1e5)
            ),
            None => "tau_T cannot be identified from this trace: the adiabatic limit is reported".into(),
        });
    }
    w
}

/// Run both methods and collect the report. Method (a) failing for lack of a
/// choked phase is reported as a note, not an error.
pub fn analyse(data: &DischargeData, setup: &DischargeSetup, opts: &AnalysisOptions) -> Result<DischargeReport, DischargeError> {
    check_setup(setup)?;
    let gamma = gamma_air(setup.t0);
    let n_samples = data.t.len();
    let opening = find_opening(data, setup.p_atm);
    let trimmed = from_opening(data, &opening)?;
    let data = &trimmed;
    let column = |v: &[f64]| -> Vec<Option<f64>> { v.iter().map(|&x| Some(x)).collect() };
    let noise_p = noise_sigma(&data.t, &column(&data.p));
    let noise_temperature = data.temperature.as_ref().and_then(|t| noise_sigma(&data.t, &column(t)));
    let (model_fit, thermal) = if opts.fit_model {
        let (m, s) = fit_discharge_thermal(data, setup, opts)?;
        (Some(m), Some(s))
    } else {
        (None, None)
    };
    let b_window = opts.b_window.or(model_fit.as_ref().map(|m| m.b)).unwrap_or(0.528);
    // method (a) with the downstream pressure and T0 of (b) (fitted or given)
    let setup_a = match &model_fit {
        Some(m) => DischargeSetup { p_atm: m.p_atm, t0: m.t0, ..*setup },
        None => *setup,
    };
    let regime = thermal.as_ref().map(|s| s.model);
    let n = if regime == Some(ThermalModel::Isothermal) { 1.0 } else { gamma };
    let (unloading, unloading_note) = match estimate_unloading_polytropic(data, &setup_a, b_window, n) {
        Ok(mut u) => {
            if regime == Some(ThermalModel::FiniteTau) {
                u.caveat = Some(
                    "adiabatic limit of the energy balance: with the finite tau_T found by (b) the gas is warmed by the wall and this C is biased low"
                        .into(),
                );
            }
            (Some(u), None)
        }
        Err(DischargeError::NotChoked(m)) => (None, Some(m)),
        Err(e) => return Err(e),
    };
    let mut iso = Vec::new();
    if let Some(u) = &unloading {
        iso.push(iso_flow("unloading_time", u.c, None, u.p0, setup_a.t0));
    }
    if let Some(m) = &model_fit {
        iso.push(iso_flow("model_fit", m.c, Some(m.b), m.p0, m.t0));
    }
    let warnings = match (&model_fit, &thermal) {
        (Some(m), Some(s)) => fit_warnings(m, s, noise_p, noise_temperature),
        _ => Vec::new(),
    };
    Ok(DischargeReport {
        setup: *setup,
        n_samples,
        opening,
        duration: data.t[data.t.len() - 1] - data.t[0],
        gamma,
        p_n: reference_pressure(),
        noise_p,
        noise_temperature,
        unloading,
        unloading_note,
        model_fit,
        thermal,
        iso,
        warnings,
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

    #[test]
    fn polytropic_closed_form_has_the_isothermal_limit() {
        let g = gamma_air(293.15);
        for t in [0.0, 0.1, 0.5, 2.0] {
            assert_eq!(choked_pressure(t, 7e5, 0.4, g), choked_pressure_polytropic(t, 7e5, 0.4, g));
            let iso = choked_pressure_polytropic(t, 7e5, 0.4, 1.0);
            assert!((iso - 7e5 * (-t / 0.4_f64).exp()).abs() < 1e-9 * 7e5);
            // n → 1 from above converges to the exponential
            let near = choked_pressure_polytropic(t, 7e5, 0.4, 1.0 + 1e-7);
            assert!((near / iso - 1.0).abs() < 1e-6, "t = {t}: {near} vs {iso}");
        }
        // Eq. 36 read with n: the isothermal C is γ times the adiabatic one
        // for the same decay time.
        let ca = conductance_from_unloading_time(0.4, 1e-3, g, 293.15);
        let ci = conductance_from_unloading_time(0.4, 1e-3, 1.0, 293.15);
        assert!((ci / ca - g).abs() < 1e-12);
    }

    #[test]
    fn first_order_lag_is_exact_for_a_ramp() {
        // y' = (x − y)/τ with x = 300 − 50 t, y(0) = 300:
        // y = 300 − 50 (t − τ (1 − e^(−t/τ))).
        let tau = 0.2;
        let series: Vec<(f64, f64)> = (0..=100).map(|i| (i as f64 * 0.01, 300.0 - 50.0 * i as f64 * 0.01)).collect();
        let y = first_order_lag(&series, tau);
        for (t, v) in y {
            let exact = 300.0 - 50.0 * (t - tau * (1.0 - (-t / tau).exp()));
            assert!((v - exact).abs() < 1e-10, "t = {t}: {v} vs {exact}");
        }
        assert_eq!(first_order_lag(&series, 0.0), series);
    }

    #[test]
    fn opening_is_found_after_a_pre_trigger_and_never_invented() {
        let s = setup();
        let mut rng = Normal::new(5);
        for (c, v) in [(100.0, 1e-3), (20.0, 4e-3)] {
            let t: Vec<f64> = (0..3000).map(|i| i as f64 * 1e-3).collect();
            let p = simulate_discharge_thermal(&DischargeSetup { volume: v, ..s }, c * LPMB, 0.3, 7e5, 5.0, 0.0, &t).expect("sim").p;
            for sigma in [0.0, 500.0] {
                let noisy: Vec<f64> = p.iter().map(|x| x + sigma * rng.normal()).collect();
                // starts at the opening: nothing dropped
                let d = DischargeData::new(t.clone(), noisy.clone(), None).expect("data");
                let o = find_opening(&d, s.p_atm);
                assert_eq!(o.samples_dropped, 0, "C = {c}, σ = {sigma}: {o:?}");
                // 37 samples at p0 first: they are dropped, to within a
                // sample or, where the start of the fall is lost in the
                // noise, 0.5 % of τ_U (which the fitted p0 absorbs)
                let k = 37;
                let tau_u = unloading_time_from_conductance(c * LPMB, v, gamma_air(s.t0), s.t0);
                let tol = 1.0 + 5e-3 * tau_u / 1e-3;
                let tt: Vec<f64> = (0..t.len() + k).map(|i| 2.0 + i as f64 * 1e-3).collect();
                let pp: Vec<f64> = (0..k).map(|_| 7e5 + sigma * rng.normal()).chain(noisy.iter().copied()).collect();
                let d = DischargeData::new(tt, pp, None).expect("data");
                let o = find_opening(&d, s.p_atm);
                assert!(o.samples_dropped.abs_diff(k) as f64 <= tol, "C = {c}, σ = {sigma}: {o:?}");
                assert!((o.p_hold - 7e5).abs() < 3.0 * sigma + 70.0, "{o:?}");
            }
        }
    }

    #[test]
    fn p_atm_is_fitted_from_the_end_of_the_trace() {
        // pneumo trace into 0.95 bar (altitude), analysed from the start value
        let s = DischargeSetup { p_atm: 0.95e5, ..setup() };
        let t: Vec<f64> = (0..1500).map(|i| i as f64 * 1e-3).collect();
        let p = simulate_discharge_thermal(&s, 100.0 * LPMB, 0.3, 7e5, f64::INFINITY, 0.0, &t).expect("sim").p;
        let d = DischargeData::new(t, p, None).expect("data");
        let start = p_atm_start(&d);
        assert!(start < 0.951e5 && start > 0.95e5, "{start}");
        let opts = AnalysisOptions { fit_p_atm: true, ..AnalysisOptions::default() };
        let rep = analyse(&d, &DischargeSetup { p_atm: start, ..s }, &opts).expect("analyse");
        let m = rep.model_fit.expect("fit");
        assert!((m.p_atm - 0.95e5).abs() < 1.0, "{}", m.p_atm);
        assert!((m.c / (100.0 * LPMB) - 1.0).abs() < 1e-4 && (m.b - 0.3).abs() < 1e-3, "{} {}", m.c / LPMB, m.b);
        // a trace ending above the standard atmosphere starts from it
        let d = DischargeData::new((0..20).map(f64::from).collect(), vec![2e5; 20], None).expect("data");
        assert_eq!(p_atm_start(&d), units::STANDARD_ATMOSPHERE);
    }

    #[test]
    fn thermal_time_constant_of_a_pneumo_trace_is_recovered() {
        // Noise-free traces of pneumo's own chamber: the automatic choice
        // finds the thermal model and gives C, b back.
        let s = setup();
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 1e-3).collect();
        for (tau, expect) in [(0.5, ThermalModel::FiniteTau), (1e-5, ThermalModel::Isothermal), (f64::INFINITY, ThermalModel::Adiabatic)] {
            let sim = simulate_discharge_thermal(&s, 80.0 * LPMB, 0.4, 6e5, tau, 0.0, &t).expect("sim");
            for with_t in [false, true] {
                let d = DischargeData::new(t.clone(), sim.p.clone(), with_t.then(|| sim.temperature.clone())).expect("data");
                let rep = analyse(&d, &s, &AnalysisOptions::default()).expect("analyse");
                let (m, th) = (rep.model_fit.expect("fit"), rep.thermal.expect("thermal"));
                assert_eq!(th.model, expect, "tau {tau}, T column {with_t}: {}", th.decision);
                assert!((m.c / (80.0 * LPMB) - 1.0).abs() < 1e-3, "tau {tau}: C {}", m.c / LPMB);
                assert!((m.b - 0.4).abs() < 2e-3, "tau {tau}: b {}", m.b);
                if expect == ThermalModel::FiniteTau {
                    let fitted = th.tau_thermal.expect("tau");
                    assert!((fitted / tau - 1.0).abs() < 1e-3, "{fitted}");
                    assert!(th.tau_ratio.is_some_and(|r| r > 0.5 && r < 2.0));
                }
                assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
            }
        }
    }

    #[test]
    fn given_and_imposed_thermal_models_are_used_and_checked() {
        let s = setup();
        let t: Vec<f64> = (0..1500).map(|i| i as f64 * 1e-3).collect();
        let p = simulate_discharge_thermal(&s, 100.0 * LPMB, 0.3, 7e5, 0.8, 0.0, &t).expect("sim").p;
        let d = DischargeData::new(t, p, None).expect("data");
        let opts = AnalysisOptions { thermal: ThermalOption::Given(0.8), ..AnalysisOptions::default() };
        let rep = analyse(&d, &s, &opts).expect("analyse");
        let th = rep.thermal.as_ref().expect("thermal");
        assert_eq!((th.model, th.source, th.tau_thermal), (ThermalModel::FiniteTau, ThermalSource::Given, Some(0.8)));
        assert!(th.candidates.is_empty());
        let m = rep.model_fit.as_ref().expect("fit");
        assert!((m.c / (100.0 * LPMB) - 1.0).abs() < 1e-4);
        // method (a) is flagged as the adiabatic limit
        assert!(rep.unloading.as_ref().and_then(|u| u.caveat.as_ref()).is_some());
        // imposing the wrong limit warns, once
        let opts = AnalysisOptions { thermal: ThermalOption::Adiabatic, ..AnalysisOptions::default() };
        let rep = analyse(&d, &s, &opts).expect("analyse");
        assert_eq!(rep.thermal.as_ref().map(|t| t.source), Some(ThermalSource::Forced));
        assert_eq!(rep.warnings.len(), 1, "{:?}", rep.warnings);
        assert!(rep.warnings[0].starts_with("the adiabatic fit leaves"), "{}", rep.warnings[0]);
        for bad in [0.0, -1.0, f64::NAN] {
            let opts = AnalysisOptions { thermal: ThermalOption::Given(bad), ..AnalysisOptions::default() };
            assert!(matches!(analyse(&d, &s, &opts), Err(DischargeError::BadSetup(_))), "{bad}");
        }
    }
}
