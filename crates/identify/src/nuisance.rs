//! Nuisance parameters of the sensors: a constant offset and, optionally, a
//! gain error of every channel of every experiment. They describe the
//! logger, not the machine, so they are always fitted with the calibration
//! and are never candidates for a missing effect.
//!
//! # Measurement model
//! Channel c of experiment k reads y = o + (1 + g)·s(t) + ε, with s the
//! true signal (absolute pressure, position, ...), o the offset [SI], g the
//! relative gain error and ε white noise of standard deviation σ. The
//! residual of a simulation ŝ is r = (o + (1 + g)·ŝ − y)/σ.
//!
//! # Elimination (variable projection)
//! o and g enter r linearly, so for every simulation they are set to their
//! least-squares values (Golub & Pereyra, "The differentiation of pseudo-
//! inverses and nonlinear least squares problems whose variables separate",
//! SIAM J. Numer. Anal. 10, 1973): with d = y − ŝ,
//! g = Σ(ŝ − mean ŝ)(d − mean d)/Σ(ŝ − mean ŝ)², o = mean d − g·mean ŝ
//! (g = 0 when only the offset is fitted, or when ŝ is constant). The fit of
//! the model parameters then minimises the residual that is left, and the
//! Jacobian of that residual gives their covariance with the offsets and
//! gains marginalised (the θ-block of the joint inverse).
//!
//! # Uncertainty
//! Given the model parameters, (o, g) is a linear regression of d on
//! [1, ŝ]; its covariance is ŝ²·τ·σ²·(XᵀX)⁻¹ with ŝ² the mean squared
//! normalised residual and τ the residual's integrated autocorrelation time
//! ([`crate::stats`]), the same honest scaling as the model parameters.
//!
//! Units: values and offsets SI, gain dimensionless, σ SI.

use serde::Serialize;

/// Which sensor errors are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorModel {
    /// A constant offset per channel and experiment.
    pub offset: bool,
    /// A relative gain error per channel and experiment.
    pub gain: bool,
}

impl Default for SensorModel {
    fn default() -> Self {
        SensorModel { offset: true, gain: false }
    }
}

/// Fitted sensor errors of one channel.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct SensorFit {
    /// Offset o [SI].
    pub offset: f64,
    /// Relative gain error g.
    pub gain: f64,
}

/// Best offset and gain for paired simulated and measured values, and the
/// normalised residuals (o + (1 + g)·ŝ − y)/σ they leave.
pub fn profile(simulated: &[f64], measured: &[f64], sigma: f64, model: &SensorModel) -> (Vec<f64>, SensorFit) {
    let n = simulated.len().min(measured.len());
    let fit = best_fit(&simulated[..n], &measured[..n], model);
    let r = (0..n).map(|i| (fit.offset + (1.0 + fit.gain) * simulated[i] - measured[i]) / sigma).collect();
    (r, fit)
}

fn best_fit(s: &[f64], y: &[f64], model: &SensorModel) -> SensorFit {
    let n = s.len();
    if n == 0 || !model.offset && !model.gain {
        return SensorFit::default();
    }
    let nf = n as f64;
    let ms = s.iter().sum::<f64>() / nf;
    let md = s.iter().zip(y).map(|(a, b)| b - a).sum::<f64>() / nf;
    let (mut sss, mut ssd) = (0.0, 0.0);
    for (a, b) in s.iter().zip(y) {
        let (ds, dd) = (a - ms, (b - a) - md);
        sss += ds * ds;
        ssd += ds * dd;
    }
    let scale = s.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let varies = sss > (1e-9 * scale).powi(2) * nf;
    match (model.offset, model.gain && varies) {
        (true, true) => {
            let g = ssd / sss;
            SensorFit { offset: md - g * ms, gain: g }
        }
        (true, false) => SensorFit { offset: md, gain: 0.0 },
        (false, true) => {
            // gain through the origin: g = Σ s·d / Σ s²
            let ss: f64 = s.iter().map(|a| a * a).sum();
            let sd: f64 = s.iter().zip(y).map(|(a, b)| a * (b - a)).sum();
            SensorFit { offset: 0.0, gain: if ss > 0.0 { sd / ss } else { 0.0 } }
        }
        (false, false) => SensorFit::default(),
    }
}

