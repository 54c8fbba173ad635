//! Modes of ẋ = A x: eigenvalues λ with natural frequency ω_n = |λ| and
//! damping ratio ζ = −Re λ / |λ| (for a pair λ = −ζω_n ± jω_n√(1−ζ²), the
//! roots of s² + 2ζω_n s + ω_n² = 0), and the states that take part in each.
//!
//! Participation factors (Pérez-Arriaga, Verghese & Schweppe 1982):
//! p_ki = |v_ki · w_ik| with v_i the right and w_i the left eigenvector
//! (W = V⁻¹), normalised to sum to 1 over the states k. They do not depend
//! on the units of the states. Where V is too ill-conditioned to invert (a
//! defective eigenvalue), the normalised right eigenvector's magnitudes in
//! the balanced coordinates are given instead. An eigenvalue below [`ZERO`]
//! times the largest is reported as exactly 0.

use crate::balance::balance;
use crate::matrix::complex_solve;
use crate::{Complex, LinearError, Matrix};

/// Eigenvalues smaller than this times the largest are zero (an integrator,
/// a conserved quantity such as the gas in a closed chamber).
pub const ZERO: f64 = 1e-10;

/// One mode (a real eigenvalue, or a complex pair given once with Im λ > 0).
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    pub eigenvalue: Complex,
    /// Whether this stands for the pair λ, λ̄.
    pub pair: bool,
    /// ω_n = |λ| [rad/s].
    pub natural_frequency: f64,
    /// ζ = −Re λ/|λ|; NaN for λ = 0.
    pub damping: f64,
    /// (state index, share) of the states that take part, largest first,
    /// shares ≥ 0.05 (at most 4).
    pub participation: Vec<(usize, f64)>,
}

impl Mode {
    /// Natural frequency in Hz.
    pub fn frequency_hz(&self) -> f64 {
        self.natural_frequency / (2.0 * std::f64::consts::PI)
    }
}

/// Eigenvalues of a square matrix (balanced first).
pub fn eigenvalues(a: &Matrix) -> Result<Vec<Complex>, LinearError> {
    a.check_finite("A")?;
    if a.rows() == 0 {
        return Ok(Vec::new());
    }
    let (_, b) = balance(a);
    b.to_faer().eigenvalues().map_err(|_| LinearError::NoConvergence { what: "eigenvalues of A" })
}

/// The modes of A, sorted by natural frequency (then by real part).
pub fn modes(a: &Matrix) -> Result<Vec<Mode>, LinearError> {
    a.check_finite("A")?;
    let n = a.rows();
    if n == 0 {
        return Ok(Vec::new());
    }
    let (d, b) = balance(a);
    let evd = b.to_faer().eigen().map_err(|_| LinearError::NoConvergence { what: "eigenvectors of A" })?;
    let values: Vec<Complex> = (0..n).map(|i| evd.S()[i]).collect();
    // right eigenvectors in the original coordinates: v = D v'
    let u = evd.U();
    let mut v = vec![Complex::new(0.0, 0.0); n * n];
    for k in 0..n {
        for i in 0..n {
            v[k * n + i] = u[(k, i)] * d[k];
        }
    }
    let shares = participation(&v, n).unwrap_or_else(|| magnitudes(u, n));
    let scale = values.iter().fold(0.0f64, |m, l| m.max(l.norm()));
    let mut out = Vec::new();
    for (i, &l) in values.iter().enumerate() {
        // a pair is listed once, with Im λ > 0
        let imag = l.im.abs() > 1e-12 * scale.max(f64::MIN_POSITIVE);
        if imag && l.im < 0.0 {
            continue;
        }
        // rounding leaves a zero eigenvalue (a conserved quantity) at ~1e-17 |λ|max
        let l = if l.norm() <= ZERO * scale { Complex::new(0.0, 0.0) } else { l };
        let wn = l.norm();
        let mut p: Vec<(usize, f64)> = (0..n).map(|k| (k, shares[k * n + i])).filter(|&(_, s)| s >= 0.05).collect();
        p.sort_by(|x, y| y.1.total_cmp(&x.1));
        p.truncate(4);
        out.push(Mode {
            eigenvalue: if imag { l } else { Complex::new(l.re, 0.0) },
            pair: imag,
            natural_frequency: wn,
            damping: if wn > 0.0 { -l.re / wn } else { f64::NAN },
            participation: p,
        });
    }
    out.sort_by(|x, y| x.natural_frequency.total_cmp(&y.natural_frequency).then(x.eigenvalue.re.total_cmp(&y.eigenvalue.re)));
    Ok(out)
}

