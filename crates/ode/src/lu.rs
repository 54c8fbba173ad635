//! In-place dense LU factorisation with partial (row) pivoting, `P·A = L·U`, on an
//! `nalgebra::DMatrix<f64>` whose storage is reused from step to step, so that the
//! integrator's step loop does not allocate (nalgebra's `LU::new` consumes its
//! matrix and allocates a permutation on every call).
//!
//! Algorithm: right-looking Gaussian elimination (Doolittle form, unit lower
//! triangle stored below the diagonal, U on and above it), e.g. G. H. Golub &
//! C. F. Van Loan, *Matrix Computations*, 4th ed., Algorithm 3.4.1. Solving is
//! forward then backward substitution. Cost O(n³/3) to factor, O(n²) to solve.
//!
//! A zero or non-finite pivot makes the factorisation fail (`Err(())`), which the
//! integrator reports as a singular iteration matrix.

use nalgebra::DMatrix;

/// LU factors of a square matrix with their row permutation.
#[derive(Debug, Clone)]
pub(crate) struct LuFactors {
    a: DMatrix<f64>,
    /// `piv[k]` = row exchanged with row `k` at elimination step `k`.
    piv: Vec<usize>,
}

/// The factorisation met a zero or non-finite pivot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Singular;

impl LuFactors {
    /// Work space for `n × n` matrices.
    pub(crate) fn new(n: usize) -> Self {
        Self { a: DMatrix::zeros(n, n), piv: vec![0; n] }
    }

    /// Mutable access to the matrix to be factored (fill it, then call [`Self::factor`]).
    pub(crate) fn matrix_mut(&mut self) -> &mut DMatrix<f64> {
        &mut self.a
    }

    /// Factor the matrix currently stored, in place.
    pub(crate) fn factor(&mut self) -> Result<(), Singular> {
        let n = self.a.nrows();
        for k in 0..n {
            // Pivot: largest magnitude in column k at or below the diagonal.
            let mut p = k;
            let mut best = self.a[(k, k)].abs();
            for i in (k + 1)..n {
                let v = self.a[(i, k)].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if best == 0.0 || !best.is_finite() {
                return Err(Singular);
            }
            self.piv[k] = p;
            if p != k {
                self.a.swap_rows(k, p);
            }
            let inv = 1.0 / self.a[(k, k)];
            for i in (k + 1)..n {
                self.a[(i, k)] *= inv;
            }
            for j in (k + 1)..n {
                let akj = self.a[(k, j)];
                if akj != 0.0 {
                    for i in (k + 1)..n {
                        let lik = self.a[(i, k)];
                        self.a[(i, j)] -= lik * akj;
                    }
                }
            }
        }
        Ok(())
    }

    /// Solve `A x = b` in place (`b` becomes `x`), using the factors.
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let n = self.a.nrows();
        for k in 0..n {
            let p = self.piv[k];
            if p != k {
                b.swap(k, p);
            }
        }
        // L y = P b (unit diagonal), column-oriented for column-major storage.
        for j in 0..n {
            let bj = b[j];
            if bj != 0.0 {
                for i in (j + 1)..n {
                    b[i] -= self.a[(i, j)] * bj;
                }
            }
        }
        // U x = y.
        for j in (0..n).rev() {
            b[j] /= self.a[(j, j)];
            let bj = b[j];
            if bj != 0.0 {
                for i in 0..j {
                    b[i] -= self.a[(i, j)] * bj;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_pivoting_system_like_nalgebra() {
        // A matrix that needs row exchanges (zero leading pivot).
        let m = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 2.0, -1.0, 3.0, //
                4.0, 1.0, 0.5, -2.0, //
                -1.0, 7.0, 3.0, 1.0, //
                2.0, -3.0, 8.0, 0.25,
            ],
        );
        let x_true = [1.5, -2.0, 0.75, 3.0];
        let b: Vec<f64> = (0..4).map(|i| (0..4).map(|j| m[(i, j)] * x_true[j]).sum()).collect();
        let mut lu = LuFactors::new(4);
        lu.matrix_mut().copy_from(&m);
        lu.factor().expect("regular matrix");
        let mut x = b.clone();
        lu.solve(&mut x);
        let reference = m.clone().lu().solve(&nalgebra::DVector::from_vec(b)).expect("regular");
        for i in 0..4 {
            assert!((x[i] - x_true[i]).abs() < 1e-13, "x[{i}] = {}", x[i]);
            assert!((x[i] - reference[i]).abs() < 1e-13);
        }
    }

    #[test]
    fn detects_singular_matrix() {
        let m = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0]);
        let mut lu = LuFactors::new(3);
        lu.matrix_mut().copy_from(&m);
        assert_eq!(lu.factor(), Err(Singular));
        lu.matrix_mut().fill(f64::NAN);
        assert_eq!(lu.factor(), Err(Singular));
    }
}
