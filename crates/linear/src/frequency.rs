//! Frequency response H(jω) = C (jωI − A)⁻¹ B + D and its Bode form:
//! magnitude 20·log₁₀|H| [dB] and phase arg H [deg], the phase unwrapped
//! along the frequency axis (no jumps of 360°).
//!
//! Each frequency is one complex LU solve of the balanced system (the
//! balancing is a similarity and leaves H unchanged). A frequency at which
//! jωI − A is singular (an undamped pole on the grid) gives NaN.

use crate::balance::balance;
use crate::matrix::complex_solve;
use crate::{Complex, LinearError, Matrix};

/// H(j 2π f) for every frequency f [Hz]: `out[k]` is the p × m matrix at
/// frequency k, row-major (output i, input j at `i * m + j`).
pub fn response(a: &Matrix, b: &Matrix, c: &Matrix, d: &Matrix, frequencies_hz: &[f64]) -> Result<Vec<Vec<Complex>>, LinearError> {
    for (m, what) in [(a, "A"), (b, "B"), (c, "C"), (d, "D")] {
        m.check_finite(what)?;
    }
    let (n, m, p) = (a.rows(), b.cols(), c.rows());
    if a.cols() != n || b.rows() != n || c.cols() != n || d.rows() != p || d.cols() != m {
        return Err(LinearError::Shape(format!(
            "A {}x{}, B {}x{}, C {}x{}, D {}x{} do not form a state-space model",
            a.rows(),
            a.cols(),
            b.rows(),
            b.cols(),
            c.rows(),
            c.cols(),
            d.rows(),
            d.cols()
        )));
    }
    let (s, ab) = balance(a);
    let mut out = Vec::with_capacity(frequencies_hz.len());
    let mut lu = vec![Complex::new(0.0, 0.0); n * n];
    let mut x = vec![Complex::new(0.0, 0.0); n * m];
    for &f in frequencies_hz {
        let w = 2.0 * std::f64::consts::PI * f;
        for i in 0..n {
            for j in 0..n {
                lu[i * n + j] = Complex::new(-ab[(i, j)], 0.0);
            }
            lu[i * n + i] += Complex::new(0.0, w);
            for j in 0..m {
                x[i * m + j] = Complex::new(b[(i, j)] / s[i], 0.0);
            }
        }
        let solved = complex_solve(&mut lu, n, &mut x, m);
        let mut h = vec![Complex::new(f64::NAN, f64::NAN); p * m];
        if solved || n == 0 {
            for i in 0..p {
                for j in 0..m {
                    let mut v = Complex::new(d[(i, j)], 0.0);
                    for k in 0..n {
                        v += x[k * m + j] * (c[(i, k)] * s[k]);
                    }
                    h[i * m + j] = v;
                }
            }
        }
        out.push(h);
    }
    Ok(out)
}

/// Magnitude [dB] and unwrapped phase [deg] of a response along frequency.
pub fn bode(values: &[Complex]) -> (Vec<f64>, Vec<f64>) {
    let mag = values.iter().map(|v| 20.0 * v.norm().log10()).collect();
    let mut phase = Vec::with_capacity(values.len());
    let mut previous: Option<f64> = None;
    for v in values {
        let raw = v.im.atan2(v.re).to_degrees();
        let unwrapped = match previous {
            Some(p) if raw.is_finite() => raw + 360.0 * ((p - raw) / 360.0).round(),
            _ => raw,
        };
        if unwrapped.is_finite() {
            previous = Some(unwrapped);
        }
        phase.push(unwrapped);
    }
    (mag, phase)
}

/// `per_decade` logarithmically spaced frequencies from `lo` to `hi` (both included).
pub fn log_grid(lo: f64, hi: f64, per_decade: usize) -> Vec<f64> {
    let (a, b) = (lo.log10(), hi.log10());
    let n = ((b - a) * per_decade as f64).ceil().max(1.0) as usize;
    (0..=n).map(|k| 10f64.powf(a + (b - a) * k as f64 / n as f64)).collect()
}

/// The default frequency range [Hz] for a system with these characteristic
/// frequencies [rad/s] (poles and zeros; zeros at the origin are ignored):
/// from a decade below the lowest to a decade above the highest, rounded out
/// to whole decades, at most 7 decades (kept around the lowest ones, where
/// the mechanics of a drive are; 0.1–100 Hz when there is nothing to go by).
pub fn default_range(characteristic: &[f64]) -> (f64, f64) {
    let hz: Vec<f64> = characteristic.iter().map(|w| w / (2.0 * std::f64::consts::PI)).filter(|f| f.is_finite() && *f > 1e-9).collect();
    if hz.is_empty() {
        return (0.1, 100.0);
    }
    let lo = hz.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = hz.iter().copied().fold(0.0, f64::max);
    let a = (lo.log10() - 1.0).floor();
    let b = (hi.log10() + 1.0).ceil().min(a + 7.0);
    (10f64.powf(a), 10f64.powf(b.max(a + 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_lag_is_minus_three_db_and_minus_45_degrees_at_its_corner() {
        // G = 1/(τ s + 1), τ = 1/(2π·10 Hz)
        let tau = 1.0 / (2.0 * std::f64::consts::PI * 10.0);
        let a = Matrix::from_rows(&[vec![-1.0 / tau]]).unwrap();
        let b = Matrix::from_rows(&[vec![1.0 / tau]]).unwrap();
        let c = Matrix::identity(1);
        let d = Matrix::zeros(1, 1);
        let h = response(&a, &b, &c, &d, &[10.0]).unwrap();
        let (mag, phase) = bode(&[h[0][0]]);
        assert!((mag[0] + 10.0 * 2f64.log10()).abs() < 1e-12);
        assert!((phase[0] + 45.0).abs() < 1e-12);
    }

    #[test]
    fn phase_is_unwrapped_past_minus_180() {
        // three poles at −1: phase runs to −270°
        let a = Matrix::from_rows(&[vec![-1.0, 1.0, 0.0], vec![0.0, -1.0, 1.0], vec![0.0, 0.0, -1.0]]).unwrap();
        let b = Matrix::from_rows(&[vec![0.0], vec![0.0], vec![1.0]]).unwrap();
        let c = Matrix::from_rows(&[vec![1.0, 0.0, 0.0]]).unwrap();
        let f = log_grid(0.001, 100.0, 20);
        let h = response(&a, &b, &c, &Matrix::zeros(1, 1), &f).unwrap();
        let (_, phase) = bode(&h.iter().map(|m| m[0]).collect::<Vec<_>>());
        assert!(phase.windows(2).all(|w| w[1] <= w[0] + 1e-9), "monotone");
        assert!((phase.last().unwrap() + 270.0).abs() < 1.0, "{}", phase.last().unwrap());
    }

    #[test]
    fn grids_and_ranges() {
        let g = log_grid(0.1, 100.0, 10);
        assert_eq!(g.len(), 31);
        assert!((g[0] - 0.1).abs() < 1e-15 && (g[30] - 100.0).abs() < 1e-12);
        let (lo, hi) = default_range(&[0.0, 2.0 * std::f64::consts::PI * 13.0, 0.2]);
        assert_eq!((lo, hi), (1e-3, 1e3));
        assert_eq!(default_range(&[]), (0.1, 100.0));
    }
}
