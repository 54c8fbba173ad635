//! Residual diagnostics: where and when a model is wrong.
//!
//! Residual e = simulated − measured [SI]; normalised residual e/σ (σ the
//! channel's noise level). Computed, pooled over experiments:
//! - per channel: RMSE [SI], normalised RMSE (1 = at the noise level), bias;
//! - per phase of the cycle ([`crate::phases`]) and channel: normalised RMSE
//!   and the share of Σ(e/σ)² falling in that phase;
//! - whiteness per channel: lag-1 autocorrelation ρ₁ and the Ljung–Box
//!   statistic Q = n(n+2)·Σ_{k=1..L} ρ_k²/(n−k) divided by L = 20 (≈ 1 for
//!   white residuals, Ljung & Box 1978), from each experiment's contiguous
//!   residuals and averaged with weights n;
//! - Pearson correlation of each channel's residual with candidate
//!   regressors (pressure difference across the piston, velocity, a
//!   low-speed indicator, pressure rates, temperature departure, time since
//!   the last valve switch), which point at the physics that is missing.
//!
//! Missing samples (measured or simulated) are skipped.

use crate::phases::Phase;
use crate::stats::{autocorrelation, correlation, ljung_box_per_lag};
use serde::Serialize;
use std::collections::BTreeMap;

/// Number of lags in the Ljung–Box statistic.
pub const LB_LAGS: usize = 20;

/// Measured and simulated channels of one experiment at its samples.
#[derive(Debug, Clone)]
pub struct Trace {
    pub name: String,
    pub times: Vec<f64>,
    pub signals: Vec<String>,
    pub sigma: Vec<f64>,
    /// The data, with the fitted sensor errors taken off in the report's
    /// traces ((measured − offset) / (1 + gain)).
    pub measured: Vec<Vec<Option<f64>>>,
    /// The model as simulated (no sensor correction on this side).
    pub simulated: Vec<Vec<Option<f64>>>,
    pub phases: Vec<Phase>,
    /// (name, value at each sample).
    pub regressors: Vec<(String, Vec<f64>)>,
}

impl Trace {
    /// Residual of channel c at sample i [SI].
    pub fn residual(&self, c: usize, i: usize) -> Option<f64> {
        Some(self.simulated[c][i]? - self.measured[c][i]?)
    }
}

/// Error statistics of one channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelStats {
    pub rmse: f64,
    pub rmse_normalized: f64,
    pub bias: f64,
    pub n: usize,
}

/// Error statistics of one channel in one phase.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhaseStats {
    pub phase: Phase,
    pub channel: String,
    pub rmse: f64,
    pub rmse_normalized: f64,
    /// Fraction of the channel's Σ(e/σ)² in this phase.
    pub share: f64,
    pub n: usize,
}

/// Whiteness of one channel's residuals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Whiteness {
    pub lag1: f64,
    /// Ljung–Box Q / L (≈ 1 for white noise; NaN when every run is shorter
    /// than 4 samples).
    pub ljung_box_per_lag: f64,
}

/// Everything the diagnosis found.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct Diagnosis {
    pub channels: BTreeMap<String, ChannelStats>,
    pub phases: Vec<PhaseStats>,
    pub whiteness: BTreeMap<String, Whiteness>,
    /// channel → regressor → correlation.
    pub correlations: BTreeMap<String, BTreeMap<String, f64>>,
    /// Normalised RMSE over all channels and samples.
    pub rmse_normalized: f64,
}

