//! The output-error fitting problem: experiments, fitted parameters, the
//! forward simulation of each experiment and the noise-weighted residuals.
//!
//! # Residuals
//! For experiment k, measured channel c and fitted sample i:
//! r = (ŷ_c(t_i; θ) − y_c(t_i)) / σ_kc, where ŷ is the simulation of the
//! netlist for parameters θ at the experiment's operating point, linearly
//! interpolated at t_i from the simulation's output grid, and σ_kc the
//! channel's noise level ([`crate::data::noise_sigma`], or given). Missing
//! samples are left out. Minimising ½Σr² is maximum likelihood for white
//! Gaussian sensor noise.
//!
//! # Parameters in the fit
//! Each parameter is fitted in a scaled coordinate u so that all are O(1):
//! linear u = θ/θ_typ, or logarithmic u = ln(θ/θ_typ) for strictly positive
//! quantities known only to a factor (conductances, friction levels).
//! Calibration parameters that the experiments set to different values
//! (e.g. one throttle setting per experiment) are fitted once per distinct
//! setting, each applying to the experiments with that setting.
//!
//! # Order of netlist edits for one experiment
//! the experiment's `set` list → calibration values → effects in order.
//!
//! # Sampling
//! The fit compares every s-th sample, s = round(fit_interval / median
//! sampling interval), and simulates with output every s·Δt (exact at the
//! samples for evenly sampled data, linear interpolation otherwise).
//! Simulation time 0 is the experiment's time origin (default: its first
//! sample); the simulation runs to the last sample.

use crate::data::{noise_sigma, Dataset};
use crate::effects::{Effect, Scale};
use crate::lsq::{least_squares, Bounds, LsqOptions};
use crate::netlist_edit::{param_si, parse_for, set_param_si, split_target};
use crate::synth::interpolate;
use graph::FlatNetlist;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::ops::Range;

/// One measured channel of an experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Model signal ("head.p").
    pub signal: String,
    /// Measured values at the experiment's times (SI); `None` = missing.
    pub values: Vec<Option<f64>>,
    /// Noise standard deviation [SI].
    pub sigma: f64,
    /// Whether `sigma` was estimated from the data (rather than given).
    pub sigma_estimated: bool,
}

/// A measured experiment at one operating point.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    pub name: String,
    /// Overrides "id.param=value" giving the operating point.
    pub sets: Vec<String>,
    /// Sample times in simulation time [s] (≥ 0).
    pub times: Vec<f64>,
    pub channels: Vec<Channel>,
    /// Data time of simulation time 0 [s].
    pub time_origin: f64,
}

impl Experiment {
    /// Build from a data table. `columns` maps data columns to model signals
    /// (all other columns ignored); without it every column is a signal.
    /// `time_origin` is the data time that corresponds to simulation time 0
    /// (default: the first sample); earlier samples are dropped. `noise`
    /// gives σ of some signals; the others are estimated from the data.
    pub fn from_dataset(
        name: &str,
        data: &Dataset,
        columns: Option<&BTreeMap<String, String>>,
        sets: Vec<String>,
        time_origin: Option<f64>,
        noise: &[(String, f64)],
    ) -> Result<Experiment, String> {
        let origin = time_origin.unwrap_or(data.times[0]);
        let first = data.times.partition_point(|&t| t < origin - 1e-12);
        if data.times.len() - first < 3 {
            return Err(format!("{}: fewer than 3 samples after the time origin {origin} s", data.origin));
        }
        let times: Vec<f64> = data.times[first..].iter().map(|t| (t - origin).max(0.0)).collect();
        let pairs: Vec<(usize, String)> = match columns {
            Some(map) => map
                .iter()
                .map(|(col, sig)| {
                    data.channel(col)
                        .map(|c| (c, sig.clone()))
                        .ok_or_else(|| format!("{}: no column \"{col}\" (columns: {})", data.origin, data.names.join(", ")))
                })
                .collect::<Result<_, _>>()?,
            None => data.names.iter().enumerate().map(|(c, n)| (c, n.clone())).collect(),
        };
        if pairs.is_empty() {
            return Err(format!("{}: no measured channel", data.origin));
        }
        let mut channels = Vec::new();
        for (c, signal) in pairs {
            let values = data.values[c][first..].to_vec();
            if values.iter().all(|v| v.is_none()) {
                return Err(format!("{}: column \"{}\" has no values", data.origin, data.names[c]));
            }
            let (sigma, estimated) = match noise.iter().find(|(s, _)| *s == signal) {
                Some((_, s)) => (*s, false),
                None => {
                    let s = noise_sigma(&times, &values).ok_or_else(|| {
                        format!(
                            "{}: cannot estimate the noise of \"{}\" (too few samples); give it under \"noise\"",
                            data.origin, data.names[c]
                        )
                    })?;
                    // noise-free data: floor at 1e-6 of the channel's magnitude
                    let scale = values.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
                    (s.max(1e-6 * scale).max(f64::MIN_POSITIVE), true)
                }
            };
            if !(sigma > 0.0 && sigma.is_finite()) {
                return Err(format!("{}: noise of \"{signal}\" must be > 0, got {sigma}", data.origin));
            }
            channels.push(Channel { signal, values, sigma, sigma_estimated: estimated });
        }
        Ok(Experiment { name: name.to_string(), sets, times, channels, time_origin: origin })
    }

