//! Synthetic "measurements" for tests, benchmarks and the shipped example:
//! the same circuit with one hidden effect, simulated with a tighter
//! integrator setting than the fits use, resampled at the sensor rate and
//! corrupted with realistic sensor noise.
//!
//! # Truth generation
//! 1. The netlist of each operating point, with the hidden effect applied,
//!    is simulated with rtol = atol = 1e-7 and output every 0.3 ms (the fits
//!    use rtol 1e-6 and their own output grid, so integrator error is part of
//!    the test).
//! 2. The fine output is resampled at the sensor rate (default 1 kHz) by
//!    linear interpolation (error below 0.1 mbar at 0.3 ms spacing).
//! 3. Noise: each channel gets white Gaussian noise (pressure σ = 5 mbar,
//!    position σ = 20 µm, temperature σ = 0.2 K, velocity σ = 2 mm/s) plus,
//!    for pressures, a constant offset drawn once per experiment and channel
//!    from N(0, (2 mbar)²).
//!
//! Random numbers: [`crate::rng::Rng`]. Deterministic for a seed.
//!
//! Nothing else in the crate depends on this module: it is a test and
//! example helper that uses the pipeline's inputs (experiments, effects).

use crate::data::interpolate;
use crate::data::Dataset;
use crate::effects;
use crate::experiment::Experiment;
use graph::FlatNetlist;

pub use crate::rng::Rng;

/// Sensor noise of a synthetic measurement, by signal kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorNoise {
    /// White noise of pressure channels [Pa].
    pub pressure: f64,
    /// Standard deviation of the constant offset of each pressure channel [Pa].
    pub pressure_offset: f64,
    /// White noise of positions [m].
    pub position: f64,
    /// White noise of temperatures [K].
    pub temperature: f64,
    /// White noise of velocities [m/s].
    pub velocity: f64,
}

impl Default for SensorNoise {
    fn default() -> Self {
        SensorNoise { pressure: 500.0, pressure_offset: 200.0, position: 20e-6, temperature: 0.2, velocity: 2e-3 }
    }
}

impl SensorNoise {
    /// (white σ, offset σ) of a signal, from its name ("head.p", "piston.x").
    pub fn of(&self, signal: &str) -> (f64, f64) {
        match signal.rsplit('.').next().unwrap_or("") {
            "p" => (self.pressure, self.pressure_offset),
            "x" => (self.position, 0.0),
            "T" => (self.temperature, 0.0),
            "v" => (self.velocity, 0.0),
            _ => (0.0, 0.0),
        }
    }
}

/// Settings of the truth simulation and the sampling.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthSettings {
    pub rtol: f64,
    /// Output interval of the fine simulation [s].
    pub fine_interval: f64,
    /// Sensor sampling interval [s].
    pub sample_interval: f64,
    /// Duration of each record [s]; with `cycles`, the longest record.
    pub duration: f64,
    /// Record until this many actuator cycles are complete (the record then
    /// ends with the last cycle).
    pub cycles: Option<u64>,
    pub noise: SensorNoise,
    /// Signals recorded.
    pub channels: Vec<String>,
}

impl Default for TruthSettings {
    fn default() -> Self {
        TruthSettings {
            rtol: 1e-7,
            fine_interval: 3e-4,
            sample_interval: 1e-3,
            duration: 4.0,
            cycles: None,
            noise: SensorNoise::default(),
            channels: vec!["head.p".into(), "rod.p".into(), "piston.x".into()],
        }
    }
}

/// Simulate `flat` finely for `duration` seconds.
pub fn simulate_fine(flat: &FlatNetlist, s: &TruthSettings) -> Result<solve::SimResult, String> {
    let circuit = graph::build(flat).map_err(|e| e.to_string())?;
    let mut opts = solve::options_from(&circuit.simulation).map_err(|e| e.to_string())?;
    opts.cycles = s.cycles;
    opts.t_end = s.duration;
    opts.rtol = s.rtol;
    opts.atol = s.rtol;
    opts.sample_interval = s.fine_interval;
    opts.max_step = opts.max_step.min(0.01);
    let mut model = solve::Model::new(circuit);
    solve::simulate(&mut model, &opts).map_err(|e| e.to_string())
}

/// Resample a fine result at the sensor rate and add noise: a measured table
/// with columns named after the signals, times starting at `t0`.
pub fn measure(result: &solve::SimResult, s: &TruthSettings, t0: f64, rng: &mut Rng) -> Result<Dataset, String> {
    if let Some(n) = s.cycles {
        if (result.cycles.len() as u64) < n {
            return Err(format!("only {} of {n} cycles completed in {} s", result.cycles.len(), s.duration));
        }
    }
    let duration = if s.cycles.is_some() { result.t_final } else { s.duration };
    let n = (duration / s.sample_interval).floor() as usize + 1;
    let times: Vec<f64> = (0..n).map(|i| i as f64 * s.sample_interval).collect();
    let mut values = Vec::new();
    for ch in &s.channels {
        let c = result.column(ch).ok_or_else(|| format!("no signal {ch} in the truth simulation"))?;
        let col: Vec<Option<f64>> = result.rows.iter().map(|r| r[c]).collect();
        let (white, offset_sd) = s.noise.of(ch);
        let offset = offset_sd * rng.normal();
        values.push(times.iter().map(|&t| interpolate(&result.times, &col, t).map(|v| v + offset + white * rng.normal())).collect());
    }
    Ok(Dataset {
        origin: "synthetic".into(),
        times: times.iter().map(|t| t + t0).collect(),
        names: s.channels.clone(),
        values,
        lines: vec![],
    })
}

