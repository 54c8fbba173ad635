//! Measured experiments: the channels of one recorded run at one operating
//! point, on simulation time (0 = the experiment's time origin), with each
//! channel's noise level.
//!
//! Built from a measured table ([`crate::data::Dataset`]) by mapping data
//! columns to model signals and choosing the time origin; σ is estimated
//! from the data ([`crate::data::noise_sigma`]) unless given. Units: SI.

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
    fn decimation_keeps_every_sth_sample() {
        let d = dataset(&["head.p"], 101);
        let e = Experiment::from_dataset("a", &d, None, vec![], None, &[("head.p".into(), 1.0)]).unwrap();
        let (s, h) = decimate(&e, 4e-3);
        assert_eq!(s, (0..=100).step_by(4).collect::<Vec<_>>());
        assert!((h - 4e-3).abs() < 1e-12);
        assert_eq!(decimate(&e, 1e-4).0.len(), 101);
    }
}
