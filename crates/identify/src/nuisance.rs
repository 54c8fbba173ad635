//! Nuisance parameters of the sensors: a constant offset and a gain error
//! of every channel of every experiment, and a logger time skew per
//! experiment. They describe the logger, not the machine, so they are
//! always fitted with the calibration and are never candidates for a
//! missing effect — but they are fitted with **priors** from the sensors'
//! specification ([`crate::experiment::SensorPrior`]), not freely: a free
//! offset absorbs physics (an adiabatic vessel model was given +69 K
//! temperature offsets, hiding its missing heat exchange).
//!
//! # Measurement model
//! Channel c of experiment k reads y = o + (1 + g)·s(t) + ε, with s the
//! true signal (absolute pressure, position, ...), o the offset [SI], g the
//! relative gain error and ε white noise of standard deviation σ. The
//! residual of a simulation ŝ is r = (o + (1 + g)·ŝ − y)/σ.
//!
//! # MAP estimates (penalised variable projection)
//! With zero-mean Gaussian priors o ~ N(0, σ_o²), g ~ N(0, σ_g²) the
//! maximum a posteriori (o, g) for a given simulation minimises
//! Σ r² + (o/σ_o)² + (g/σ_g)², a ridge regression of d = y − ŝ on [1, ŝ]
//! with the normal equations
//! [n + σ²/σ_o², Σŝ; Σŝ, Σŝ² + σ²/σ_g²]·[o; g] = [Σd; Σŝd]
//! (Golub & Pereyra 1973 for the elimination, Hoerl & Kennard 1970 for the
//! ridge). They are solved for every simulation and the model parameters
//! are fitted on what is left; the two prior terms o/σ_o and g/σ_g are
//! rows of the residual vector ([`SensorFit::prior_rows`]), so that the fit
//! minimises the posterior and their Jacobian carries the coupling. σ_o = ∞
//! is a free offset (no row), σ = 0 a term not fitted. Estimates are kept
//! within ±[`BOUND`] prior σ (a clipped estimate re-solves the other one);
//! one beyond [`SYMPTOM`] prior σ is reported as a symptom of model-form
//! error ([`crate::report`]).
//!
//! # Logger time skew
//! The logger's clock may run a constant δ ahead of the command's (a PLC
//! scan, a trigger latency): a sample stamped t was taken at true time
//! t − δ and compares with ŷ(t − δ). δ is one value per experiment, shared
//! by its channels, with the prior δ ~ N(0, σ_δ²) ([`SensorModel::skew`],
//! default 1 ms) and the bound |δ| ≤ [`BOUND`]·σ_δ. For every simulation it
//! is profiled by Newton steps on the experiment's posterior cost
//! c(δ) = Σ r² + Σ prior terms + (δ/σ_δ)² (offsets and gains re-eliminated
//! at each trial δ), derivatives by central differences over 50 µs, from
//! δ = 0, each step accepted only if c falls (else halved), until the step
//! is below 10 ns ([`best_skew`]). The simulation is read at t − δ through
//! a cubic Hermite curve so that c is smooth in δ
//! ([`crate::problem::Sampler::at`] says why that matters), and δ/σ_δ is a
//! residual row as the other priors. The bound keeps δ from absorbing a
//! real valve delay: a delay shifts every stroke after its own switching
//! command (three cycles accumulate six of them), a skew shifts the whole
//! record once, and a realistic delay (10 … 20 ms) is far above 4 ms.
//!
//! # Uncertainty
//! Given the model parameters, (o, g) is a ridge regression of d on
//! [1, ŝ]; its covariance is ŝ²·τ·σ²·(XᵀX + Λ)⁻¹ with Λ the prior
//! precisions, ŝ² the mean squared normalised residual and τ the residual's
//! integrated autocorrelation time ([`crate::stats`]).
//!
//! Units: values and offsets SI, gain dimensionless, σ SI, skew s.

use crate::experiment::SensorPrior;
use serde::Serialize;

