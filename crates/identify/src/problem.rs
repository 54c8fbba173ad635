//! The output-error fitting problem of one model structure: the netlist of
//! each experiment for given parameter values, its forward simulation, and
//! the noise-weighted residuals with the sensors' nuisance parameters
//! eliminated.
//!
//! # Residuals
//! For experiment k, measured channel c and fitted sample i:
//! r = (o_kc + (1 + g_kc)·ŷ_c(t_i − δ_k; θ) − y_c(t_i)) / σ_kc, where ŷ is
//! the simulation of the netlist for parameters θ at the experiment's
//! operating point, linearly interpolated at t_i − δ_k from the simulation's
//! output grid, σ_kc the channel's noise level ([`crate::data::noise_sigma`],
//! or given), o, g the sensor offset and gain error and δ_k the
//! experiment's logger time skew, all set to their MAP values under the
//! channels' priors for every simulation ([`crate::nuisance`]). Missing
//! samples are left out; a sample the simulation leaves undefined counts as
//! zero. Minimising ½Σr² is maximum likelihood for white Gaussian sensor
//! noise; how the residual correlation that remains is accounted for is in
//! [`crate::stats`].
//!
//! # Prior rows
//! The priors are rows of the residual vector too, so that the fit
//! minimises the posterior: after the data rows of experiment k come its
//! sensors' prior rows (o/σ_o, g/σ_g of each channel that has them, then
//! δ_k/σ_δ), and after every experiment the rows (θ − μ)/s of the
//! calibration parameters with a prior ([`crate::params::FitParam::prior`]).
//! [`Problem::blocks`] holds the data rows only (the statistics of
//! [`crate::stats`] are about data); [`Problem::layout`] gives each
//! experiment's data and prior rows.
//!
//! # Order of netlist edits for one experiment
//! the experiment's `set` list → calibration values → effects in order.
//!
//! # Sampling
//! The fit compares every s-th sample ([`crate::experiment::decimate`]) and
//! simulates with output every s·Δt (exact at the samples for evenly
//! sampled data, linear interpolation otherwise). Simulation time 0 is the
//! experiment's time origin (default: its first sample); the simulation
//! runs to the last sample, or to the `horizon` fraction of it, plus the
//! skew bound (so that a sample shifted by −δ still has a simulated value).
//!
//! # Rows
//! Experiments in order, and within one experiment its channels in order
//! (all fitted samples of channel 0, then channel 1, …): each (experiment,
//! channel) is one [`Block`] of rows.

use crate::data::{interpolate_many, interpolate_many_smooth};
use crate::effects::Effect;
use crate::experiment::{decimate, Experiment};
use crate::netlist_edit::set_param_si;
use crate::nuisance::{best_skew, profile, SensorFit, SensorModel};
use crate::params::{FitParam, Target};
use crate::reuse::RowCache;
use graph::FlatNetlist;
use rayon::prelude::*;
use std::ops::Range;

/// Integrator settings of the forward simulations.
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

/// The rows of one channel of one experiment in the residual vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// Index of the experiment.
    pub experiment: usize,
    /// Index of the channel within the experiment.
    pub channel: usize,
    pub rows: Range<usize>,
}

/// The fitting problem for one model structure.
#[derive(Clone)]
pub struct Problem<'a> {
    pub base: &'a FlatNetlist,
    pub experiments: &'a [Experiment],
    /// Effects applied after calibration, in order.
    pub effects: Vec<&'a dyn Effect>,
    pub params: Vec<FitParam>,
    pub settings: SimSettings,
    /// Sensor errors eliminated from the residuals.
    pub sensors: SensorModel,
    /// Fitted sample indices of each experiment.
    pub samples: Vec<Vec<usize>>,
    /// Simulation output interval of each experiment [s].
    pub intervals: Vec<f64>,
    /// Experiments included in the residual vector (all if `None`).
    pub included: Option<Vec<usize>>,
    /// Fraction of each record fitted (from its start); 1 = all of it.
    pub horizon: f64,
}

