//! Diagonal balancing of a square matrix (Parlett & Reinsch 1969, the
//! scaling half of LAPACK's `gebal`): a similarity A' = D⁻¹ A D with D
//! diagonal, powers of two (so exact in floating point), chosen so that each
//! row and column of A' have comparable norms.
//!
//! A model's states have wildly different units (kg of gas, K, m, m/s): its
//! A has entries from 1e-6 to 1e8. Eigenvalues of a badly scaled matrix lose
//! accuracy in proportion to ‖A‖, so every decomposition here balances first.

use crate::Matrix;

/// D (its diagonal) and A' = D⁻¹ A D.
pub fn balance(a: &Matrix) -> (Vec<f64>, Matrix) {
    let n = a.rows();
    let mut b = a.clone();
    let mut d = vec![1.0; n];
    const RADIX: f64 = 2.0;
    for _sweep in 0..100 {
        let mut converged = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0, 0.0);
            for k in 0..n {
                if k != i {
                    c += b[(k, i)].abs();
                    r += b[(i, k)].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            let (mut cc, mut rr) = (c, r);
            while cc < rr / RADIX {
                cc *= RADIX;
                rr /= RADIX;
                f *= RADIX;
            }
            while cc >= rr * RADIX {
                cc /= RADIX;
                rr *= RADIX;
                f /= RADIX;
            }
            if (cc + rr) < 0.95 * s && (d[i] * f).is_normal() {
                converged = false;
                d[i] *= f;
                for k in 0..n {
                    b[(i, k)] /= f;
                    b[(k, i)] *= f;
                }
            }
        }
        if converged {
            break;
        }
    }
    (d, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balancing_is_a_similarity_that_evens_the_norms() {
        let a = Matrix::from_rows(&[vec![1.0, 1e6, 0.0], vec![1e-6, 2.0, 1e4], vec![0.0, 1e-4, 3.0]]).unwrap();
        let (d, b) = balance(&a);
        for i in 0..3 {
            for j in 0..3 {
                assert!((b[(i, j)] - a[(i, j)] * d[j] / d[i]).abs() <= 1e-15 * b[(i, j)].abs().max(1e-300));
            }
        }
        assert!(b.max_abs() < 10.0, "{b:?}");
    }
}
