//! Rank-revealing least squares by the singular value decomposition
//! (faer's): the numerical rank, the minimum-norm least-squares solution of
//! J x ≈ r, and the null space of J. A singular value counts when it
//! exceeds `rcond` times the largest one.

use crate::{LinearError, Matrix};

/// J = U Σ Vᵀ: singular values in decreasing order with U's and V's columns.
#[derive(Debug, Clone)]
pub struct Svd {
    pub u: Matrix,
    pub s: Vec<f64>,
    pub v: Matrix,
}

/// The full SVD of `j`.
pub fn svd(j: &Matrix) -> Result<Svd, LinearError> {
    j.check_finite("Jacobian")?;
    if j.rows() == 0 || j.cols() == 0 {
        return Ok(Svd { u: Matrix::identity(j.rows()), s: Vec::new(), v: Matrix::identity(j.cols()) });
    }
    let d = j.to_faer().svd().map_err(|_| LinearError::NoConvergence { what: "singular values" })?;
    let k = j.rows().min(j.cols());
    Ok(Svd { u: Matrix::from_faer(d.U()), s: (0..k).map(|i| d.S()[i]).collect(), v: Matrix::from_faer(d.V()) })
}

impl Svd {
    /// Number of singular values above `rcond` · σ_max.
    pub fn rank(&self, rcond: f64) -> usize {
        let top = self.s.first().copied().unwrap_or(0.0);
        self.s.iter().filter(|&&s| s > rcond * top && s > 0.0).count()
    }

    /// Minimum-norm x minimising ‖J x − r‖ with the singular values below
    /// `rcond` · σ_max treated as zero.
    pub fn solve(&self, r: &[f64], rcond: f64) -> Vec<f64> {
        let k = self.rank(rcond);
        let mut x = vec![0.0; self.v.rows()];
        for i in 0..k {
            let ui_r: f64 = (0..self.u.rows()).map(|row| self.u[(row, i)] * r[row]).sum();
            let coef = ui_r / self.s[i];
            for (row, xr) in x.iter_mut().enumerate() {
                *xr += coef * self.v[(row, i)];
            }
        }
        x
    }

    /// Orthonormal basis of the null space (columns of V beyond the rank).
    pub fn null_space(&self, rcond: f64) -> Vec<Vec<f64>> {
        (self.rank(rcond)..self.v.cols()).map(|i| self.v.col(i)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rank_deficient_system_gets_the_minimum_norm_solution() {
        // x + y = 2, 2x + 2y = 4: rank 1, minimum-norm solution (1, 1), null space (1, -1)/√2
        let j = Matrix::from_rows(&[vec![1.0, 1.0], vec![2.0, 2.0]]).unwrap();
        let d = svd(&j).unwrap();
        assert_eq!(d.rank(1e-12), 1);
        let x = d.solve(&[2.0, 4.0], 1e-12);
        assert!((x[0] - 1.0).abs() < 1e-14 && (x[1] - 1.0).abs() < 1e-14);
        let null = d.null_space(1e-12);
        assert_eq!(null.len(), 1);
        assert!((null[0][0] + null[0][1]).abs() < 1e-14);
    }

    #[test]
    fn tall_and_wide_matrices() {
        let tall = Matrix::from_rows(&[vec![1.0], vec![0.0], vec![1.0]]).unwrap();
        let x = svd(&tall).unwrap().solve(&[1.0, 5.0, 3.0], 1e-12);
        assert!((x[0] - 2.0).abs() < 1e-14);
        let wide = Matrix::from_rows(&[vec![3.0, 4.0]]).unwrap();
        let d = svd(&wide).unwrap();
        let x = d.solve(&[5.0], 1e-12);
        assert!((x[0] - 0.6).abs() < 1e-14 && (x[1] - 0.8).abs() < 1e-14);
        assert_eq!(d.null_space(1e-12).len(), 1);
    }
}