impl<'a> Problem<'a> {
    /// Problem on every experiment, comparing samples `fit_interval` apart.
    pub fn new(
        base: &'a FlatNetlist,
        experiments: &'a [Experiment],
        effects: Vec<&'a dyn Effect>,
        params: Vec<FitParam>,
        settings: SimSettings,
        sensors: SensorModel,
        fit_interval: f64,
    ) -> Self {
        let (samples, intervals) = experiments.iter().map(|e| decimate(e, fit_interval)).unzip();
        Problem { base, experiments, effects, params, settings, sensors, samples, intervals, included: None, horizon: 1.0 }
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
        Problem { samples, horizon: fraction, ..self.clone() }
    }

    /// The same problem restricted to some experiments.
    pub fn with_included(&self, included: Vec<usize>) -> Problem<'a> {
        Problem { included: Some(included), ..self.clone() }
    }

    /// The same problem with other parameters (same effects).
    pub fn with_params(&self, params: Vec<FitParam>) -> Problem<'a> {
        Problem { params, ..self.clone() }
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

    /// Simulate experiment k with output every `interval` seconds (at the
    /// data's own interval at most while a skew is fitted: the shifted
    /// samples are read between output points by a cubic curve, whose
    /// error at a valve's pressure edge on a 4 ms grid biased the skew by
    /// half a millisecond).
    ///
    /// Only the experiment's channels are recorded (the other columns stay
    /// empty): when they are all block signals an output row then costs no
    /// model evaluation, and the numbers are the same
    /// ([`solve::SimOptions::record_only`]). [`Problem::simulate_with`]
    /// records more columns, [`Problem::simulate_all`] every one.
    pub fn simulate(&self, k: usize, values: &[f64], interval: f64) -> Result<solve::SimResult, String> {
        self.simulate_with(k, values, interval, &[])
    }

    /// [`Problem::simulate`] recording the columns `extra` too.
    pub fn simulate_with(&self, k: usize, values: &[f64], interval: f64, extra: &[String]) -> Result<solve::SimResult, String> {
        let channels = self.experiments[k].channels.iter().map(|c| c.signal.clone()).chain(extra.iter().cloned()).collect();
        self.simulate_recording(k, values, interval, Some(channels))
    }

    /// [`Problem::simulate`] recording every output column (for the report's
    /// phases and regressors).
    pub fn simulate_all(&self, k: usize, values: &[f64], interval: f64) -> Result<solve::SimResult, String> {
        self.simulate_recording(k, values, interval, None)
    }

    fn simulate_recording(
        &self,
        k: usize,
        values: &[f64],
        interval: f64,
        record_only: Option<Vec<String>>,
    ) -> Result<solve::SimResult, String> {
        let flat = self.netlist(k, values)?;
        let e = &self.experiments[k];
        let interval = if self.sensors.fits_skew() { interval.min(e.median_interval()) } else { interval };
        let duration = self.horizon * e.duration() + self.sensors.skew_bound();
        simulate_netlist_recording(&flat, duration, interval, &self.settings, record_only)
    }

    /// Rows of experiment k at its fitted samples from a simulation
    /// `result` of it — the data rows of each channel in turn, then the
    /// experiment's sensor prior rows (see the module header) — and the
    /// sensor errors fitted per channel.
    pub fn residuals_from(&self, k: usize, result: &solve::SimResult) -> Result<(Vec<f64>, Vec<SensorFit>), String> {
        let e = &self.experiments[k];
        let (pred, skew) = Sampler::new(result, e, &self.samples[k])?.best(&self.sensors);
        let mut r = Vec::new();
        let mut fits = Vec::new();
        for (ch, sim) in e.channels.iter().zip(&pred) {
            let (so, sg) = self.sensors.effective(ch.prior.as_ref());
            let (rows, fit) = channel_residuals(&ch.values, &self.samples[k], sim, ch.sigma, so, sg);
            r.extend(rows);
            fits.push(fit);
        }
        r.extend(fits.iter().flat_map(|f| f.prior_rows()));
        if self.sensors.fits_skew() {
            r.push(skew / self.sensors.skew);
        }
        Ok((r, fits))
    }

    /// Rows of experiment k (data and sensor priors) for SI parameter values.
    pub fn residuals_of(&self, k: usize, values: &[f64]) -> Result<Vec<f64>, String> {
        let result = self.simulate(k, values, self.intervals[k])?;
        Ok(self.residuals_from(k, &result)?.0)
    }

    /// The residual vector for SI values: every included experiment's rows,
    /// then the calibration parameters' prior rows.
    pub fn residuals(&self, values: &[f64]) -> Result<Vec<f64>, String> {
        let parts: Vec<Vec<f64>> = self.included().par_iter().map(|&k| self.residuals_of(k, values)).collect::<Result<_, _>>()?;
        let mut r = parts.concat();
        r.extend(self.param_prior_rows(values));
        Ok(r)
    }

    /// Whether parameter `j` changes the netlist of experiment `k` (a
    /// netlist parameter fitted for some experiments only does not reach
    /// the others; every other parameter reaches every experiment).
    pub fn reaches(&self, j: usize, k: usize) -> bool {
        match &self.params[j].target {
            Target::Netlist { experiments: Some(m), .. } => m.contains(&k),
            _ => true,
        }
    }

    /// [`Problem::residuals`] at fit coordinates `u`, with the rows of an
    /// experiment taken from `cache` where a kept evaluation differs from
    /// `u` only in coordinates that do not reach it ([`crate::reuse`]: the
    /// same result bit for bit, fewer simulations); the rows computed are
    /// kept for later calls.
    pub fn residuals_reusing(&self, u: &[f64], cache: &RowCache) -> Result<Vec<f64>, String> {
        let values = self.values_of(u);
        let included = self.included();
        let found = cache.lookup(u, included.len(), |j, i| self.reaches(j, included[i]));
        let parts: Vec<Vec<f64>> = included
            .par_iter()
            .zip(found.into_par_iter())
            .map(|(&k, kept)| match kept {
                Some(rows) => Ok(rows),
                None => self.residuals_of(k, &values),
            })
            .collect::<Result<_, _>>()?;
        cache.keep(u, &parts);
        let mut r = parts.concat();
        r.extend(self.param_prior_rows(&values));
        Ok(r)
    }

    /// (θ − μ)/s of every parameter with a prior, in order.
    pub fn param_prior_rows<'v>(&'v self, values: &'v [f64]) -> impl Iterator<Item = f64> + 'v {
        self.params.iter().zip(values).filter_map(|(p, v)| p.prior_row(*v))
    }

    /// Number of sensor prior rows of experiment k.
    pub fn sensor_prior_rows(&self, k: usize) -> usize {
        let e = &self.experiments[k];
        e.channels.iter().map(|c| self.sensors.rows_per_channel(c.prior.as_ref())).sum::<usize>() + usize::from(self.sensors.fits_skew())
    }

    /// Row blocks (experiment × channel) of the data rows of the residual vector.
    pub fn blocks(&self) -> Vec<Block> {
        let mut at = 0;
        let mut out = Vec::new();
        for k in self.included() {
            let e = &self.experiments[k];
            for (c, ch) in e.channels.iter().enumerate() {
                let n = self.samples[k].iter().filter(|&&i| ch.values[i].is_some()).count();
                out.push(Block { experiment: k, channel: c, rows: at..at + n });
                at += n;
            }
            at += self.sensor_prior_rows(k);
        }
        out
    }

    /// Row ranges of each included experiment (data and sensor prior rows).
    pub fn layout(&self) -> Vec<(usize, Range<usize>)> {
        let mut at = 0;
        let mut out = Vec::new();
        for k in self.included() {
            let e = &self.experiments[k];
            let n: usize = e.channels.iter().map(|ch| self.samples[k].iter().filter(|&&i| ch.values[i].is_some()).count()).sum();
            let end = at + n + self.sensor_prior_rows(k);
            out.push((k, at..end));
            at = end;
        }
        out
    }

    /// Number of residuals (data and prior rows).
    pub fn len(&self) -> usize {
        self.layout().last().map_or(0, |(_, r)| r.end) + self.params.iter().filter(|p| p.prior.is_some()).count()
    }

    /// Whether there are no residuals.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// SI values of fit coordinates.
    pub fn values_of(&self, u: &[f64]) -> Vec<f64> {
        self.params.iter().zip(u).map(|(p, &x)| p.from_u(x)).collect()
    }
}

