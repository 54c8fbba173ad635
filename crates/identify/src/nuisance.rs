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
//! # Logger time skew
//! The logger's clock may run a constant δ ahead of the command's (a PLC
//! scan, a trigger latency): a sample stamped t was taken at true time
//! t − δ and compares with ŷ(t − δ). δ is one value per experiment, shared
//! by its channels, bounded by |δ| ≤ [`SensorModel::skew`] (off by
//! default; a manifest turns it on with `"nuisance": {"skew": "2 ms"}`), and profiled
//! like the offsets: for every simulation, [`best_skew`] minimises the
//! experiment's Σr² (offsets and gains eliminated at each trial δ) by a
//! grid of 9 points over the bound followed by Brent's method (parabolic
//! steps with golden-section safeguards) in the bracket around the best
//! grid point, to 10⁻⁶ of the grid spacing. The simulation is interpolated
//! at t − δ by a cubic Hermite curve, so that the cost is smooth in δ
//! ([`crate::problem::Sampler::at`] says why that matters). δ enters the
//! model's parameters' covariance marginalised, as the offsets do. The
//! bound keeps δ from absorbing a real valve delay: a delay shifts every
//! stroke after its own switching command (three cycles accumulate six of
//! them), a skew shifts the whole record once, and a realistic delay
//! (10 … 20 ms) is far above a bound of 2 ms.
//!
//! Units: values and offsets SI, gain dimensionless, σ SI, skew s.

use serde::Serialize;

/// Which sensor errors are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorModel {
    /// A constant offset per channel and experiment.
    pub offset: bool,
    /// A relative gain error per channel and experiment.
    pub gain: bool,
    /// Largest logger time skew |δ| fitted per experiment [s]; 0 = none.
    pub skew: f64,
}

impl Default for SensorModel {
    /// Offsets only: the gain and the skew are opt-in (docs/discrepancy.md
    /// gives what each costs and buys on the independent truth).
    fn default() -> Self {
        SensorModel { offset: true, gain: false, skew: 0.0 }
    }
}

impl SensorModel {
    /// Whether a logger time skew is fitted.
    pub fn fits_skew(&self) -> bool {
        self.skew > 0.0 && self.skew.is_finite()
    }
}

/// The skew δ ∈ [−max, max] that minimises `cost(δ)` (see the module
/// header); 0 when `max` is 0 or not finite.
pub fn best_skew(max: f64, cost: impl Fn(f64) -> f64) -> f64 {
    if !(max > 0.0 && max.is_finite()) {
        return 0.0;
    }
    const GRID: usize = 9;
    let spacing = 2.0 * max / (GRID - 1) as f64;
    let at = |j: usize| -max + spacing * j as f64;
    let values: Vec<f64> = (0..GRID).map(|j| cost(at(j))).collect();
    // the best grid point (the centre on ties and non-finite costs)
    let mut best = GRID / 2;
    for (j, v) in values.iter().enumerate() {
        if *v < values[best] {
            best = j;
        }
    }
    if !values[best].is_finite() {
        return 0.0;
    }
    let (lo, hi) = (at(best.saturating_sub(1)), at((best + 1).min(GRID - 1)));
    brent_min(lo, hi, at(best), values[best], 1e-6 * spacing, &cost)
}