/// Estimates are bounded at this many prior standard deviations.
pub const BOUND: f64 = 4.0;
/// An estimate beyond this many prior standard deviations is a symptom of model-form error.
pub const SYMPTOM: f64 = 3.0;

/// Which sensor errors are fitted (master switches; the size of each is the channel's prior).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorModel {
    /// A constant offset per channel and experiment.
    pub offset: bool,
    /// A relative gain error per channel and experiment (where the channel's prior has one).
    pub gain: bool,
    /// Prior σ of the logger time skew δ per experiment [s]; 0 = none.
    pub skew: f64,
}

impl Default for SensorModel {
    /// Offsets, gains (where the quantity has a gain prior) and a skew of
    /// prior σ 1 ms (docs/discrepancy.md gives what each buys).
    fn default() -> Self {
        SensorModel { offset: true, gain: true, skew: 1e-3 }
    }
}

impl SensorModel {
    /// Whether a logger time skew is fitted.
    pub fn fits_skew(&self) -> bool {
        self.skew > 0.0 && self.skew.is_finite()
    }
    /// Largest |δ| [s].
    pub fn skew_bound(&self) -> f64 {
        if self.fits_skew() {
            BOUND * self.skew
        } else {
            0.0
        }
    }
    /// σ of the offset and of the gain actually fitted for a channel of this prior.
    pub fn effective(&self, prior: Option<&SensorPrior>) -> (f64, f64) {
        let (so, sg) = prior.map_or((f64::INFINITY, 0.0), |p| (p.offset_sd, p.gain_sd));
        (if self.offset { so } else { 0.0 }, if self.gain { sg } else { 0.0 })
    }
    /// Prior rows a channel of this prior adds to the residual vector.
    pub fn rows_per_channel(&self, prior: Option<&SensorPrior>) -> usize {
        let (so, sg) = self.effective(prior);
        usize::from(so > 0.0 && so.is_finite()) + usize::from(sg > 0.0)
    }
}

/// The skew δ ∈ [−bound, bound] that minimises `cost(δ)` (see the module
/// header); 0 when the bound is 0 or the cost is not finite at 0.
pub fn best_skew(bound: f64, cost: impl Fn(f64) -> f64) -> f64 {
    if !(bound > 0.0 && bound.is_finite()) {
        return 0.0;
    }
    let h = (bound / 80.0).min(50e-6);
    let mut x = 0.0_f64;
    let mut fx = cost(x);
    if !fx.is_finite() {
        return 0.0;
    }
    for _ in 0..12 {
        let (a, b) = (cost((x - h).max(-bound)), cost((x + h).min(bound)));
        let (xa, xb) = ((x - h).max(-bound), (x + h).min(bound));
        let d1 = (b - a) / (xb - xa);
        let d2 = if xb - x > 0.0 && x - xa > 0.0 { 2.0 * ((b - fx) / (xb - x) - (fx - a) / (x - xa)) / (xb - xa) } else { 0.0 };
        // Newton where the curvature is positive, else a descent step of one h
        let mut step = if d2 > 0.0 && d2.is_finite() { -d1 / d2 } else { -d1.signum() * 4.0 * h };
        if !step.is_finite() {
            break;
        }
        let mut moved = false;
        for _ in 0..6 {
            let y = (x + step).clamp(-bound, bound);
            let fy = cost(y);
            if fy < fx {
                moved = (y - x).abs() > 1e-8;
                x = y;
                fx = fy;
                break;
            }
            step *= 0.5;
            if step.abs() < 1e-9 {
                break;
            }
        }
        if !moved {
            break;
        }
    }
    x
}

/// Standard error of a profiled skew δ from the curvature of `cost`
/// (Σr², r in noise units) at δ, scaled by the mean squared normalised
/// residual `ms` and the correlation time `tau` as the offsets are; `None`
/// when the curvature is not positive.
pub fn skew_standard_error(delta: f64, bound: f64, ms: f64, tau: f64, cost: impl Fn(f64) -> f64) -> Option<f64> {
    let h = (bound / 50.0).max(1e-6);
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
    /// o/σ_o and g/σ_g (`None` where the term has no prior row).
    pub offset_z: Option<f64>,
    pub gain_z: Option<f64>,
}