/// Residuals of one channel: measured values `values` (all samples of the
/// experiment), the fitted sample indices, the simulated values at those
/// samples, σ and the prior σ of offset and gain (∞ = free, 0 = not
/// fitted; [`SensorModel::effective`]). One row per sample with a
/// measurement; the prior rows are in the returned fit.
pub fn channel_residuals(
    values: &[Option<f64>],
    samples: &[usize],
    simulated: &[Option<f64>],
    sigma: f64,
    so: f64,
    sg: f64,
) -> (Vec<f64>, SensorFit) {
    let (mut s, mut y) = (Vec::new(), Vec::new());
    for (j, &i) in samples.iter().enumerate() {
        if let (Some(m), Some(p)) = (values[i], simulated[j]) {
            s.push(p);
            y.push(m);
        }
    }
    let (r, fit) = profile(&s, &y, sigma, so, sg);
    let mut rows = Vec::with_capacity(samples.len());
    let mut it = r.into_iter();
    for (j, &i) in samples.iter().enumerate() {
        if values[i].is_some() {
            rows.push(if simulated[j].is_some() { it.next().unwrap_or(0.0) } else { 0.0 });
        }
    }
    (rows, fit)
}

/// Simulations run by this process and their summed wall time [ns]
/// (run-time accounting of docs/discrepancy.md, "Run time").
static SIMULATIONS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
static SIMULATED_NS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
static SIMULATED_SECONDS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// (simulations run, their summed wall time [s], simulated time [s]) since the process started.
pub fn simulation_count() -> (usize, f64, f64) {
    use std::sync::atomic::Ordering::Relaxed;
    (SIMULATIONS.load(Relaxed), SIMULATED_NS.load(Relaxed) as f64 * 1e-9, SIMULATED_SECONDS.load(Relaxed) as f64 * 1e-6)
}

