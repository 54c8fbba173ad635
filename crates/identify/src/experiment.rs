//! Measured experiments: the channels of one recorded run at one operating
//! point, on simulation time (0 = the experiment's time origin), with each
//! channel's noise level.
//!
//! Built from a measured table ([`crate::data::Dataset`]) by mapping data
//! columns to model signals and choosing the time origin; σ is estimated
//! from the data ([`crate::data::noise_sigma`]) unless given. Units: SI.
//!
//! # Sensor priors
//! Each channel carries the prior of its sensor's errors ([`SensorPrior`]):
//! a zero-mean Gaussian on the constant offset o [SI] and on the relative
//! gain error g, from the sensor's specification (the manifest's `sensors`
//! entry) or, when none is given, from a default per quantity
//! ([`default_prior`]). The prior σ is the stated accuracy (a datasheet's
//! "±x" is an error envelope, so taking it as one σ is the cautious
//! reading: an estimate beyond three of them is a fault of the model, not
//! of the sensor). Defaults and their sources:
//!
//! | quantity (unit) | offset σ | gain σ | source |
//! |---|---|---|---|
//! | pressure (Pa) | 0.5 % of full scale | 0.5 % | industrial transducers are specified at 0.25 … 1 % FS (e.g. WIKA A-10: ≤ ±0.5 % of span; Festo SPAN: ±1.5 % FS); full scale = the smallest of the EN 837-1 ranges 1, 1.6, 2.5, 4, 6, 10, 16, 25, 40, 60, 100, 160, 250, 400, 600 bar that holds 1.1 × the largest reading |
//! | temperature (K) | 1.5 K | — | IEC 60584-1 class 1 thermocouples: ±1.5 K below 375 °C |
//! | position (m) | 0.1 % of the reading span | — | linear potentiometers and magnetostrictive sensors: 0.02 … 0.1 % FS |
//! | velocity (m/s) | 1 % of the largest reading | 1 % | |
//! | anything else | 1 % of the largest reading | — | |

use crate::data::{noise_sigma, Dataset};
use std::collections::BTreeMap;

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
    /// Prior of the sensor's offset and gain error; `None` until the
    /// workflow assigns the default of the signal's quantity.
    pub prior: Option<SensorPrior>,
}

/// Zero-mean Gaussian prior of a channel's sensor errors (see the module header).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SensorPrior {
    /// σ of the constant offset [SI]; `f64::INFINITY`: free (no prior); 0: not fitted.
    pub offset_sd: f64,
    /// σ of the relative gain error; 0: not fitted.
    pub gain_sd: f64,
    /// Where it comes from, for the report ("default for a pressure: 0.5 % of 10 bar").
    pub source: String,
}

/// Standard pressure-gauge ranges of EN 837-1 [bar].
const PRESSURE_RANGES_BAR: [f64; 15] = [1.0, 1.6, 2.5, 4.0, 6.0, 10.0, 16.0, 25.0, 40.0, 60.0, 100.0, 160.0, 250.0, 400.0, 600.0];

/// The smallest standard full scale [Pa] that holds 1.1 × `largest` [Pa].
pub fn pressure_full_scale(largest: f64) -> f64 {
    let need = 1.1 * largest.abs() / 1e5;
    PRESSURE_RANGES_BAR.iter().copied().find(|r| *r >= need).map_or(need.ceil() * 1e5, |r| r * 1e5)
}

