//! Small dense linear algebra for the integrator: LU factorisation with
//! partial (row) pivoting of an n×n matrix stored row-major, and the
//! forward/back substitution that goes with it. n is 6–8 here, so nothing
//! clever (Golub & Van Loan, Algorithm 3.4.1, written out by hand).

// Index loops read like the textbook algorithms they implement.
#![allow(clippy::needless_range_loop)]

/// An LU factorisation `P·M = L·U` of a square matrix, computed in place.
#[derive(Debug, Clone)]
pub(crate) struct Lu {
    n: usize,
    /// L (unit lower, below the diagonal) and U (on and above), row-major.
    a: Vec<f64>,
    /// Row permutation: row `i` of the factorised matrix is row `perm[i]` of M.
    perm: Vec<usize>,
}

impl Lu {
    pub(crate) fn new(n: usize) -> Self {
        Lu { n, a: vec![0.0; n * n], perm: (0..n).collect() }
    }

    /// Factorises `m` (row-major n×n). Returns `false` if a pivot is zero or
    /// not finite (the matrix is singular to working precision).
    pub(crate) fn factor(&mut self, m: &[f64]) -> bool {
        let n = self.n;
        self.a.copy_from_slice(&m[..n * n]);
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        for k in 0..n {
            // pivot: largest magnitude in column k at or below the diagonal
            let mut piv = k;
            let mut best = self.a[k * n + k].abs();
            for i in (k + 1)..n {
                let v = self.a[i * n + k].abs();
                if v > best {
                    best = v;
                    piv = i;
                }
            }
            if best <= 0.0 || !best.is_finite() {
                return false;
            }
            if piv != k {
                for j in 0..n {
                    self.a.swap(k * n + j, piv * n + j);
                }
                self.perm.swap(k, piv);
            }
            let d = self.a[k * n + k];
            for i in (k + 1)..n {
                let l = self.a[i * n + k] / d;
                self.a[i * n + k] = l;
                if l != 0.0 {
                    for j in (k + 1)..n {
                        self.a[i * n + j] -= l * self.a[k * n + j];
                    }
                }
            }
        }
        true
    }

    /// Solves `M x = b` in place (`b` becomes `x`), using `work` (length n).
    pub(crate) fn solve(&self, b: &mut [f64], work: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            work[i] = b[self.perm[i]];
        }
        for i in 0..n {
            let mut s = work[i];
            for j in 0..i {
                s -= self.a[i * n + j] * work[j];
            }
            work[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = work[i];
            for j in (i + 1)..n {
                s -= self.a[i * n + j] * work[j];
            }
            work[i] = s / self.a[i * n + i];
        }
        b[..n].copy_from_slice(&work[..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_permuted_system() {
        // needs a row swap at the first pivot
        let m = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x_true = [1.0, -2.0, 0.5];
        let mut b = [0.0; 3];
        for i in 0..3 {
            b[i] = (0..3).map(|j| m[i * 3 + j] * x_true[j]).sum();
        }
        let mut lu = Lu::new(3);
        assert!(lu.factor(&m));
        let mut w = [0.0; 3];
        lu.solve(&mut b, &mut w);
        for i in 0..3 {
            assert!((b[i] - x_true[i]).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn reports_singular() {
        let m = [1.0, 2.0, 2.0, 4.0];
        let mut lu = Lu::new(2);
        assert!(!lu.factor(&m));
    }
}