/// Brent's minimisation without derivatives (R. P. Brent, "Algorithms for
/// minimization without derivatives", 1973, ch. 5): golden-section steps
/// where a parabola through the last three points is not trusted, parabolic
/// steps where it is. `x` in [a, b] is the starting point with cost `fx`;
/// stops when the bracket around the best point is below ≈ 4·`tol`.
fn brent_min(mut a: f64, mut b: f64, x0: f64, f0: f64, tol: f64, cost: &impl Fn(f64) -> f64) -> f64 {
    const GOLD: f64 = 0.381_966_011_250_105_1; // (3 − √5)/2
    let (mut x, mut w, mut v) = (x0, x0, x0);
    let (mut fx, mut fw, mut fv) = (f0, f0, f0);
    let (mut d, mut e) = (0.0_f64, 0.0_f64);
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        let tol1 = 1e-10 * x.abs() + tol;
        let tol2 = 2.0 * tol1;
        if (x - m).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // parabola through (v, fv), (w, fw), (x, fx)
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            } else {
                q = -q;
            }
            let last = e;
            e = d;
            if p.abs() < (0.5 * q * last).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = if m >= x { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if x < m { b - x } else { a - x };
            d = GOLD * e;
        }
        let u = x + if d.abs() >= tol1 {
            d
        } else if d >= 0.0 {
            tol1
        } else {
            -tol1
        };
        let fu = cost(u);
        if fu <= fx {
            if u < x {
                b = x;
            } else {
                a = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    x
}

/// Standard error of a profiled skew δ from the curvature of `cost`
/// (Σr², r in noise units) at δ, scaled by the mean squared normalised
/// residual `ms` and the correlation time `tau` as the offsets are; `None`
/// when the curvature is not positive.
pub fn skew_standard_error(delta: f64, max: f64, ms: f64, tau: f64, cost: impl Fn(f64) -> f64) -> Option<f64> {
    let h = (max / 50.0).max(1e-6);
    let c2 = (cost(delta + h) - 2.0 * cost(delta) + cost(delta - h)) / (h * h);
    (c2 > 0.0 && c2.is_finite()).then(|| (2.0 * ms.max(0.0) * tau.max(1.0) / c2).sqrt())
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
        let both = SensorModel { offset: true, gain: true, skew: 0.0 };
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
        let none = SensorModel { offset: false, gain: false, skew: 0.0 };
        let (r, _) = profile(&s, &y, sigma, &none);
        assert!((r[10] - (s[10] - y[10]) / sigma).abs() < 1e-12);
    }

    #[test]
    fn a_constant_signal_gets_an_offset_but_no_gain() {
        let s = vec![4e5; 100];
        let y: Vec<f64> = (0..100).map(|i| 4.01e5 + if i % 2 == 0 { 10.0 } else { -10.0 }).collect();
        let (_, fit) = profile(&s, &y, 500.0, &SensorModel { offset: true, gain: true, skew: 0.0 });
        assert_eq!(fit.gain, 0.0);
        assert!((fit.offset - 1000.0).abs() < 1e-6);
        let (se_o, se_g) = standard_errors(&s, 500.0, 1.0, 4.0, &SensorModel { offset: true, gain: true, skew: 0.0 });
        assert!((se_o.unwrap() - 500.0 * (4.0f64 / 100.0).sqrt()).abs() < 1e-9);
        assert!(se_g.is_none());
    }

    #[test]
    fn the_skew_search_finds_the_minimum_of_a_smooth_cost_and_stays_in_bounds() {
        // on a cost of size 1 the minimum is located to about √ε of the scale
        let d = best_skew(2e-3, |x| (x - 0.7e-3).powi(2) + 1.0);
        assert!((d - 0.7e-3).abs() < 5e-8, "{d}");
        // not a parabola: a quartic well and a bowl with a flat floor far off
        let d = best_skew(2e-3, |x| ((x - 0.37e-3) * 1e3).powi(4) + 3.0 * ((x - 0.37e-3) * 1e3).powi(2));
        assert!((d - 0.37e-3).abs() < 1e-9, "{d}");
        let d = best_skew(2e-3, |x| (x + 1.3e-3).powi(2));
        assert!((d + 1.3e-3).abs() < 1e-9, "{d}");
        // a minimum beyond the bound ends at the bound
        let d = best_skew(2e-3, |x| (x - 5e-3).powi(2));
        assert!((d - 2e-3).abs() < 1e-9, "{d}");
        assert_eq!(best_skew(0.0, |x| x * x), 0.0);
        assert_eq!(best_skew(2e-3, |_| f64::NAN), 0.0);
        // the curvature error of a parabola Σr² = (δ − δ₀)²/s²: s·√(2/2) = s
        let s = 1e-4;
        let se = skew_standard_error(0.3e-3, 2e-3, 1.0, 1.0, |x| ((x - 0.3e-3) / s).powi(2)).unwrap();
        assert!((se - s).abs() < 1e-9 * s.max(1.0) + 1e-12, "{se}");
    }
}