    /// Median sampling interval [s].
    pub fn median_interval(&self) -> f64 {
        let mut d: Vec<f64> = self.times.windows(2).map(|w| w[1] - w[0]).collect();
        crate::data::median(&mut d).unwrap_or(1e-3)
    }

    /// The duration simulated [s].
    pub fn duration(&self) -> f64 {
        self.times.last().copied().unwrap_or(0.0)
    }
}

/// What a fitted parameter acts on.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A netlist parameter "id.param", for the listed experiments (all if `None`).
    Netlist { id: String, param: String, experiments: Option<Vec<usize>> },
    /// Parameter `k` of effect slot `slot` of the problem.
    Effect { slot: usize, k: usize },
}

/// A fitted parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct FitParam {
    /// "friction.k0", "flow_control.C@13.2 L/min/bar", "piston_seal_leak.C".
    pub name: String,
    /// Unit shown to people; values are SI.
    pub unit: String,
    pub lo: f64,
    pub hi: f64,
    /// Starting value [SI].
    pub start: f64,
    /// Scale of the fit coordinate [SI].
    pub typical: f64,
    pub scale: Scale,
    /// Null value of an effect parameter.
    pub null: Option<f64>,
    pub target: Target,
}

impl FitParam {
    /// Fit coordinate of an SI value.
    pub fn to_u(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v / self.typical,
            Scale::Log => (v / self.typical).ln(),
        }
    }
    /// SI value of a fit coordinate.
    pub fn from_u(&self, u: f64) -> f64 {
        match self.scale {
            Scale::Linear => u * self.typical,
            Scale::Log => self.typical * u.exp(),
        }
    }
    /// Whether this is an effect parameter.
    pub fn is_effect(&self) -> bool {
        matches!(self.target, Target::Effect { .. })
    }
}

/// A calibration target with optional bounds (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibSpec {
    pub target: String,
    pub bounds: Option<(f64, f64)>,
}

/// The default calibration set of a cylinder circuit: Coulomb and viscous
/// friction at zero pressure (k0, k2), every throttle's C and the
/// directional valve's C (see docs/discrepancy.md for the reasons).
/// Parameters that are zero in the netlist are skipped (no scale to fit on).
pub fn default_calibration(flat: &FlatNetlist) -> Vec<CalibSpec> {
    let topo = crate::netlist_edit::Topology::of(flat);
    let mut targets = Vec::new();
    if let Some(f) = &topo.friction {
        targets.push(format!("{f}.k0"));
        targets.push(format!("{f}.k2"));
    }
    for t in &topo.throttles {
        targets.push(format!("{t}.C"));
    }
    if let Some(v) = &topo.valve {
        targets.push(format!("{v}.C"));
    }
    targets
        .into_iter()
        .filter(|t| split_target(t).ok().and_then(|(id, p)| param_si(flat, id, p).ok()).is_some_and(|v| v > 0.0))
        .map(|target| CalibSpec { target, bounds: None })
        .collect()
}