impl SensorFit {
    /// The prior rows this fit adds to the residual vector, in order.
    pub fn prior_rows(&self) -> impl Iterator<Item = f64> {
        self.offset_z.into_iter().chain(self.gain_z)
    }
    /// Σ of the squared prior rows.
    pub fn penalty(&self) -> f64 {
        self.prior_rows().map(|z| z * z).sum()
    }
}

/// MAP offset and gain for paired simulated and measured values (see the
/// module header), and the normalised residuals (o + (1 + g)·ŝ − y)/σ they
/// leave. `so`, `sg`: prior σ of offset and gain (∞ = free, 0 = not fitted).
pub fn profile(simulated: &[f64], measured: &[f64], sigma: f64, so: f64, sg: f64) -> (Vec<f64>, SensorFit) {
    let n = simulated.len().min(measured.len());
    let fit = best_fit(&simulated[..n], &measured[..n], sigma, so, sg);
    let r = (0..n).map(|i| (fit.offset + (1.0 + fit.gain) * simulated[i] - measured[i]) / sigma).collect();
    (r, fit)
}

fn best_fit(s: &[f64], y: &[f64], sigma: f64, so: f64, sg: f64) -> SensorFit {
    let n = s.len();
    let with_offset = so > 0.0;
    let scale = s.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mean = if n > 0 { s.iter().sum::<f64>() / n as f64 } else { 0.0 };
    let spread: f64 = s.iter().map(|a| (a - mean) * (a - mean)).sum();
    // a gain needs a signal that varies (else it is an offset)
    let with_gain = sg > 0.0 && n > 1 && scale > 0.0 && spread > (1e-9 * scale).powi(2) * n as f64;
    let z = |v: f64, sd: f64| (sd > 0.0 && sd.is_finite()).then(|| v / sd);
    let done = |o: f64, g: f64| SensorFit {
        offset: o,
        gain: g,
        offset_z: if with_offset { z(o, so) } else { None },
        gain_z: if sg > 0.0 { Some(if sg.is_finite() { g / sg } else { 0.0 }) } else { None },
    };
    if n == 0 {
        return done(0.0, 0.0);
    }
    // sums in the scaled regressor u = ŝ/S (S = scale) for conditioning
    let sc = if scale > 0.0 { scale } else { 1.0 };
    let (mut su, mut suu, mut sd, mut sud) = (0.0, 0.0, 0.0, 0.0);
    for (a, b) in s.iter().zip(y) {
        let (u, d) = (a / sc, b - a);
        su += u;
        suu += u * u;
        sd += d;
        sud += u * d;
    }
    let nf = n as f64;
    let lam_o = if so.is_finite() && so > 0.0 { (sigma / so).powi(2) } else { 0.0 };
    // g = G/S: the prior g/σ_g becomes G/(S σ_g)
    let lam_g = if sg.is_finite() && sg > 0.0 { (sigma / (sc * sg)).powi(2) } else { 0.0 };
    let lim_o = if so.is_finite() { BOUND * so } else { f64::INFINITY };
    let lim_g = if sg.is_finite() { BOUND * sg } else { f64::INFINITY };
    let offset_given = |g_scaled: f64| ((sd - g_scaled * su) / (nf + lam_o)).clamp(-lim_o, lim_o);
    let gain_given = |o: f64| ((sud - o * su) / (suu + lam_g) / sc).clamp(-lim_g, lim_g);
    match (with_offset, with_gain) {
        (false, false) => done(0.0, 0.0),
        (true, false) => done(offset_given(0.0), 0.0),
        (false, true) => done(0.0, gain_given(0.0)),
        (true, true) => {
            let (a11, a12, a22) = (nf + lam_o, su, suu + lam_g);
            let det = a11 * a22 - a12 * a12;
            if det.partial_cmp(&(1e-14 * a11 * a22)) != Some(std::cmp::Ordering::Greater) {
                return done(offset_given(0.0), 0.0);
            }
            let o = (a22 * sd - a12 * sud) / det;
            let gs = (a11 * sud - a12 * sd) / det;
            let g = gs / sc;
            if o.abs() <= lim_o && g.abs() <= lim_g {
                done(o, g)
            } else if o.abs() > lim_o {
                let o = o.clamp(-lim_o, lim_o);
                let g = gain_given(o);
                done(offset_given(g * sc), g)
            } else {
                let g = g.clamp(-lim_g, lim_g);
                done(offset_given(g * sc), g)
            }
        }
    }
}