/// The default prior of a channel measuring a quantity of unit `unit` (as
/// the model records it: "Pa", "K", "m", "m/s", ...), given every value
/// recorded for that signal (see the module header).
pub fn default_prior(unit: &str, values: &[f64]) -> SensorPrior {
    let largest = values.iter().fold(0.0_f64, |m, v| if v.is_finite() { m.max(v.abs()) } else { m });
    let (lo, hi) = values.iter().filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    let span = if hi > lo { hi - lo } else { largest };
    let floor = |x: f64| if x > 0.0 && x.is_finite() { x } else { f64::INFINITY };
    match unit {
        "Pa" => {
            let fs = pressure_full_scale(largest);
            SensorPrior {
                offset_sd: 0.005 * fs,
                gain_sd: 0.005,
                source: format!("default for a pressure: 0.5 % of a {} bar full scale, gain 0.5 %", fs / 1e5),
            }
        }
        "K" => SensorPrior { offset_sd: 1.5, gain_sd: 0.0, source: "default for a temperature: 1.5 K (IEC 60584-1 class 1)".into() },
        "m" => SensorPrior {
            offset_sd: floor(1e-3 * span),
            gain_sd: 0.0,
            source: format!("default for a position: 0.1 % of the {:.4} m span", span),
        },
        "m/s" => SensorPrior {
            offset_sd: floor(0.01 * largest),
            gain_sd: 0.01,
            source: "default for a velocity: 1 % of the largest reading, gain 1 %".into(),
        },
        _ => {
            SensorPrior { offset_sd: floor(0.01 * largest), gain_sd: 0.0, source: format!("default ({unit}): 1 % of the largest reading") }
        }
    }
}

/// Give every channel without a prior the default of its quantity;
/// `unit(signal)` is the unit the model records it in. The values of a
/// signal are pooled over the experiments (one sensor, one range).
pub fn assign_default_priors(experiments: &mut [Experiment], unit: impl Fn(&str) -> String) {
    let mut pooled: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for e in experiments.iter() {
        for c in &e.channels {
            pooled.entry(c.signal.clone()).or_default().extend(c.values.iter().flatten().copied());
        }
    }
    for e in experiments.iter_mut() {
        for c in &mut e.channels {
            if c.prior.is_none() {
                c.prior = Some(default_prior(&unit(&c.signal), &pooled[&c.signal]));
            }
        }
    }
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
            return Err(format!("{}: fewer than 3 samples after the time origin {} s", data.origin, units::show::num(origin)));
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
            channels.push(Channel { signal, values, sigma, sigma_estimated: estimated, prior: None });
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

/// Every s-th sample index and the matching output interval, for a target
/// interval between fitted samples (s = round(fit_interval / median interval), ≥ 1).
pub fn decimate(e: &Experiment, fit_interval: f64) -> (Vec<usize>, f64) {
    let d = e.median_interval();
    let stride = ((fit_interval / d).round() as usize).max(1);
    ((0..e.times.len()).step_by(stride).collect(), stride as f64 * d)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn dataset(names: &[&str], n: usize) -> Dataset {
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
    fn default_priors_follow_the_quantity() {
        assert_eq!(pressure_full_scale(7.2e5), 10e5);
        assert_eq!(pressure_full_scale(150e5), 250e5);
        assert_eq!(pressure_full_scale(5.9e5), 10e5);
        let p = default_prior("Pa", &[1e5, 7e5]);
        assert!((p.offset_sd - 5000.0).abs() < 1e-9 && p.gain_sd == 0.005, "{p:?}");
        let t = default_prior("K", &[290.0, 250.0]);
        assert_eq!((t.offset_sd, t.gain_sd), (1.5, 0.0));
        let x = default_prior("m", &[0.0, 0.45]);
        assert!((x.offset_sd - 4.5e-4).abs() < 1e-12);
        // a constant channel still gets a finite prior
        assert!(default_prior("m", &[0.2, 0.2]).offset_sd.is_finite());
        assert!(default_prior("kg/s", &[0.0]).offset_sd.is_infinite());
    }

    #[test]
    fn decimation_keeps_every_sth_sample() {
        let d = dataset(&["head.p"], 101);
        let e = Experiment::from_dataset("a", &d, None, vec![], None, &[("head.p".into(), 1.0)]).unwrap();
        let (s, h) = decimate(&e, 4e-3);
        assert_eq!(s, (0..=100).step_by(4).collect::<Vec<_>>());
        assert!((h - 4e-3).abs() < 1e-12);
        assert_eq!(decimate(&e, 1e-4).0.len(), 101);
    }
}