/// Turn calibration targets into fit parameters, one per distinct setting
/// among the experiments.
pub fn calibration_params(flat: &FlatNetlist, experiments: &[Experiment], specs: &[CalibSpec]) -> Result<Vec<FitParam>, String> {
    let mut out = Vec::new();
    for spec in specs {
        let (id, param) = split_target(&spec.target).map_err(|e| e.to_string())?;
        let base = param_si(flat, id, param).map_err(|e| format!("calibrate {}: {e}", spec.target))?;
        let unit = crate::netlist_edit::spec_of(flat, id, param).map_err(|e| e.to_string())?.display_unit.to_string();
        // nominal value of each experiment, grouped
        let mut groups: Vec<(f64, String, Vec<usize>)> = Vec::new();
        for (k, e) in experiments.iter().enumerate() {
            let mut v = base;
            let mut label = String::new();
            for s in &e.sets {
                if let Some((t, val)) = s.split_once('=') {
                    if t.trim() == spec.target {
                        v = parse_for(flat, id, param, &graph::expand::value_from_text(val)).map_err(|e| e.to_string())?;
                        label = val.trim().to_string();
                    }
                }
            }
            match groups.iter_mut().find(|g| g.0 == v) {
                Some(g) => g.2.push(k),
                None => groups.push((v, label, vec![k])),
            }
        }
        let single = groups.len() == 1;
        for (v, label, members) in groups {
            let (lo, hi) = match spec.bounds {
                Some(b) => b,
                None if v > 0.0 => (v / 3.0, v * 3.0),
                None => return Err(format!("calibrate {}: the value is {v}; give bounds [lo, hi]", spec.target)),
            };
            if lo >= hi || !lo.is_finite() || !hi.is_finite() {
                return Err(format!("calibrate {}: bounds [{lo}, {hi}] are not an interval", spec.target));
            }
            let start = v.clamp(lo, hi);
            let (scale, typical) = if lo > 0.0 { (Scale::Log, start) } else { (Scale::Linear, start.abs().max((hi - lo) / 10.0)) };
            let name = if single {
                spec.target.clone()
            } else if label.is_empty() {
                format!("{}@netlist value", spec.target)
            } else if label.parse::<f64>().is_ok() {
                // a plain SI number: show it in the parameter's display unit
                match units::to_unit(v, &unit) {
                    Ok(x) if !unit.is_empty() => format!("{}@{} {unit}", spec.target, significant(x, 4)),
                    _ => format!("{}@{}", spec.target, significant(v, 4)),
                }
            } else {
                format!("{}@{label}", spec.target)
            };
            out.push(FitParam {
                name,
                unit: unit.clone(),
                lo,
                hi,
                start,
                typical,
                scale,
                null: None,
                target: Target::Netlist {
                    id: id.to_string(),
                    param: param.to_string(),
                    experiments: if single { None } else { Some(members) },
                },
            });
        }
    }
    Ok(out)
}

/// `x` with `digits` significant digits, without trailing zeros.
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Fit parameters of an effect placed in slot `slot`.
pub fn effect_params(effect: &dyn Effect, slot: usize) -> Vec<FitParam> {
    effect
        .params()
        .into_iter()
        .enumerate()
        .map(|(k, p)| FitParam {
            name: format!("{}.{}", effect.name(), p.name),
            unit: p.unit.to_string(),
            lo: p.lo,
            hi: p.hi,
            start: p.start,
            typical: p.typical,
            scale: p.scale,
            null: p.null,
            target: Target::Effect { slot, k },
        })
        .collect()
}

/// Integrator and output settings of the forward simulations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimSettings {
    pub rtol: f64,
    pub atol: f64,
    /// Largest step [s].
    pub max_step: f64,
}

impl Default for SimSettings {
    fn default() -> Self {
        SimSettings { rtol: 1e-6, atol: 1e-5, max_step: 0.05 }
    }
}

/// The fitting problem for one model structure.
pub struct Problem<'a> {
    pub base: &'a FlatNetlist,
    pub experiments: &'a [Experiment],
    /// Effects applied after calibration, in order.
    pub effects: Vec<&'a dyn Effect>,
    pub params: Vec<FitParam>,
    pub settings: SimSettings,
    /// Fitted sample indices of each experiment.
    pub samples: Vec<Vec<usize>>,
    /// Simulation output interval of each experiment [s].
    pub intervals: Vec<f64>,
    /// Experiments included in the residual vector (all if `None`).
    pub included: Option<Vec<usize>>,
    /// Fraction of each record fitted (from its start); 1 = all of it.
    pub horizon: f64,
}

