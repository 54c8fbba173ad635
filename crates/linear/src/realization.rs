//! The minimal realisation of one input–output pair (A, b, c, d): the part
//! of the state space the input reaches and the output sees.
//!
//! A model's full A carries modes a given pair does not involve: the gas
//! mass of a closed chamber (conserved, eigenvalue 0), a controller left
//! without a loop. Its transfer function G(s) = c (sI − A)⁻¹ b + d is that of
//! the minimal realisation, and the pair's poles are the eigenvalues of that
//! realisation only (MATLAB's `minreal`, python-control's `minreal`).
//!
//! Method: orthogonal projections onto Krylov subspaces, computed by Arnoldi
//! with full re-orthogonalisation (Boley & Golub 1984): the controllable
//! subspace span{b, Ab, A²b, …} first, then, in it, the observable subspace
//! span{cᵀ, Aᵀcᵀ, …}. A new direction counts when its norm after
//! orthogonalisation exceeds `tol`·‖A‖ (in the balanced coordinates, with b
//! and c scaled to norm 1); `tol` is √ε ≈ 1.5e-8 by default, as in MATLAB's
//! `minreal`. The transfer function is unchanged by the balancing and the
//! projections.

use crate::balance::balance;
use crate::Matrix;

/// Default relative tolerance of a direction (√ε).
pub const DEFAULT_TOL: f64 = 1.4901161193847656e-8;

/// A single-input single-output realisation.
#[derive(Debug, Clone, PartialEq)]
pub struct Siso {
    pub a: Matrix,
    pub b: Vec<f64>,
    pub c: Vec<f64>,
    pub d: f64,
}

/// The minimal realisation of (a, b, c, d).
pub fn minimal(a: &Matrix, b: &[f64], c: &[f64], d: f64, tol: f64) -> Siso {
    let (scale, ab) = balance(a);
    let bb: Vec<f64> = b.iter().zip(&scale).map(|(v, s)| v / s).collect();
    let cb: Vec<f64> = c.iter().zip(&scale).map(|(v, s)| v * s).collect();
    let norm = ab.norm().max(f64::MIN_POSITIVE);
    // controllable part
    let q = krylov(&ab, &bb, tol * norm, false);
    let (a1, b1, c1) = project(&ab, &bb, &cb, &q);
    // observable part of it
    let norm1 = a1.norm().max(f64::MIN_POSITIVE);
    let p = krylov(&a1, &c1, tol * norm1, true);
    let (a2, b2, c2) = project(&a1, &b1, &c1, &p);
    Siso { a: a2, b: b2, c: c2, d }
}

/// Orthonormal basis (as columns, one Vec per basis vector) of the Krylov
/// subspace of `m` (or mᵀ) started at `start`.
fn krylov(m: &Matrix, start: &[f64], threshold: f64, transpose: bool) -> Vec<Vec<f64>> {
    let n = m.rows();
    let mut basis: Vec<Vec<f64>> = Vec::new();
    let s = norm(start);
    if s == 0.0 || n == 0 {
        return basis;
    }
    basis.push(start.iter().map(|v| v / s).collect());
    while basis.len() < n {
        let last = basis.last().expect("basis is not empty");
        let mut w = if transpose { m.transpose().mul_vec(last) } else { m.mul_vec(last) };
        // two passes of Gram–Schmidt ("twice is enough", Giraud et al. 2005)
        for _ in 0..2 {
            for q in &basis {
                let h: f64 = q.iter().zip(&w).map(|(a, b)| a * b).sum();
                for (wi, qi) in w.iter_mut().zip(q) {
                    *wi -= h * qi;
                }
            }
        }
        let h = norm(&w);
        if h <= threshold {
            break;
        }
        basis.push(w.iter().map(|v| v / h).collect());
    }
    basis
}

/// (Qᵀ A Q, Qᵀ b, c Q) for the basis Q.
fn project(a: &Matrix, b: &[f64], c: &[f64], q: &[Vec<f64>]) -> (Matrix, Vec<f64>, Vec<f64>) {
    let r = q.len();
    let mut a1 = Matrix::zeros(r, r);
    for j in 0..r {
        let aq = a.mul_vec(&q[j]);
        for i in 0..r {
            a1[(i, j)] = q[i].iter().zip(&aq).map(|(x, y)| x * y).sum();
        }
    }
    let b1 = q.iter().map(|qi| qi.iter().zip(b).map(|(x, y)| x * y).sum()).collect();
    let c1 = q.iter().map(|qi| qi.iter().zip(c).map(|(x, y)| x * y).sum()).collect();
    (a1, b1, c1)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uncontrollable_and_unobservable_modes_are_removed() {
        // states: x1 driven by u (pole −1), x2 free (pole −2, not reached), x3
        // driven by x1 but not seen (pole −3); y = x1
        let a = Matrix::from_rows(&[vec![-1.0, 0.0, 0.0], vec![0.0, -2.0, 0.0], vec![5.0, 0.0, -3.0]]).unwrap();
        let s = minimal(&a, &[1.0, 0.0, 0.0], &[1.0, 0.0, 0.0], 0.0, DEFAULT_TOL);
        assert_eq!(s.a.rows(), 1);
        assert!((s.a[(0, 0)] + 1.0).abs() < 1e-14);
        assert!((s.b[0] * s.c[0] - 1.0).abs() < 1e-14);
    }

    #[test]
    fn a_minimal_system_keeps_its_order() {
        let a = Matrix::from_rows(&[vec![0.0, 1.0], vec![-100.0, -2.0]]).unwrap();
        let s = minimal(&a, &[0.0, 1.0], &[1.0, 0.0], 0.0, DEFAULT_TOL);
        assert_eq!(s.a.rows(), 2);
    }
}