/// Standard errors (offset [SI], gain) of a channel's fitted sensor errors,
/// given the simulated values at its samples, σ, the prior σ's, the mean
/// squared normalised residual `ms` and the residual's correlation time
/// `tau` (see the module header).
pub fn standard_errors(simulated: &[f64], sigma: f64, so: f64, sg: f64, ms: f64, tau: f64) -> (Option<f64>, Option<f64>) {
    let n = simulated.len() as f64;
    if n < 2.0 {
        return (None, None);
    }
    let var = ms.max(0.0) * tau.max(1.0) * sigma * sigma;
    let lam_o = if so.is_finite() && so > 0.0 { (sigma / so).powi(2) } else { 0.0 };
    let lam_g = if sg.is_finite() && sg > 0.0 { (sigma / sg).powi(2) } else { 0.0 };
    let s1: f64 = simulated.iter().sum();
    let s2: f64 = simulated.iter().map(|a| a * a).sum();
    let mean = s1 / n;
    let spread: f64 = simulated.iter().map(|a| (a - mean) * (a - mean)).sum();
    let scale = simulated.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let varies = spread > (1e-9 * scale).powi(2) * n;
    match (so > 0.0, sg > 0.0 && varies) {
        (true, true) => {
            let (a11, a12, a22) = (n + lam_o, s1, s2 + lam_g);
            let det = a11 * a22 - a12 * a12;
            if det <= 0.0 {
                return (None, None);
            }
            (Some((var * a22 / det).sqrt()), Some((var * a11 / det).sqrt()))
        }
        (true, false) => (Some((var / (n + lam_o)).sqrt()), None),
        (false, true) => (None, (s2 + lam_g > 0.0).then(|| (var / (s2 + lam_g)).sqrt())),
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
        // free offset and gain (no prior): the least-squares values
        let inf = f64::INFINITY;
        let (r, fit) = profile(&s, &y, sigma, inf, inf);
        let (se_o, se_g) = standard_errors(&s, sigma, inf, inf, 1.0, 1.0);
        assert!((fit.offset - o).abs() < 4.0 * se_o.unwrap(), "{fit:?} {se_o:?}");
        assert!((fit.gain - g).abs() < 4.0 * se_g.unwrap(), "{fit:?} {se_g:?}");
        let ms = r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64;
        assert!((ms - 1.0).abs() < 0.08, "{ms}");
        assert_eq!(fit.prior_rows().count(), 1, "a free offset has no row, an infinite-σ gain one row of 0");
        // with priors wide against the data the estimates hardly move; rows are o/σ_o, g/σ_g
        let (_, wide) = profile(&s, &y, sigma, 5000.0, 0.01);
        assert!((wide.offset - fit.offset).abs() < 0.05 * se_o.unwrap() + 1.0, "{wide:?}");
        assert!((wide.offset_z.unwrap() - wide.offset / 5000.0).abs() < 1e-12);
        assert!((wide.gain_z.unwrap() - wide.gain / 0.01).abs() < 1e-12);
        // offset only: the gain shows as a residual slope
        let (r, fit) = profile(&s, &y, sigma, inf, 0.0);
        assert_eq!(fit.gain, 0.0);
        let mean_d = s.iter().zip(&y).map(|(a, b)| b - a).sum::<f64>() / s.len() as f64;
        assert!((fit.offset - mean_d).abs() < 1e-9);
        assert!(r.iter().sum::<f64>().abs() < 1e-6, "residuals have zero mean");
        // nothing fitted: the plain residual
        let (r, fit) = profile(&s, &y, sigma, 0.0, 0.0);
        assert!((r[10] - (s[10] - y[10]) / sigma).abs() < 1e-12);
        assert_eq!(fit.prior_rows().count(), 0);
    }

    #[test]
    fn a_prior_shrinks_the_offset_and_bounds_it() {
        // 100 samples 1000 above the model, σ 500, prior σ_o 250:
        // MAP o = Σd/(n + σ²/σ_o²) = 1e5/(100 + 4) = 961.5…, 3.85 prior σ
        let s = vec![4e5; 100];
        let y = vec![4.01e5; 100];
        let (_, fit) = profile(&s, &y, 500.0, 250.0, 0.0);
        assert!((fit.offset - 1e5 / 104.0).abs() < 1e-9, "{fit:?}");
        assert!((fit.offset_z.unwrap() - 1e5 / 104.0 / 250.0).abs() < 1e-12);
        // with σ_o 100 the MAP value (800) is beyond 4 σ: it stops at the bound
        let (_, fit) = profile(&s, &y, 500.0, 100.0, 0.0);
        assert_eq!(fit.offset, 400.0);
        // a model 50 K off cannot hide behind a 1.5 K thermocouple: the offset stops at 4 σ
        let s = vec![250.0; 50];
        let y = vec![300.0; 50];
        let (r, fit) = profile(&s, &y, 0.2, 1.5, 0.0);
        assert_eq!(fit.offset, BOUND * 1.5);
        assert!(r.iter().all(|v| (v + (50.0 - 6.0) / 0.2).abs() < 1e-9));
        // and with a gain as well, the offset clipped, the gain re-solved within its own bound
        let s: Vec<f64> = (0..50).map(|i| 250.0 + i as f64).collect();
        let y: Vec<f64> = s.iter().map(|v| v + 50.0).collect();
        let (_, fit) = profile(&s, &y, 0.2, 1.5, 0.01);
        assert!(fit.offset.abs() <= 6.0 + 1e-12 && fit.gain.abs() <= 0.04 + 1e-12, "{fit:?}");
    }

    #[test]
    fn a_constant_signal_gets_an_offset_but_no_gain() {
        let s = vec![4e5; 100];
        let y: Vec<f64> = (0..100).map(|i| 4.01e5 + if i % 2 == 0 { 10.0 } else { -10.0 }).collect();
        let (_, fit) = profile(&s, &y, 500.0, f64::INFINITY, 0.01);
        assert_eq!(fit.gain, 0.0);
        assert!((fit.offset - 1000.0).abs() < 1e-6);
        let (se_o, se_g) = standard_errors(&s, 500.0, f64::INFINITY, 0.01, 1.0, 4.0);
        assert!((se_o.unwrap() - 500.0 * (4.0f64 / 100.0).sqrt()).abs() < 1e-9);
        assert!(se_g.is_none());
    }

    #[test]
    fn the_skew_search_finds_the_minimum_of_a_smooth_cost_and_stays_in_bounds() {
        // on a cost of size 1 the minimum is located to about √ε of the scale
        let d = best_skew(2e-3, |x| (x - 0.7e-3).powi(2) + 1.0);
        assert!((d - 0.7e-3).abs() < 5e-8, "{d}");
        // not a parabola: a quartic well
        let d = best_skew(2e-3, |x| ((x - 0.37e-3) * 1e3).powi(4) + 3.0 * ((x - 0.37e-3) * 1e3).powi(2));
        assert!((d - 0.37e-3).abs() < 1e-8, "{d}");
        let d = best_skew(2e-3, |x| (x + 1.3e-3).powi(2));
        assert!((d + 1.3e-3).abs() < 1e-8, "{d}");
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