/// Every s-th sample index and the matching output interval, for a target interval.
pub fn decimate(e: &Experiment, fit_interval: f64) -> (Vec<usize>, f64) {
    let d = e.median_interval();
    let stride = ((fit_interval / d).round() as usize).max(1);
    ((0..e.times.len()).step_by(stride).collect(), stride as f64 * d)
}

impl<'a> Problem<'a> {
    /// Problem on every experiment, comparing samples `fit_interval` apart.
    pub fn new(
        base: &'a FlatNetlist,
        experiments: &'a [Experiment],
        effects: Vec<&'a dyn Effect>,
        params: Vec<FitParam>,
        settings: SimSettings,
        fit_interval: f64,
    ) -> Self {
        let (samples, intervals) = experiments.iter().map(|e| decimate(e, fit_interval)).unzip();
        Problem { base, experiments, effects, params, settings, samples, intervals, included: None, horizon: 1.0 }
    }

    /// The same problem fitted on the first `fraction` of each record only.
    pub fn truncated(&self, fraction: f64) -> Problem<'a> {
        let fraction = fraction.clamp(0.0, 1.0);
        let samples = self
            .samples
            .iter()
            .zip(self.experiments)
            .map(|(s, e)| {
                let end = fraction * e.duration();
                s.iter().copied().filter(|&i| e.times[i] <= end).collect()
            })
            .collect();
        Problem { samples, horizon: fraction, ..self.with_included(self.included()) }
    }

    /// The same problem compared only after the first `fraction` of each
    /// record (simulated over the whole record): the forward held-out part.
    pub fn tail(&self, fraction: f64) -> Problem<'a> {
        let samples = self
            .samples
            .iter()
            .zip(self.experiments)
            .map(|(s, e)| {
                let start = fraction * e.duration();
                s.iter().copied().filter(|&i| e.times[i] > start).collect()
            })
            .collect();
        Problem { samples, horizon: 1.0, ..self.with_included(self.included()) }
    }

    /// The same problem restricted to some experiments.
    pub fn with_included(&self, included: Vec<usize>) -> Problem<'a> {
        Problem {
            base: self.base,
            experiments: self.experiments,
            effects: self.effects.clone(),
            params: self.params.clone(),
            settings: self.settings,
            samples: self.samples.clone(),
            intervals: self.intervals.clone(),
            included: Some(included),
            horizon: self.horizon,
        }
    }

    /// Indices of the experiments in the residual vector.
    pub fn included(&self) -> Vec<usize> {
        self.included.clone().unwrap_or_else(|| (0..self.experiments.len()).collect())
    }

    /// The netlist of experiment k for SI parameter values.
    pub fn netlist(&self, k: usize, values: &[f64]) -> Result<FlatNetlist, String> {
        let mut flat = self.base.clone();
        for s in &self.experiments[k].sets {
            graph::apply_set(&mut flat, s).map_err(|e| format!("{}: {e}", self.experiments[k].name))?;
        }
        for (p, &v) in self.params.iter().zip(values) {
            if let Target::Netlist { id, param, experiments } = &p.target {
                if experiments.as_ref().is_none_or(|m| m.contains(&k)) {
                    set_param_si(&mut flat, id, param, v).map_err(|e| e.to_string())?;
                }
            }
        }
        for (slot, effect) in self.effects.iter().enumerate() {
            let vals: Vec<f64> = self
                .params
                .iter()
                .zip(values)
                .filter_map(|(p, &v)| match p.target {
                    Target::Effect { slot: s, .. } if s == slot => Some(v),
                    _ => None,
                })
                .collect();
            effect.apply(&mut flat, &vals).map_err(|e| e.to_string())?;
        }
        Ok(flat)
    }

    /// Simulate experiment k with output every `interval` seconds.
    pub fn simulate(&self, k: usize, values: &[f64], interval: f64) -> Result<solve::SimResult, String> {
        let flat = self.netlist(k, values)?;
        simulate_netlist(&flat, self.horizon * self.experiments[k].duration(), interval, &self.settings)
    }

    /// Simulated channels of experiment k at the given sample indices.
    pub fn predict(&self, k: usize, values: &[f64], samples: &[usize], interval: f64) -> Result<Vec<Vec<Option<f64>>>, String> {
        let result = self.simulate(k, values, interval)?;
        sample_channels(&result, &self.experiments[k], samples)
    }

    /// Residuals of experiment k at its fitted samples.
    pub fn residuals_of(&self, k: usize, values: &[f64]) -> Result<Vec<f64>, String> {
        let pred = self.predict(k, values, &self.samples[k], self.intervals[k])?;
        Ok(weighted_residuals(&self.experiments[k], &self.samples[k], &pred))
    }

    /// The residual vector for SI values.
    pub fn residuals(&self, values: &[f64]) -> Result<Vec<f64>, String> {
        let parts: Vec<Vec<f64>> = self.included().par_iter().map(|&k| self.residuals_of(k, values)).collect::<Result<_, _>>()?;
        Ok(parts.concat())
    }

    /// Row ranges of each included experiment in the residual vector.
    pub fn layout(&self) -> Vec<(usize, Range<usize>)> {
        let mut at = 0;
        self.included()
            .into_iter()
            .map(|k| {
                let e = &self.experiments[k];
                let n: usize = e.channels.iter().map(|c| self.samples[k].iter().filter(|&&i| c.values[i].is_some()).count()).sum();
                let r = at..at + n;
                at += n;
                (k, r)
            })
            .collect()
    }

    /// SI values of fit coordinates.
    pub fn values_of(&self, u: &[f64]) -> Vec<f64> {
        self.params.iter().zip(u).map(|(p, &x)| p.from_u(x)).collect()
    }
}