/// Participation factors |v_ki w_ik| normalised per mode; None if V is singular.
fn participation(v: &[Complex], n: usize) -> Option<Vec<f64>> {
    let mut m = v.to_vec();
    let mut w = vec![Complex::new(0.0, 0.0); n * n];
    for i in 0..n {
        w[i * n + i] = Complex::new(1.0, 0.0);
    }
    if !complex_solve(&mut m, n, &mut w, n) {
        return None;
    }
    // W = V⁻¹: row i of W is the left eigenvector of mode i
    let mut p = vec![0.0; n * n];
    for i in 0..n {
        let total: f64 = (0..n).map(|k| (v[k * n + i] * w[i * n + k]).norm()).sum();
        if !(total.is_finite() && total > 0.0) {
            return None;
        }
        for k in 0..n {
            p[k * n + i] = (v[k * n + i] * w[i * n + k]).norm() / total;
        }
    }
    // an ill-conditioned V shows as shares that do not add to about one per state either
    let per_state_ok = (0..n).all(|k| {
        let s: f64 = (0..n).map(|i| (v[k * n + i] * w[i * n + k]).re).sum();
        (s - 1.0).abs() < 1e-6
    });
    per_state_ok.then_some(p)
}

/// Squared magnitudes of the (balanced) right eigenvectors, normalised per mode.
fn magnitudes(u: faer::MatRef<'_, Complex>, n: usize) -> Vec<f64> {
    let mut p = vec![0.0; n * n];
    for i in 0..n {
        let total: f64 = (0..n).map(|k| u[(k, i)].norm_sqr()).sum();
        for k in 0..n {
            p[k * n + i] = if total > 0.0 { u[(k, i)].norm_sqr() / total } else { 0.0 };
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mass_spring_damper_has_its_textbook_mode() {
        // m ẍ + c ẋ + k x = 0 with ω_n = 10 rad/s, ζ = 0.1; states (x, v)
        let (m, k) = (2.0f64, 200.0f64);
        let c = 2.0 * 0.1 * (k * m).sqrt();
        let a = Matrix::from_rows(&[vec![0.0, 1.0], vec![-k / m, -c / m]]).unwrap();
        let modes = modes(&a).unwrap();
        assert_eq!(modes.len(), 1);
        assert!(modes[0].pair);
        assert!((modes[0].natural_frequency - 10.0).abs() < 1e-12);
        assert!((modes[0].damping - 0.1).abs() < 1e-12);
        let states: Vec<usize> = modes[0].participation.iter().map(|p| p.0).collect();
        assert_eq!(states.len(), 2, "both states take part: {:?}", modes[0].participation);
    }

    #[test]
    fn integrators_and_badly_scaled_states() {
        // a conserved quantity (zero row), a fast real mode at −1e6 and a slow one,
        // with state units 1e-4 and 1e3 apart
        let a = Matrix::from_rows(&[vec![0.0, 0.0, 0.0], vec![1e-4, -1e6, 0.0], vec![0.0, 1e3, -0.2]]).unwrap();
        let modes = modes(&a).unwrap();
        let wn: Vec<f64> = modes.iter().map(|m| m.natural_frequency).collect();
        assert!(wn[0] < 1e-12 && modes[0].damping.is_nan(), "{modes:?}");
        assert!((wn[1] - 0.2).abs() < 1e-12 && (modes[1].damping - 1.0).abs() < 1e-12);
        assert!((wn[2] - 1e6).abs() < 1e-6);
        assert_eq!(modes[2].participation[0].0, 1);
        assert!(eigenvalues(&Matrix::from_rows(&[vec![f64::NAN]]).unwrap()).is_err());
    }
}
