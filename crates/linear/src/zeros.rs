//! Poles, zeros and gain of one input–output pair:
//! G(s) = k · Π(s − zᵢ) / Π(s − pᵢ), from its minimal realisation
//! ([`crate::realization::minimal`]).
//!
//! Poles are the eigenvalues of the minimal A. Zeros are the finite
//! generalised eigenvalues of the Rosenbrock system pencil
//! ( [A b; c d], [I 0; 0 0] ) (Emami-Naeini & Van Dooren 1982): s is a zero
//! where [sI − A, −b; c, d] loses rank. An eigenvalue of the pencil counts as
//! infinite when |λ| exceeds 1e8 times the pencil's norm. A minimal SISO
//! realisation of order n and relative degree r has exactly n − r finite
//! zeros (Kailath 1980, §6.5), so only the n − r smallest are kept: with
//! r ≥ 2 the pencil's multiple infinite eigenvalue splits under rounding
//! into large finite values (±3.6e10 1/s on position_control's x/u), which
//! the 1e8 test alone does not catch. r is the index of the first Markov
//! parameter c Aᵏ b that exceeds 1e-10 ‖c‖ ‖Aᵏ b‖ (a sum that does not
//! cancel to rounding). The gain k is
//! G(s₀) Π(s₀ − pᵢ)/Π(s₀ − zᵢ) at a point s₀ on the imaginary axis away
//! from every pole and zero; the DC gain is G(0) unless a pole sits at 0.

use crate::matrix::complex_solve;
use crate::modal::eigenvalues;
use crate::realization::{minimal, DEFAULT_TOL};
use crate::{Complex, LinearError, Matrix};

/// Poles, zeros and gains of one pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PoleZero {
    /// Order of the minimal realisation.
    pub order: usize,
    pub poles: Vec<Complex>,
    pub zeros: Vec<Complex>,
    /// k in G(s) = k Π(s − z)/Π(s − p).
    pub gain: f64,
    /// G(0), or None if a pole is at the origin (an integrator).
    pub dc_gain: Option<f64>,
}

/// Poles and zeros of the pair (b = column of B, c = row of C, d).
pub fn pole_zero(a: &Matrix, b: &[f64], c: &[f64], d: f64) -> Result<PoleZero, LinearError> {
    a.check_finite("A")?;
    if !b.iter().chain(c).chain(std::iter::once(&d)).all(|v| v.is_finite()) {
        return Err(LinearError::NonFinite { what: "B, C or D" });
    }
    let s = minimal(a, b, c, d, DEFAULT_TOL);
    let r = s.a.rows();
    let poles = eigenvalues(&s.a)?;
    let zeros = if r == 0 { Vec::new() } else { pencil_zeros(&s)? };
    let scale = poles.iter().chain(&zeros).fold(1.0f64, |m, z| m.max(z.norm()));
    let g = |x: Complex| evaluate(&s, x);
    // a point on the imaginary axis away from every pole and zero
    let s0 = (1..=8)
        .map(|k| Complex::new(0.0, scale * 0.37 * k as f64))
        .max_by(|x, y| distance(*x, &poles, &zeros).total_cmp(&distance(*y, &poles, &zeros)))
        .unwrap_or(Complex::new(0.0, 1.0));
    let gain = match g(s0) {
        Some(value) => {
            let num: Complex = zeros.iter().map(|z| s0 - z).product();
            let den: Complex = poles.iter().map(|p| s0 - p).product();
            (value * den / num).re
        }
        None => f64::NAN,
    };
    let at_origin = poles.iter().any(|p| p.norm() <= 1e-9 * scale);
    let dc_gain = if at_origin { None } else { g(Complex::new(0.0, 0.0)).map(|v| v.re) };
    Ok(PoleZero { order: r, poles, zeros, gain, dc_gain })
}

/// Smallest distance from x to a pole or zero.
fn distance(x: Complex, poles: &[Complex], zeros: &[Complex]) -> f64 {
    poles.iter().chain(zeros).map(|p| (x - p).norm()).fold(f64::INFINITY, f64::min)
}

/// G(x) = c (xI − A)⁻¹ b + d, or None if x is a pole to working precision.
fn evaluate(s: &crate::realization::Siso, x: Complex) -> Option<Complex> {
    let r = s.a.rows();
    let mut m = vec![Complex::new(0.0, 0.0); r * r];
    for i in 0..r {
        for j in 0..r {
            m[i * r + j] = Complex::new(-s.a[(i, j)], 0.0);
        }
        m[i * r + i] += x;
    }
    let mut rhs: Vec<Complex> = s.b.iter().map(|&v| Complex::new(v, 0.0)).collect();
    if !complex_solve(&mut m, r, &mut rhs, 1) {
        return None;
    }
    Some(s.c.iter().zip(&rhs).map(|(c, v)| v * c).sum::<Complex>() + s.d)
}

/// Finite generalised eigenvalues of ([A b; c d], [I 0; 0 0]).
fn pencil_zeros(s: &crate::realization::Siso) -> Result<Vec<Complex>, LinearError> {
    let r = s.a.rows();
    let mut m = Matrix::zeros(r + 1, r + 1);
    let mut e = Matrix::zeros(r + 1, r + 1);
    for i in 0..r {
        for j in 0..r {
            m[(i, j)] = s.a[(i, j)];
        }
        m[(i, r)] = s.b[i];
        m[(r, i)] = s.c[i];
        e[(i, i)] = 1.0;
    }
    m[(r, r)] = s.d;
    let norm = m.norm().max(f64::MIN_POSITIVE);
    let g = m.to_faer().generalized_eigen(e.to_faer()).map_err(|_| LinearError::NoConvergence { what: "zeros (QZ)" })?;
    let mut zeros = Vec::new();
    for i in 0..=r {
        let (alpha, beta) = (g.S_a()[i], g.S_b()[i]);
        if beta.norm() == 0.0 {
            continue;
        }
        let z = alpha / beta;
        if z.norm() <= 1e8 * norm {
            zeros.push(z);
        }
    }
    // numbers meant to be real come out with rounding noise in Im
    for z in zeros.iter_mut() {
        if z.im.abs() <= 1e-10 * z.norm() {
            z.im = 0.0;
        }
    }
    zeros.sort_by(|a, b| a.norm().total_cmp(&b.norm()).then(a.im.total_cmp(&b.im)));
    zeros.truncate(r - relative_degree(s).min(r));
    Ok(zeros)
}