/// Simulate a netlist for `duration` seconds with output every `interval`.
pub fn simulate_netlist(flat: &FlatNetlist, duration: f64, interval: f64, s: &SimSettings) -> Result<solve::SimResult, String> {
    let circuit = graph::build(flat).map_err(|e| e.to_string())?;
    let mut opts = solve::options_from(&circuit.simulation).map_err(|e| e.to_string())?;
    opts.cycles = None;
    opts.t_end = duration.max(1e-6);
    opts.rtol = s.rtol;
    opts.atol = s.atol;
    opts.sample_interval = interval;
    opts.max_step = opts.max_step.min(s.max_step);
    let mut model = solve::Model::new(circuit);
    solve::simulate(&mut model, &opts).map_err(|e| e.to_string())
}

/// The experiment's channels from a simulation, interpolated at the samples.
pub fn sample_channels(result: &solve::SimResult, e: &Experiment, samples: &[usize]) -> Result<Vec<Vec<Option<f64>>>, String> {
    e.channels
        .iter()
        .map(|ch| {
            let c = result
                .column(&ch.signal)
                .ok_or_else(|| format!("\"{}\" is not a signal of the model (signals: {})", ch.signal, result.columns.join(", ")))?;
            let col: Vec<Option<f64>> = result.rows.iter().map(|r| r[c]).collect();
            Ok(samples.iter().map(|&i| interpolate(&result.times, &col, e.times[i])).collect())
        })
        .collect()
}

/// (simulated − measured)/σ over the samples where a measurement exists
/// (an undefined simulated value counts as a zero residual).
pub fn weighted_residuals(e: &Experiment, samples: &[usize], pred: &[Vec<Option<f64>>]) -> Vec<f64> {
    let mut r = Vec::new();
    for (ch, sim) in e.channels.iter().zip(pred) {
        for (j, &i) in samples.iter().enumerate() {
            if let Some(y) = ch.values[i] {
                r.push(sim[j].map(|s| (s - y) / ch.sigma).unwrap_or(0.0));
            }
        }
    }
    r
}

/// Result of one fit.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Fit coordinates and SI values at the solution.
    pub u: Vec<f64>,
    pub values: Vec<f64>,
    /// Standard errors in fit coordinates (linearised; `None` if not identifiable).
    pub std_u: Option<Vec<f64>>,
    pub residuals: Vec<f64>,
    pub jacobian: nalgebra::DMatrix<f64>,
    /// Σr² (χ² in noise units).
    pub chi2: f64,
    pub at_bound: Vec<bool>,
    pub converged: bool,
    pub evaluations: usize,
    pub iterations: usize,
    pub message: String,
}