/// Simulate a netlist for `duration` seconds with output every `interval`.
pub fn simulate_netlist(flat: &FlatNetlist, duration: f64, interval: f64, s: &SimSettings) -> Result<solve::SimResult, String> {
    simulate_netlist_recording(flat, duration, interval, s, None)
}

/// [`simulate_netlist`] recording only the columns `record_only` names
/// (every column if `None`; [`solve::SimOptions::record_only`]).
pub fn simulate_netlist_recording(
    flat: &FlatNetlist,
    duration: f64,
    interval: f64,
    s: &SimSettings,
    record_only: Option<Vec<String>>,
) -> Result<solve::SimResult, String> {
    use std::sync::atomic::Ordering::Relaxed;
    let clock = std::time::Instant::now();
    let run = || -> Result<solve::SimResult, String> {
        let circuit = graph::build(flat).map_err(|e| e.to_string())?;
        let mut opts = solve::options_from(&circuit.simulation).map_err(|e| e.to_string())?;
        opts.cycles = None;
        opts.t_end = duration.max(1e-6);
        opts.rtol = s.rtol;
        opts.atol = s.atol;
        opts.sample_interval = interval;
        opts.max_step = opts.max_step.min(s.max_step);
        opts.record_only = record_only;
        let mut model = solve::Model::new(circuit);
        solve::simulate(&mut model, &opts).map_err(|e| e.to_string())
    };
    let out = run();
    SIMULATIONS.fetch_add(1, Relaxed);
    SIMULATED_NS.fetch_add(clock.elapsed().as_nanos() as u64, Relaxed);
    SIMULATED_SECONDS.fetch_add((duration * 1e6) as u64, Relaxed);
    out
}

/// A column of a simulation interpolated at the experiment's samples.
pub fn column_at(result: &solve::SimResult, name: &str, e: &Experiment, samples: &[usize]) -> Option<Vec<Option<f64>>> {
    let c = result.column(name)?;
    let col: Vec<Option<f64>> = result.rows.iter().map(|r| r[c]).collect();
    Some(interpolate_many(&result.times, &col, samples.iter().map(|&i| e.times[i])))
}

/// The experiment's channels from a simulation, interpolated at the samples.
pub fn sample_channels(result: &solve::SimResult, e: &Experiment, samples: &[usize]) -> Result<Vec<Vec<Option<f64>>>, String> {
    Ok(Sampler::new(result, e, samples)?.at(0.0, false))
}