/// A synthetic identification problem on a cylinder circuit.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Hidden effect (catalogue name) and its SI parameter values.
    pub hidden: Option<(String, Vec<f64>)>,
    /// Operating points: each a list of "id.param=value" settings.
    pub operating_points: Vec<Vec<String>>,
    /// Baseline parameters perturbed in the model handed to the fit:
    /// (id.param, multiplicative factor). The truth keeps the nominal value.
    pub perturb: Vec<(String, f64)>,
    /// Parameters changed in the truth only (id.param, SI value).
    pub truth_only: Vec<String>,
    pub settings: TruthSettings,
    pub seed: u64,
}

/// Four operating points: 4 and 7 bar supply × the two throttle settings
/// given (e.g. "26 L/min/bar"). The circuit starts from rest (`"initial":
/// "rest"`), so the rod chamber starts at the supply pressure as in the
/// paper's experiments.
pub fn operating_points(throttles: [&str; 2]) -> Vec<Vec<String>> {
    let mut v = Vec::new();
    for p in ["4 bar", "7 bar"] {
        for c in throttles {
            v.push(vec![format!("supply.p={p}"), format!("flow_control.C={c}")]);
        }
    }
    v
}

/// The operating points of the tests: 4 and 7 bar × 26 and 52 L/(min·bar)
/// (two and four times the paper's switch-2 conductance, which keeps the
/// cycles short: about 2.2 s and 1.4 s with 0.2 s dwells).
pub fn standard_operating_points() -> Vec<Vec<String>> {
    operating_points(["26 L/min/bar", "52 L/min/bar"])
}

/// Draw perturbation factors 1 ± U(0.10, 0.20) for the given targets.
pub fn draw_perturbation(targets: &[&str], rng: &mut Rng) -> Vec<(String, f64)> {
    targets
        .iter()
        .map(|t| {
            let size = 0.10 + 0.10 * rng.uniform();
            let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            (t.to_string(), 1.0 + sign * size)
        })
        .collect()
}

impl Scenario {
    /// Generate the measured experiments. `model` is the nominal netlist (the
    /// truth before the hidden effect); the returned netlist is the model
    /// handed to the fit (perturbed baseline parameters, no hidden effect).
    /// Perturbed targets that an operating point sets are perturbed in that
    /// operating point's settings.
    pub fn generate(&self, model: &FlatNetlist) -> Result<(FlatNetlist, Vec<Experiment>), String> {
        let mut rng = Rng::new(self.seed);
        let mut experiments = Vec::new();
        for (k, op) in self.operating_points.iter().enumerate() {
            let mut truth = model.clone();
            for s in op.iter().chain(&self.truth_only) {
                graph::apply_set(&mut truth, s).map_err(|e| e.to_string())?;
            }
            if let Some((name, values)) = &self.hidden {
                let e = effects::by_name(name).ok_or_else(|| format!("unknown effect {name}"))?;
                e.apply(&mut truth, values).map_err(|e| e.to_string())?;
            }
            let fine = simulate_fine(&truth, &self.settings)?;
            let data = measure(&fine, &self.settings, 0.0, &mut rng)?;
            // the fit sees the operating point with perturbed per-experiment values
            let mut sets = Vec::new();
            for s in op {
                let (target, value) = s.split_once('=').ok_or_else(|| format!("bad setting {s}"))?;
                match self.perturb.iter().find(|(t, _)| t == target) {
                    Some((_, f)) => {
                        let (id, param) = crate::netlist_edit::split_target(target).map_err(|e| e.to_string())?;
                        let si = crate::netlist_edit::parse_for(&truth, id, param, &graph::expand::value_from_text(value))
                            .map_err(|e| e.to_string())?;
                        sets.push(format!("{target}={}", si * f));
                    }
                    None => sets.push(s.clone()),
                }
            }
            experiments.push(Experiment::from_dataset(&format!("exp{}", k + 1), &data, None, sets, Some(0.0), &[])?);
        }
        let mut fitted = model.clone();
        for (target, f) in &self.perturb {
            let (id, param) = crate::netlist_edit::split_target(target).map_err(|e| e.to_string())?;
            let v = crate::netlist_edit::param_si(&fitted, id, param).map_err(|e| e.to_string())?;
            crate::netlist_edit::set_param_si(&mut fitted, id, param, v * f).map_err(|e| e.to_string())?;
        }
        Ok((fitted, experiments))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perturbation_sizes_are_between_10_and_20_percent() {
        let mut rng = Rng::new(3);
        for _ in 0..100 {
            for (_, f) in draw_perturbation(&["a.b", "c.d"], &mut rng) {
                let d = (f - 1.0).abs();
                assert!((0.10..=0.20).contains(&d), "{f}");
            }
        }
    }
}