/// Options of one least-squares fit.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Step attempts of the full-record stage.
    pub max_iter: usize,
    /// Step attempts of each short-record stage.
    pub stage_max_iter: usize,
    pub ftol: f64,
    /// Finite-difference step in fit coordinates.
    pub fd_step: f64,
    pub parallel: bool,
    /// Continuation in the record length: the fit is run on the first
    /// fraction h of each record for each h in turn, each stage starting
    /// from the previous one's solution. Fitting the start of the records
    /// first keeps cycle-timing errors from accumulating over many cycles
    /// (where a position residual stops growing with the timing error and
    /// the least-squares landscape gets local minima).
    pub horizons: Vec<f64>,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions { max_iter: 30, stage_max_iter: 30, ftol: 1e-8, fd_step: 1e-3, parallel: true, horizons: vec![0.15, 0.4, 1.0] }
    }
}

/// Fit with continuation over the record length (see [`FitOptions::horizons`]).
pub fn fit(problem: &Problem, start: &[f64], opts: &FitOptions) -> Result<Fit, String> {
    let s = fit_staged(problem, start, opts, None)?;
    let mut f = s.fit.ok_or("no full-record stage")?;
    f.evaluations = s.evaluations;
    Ok(f)
}

/// Σr² of the problem at SI values.
pub fn chi2(problem: &Problem, values: &[f64]) -> Result<f64, String> {
    Ok(problem.residuals(values)?.iter().map(|x| x * x).sum())
}

/// Outcome of [`fit_staged`].
#[derive(Debug, Clone)]
pub struct Staged {
    /// The full-record fit (`None` when the screen stopped before it).
    pub fit: Option<Fit>,
    /// Parameters after the last short-record stage, and that stage's χ² on
    /// its own records (`None` without short stages).
    pub values_short: Option<Vec<f64>>,
    pub chi2_short: Option<f64>,
    /// Simulations of the problem run (all stages).
    pub evaluations: usize,
}

/// Fit with continuation over the record length: each short-record stage
/// starts from the previous stage's solution, the full-record stage from the
/// last short one. `screen`, given the last short stage's χ² (on its own
/// records), decides whether the full-record stage is worth running.
///
/// Shape parameters of effects (those without a null value, e.g. a Stribeck
/// velocity or a line volume) are held at their starting values during the
/// short-record stages: the first part of a record rarely determines them,
/// and left free they drift to their bounds.
pub fn fit_staged(
    problem: &Problem,
    start: &[f64],
    opts: &FitOptions,
    screen: Option<&(dyn Fn(f64) -> bool + Sync)>,
) -> Result<Staged, String> {
    let short = fit_short_stages(problem, start, opts)?;
    let values = short.values_short.clone().unwrap_or_else(|| start.to_vec());
    if let (Some(keep_going), Some(c)) = (screen, short.chi2_short) {
        if !keep_going(c) {
            return Ok(short);
        }
    }
    let f = fit_once(problem, &values, opts)?;
    Ok(Staged { evaluations: short.evaluations + f.evaluations, fit: Some(f), ..short })
}

/// The short-record stages of [`fit_staged`] only (`fit` is `None`).
pub fn fit_short_stages(problem: &Problem, start: &[f64], opts: &FitOptions) -> Result<Staged, String> {
    let mut values = start.to_vec();
    let mut spent = 0;
    let mut chi2_short = None;
    let mut values_short = None;
    let short: Vec<f64> = opts.horizons.iter().copied().filter(|h| *h > 0.0 && *h < 1.0).collect();
    let shape: Vec<bool> = problem.params.iter().map(|p| p.is_effect() && p.null.is_none()).collect();
    for &h in &short {
        let mut stage = problem.truncated(h);
        for (p, (&fixed, &v)) in stage.params.iter_mut().zip(shape.iter().zip(&values)) {
            if fixed {
                p.lo = v;
                p.hi = v;
            }
        }
        let f = fit_once(&stage, &values, &FitOptions { max_iter: opts.stage_max_iter, ..opts.clone() })?;
        spent += f.evaluations;
        chi2_short = Some(f.chi2);
        values = f.values;
        values_short = Some(values.clone());
    }
    Ok(Staged { fit: None, values_short, chi2_short, evaluations: spent })
}