/// Relative degree of a SISO realisation: 0 if d ≠ 0, else 1 + the index of
/// the first Markov parameter c Aᵏ b that is not rounding noise (relative
/// 1e-10 of ‖c‖ ‖Aᵏ b‖); the order if none is.
fn relative_degree(s: &crate::realization::Siso) -> usize {
    let r = s.a.rows();
    if s.d != 0.0 {
        return 0;
    }
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let c_norm = norm(&s.c);
    let mut w = s.b.clone();
    for k in 0..r {
        let markov: f64 = s.c.iter().zip(&w).map(|(c, w)| c * w).sum();
        if markov.abs() > 1e-10 * c_norm * norm(&w) {
            return k + 1;
        }
        w = (0..r).map(|i| (0..r).map(|j| s.a[(i, j)] * w[j]).sum()).collect();
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Complex, b: Complex, tol: f64) -> bool {
        (a - b).norm() <= tol * b.norm().max(1.0)
    }

    #[test]
    fn second_order_with_a_zero() {
        // G(s) = 3 (s + 5) / (s² + 2 s + 100), in controllable canonical form
        let a = Matrix::from_rows(&[vec![0.0, 1.0], vec![-100.0, -2.0]]).unwrap();
        let pz = pole_zero(&a, &[0.0, 1.0], &[15.0, 3.0], 0.0).unwrap();
        assert_eq!(pz.order, 2);
        assert_eq!(pz.zeros.len(), 1);
        assert!(close(pz.zeros[0], Complex::new(-5.0, 0.0), 1e-10), "{:?}", pz.zeros);
        assert!((pz.gain - 3.0).abs() < 1e-10, "{}", pz.gain);
        assert!((pz.dc_gain.unwrap() - 0.15).abs() < 1e-12);
        let mut poles = pz.poles.clone();
        poles.sort_by(|a, b| a.im.total_cmp(&b.im));
        assert!(close(poles[1], Complex::new(-1.0, 99f64.sqrt()), 1e-12));
    }

    #[test]
    fn an_integrator_has_no_dc_gain_and_hidden_modes_are_not_poles() {
        // x1' = u (integrator, seen), x2' = -4 x2 + u (not seen), y = x1 + 0.5 u
        let a = Matrix::from_rows(&[vec![0.0, 0.0], vec![0.0, -4.0]]).unwrap();
        let pz = pole_zero(&a, &[1.0, 1.0], &[1.0, 0.0], 0.5).unwrap();
        assert_eq!(pz.order, 1);
        assert_eq!(pz.poles.len(), 1);
        assert!(pz.poles[0].norm() < 1e-14);
        // G = 1/s + 0.5 = 0.5 (s + 2)/s
        assert!(close(pz.zeros[0], Complex::new(-2.0, 0.0), 1e-10), "{:?}", pz.zeros);
        assert!((pz.gain - 0.5).abs() < 1e-12);
        assert_eq!(pz.dc_gain, None);
    }

    #[test]
    fn a_chain_of_integrators_with_a_high_relative_degree_has_no_spurious_zeros() {
        // G(s) = 2 κ' (s + 3) / ((s + 1)(s + 2)(s + 4)(s + 5)(s + 6)),
        // relative degree 4, as a chain of first-order lags whose output
        // mixes the last two states: order 5, so exactly one finite zero;
        // a second case with couplings spread over decades (as in a
        // pneumatic chain: spool, flow, pressure, velocity, position). The
        // regression case of the truncation to n − r zeros is
        // position_control's x/u (crates/app/tests/linearize.rs)
        for scale in [1.0, 1e4] {
            let mut a = Matrix::zeros(5, 5);
            let poles = [-1.0, -2.0, -4.0, -5.0, -6.0];
            for (i, p) in poles.iter().enumerate() {
                a[(i, i)] = *p;
                if i > 0 {
                    // x_i' = p x_i + g x_{i-1}, gains alternately large and small
                    a[(i, i - 1)] = if i % 2 == 0 { scale } else { 1.0 / scale };
                }
            }
            let mut b = vec![0.0; 5];
            b[0] = 1.0;
            // y = c x with c picking x_4 and x_3 so that G has one zero
            let mut c = vec![0.0; 5];
            let gain: f64 = (1..5).map(|i| a[(i, i - 1)]).product();
            c[4] = 2.0 / gain;
            // x_4 = a43 x_3 / (s + 6): y = (2/gain)(a43/(s+6) + κ) x_3 = zero at −6 − a43/κ
            let a43 = a[(4, 3)];
            let kappa = -a43 / 3.0; // zero at −6 + 3 = −3
            c[3] = 2.0 / gain * kappa;
            let pz = pole_zero(&a, &b, &c, 0.0).unwrap();
            assert_eq!(pz.order, 5);
            assert_eq!(pz.zeros.len(), 1, "scale {scale}: {:?}", pz.zeros);
            assert!(close(pz.zeros[0], Complex::new(-3.0, 0.0), 1e-8), "{:?}", pz.zeros);
        }
    }
}