/// The simulated columns of an experiment's channels, read at its samples
/// shifted by a logger time skew δ (a sample stamped t compares with the
/// simulation at t − δ; [`crate::nuisance`]).
pub struct Sampler<'r> {
    result: &'r solve::SimResult,
    e: &'r Experiment,
    samples: &'r [usize],
    columns: Vec<Vec<Option<f64>>>,
}

impl<'r> Sampler<'r> {
    /// The columns of `e`'s channels; an error names a channel the model does not record.
    pub fn new(result: &'r solve::SimResult, e: &'r Experiment, samples: &'r [usize]) -> Result<Self, String> {
        let columns = e
            .channels
            .iter()
            .map(|ch| {
                let c = result
                    .column(&ch.signal)
                    .ok_or_else(|| format!("\"{}\" is not a signal of the model (signals: {})", ch.signal, result.columns.join(", ")))?;
                Ok(result.rows.iter().map(|r| r[c]).collect())
            })
            .collect::<Result<_, String>>()?;
        Ok(Sampler { result, e, samples, columns })
    }

    /// Every channel at the samples shifted by δ [s]; by cubic Hermite
    /// interpolation ([`crate::data::interpolate_many_smooth`]) when
    /// `smooth`, linearly otherwise. A fitted skew needs the smooth form:
    /// linear interpolation has a kink wherever a shifted sample crosses a
    /// point of the simulation's output grid, and with near-even sampling
    /// every sample crosses at once near δ = 0, so the profiled δ sat on a
    /// kink and the residuals were not differentiable in the model
    /// parameters — a seal-leak fit stopped at χ² 56 655 where the smooth
    /// version reaches 21 324 (nominal leak seed 2, skew and throttle index
    /// fitted).
    pub fn at(&self, delta: f64, smooth: bool) -> Vec<Vec<Option<f64>>> {
        let times = self.samples.iter().map(|&i| self.e.times[i] - delta);
        self.columns
            .iter()
            .map(|col| {
                if smooth {
                    interpolate_many_smooth(&self.result.times, col, times.clone())
                } else {
                    interpolate_many(&self.result.times, col, times.clone())
                }
            })
            .collect()
    }

    /// The experiment's posterior cost at skew δ: Σr² over the channels
    /// with offsets and gains eliminated, their prior terms, and (δ/σ_δ)².
    pub fn cost(&self, delta: f64, sensors: &SensorModel) -> f64 {
        let data: f64 = self
            .at(delta, sensors.fits_skew())
            .iter()
            .zip(&self.e.channels)
            .map(|(sim, ch)| {
                let (so, sg) = sensors.effective(ch.prior.as_ref());
                let (r, fit) = channel_residuals(&ch.values, self.samples, sim, ch.sigma, so, sg);
                r.iter().map(|x| x * x).sum::<f64>() + fit.penalty()
            })
            .sum();
        let prior = if sensors.fits_skew() { (delta / sensors.skew).powi(2) } else { 0.0 };
        data + prior
    }