/// One least-squares fit starting from SI values `start`.
pub fn fit_once(problem: &Problem, start: &[f64], opts: &FitOptions) -> Result<Fit, String> {
    let lo: Vec<f64> = problem.params.iter().map(|p| p.to_u(p.lo)).collect();
    let hi: Vec<f64> = problem.params.iter().map(|p| p.to_u(p.hi)).collect();
    let u0: Vec<f64> = problem.params.iter().zip(start).map(|(p, &v)| p.to_u(v.clamp(p.lo, p.hi))).collect();
    let f = |u: &[f64]| problem.residuals(&problem.values_of(u));
    if problem.params.is_empty() {
        let r = f(&[])?;
        let chi2 = r.iter().map(|x| x * x).sum();
        return Ok(Fit {
            u: vec![],
            values: vec![],
            std_u: Some(vec![]),
            jacobian: nalgebra::DMatrix::zeros(r.len(), 0),
            residuals: r,
            chi2,
            at_bound: vec![],
            converged: true,
            evaluations: 1,
            iterations: 0,
            message: "no parameters".into(),
        });
    }
    let lsq_opts =
        LsqOptions { max_iter: opts.max_iter, ftol: opts.ftol, xtol: 1e-8, gtol: 1e-8, fd_rel_step: opts.fd_step, parallel: opts.parallel };
    let res = least_squares(f, &u0, &Bounds::new(lo, hi), &lsq_opts).map_err(|e| e.to_string())?;
    let values = problem.values_of(&res.x);
    Ok(Fit {
        chi2: 2.0 * res.cost,
        values,
        u: res.x,
        std_u: res.std_errors,
        residuals: res.residuals,
        jacobian: res.jacobian,
        at_bound: res.at_bound,
        converged: res.converged,
        evaluations: res.evaluations,
        iterations: res.iterations,
        message: res.message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::netlist_edit::tests_support::meter_out;

    fn dataset(names: &[&str], n: usize) -> Dataset {
        Dataset {
            origin: "mem".into(),
            times: (0..n).map(|i| 5.0 + i as f64 * 1e-3).collect(),
            names: names.iter().map(|s| s.to_string()).collect(),
            values: names.iter().map(|_| (0..n).map(|i| Some((i % 7) as f64)).collect()).collect(),
            lines: vec![],
        }
    }

    #[test]
    fn experiments_map_columns_and_shift_time() {
        let d = dataset(&["p1_Pa", "x_m", "extra"], 50);
        let map: BTreeMap<String, String> =
            [("p1_Pa".to_string(), "head.p".to_string()), ("x_m".to_string(), "piston.x".to_string())].into();
        let e = Experiment::from_dataset("a", &d, Some(&map), vec![], None, &[("head.p".into(), 500.0)]).unwrap();
        assert_eq!(e.channels.len(), 2);
        assert_eq!(e.times[0], 0.0);
        assert!((e.times[10] - 0.010).abs() < 1e-12);
        let p = e.channels.iter().find(|c| c.signal == "head.p").unwrap();
        assert_eq!((p.sigma, p.sigma_estimated), (500.0, false));
        assert!(e.channels.iter().find(|c| c.signal == "piston.x").unwrap().sigma_estimated);
        // an explicit origin drops earlier samples
        let e = Experiment::from_dataset("a", &d, Some(&map), vec![], Some(5.02), &[]).unwrap();
        assert_eq!(e.times.len(), 30);
        let bad: BTreeMap<String, String> = [("nope".to_string(), "head.p".to_string())].into();
        assert!(Experiment::from_dataset("a", &d, Some(&bad), vec![], None, &[]).unwrap_err().contains("nope"));
    }

    #[test]
    fn calibration_groups_per_distinct_setting() {
        let flat = meter_out();
        let d = dataset(&["head.p"], 20);
        let mk = |c: &str| {
            Experiment::from_dataset("e", &d, None, vec![format!("flow_control.C={c}"), "supply.p=4 bar".into()], None, &[]).unwrap()
        };
        let exps = vec![mk("13.2 L/min/bar"), mk("26 L/min/bar"), mk("13.2 L/min/bar")];
        let specs = vec![
            CalibSpec { target: "flow_control.C".into(), bounds: None },
            CalibSpec { target: "friction.k0".into(), bounds: Some((1.0, 60.0)) },
        ];
        let ps = calibration_params(&flat, &exps, &specs).unwrap();
        assert_eq!(ps.len(), 3);
        assert_eq!(ps[0].name, "flow_control.C@13.2 L/min/bar");
        assert_eq!(ps[0].target, Target::Netlist { id: "flow_control".into(), param: "C".into(), experiments: Some(vec![0, 2]) });
        assert!((ps[1].start - 26e-3 / 60.0 / 1e5).abs() < 1e-20);
        assert_eq!((ps[2].name.as_str(), ps[2].lo, ps[2].hi, ps[2].start), ("friction.k0", 1.0, 60.0, 10.0));
        // log coordinate round trip, and linear for a bound at zero
        let p = &ps[2];
        assert!((p.from_u(p.to_u(33.0)) - 33.0).abs() < 1e-12);
        let specs = vec![CalibSpec { target: "friction.k0".into(), bounds: Some((0.0, 60.0)) }];
        let q = &calibration_params(&flat, &exps, &specs).unwrap()[0];
        assert_eq!(q.scale, Scale::Linear);
        assert!((q.from_u(q.to_u(12.0)) - 12.0).abs() < 1e-12);
    }

    #[test]
    fn significant_digits() {
        assert_eq!(significant(29.87654, 4), "29.88");
        assert_eq!(significant(0.000123456, 3), "0.000123");
        assert_eq!(significant(1500.0, 3), "1500");
        assert_eq!(significant(13.2, 4), "13.2");
        // a group named by an SI number is shown in the display unit
        let flat = meter_out();
        let d = dataset(&["head.p"], 20);
        let e = Experiment::from_dataset("e", &d, None, vec!["flow_control.C=4.4e-9".into()], None, &[]).unwrap();
        let f = Experiment::from_dataset("f", &d, None, vec!["flow_control.C=13.2 L/min/bar".into()], None, &[]).unwrap();
        let ps = calibration_params(&flat, &[e, f], &[CalibSpec { target: "flow_control.C".into(), bounds: None }]).unwrap();
        assert_eq!(ps[0].name, "flow_control.C@26.4 L/min/bar");
        assert_eq!(ps[1].name, "flow_control.C@13.2 L/min/bar");
    }

    #[test]
    fn default_calibration_of_meter_out() {
        let names: Vec<String> = default_calibration(&meter_out()).into_iter().map(|c| c.target).collect();
        assert_eq!(names, vec!["friction.k0", "friction.k2", "flow_control.C", "dcv.C"]);
    }

    #[test]
    fn residuals_vanish_on_noise_free_data_of_the_same_model() {
        // Data simulated by the problem itself: zero residuals at the start
        // values, nonzero ones when a parameter moves.
        let flat = meter_out();
        let probe = Experiment {
            name: "probe".into(),
            sets: vec!["supply.p=5 bar".into()],
            times: (0..=400).map(|i| i as f64 * 1e-3).collect(),
            channels: vec![Channel { signal: "head.p".into(), values: vec![Some(0.0); 401], sigma: 500.0, sigma_estimated: false }],
            time_origin: 0.0,
        };
        let specs = vec![CalibSpec { target: "friction.k0".into(), bounds: None }];
        let exps = vec![probe.clone()];
        let params = calibration_params(&flat, &exps, &specs).unwrap();
        let pr = Problem::new(&flat, &exps, vec![], params.clone(), SimSettings { rtol: 1e-6, atol: 1e-6, max_step: 0.05 }, 2e-3);
        let start: Vec<f64> = params.iter().map(|p| p.start).collect();
        let pred = pr.predict(0, &start, &(0..=400).collect::<Vec<_>>(), 1e-3).unwrap();
        let mut measured = probe;
        measured.channels[0].values = pred[0].clone();
        let exps = vec![measured];
        let pr = Problem::new(&flat, &exps, vec![], params, SimSettings { rtol: 1e-6, atol: 1e-6, max_step: 0.05 }, 2e-3);
        assert_eq!(pr.samples[0].len(), 201);
        assert!((pr.intervals[0] - 2e-3).abs() < 1e-12);
        let r = pr.residuals(&start).unwrap();
        assert_eq!(r.len(), 201);
        // equal up to the integrator tolerance (rtol 1e-6 of 5 bar = 0.5 Pa = 1e-3 σ)
        assert!(r.iter().all(|x| x.abs() < 1e-3), "{:?}", r.iter().fold(0.0_f64, |m, x| m.max(x.abs())));
        let r2 = pr.residuals(&[30.0]).unwrap();
        assert!(r2.iter().any(|x| x.abs() > 1.0));
        assert_eq!(pr.layout(), vec![(0, 0..201)]);
    }
}
