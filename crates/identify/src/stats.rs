//! Statistics of correlated residuals: autocorrelation, the integrated
//! autocorrelation time and effective sample size, the information
//! criterion on effective sample sizes, and parameter covariances that
//! account for residual correlation.
//!
//! # Why
//! After a fit, the residual of a channel is white sensor noise plus a
//! systematic part: what the model gets wrong (a missing effect, or the small
//! differences of model form between any two honest implementations of the
//! same machine). The systematic part is smooth in time, so neighbouring
//! samples carry nearly the same information. Counting 13 000 such samples
//! as independent overstates the evidence for any change that moves the
//! systematic part by orders of magnitude.
//!
//! # Effective sample size (per block)
//! A block is the residual sequence of one channel of one experiment at the
//! fitted samples. For a stationary sequence with autocorrelation ρ_k, the
//! variance of a mean over n samples is (σ²/n)·τ with the integrated
//! autocorrelation time τ = 1 + 2·Σ_{k≥1} ρ_k, so the block holds the
//! information of n_eff = n/τ independent samples (for AR(1) residuals,
//! τ = (1 + ρ)/(1 − ρ)). τ is estimated with Sokal's adaptive window
//! (A. Sokal, "Monte Carlo methods in statistical mechanics", 1996, §3):
//! τ̂(W) = 1 + 2·Σ_{k=1..W} ρ̂_k with the smallest W ≥ c·τ̂(W), c = 5; it is
//! floored at 1 (negative correlation is not counted as extra information)
//! and capped at n.
//!
//! # Information criterion
//! With a Gaussian error of unknown scale s_b² in each block, −2 ln L =
//! Σ_b n_b·ln(χ²_b/n_b) + const; counting each block by its effective size
//! instead, Schwarz's criterion for adding Δk parameters becomes
//! ΔIC = Σ_b n_eff,b·ln(χ²_b,new/χ²_b,old) + Δk·ln(Σ_b n_eff,b).
//! The effective sizes are those of the larger model's residuals: if the
//! added effect is real its residuals are close to white and the evidence
//! counts fully; if it only absorbs part of a smooth model-form error, the
//! residuals stay correlated and the evidence is discounted.
//!
//! # Covariance of fitted parameters
//! For least squares with correlated errors the covariance of the estimate is
//! the sandwich (JᵀJ)⁻¹·JᵀΣJ·(JᵀJ)⁻¹. With block-wise scale ŝ_b² = χ²_b/n_b
//! and correlation time τ_b, and Jacobian rows varying slowly against the
//! correlation length, JᵀΣJ ≈ Σ_b τ_b·ŝ_b²·J_bᵀJ_b. For white residuals at the
//! noise level (τ = 1, ŝ = 1) this is the textbook (JᵀJ)⁻¹.
//!
//! Units: residuals are noise-normalised (dimensionless); the covariance is
//! in the coordinates of the Jacobian's columns.

use nalgebra::DMatrix;
use std::ops::Range;

/// Sokal's window constant.
pub const SOKAL_C: f64 = 5.0;