/// Diagnose a set of traces (same channel names in each, in any order).
pub fn diagnose(traces: &[Trace]) -> Diagnosis {
    let mut d = Diagnosis::default();
    let mut names: Vec<String> = Vec::new();
    for t in traces {
        for s in &t.signals {
            if !names.contains(s) {
                names.push(s.clone());
            }
        }
    }
    let (mut total_sq, mut total_n) = (0.0, 0usize);
    for name in &names {
        let (mut sq, mut sqn, mut sum, mut n) = (0.0, 0.0, 0.0, 0usize);
        let mut by_phase: BTreeMap<Phase, (f64, f64, usize)> = BTreeMap::new();
        let (mut lag1_w, mut lb_w, mut wn, mut lb_n) = (0.0, 0.0, 0.0, 0.0);
        let mut res_all: Vec<f64> = Vec::new();
        let mut reg_all: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        let mut res_for_reg: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        for t in traces {
            let Some(c) = t.signals.iter().position(|s| s == name) else { continue };
            let sigma = t.sigma[c];
            let mut run: Vec<f64> = Vec::new();
            for i in 0..t.times.len() {
                let Some(e) = t.residual(c, i) else { continue };
                let z = e / sigma;
                sq += e * e;
                sqn += z * z;
                sum += e;
                n += 1;
                let entry = by_phase.entry(t.phases.get(i).copied().unwrap_or(Phase::Rest)).or_insert((0.0, 0.0, 0));
                entry.0 += e * e;
                entry.1 += z * z;
                entry.2 += 1;
                run.push(z);
                res_all.push(z);
                for (rn, rv) in &t.regressors {
                    if let Some(v) = rv.get(i) {
                        reg_all.entry(rn.clone()).or_default().push(*v);
                        res_for_reg.entry(rn.clone()).or_default().push(z);
                    }
                }
            }
            let w = run.len() as f64;
            if w > 0.0 {
                lag1_w += w * autocorrelation(&run, 1);
                let lb = ljung_box_per_lag(&run, LB_LAGS);
                if lb.is_finite() {
                    lb_w += w * lb;
                    lb_n += w;
                }
                wn += w;
            }
        }
        if n == 0 {
            continue;
        }
        total_sq += sqn;
        total_n += n;
        d.channels.insert(
            name.clone(),
            ChannelStats { rmse: (sq / n as f64).sqrt(), rmse_normalized: (sqn / n as f64).sqrt(), bias: sum / n as f64, n },
        );
        for (phase, (s, sn, k)) in by_phase {
            d.phases.push(PhaseStats {
                phase,
                channel: name.clone(),
                rmse: (s / k as f64).sqrt(),
                rmse_normalized: (sn / k as f64).sqrt(),
                share: if sqn > 0.0 { sn / sqn } else { 0.0 },
                n: k,
            });
        }
        if wn > 0.0 {
            d.whiteness
                .insert(name.clone(), Whiteness { lag1: lag1_w / wn, ljung_box_per_lag: if lb_n > 0.0 { lb_w / lb_n } else { f64::NAN } });
        }
        let mut corr = BTreeMap::new();
        for (rn, rv) in &reg_all {
            corr.insert(rn.clone(), correlation(&res_for_reg[rn], rv));
        }
        d.correlations.insert(name.clone(), corr);
        let _ = res_all;
    }
    d.rmse_normalized = if total_n > 0 { (total_sq / total_n as f64).sqrt() } else { 0.0 };
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn trace(noise: &[f64], shift: impl Fn(f64) -> f64, phases: Vec<Phase>) -> Trace {
        let times: Vec<f64> = (0..noise.len()).map(|i| i as f64 * 1e-3).collect();
        let meas: Vec<Option<f64>> = times.iter().map(|&t| Some(1e5 + 1e4 * t)).collect();
        let sim: Vec<Option<f64>> = times.iter().zip(noise).map(|(&t, z)| Some(1e5 + 1e4 * t + 500.0 * z + shift(t))).collect();
        let reg: Vec<f64> = times.iter().map(|&t| shift(t)).collect();
        Trace {
            name: "e".into(),
            times,
            signals: vec!["head.p".into()],
            sigma: vec![500.0],
            measured: vec![meas],
            simulated: vec![sim],
            phases,
            regressors: vec![("driver".into(), reg)],
        }
    }

    #[test]
    fn white_residuals_are_white_and_a_drift_is_not() {
        let mut rng = Rng::new(11);
        let n = 5000;
        let z: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let d = diagnose(&[trace(&z, |_| 0.0, vec![Phase::Steady; n])]);
        let c = &d.channels["head.p"];
        assert!((c.rmse_normalized - 1.0).abs() < 0.05 && (c.rmse - 500.0).abs() < 25.0, "{c:?}");
        let w = &d.whiteness["head.p"];
        assert!(w.lag1.abs() < 0.05 && (w.ljung_box_per_lag - 1.0).abs() < 0.5, "{w:?}");
        // a slow systematic error: correlated, not white, and tied to its driver
        let d = diagnose(&[trace(&z, |t| 2000.0 * (3.0 * t).sin(), vec![Phase::Steady; n])]);
        let w = &d.whiteness["head.p"];
        assert!(w.lag1 > 0.8 && w.ljung_box_per_lag > 50.0, "{w:?}");
        assert!(d.correlations["head.p"]["driver"] > 0.9);
        assert!(d.channels["head.p"].rmse_normalized > 2.5);
    }

    #[test]
    fn sparse_correlated_residuals_are_not_called_white() {
        // 15 samples per run (a vessel test logged every few seconds), AR(1) with ρ = 0.8
        let mut rng = Rng::new(5);
        let mut z = vec![0.0; 15];
        for i in 1..z.len() {
            z[i] = 0.8 * z[i - 1] + 0.6 * rng.normal();
        }
        let d = diagnose(&[trace(&z, |_| 0.0, vec![Phase::Hold; z.len()])]);
        let w = &d.whiteness["head.p"];
        // Q/L and the lag-1 autocorrelation tell the same story (Q/L was 0 here)
        assert!(w.lag1 > 0.3 && w.ljung_box_per_lag > 2.0, "{w:?}");
        let short = diagnose(&[trace(&z[..3], |_| 0.0, vec![Phase::Hold; 3])]);
        assert!(short.whiteness["head.p"].ljung_box_per_lag.is_nan());
    }

    #[test]
    fn the_phase_with_the_error_takes_its_share() {
        let mut rng = Rng::new(12);
        let n = 4000;
        let z: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let phases: Vec<Phase> = (0..n).map(|i| if i < 1000 { Phase::Switching } else { Phase::Steady }).collect();
        // 5 σ error during the first second only
        let d = diagnose(&[trace(&z, |t| if t < 1.0 { 2500.0 } else { 0.0 }, phases)]);
        let sw = d.phases.iter().find(|p| p.phase == Phase::Switching).unwrap();
        let st = d.phases.iter().find(|p| p.phase == Phase::Steady).unwrap();
        assert!(sw.rmse_normalized > 4.5 && (st.rmse_normalized - 1.0).abs() < 0.1, "{sw:?} {st:?}");
        assert!(sw.share > 0.85 && (sw.share + st.share - 1.0).abs() < 1e-12);
        assert!((d.channels["head.p"].bias - 2500.0 * 0.25).abs() < 50.0);
    }

    #[test]
    fn correlation_by_hand() {
        assert!((correlation(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0]) - 1.0).abs() < 1e-12);
        assert!((correlation(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        assert_eq!(correlation(&[1.0, 1.0, 1.0], &[3.0, 2.0, 1.0]), 0.0);
        // lag-1 autocorrelation of an alternating sequence is close to −1
        let alt: Vec<f64> = (0..100).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        assert!(autocorrelation(&alt, 1) < -0.95);
    }
}