    /// The channels at the MAP skew within the sensor model's bound, and that skew.
    pub fn best(&self, sensors: &SensorModel) -> (Vec<Vec<Option<f64>>>, f64) {
        let delta = best_skew(sensors.skew_bound(), |d| self.cost(d, sensors));
        (self.at(delta, sensors.fits_skew()), delta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::Channel;
    use crate::netlist_edit::tests_support::meter_out;
    use crate::params::{calibration_params, CalibSpec};

    fn probe(values: Vec<Option<f64>>) -> Experiment {
        let n = values.len();
        Experiment {
            name: "probe".into(),
            sets: vec!["supply.p=5 bar".into()],
            times: (0..n).map(|i| i as f64 * 1e-3).collect(),
            channels: vec![Channel { signal: "head.p".into(), values, sigma: 500.0, sigma_estimated: false, prior: None }],
            time_origin: 0.0,
        }
    }

    #[test]
    fn residuals_vanish_on_data_of_the_same_model_with_a_sensor_offset() {
        // Data simulated by the problem itself plus a 1 kPa offset: zero
        // residuals at the start values once the offset is eliminated,
        // nonzero ones when a parameter moves.
        let flat = meter_out();
        let exps = vec![probe(vec![Some(0.0); 401])];
        let specs = vec![CalibSpec::plain("friction.k0")];
        let params = calibration_params(&flat, &exps, &specs).unwrap();
        let settings = SimSettings { rtol: 1e-6, atol: 1e-6, max_step: 0.05 };
        let offsets = SensorModel { offset: true, gain: false, skew: 0.0 };
        let pr = Problem::new(&flat, &exps, vec![], params.clone(), settings, offsets, 1e-3);
        let start: Vec<f64> = params.iter().map(|p| p.start).collect();
        let result = pr.simulate(0, &start, 1e-3).unwrap();
        let pred = sample_channels(&result, &exps[0], &(0..=400).collect::<Vec<_>>()).unwrap();
        let exps = vec![probe(pred[0].iter().map(|v| v.map(|p| p + 1000.0)).collect())];
        let pr = Problem::new(&flat, &exps, vec![], params.clone(), settings, offsets, 2e-3);
        assert_eq!(pr.samples[0].len(), 201);
        assert!((pr.intervals[0] - 2e-3).abs() < 1e-12);
        let result = pr.simulate(0, &start, pr.intervals[0]).unwrap();
        let (r, fits) = pr.residuals_from(0, &result).unwrap();
        assert_eq!(r.len(), 201);
        // equal up to the integrator tolerance (rtol 1e-6 of 5 bar = 0.5 Pa = 1e-3 σ)
        assert!(r.iter().all(|x| x.abs() < 2e-3), "{:?}", r.iter().fold(0.0_f64, |m, x| m.max(x.abs())));
        // the data read 1 kPa high: y = o + s with o = +1 kPa (crate::nuisance)
        assert!((fits[0].offset - 1000.0).abs() < 1.0, "{fits:?}");
        let r2 = pr.residuals(&[30.0]).unwrap();
        assert!(r2.iter().any(|x| x.abs() > 1.0));
        assert_eq!(pr.layout(), vec![(0, 0..201)]);
        // without the offset model the offset is a 2 σ bias
        let plain = Problem { sensors: SensorModel { offset: false, gain: false, skew: 0.0 }, ..pr.clone() };
        let r = plain.residuals(&start).unwrap();
        assert!(r.iter().all(|x| (x + 2.0).abs() < 2e-3));
    }

    #[test]
    fn a_logger_skew_is_found_and_removed_when_fitted() {
        // Data of the model itself, stamped 0.7 ms late (a sample stamped t
        // was taken at t − 0.7 ms), read from a fine simulation.
        let flat = meter_out();
        let specs = vec![CalibSpec::plain("friction.k0")];
        let exps = vec![probe(vec![Some(0.0); 401])];
        let params = calibration_params(&flat, &exps, &specs).unwrap();
        let settings = SimSettings { rtol: 1e-8, atol: 1e-8, max_step: 0.05 };
        let start: Vec<f64> = params.iter().map(|p| p.start).collect();
        let pr = Problem::new(&flat, &exps, vec![], params.clone(), settings, SensorModel::default(), 1e-3);
        let fine = pr.simulate(0, &start, 1e-5).unwrap();
        let skew = 0.7e-3;
        let c = fine.column("head.p").unwrap();
        let col: Vec<Option<f64>> = fine.rows.iter().map(|r| r[c]).collect();
        let data = interpolate_many(&fine.times, &col, (0..401).map(|i| i as f64 * 1e-3 - skew));
        let exps = vec![probe(data)];
        let fitted = SensorModel { offset: true, gain: false, skew: 1e-3 };
        let pr = Problem::new(&flat, &exps, vec![], params.clone(), settings, fitted, 1e-3);
        let result = pr.simulate(0, &start, pr.intervals[0]).unwrap();
        let sampler = Sampler::new(&result, &exps[0], &pr.samples[0]).unwrap();
        let (_, found) = sampler.best(&fitted);
        assert!((found - skew).abs() < 10e-6, "skew {found} s, truth {skew} s");
        let worst = |r: &[f64]| r.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let with = pr.residuals(&start).unwrap();
        // without the skew the pressure rise is read 0.7 ms early: tens of σ
        let without = Problem { sensors: SensorModel { skew: 0.0, ..fitted }, ..pr.clone() }.residuals(&start).unwrap();
        let rms = |r: &[f64]| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt();
        assert!(rms(&with) < 0.3 && worst(&without) > 10.0, "with {} (worst {}) without {}", rms(&with), worst(&with), worst(&without));
        // what is left is the interpolation of the 1 ms output grid at the valve switch (a few σ at one sample)
        assert!(worst(&with) < 5.0, "{}", worst(&with));
    }

    #[test]
    fn rows_reused_for_an_experiment_a_parameter_does_not_reach_are_the_same_bit_for_bit() {
        // friction.k0 for both experiments, friction.k2 fitted for the
        // second only (as a throttle's C per operating point is)
        let flat = meter_out();
        let mut second = probe(vec![Some(2e5); 301]);
        second.sets = vec!["supply.p=6 bar".into()];
        let exps = vec![probe(vec![Some(2e5); 301]), second];
        let specs = vec![CalibSpec::plain("friction.k0"), CalibSpec::plain("friction.k2")];
        let mut params = calibration_params(&flat, &exps, &specs).unwrap();
        params[1].target = Target::Netlist { id: "friction".into(), param: "k2".into(), experiments: Some(vec![1]) };
        let settings = SimSettings { rtol: 1e-6, atol: 1e-6, max_step: 0.05 };
        let pr = Problem::new(&flat, &exps, vec![], params.clone(), settings, SensorModel::default(), 1e-3);
        assert!(pr.reaches(0, 0) && pr.reaches(0, 1) && pr.reaches(1, 1) && !pr.reaches(1, 0));
        let u0: Vec<f64> = params.iter().map(|p| p.to_u(p.start)).collect();
        let cache = RowCache::for_coordinates(2);
        let plain = |u: &[f64]| pr.residuals(&pr.values_of(u)).unwrap();
        assert_eq!(pr.residuals_reusing(&u0, &cache).unwrap(), plain(&u0));
        // a column in k2 (the first experiment's rows come from the cache)
        // and one in k0 (nothing to reuse): both as computed afresh
        for j in 0..2 {
            let mut u = u0.clone();
            u[j] += 0.3;
            let reused = pr.residuals_reusing(&u, &cache).unwrap();
            let fresh = plain(&u);
            assert_eq!(reused.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), fresh.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
            assert_ne!(fresh, plain(&u0), "moving coordinate {j} changes the residuals");
        }
        // at a new value of k2 the first experiment's rows are kept ones, the second's are not
        let found = cache.lookup(&[u0[0], u0[1] + 0.7], 2, |j, i| pr.reaches(j, i));
        assert!(found[0].is_some() && found[1].is_none());
    }

    #[test]
    fn blocks_follow_experiments_and_channels_and_skip_missing_samples() {
        let flat = meter_out();
        let mut e = probe(vec![Some(1e5); 9]);
        e.channels.push(Channel {
            signal: "piston.x".into(),
            values: vec![Some(0.0), None, Some(0.0), None, None, Some(0.0), None, None, None],
            sigma: 1e-5,
            sigma_estimated: false,
            prior: None,
        });
        let exps = vec![e.clone(), e];
        let pr =
            Problem::new(&flat, &exps, vec![], vec![], SimSettings::default(), SensorModel { offset: true, gain: false, skew: 0.0 }, 1e-3);
        let b = pr.blocks();
        assert_eq!(
            b.iter().map(|b| (b.experiment, b.channel, b.rows.clone())).collect::<Vec<_>>(),
            vec![(0, 0, 0..9), (0, 1, 9..12), (1, 0, 12..21), (1, 1, 21..24)]
        );
        assert_eq!(pr.layout(), vec![(0, 0..12), (1, 12..24)]);
        assert_eq!(pr.len(), 24);
        // a missing simulated value counts as zero and is kept out of the offset
        let (rows, fit) =
            channel_residuals(&[Some(1.0), Some(3.0), Some(5.0)], &[0, 1, 2], &[Some(0.0), None, Some(2.0)], 1.0, f64::INFINITY, 0.0);
        assert_eq!(fit.offset, 2.0);
        assert_eq!(rows, vec![1.0, 0.0, -1.0]);
    }
}