/// Sample autocorrelation of `x` at `lag` (mean removed; 0 when too short or constant).
pub fn autocorrelation(x: &[f64], lag: usize) -> f64 {
    let n = x.len();
    if n <= lag + 1 {
        return 0.0;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let var: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    if var <= 0.0 {
        return 0.0;
    }
    let cov: f64 = (0..n - lag).map(|i| (x[i] - mean) * (x[i + lag] - mean)).sum();
    cov / var
}

/// Ljung–Box Q over lags 1..=L, divided by L (≈ 1 for white noise; Ljung & Box 1978).
/// A short series uses fewer lags, L = min(`lags`, n/4) (the autocorrelation
/// at a lag near n is estimated from a handful of pairs); below 4 samples
/// there is no statistic (NaN), never a 0 that would read as "white".
pub fn ljung_box_per_lag(x: &[f64], lags: usize) -> f64 {
    let n = x.len() as f64;
    let lags = lags.min(x.len() / 4);
    if lags == 0 {
        return f64::NAN;
    }
    let q: f64 = (1..=lags).map(|k| autocorrelation(x, k).powi(2) / (n - k as f64)).sum::<f64>() * n * (n + 2.0);
    q / lags as f64
}

/// Pearson correlation of paired samples (0 if either is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 3 {
        return 0.0;
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (da, db) = (a[i] - ma, b[i] - mb);
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Integrated autocorrelation time τ of a sequence (see the module header), in [1, n].
pub fn integrated_time(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 4 {
        return 1.0;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let d: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let var: f64 = d.iter().map(|v| v * v).sum();
    if var <= 0.0 {
        return 1.0;
    }
    let mut tau = 1.0;
    let max_lag = n / 2;
    for w in 1..=max_lag {
        let cov: f64 = d[..n - w].iter().zip(&d[w..]).map(|(a, b)| a * b).sum();
        tau += 2.0 * cov / var;
        if w as f64 >= SOKAL_C * tau {
            break;
        }
    }
    tau.clamp(1.0, n as f64)
}

/// Per-block statistics of a residual vector.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockStats {
    /// Σr² of each block.
    pub chi2: Vec<f64>,
    /// Samples of each block.
    pub n: Vec<usize>,
    /// Integrated autocorrelation time of each block.
    pub tau: Vec<f64>,
}

impl BlockStats {
    /// Statistics of the blocks `blocks` (row ranges) of `r`.
    pub fn of(r: &[f64], blocks: &[Range<usize>]) -> BlockStats {
        let mut s = BlockStats { chi2: Vec::new(), n: Vec::new(), tau: Vec::new() };
        for b in blocks {
            let x = &r[b.clone()];
            s.chi2.push(x.iter().map(|v| v * v).sum());
            s.n.push(x.len());
            s.tau.push(integrated_time(x));
        }
        s
    }

    /// Effective sample size of each block, n/τ.
    pub fn n_eff(&self) -> Vec<f64> {
        self.n.iter().zip(&self.tau).map(|(&n, &t)| n as f64 / t).collect()
    }

    /// Total effective sample size.
    pub fn n_eff_total(&self) -> f64 {
        self.n_eff().iter().sum()
    }

    /// Total Σr².
    pub fn chi2_total(&self) -> f64 {
        self.chi2.iter().sum()
    }
}

/// ΔIC of a model with block χ² `new` and `dk` more parameters than a model
/// with block χ² `old`, counting each block by `n_eff` (see the module header).
/// Blocks where either χ² is zero are skipped.
pub fn delta_ic(old: &[f64], new: &[f64], n_eff: &[f64], dk: isize) -> f64 {
    let mut d = 0.0;
    let mut total = 0.0;
    for ((&a, &b), &n) in old.iter().zip(new).zip(n_eff) {
        total += n;
        if a > 0.0 && b > 0.0 {
            d += n * (b / a).ln();
        }
    }
    d + dk as f64 * total.max(1.0).ln()
}

/// Schwarz's criterion of one model on effective sizes (for reporting):
/// Σ_b n_eff,b·ln(χ²_b/n_b) + k·ln(Σ n_eff).
pub fn information_criterion(s: &BlockStats, k: usize) -> f64 {
    let ne = s.n_eff();
    let mut v = 0.0;
    for ((&c, &n), &e) in s.chi2.iter().zip(&s.n).zip(&ne) {
        if c > 0.0 && n > 0 {
            v += e * (c / n as f64).ln();
        }
    }
    v + k as f64 * s.n_eff_total().max(1.0).ln()
}

/// Covariance of the parameters from the Jacobian `j` (rows as `r`),
/// accounting for block-wise scale and correlation (see the module header);
/// `None` when JᵀJ is numerically singular or a block is empty.
pub fn sandwich_covariance(j: &DMatrix<f64>, stats: &BlockStats, blocks: &[Range<usize>]) -> Option<DMatrix<f64>> {
    let (m, p) = j.shape();
    if p == 0 || m <= p {
        return None;
    }
    let jtj = j.transpose() * j;
    let svd = jtj.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smax <= 0.0 || smin <= smax * 1e-13 {
        return None;
    }
    let inv = svd.pseudo_inverse(0.0).ok()?;
    let mut meat = DMatrix::zeros(p, p);
    for (k, b) in blocks.iter().enumerate() {
        if b.is_empty() {
            continue;
        }
        let jb = j.rows(b.start, b.len());
        let s2 = stats.chi2[k] / stats.n[k].max(1) as f64;
        meat += (jb.transpose() * jb) * (stats.tau[k] * s2);
    }
    let cov = &inv * meat * &inv;
    cov.iter().all(|v| v.is_finite()).then_some(cov)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn white_noise_has_unit_correlation_time() {
        let mut g = Rng::new(3);
        for _ in 0..5 {
            let x: Vec<f64> = (0..2000).map(|_| g.normal()).collect();
            let t = integrated_time(&x);
            assert!((0.9..1.35).contains(&t), "{t}");
        }
    }

    #[test]
    fn ar1_correlation_time_matches_theory() {
        // τ = (1 + ρ)/(1 − ρ) for AR(1): 19 for ρ = 0.9, 3 for ρ = 0.5
        let mut g = Rng::new(4);
        for (rho, expect) in [(0.5, 3.0), (0.9, 19.0)] {
            let mut taus = Vec::new();
            for _ in 0..20 {
                let mut x = Vec::with_capacity(20_000);
                let mut v = 0.0;
                for _ in 0..20_000 {
                    v = rho * v + g.normal();
                    x.push(v);
                }
                taus.push(integrated_time(&x));
            }
            let mean = taus.iter().sum::<f64>() / taus.len() as f64;
            assert!((mean / expect - 1.0).abs() < 0.12, "rho {rho}: mean tau {mean}, expected {expect}");
        }
    }

    #[test]
    fn a_smooth_error_on_top_of_noise_is_counted_as_few_samples() {
        // noise plus a slow sine of 3 σ: the variance of the mean is far above σ²/n
        let mut g = Rng::new(5);
        let x: Vec<f64> = (0..2000).map(|i| g.normal() + 3.0 * (i as f64 / 150.0).sin()).collect();
        let t = integrated_time(&x);
        assert!(t > 30.0, "{t}");
        assert!(integrated_time(&[1.0; 50]) == 1.0);
    }

    #[test]
    fn information_criterion_by_hand() {
        // one block, n_eff 100: halving χ² gains 100 ln 2, one parameter costs ln 100
        let d = delta_ic(&[2000.0], &[1000.0], &[100.0], 1);
        assert!((d - (-100.0 * 2f64.ln() + 100f64.ln())).abs() < 1e-9);
        // two blocks counted separately
        let d = delta_ic(&[100.0, 400.0], &[50.0, 400.0], &[10.0, 30.0], 0);
        assert!((d - 10.0 * 0.5f64.ln()).abs() < 1e-12);
        let s = BlockStats { chi2: vec![200.0], n: vec![100], tau: vec![4.0] };
        assert!((information_criterion(&s, 2) - (25.0 * 2f64.ln() + 2.0 * 25f64.ln())).abs() < 1e-9);
    }

    #[test]
    fn sandwich_reduces_to_the_textbook_covariance_for_white_unit_residuals_and_inflates_with_tau() {
        // y = a + b t with unit noise: the covariance is (JᵀJ)⁻¹ when ŝ = 1, τ = 1
        let n = 200;
        let j = DMatrix::from_fn(n, 2, |i, c| if c == 0 { 1.0 } else { i as f64 / n as f64 });
        let blocks: Vec<std::ops::Range<usize>> = std::iter::once(0..n).collect();
        let white = BlockStats { chi2: vec![n as f64], n: vec![n], tau: vec![1.0] };
        let cov = sandwich_covariance(&j, &white, &blocks).unwrap();
        let expect = (j.transpose() * &j).try_inverse().unwrap();
        assert!((&cov - &expect).abs().max() < 1e-12);
        let slow = BlockStats { chi2: vec![4.0 * n as f64], n: vec![n], tau: vec![10.0] };
        let cov = sandwich_covariance(&j, &slow, &blocks).unwrap();
        assert!((&cov - &expect * 40.0).abs().max() < 1e-9);
        // singular: two equal columns
        let bad = DMatrix::from_fn(n, 2, |_, _| 1.0);
        assert!(sandwich_covariance(&bad, &white, &blocks).is_none());
    }
}