/// Standard errors (offset [SI], gain) of a channel's fitted sensor errors,
/// given the simulated values at its samples, σ, the mean squared normalised
/// residual `ms` and the residual's correlation time `tau` (see the module header).
pub fn standard_errors(simulated: &[f64], sigma: f64, ms: f64, tau: f64, model: &SensorModel) -> (Option<f64>, Option<f64>) {
    let n = simulated.len() as f64;
    if n < 2.0 {
        return (None, None);
    }
    let var = ms.max(0.0) * tau.max(1.0) * sigma * sigma;
    let mean = simulated.iter().sum::<f64>() / n;
    let sss: f64 = simulated.iter().map(|a| (a - mean) * (a - mean)).sum();
    let scale = simulated.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let varies = sss > (1e-9 * scale).powi(2) * n;
    match (model.offset, model.gain && varies) {
        // regression on [1, s]: Var(g) = v/Sss, Var(o) = v(1/n + mean²/Sss)
        (true, true) => (Some((var * (1.0 / n + mean * mean / sss)).sqrt()), Some((var / sss).sqrt())),
        (true, false) => (Some((var / n).sqrt()), None),
        (false, true) => {
            let ss: f64 = simulated.iter().map(|a| a * a).sum();
            (None, (ss > 0.0).then(|| (var / ss).sqrt()))
        }
        (false, false) => (None, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn offset_and_gain_are_recovered_and_leave_the_noise() {
        let mut rng = Rng::new(9);
        let s: Vec<f64> = (0..3000).map(|i| 1e5 + 6e5 * (i as f64 / 3000.0)).collect();
        let (o, g, sigma) = (1200.0, 2e-3, 500.0);
        let y: Vec<f64> = s.iter().map(|v| o + (1.0 + g) * v + sigma * rng.normal()).collect();
        let both = SensorModel { offset: true, gain: true };
        let (r, fit) = profile(&s, &y, sigma, &both);
        let (se_o, se_g) = standard_errors(&s, sigma, 1.0, 1.0, &both);
        assert!((fit.offset - o).abs() < 4.0 * se_o.unwrap(), "{fit:?} {se_o:?}");
        assert!((fit.gain - g).abs() < 4.0 * se_g.unwrap(), "{fit:?} {se_g:?}");
        let ms = r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64;
        assert!((ms - 1.0).abs() < 0.08, "{ms}");
        // offset only: the gain shows as a residual slope
        let (r, fit) = profile(&s, &y, sigma, &SensorModel::default());
        assert_eq!(fit.gain, 0.0);
        let mean_d = s.iter().zip(&y).map(|(a, b)| b - a).sum::<f64>() / s.len() as f64;
        assert!((fit.offset - mean_d).abs() < 1e-9);
        assert!(r.iter().sum::<f64>().abs() < 1e-6, "residuals have zero mean");
        // nothing fitted: the plain residual
        let none = SensorModel { offset: false, gain: false };
        let (r, _) = profile(&s, &y, sigma, &none);
        assert!((r[10] - (s[10] - y[10]) / sigma).abs() < 1e-12);
    }

    #[test]
    fn a_constant_signal_gets_an_offset_but_no_gain() {
        let s = vec![4e5; 100];
        let y: Vec<f64> = (0..100).map(|i| 4.01e5 + if i % 2 == 0 { 10.0 } else { -10.0 }).collect();
        let (_, fit) = profile(&s, &y, 500.0, &SensorModel { offset: true, gain: true });
        assert_eq!(fit.gain, 0.0);
        assert!((fit.offset - 1000.0).abs() < 1e-6);
        let (se_o, se_g) = standard_errors(&s, 500.0, 1.0, 4.0, &SensorModel { offset: true, gain: true });
        assert!((se_o.unwrap() - 500.0 * (4.0f64 / 100.0).sqrt()).abs() < 1e-9);
        assert!(se_g.is_none());
    }
}
