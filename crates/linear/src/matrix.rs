//! A dense real matrix, row-major: what the rest of pneumo passes around
//! (serialised as rows, indexed as (row, column)), converted to faer's
//! column-major `Mat` only inside the decompositions.

use crate::{Complex, LinearError};

/// A dense real matrix, row-major.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Matrix {
    /// All zeros.
    pub fn zeros(rows: usize, cols: usize) -> Matrix {
        Matrix { rows, cols, data: vec![0.0; rows * cols] }
    }

    /// The identity of size n.
    pub fn identity(n: usize) -> Matrix {
        let mut m = Matrix::zeros(n, n);
        for i in 0..n {
            m[(i, i)] = 1.0;
        }
        m
    }

    /// From rows of equal length.
    pub fn from_rows(rows: &[Vec<f64>]) -> Result<Matrix, LinearError> {
        let cols = rows.first().map_or(0, Vec::len);
        if rows.iter().any(|r| r.len() != cols) {
            return Err(LinearError::Shape("rows of different lengths".into()));
        }
        Ok(Matrix { rows: rows.len(), cols, data: rows.concat() })
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Row i.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// Column j (a copy).
    pub fn col(&self, j: usize) -> Vec<f64> {
        (0..self.rows).map(|i| self[(i, j)]).collect()
    }

    /// Every row, as vectors (for JSON).
    pub fn to_rows(&self) -> Vec<Vec<f64>> {
        (0..self.rows).map(|i| self.row(i).to_vec()).collect()
    }

    /// The sub-matrix of the given rows and columns, in that order.
    pub fn select(&self, rows: &[usize], cols: &[usize]) -> Matrix {
        let mut m = Matrix::zeros(rows.len(), cols.len());
        for (a, &i) in rows.iter().enumerate() {
            for (b, &j) in cols.iter().enumerate() {
                m[(a, b)] = self[(i, j)];
            }
        }
        m
    }

    /// A · B.
    pub fn mul(&self, other: &Matrix) -> Matrix {
        assert_eq!(self.cols, other.rows, "matrix product of incompatible shapes");
        let mut out = Matrix::zeros(self.rows, other.cols);
        for i in 0..self.rows {
            for k in 0..self.cols {
                let a = self[(i, k)];
                if a == 0.0 {
                    continue;
                }
                for j in 0..other.cols {
                    out.data[i * other.cols + j] += a * other[(k, j)];
                }
            }
        }
        out
    }

    /// A · x.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        (0..self.rows).map(|i| self.row(i).iter().zip(x).map(|(a, b)| a * b).sum()).collect()
    }

    /// Aᵀ.
    pub fn transpose(&self) -> Matrix {
        let mut t = Matrix::zeros(self.cols, self.rows);
        for i in 0..self.rows {
            for j in 0..self.cols {
                t[(j, i)] = self[(i, j)];
            }
        }
        t
    }

    /// Frobenius norm.
    pub fn norm(&self) -> f64 {
        self.data.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// Largest absolute entry.
    pub fn max_abs(&self) -> f64 {
        self.data.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// Err if an entry is NaN or infinite; `what` names the matrix.
    pub fn check_finite(&self, what: &'static str) -> Result<(), LinearError> {
        if self.data.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(LinearError::NonFinite { what })
        }
    }

    /// faer's copy (column-major).
    pub(crate) fn to_faer(&self) -> faer::Mat<f64> {
        faer::Mat::from_fn(self.rows, self.cols, |i, j| self[(i, j)])
    }

    /// From faer's matrix.
    pub(crate) fn from_faer(m: faer::MatRef<'_, f64>) -> Matrix {
        let mut out = Matrix::zeros(m.nrows(), m.ncols());
        for i in 0..m.nrows() {
            for j in 0..m.ncols() {
                out[(i, j)] = m[(i, j)];
            }
        }
        out
    }
}

impl std::ops::Index<(usize, usize)> for Matrix {
    type Output = f64;
    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        &self.data[i * self.cols + j]
    }
}

impl std::ops::IndexMut<(usize, usize)> for Matrix {
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut f64 {
        &mut self.data[i * self.cols + j]
    }
}

/// Solve M X = R in place for a square complex M (LU with partial
/// pivoting); R has `nrhs` columns, row-major. Returns false if M is
/// singular to working precision (a pivot below 1e-300 or exactly zero).
pub(crate) fn complex_solve(m: &mut [Complex], n: usize, r: &mut [Complex], nrhs: usize) -> bool {
    for k in 0..n {
        let p = (k..n).max_by(|&a, &b| m[a * n + k].norm().total_cmp(&m[b * n + k].norm())).unwrap_or(k);
        if m[p * n + k].norm() < 1e-300 {
            return false;
        }
        if p != k {
            for j in 0..n {
                m.swap(k * n + j, p * n + j);
            }
            for j in 0..nrhs {
                r.swap(k * nrhs + j, p * nrhs + j);
            }
        }
        let pivot = m[k * n + k];
        for i in k + 1..n {
            let f = m[i * n + k] / pivot;
            if f == Complex::new(0.0, 0.0) {
                continue;
            }
            for j in k..n {
                let v = m[k * n + j];
                m[i * n + j] -= f * v;
            }
            for j in 0..nrhs {
                let v = r[k * nrhs + j];
                r[i * nrhs + j] -= f * v;
            }
        }
    }
    for k in (0..n).rev() {
        for j in 0..nrhs {
            let mut s = r[k * nrhs + j];
            for c in k + 1..n {
                s -= m[k * n + c] * r[c * nrhs + j];
            }
            r[k * nrhs + j] = s / m[k * n + k];
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_transpose_and_selection() {
        let a = Matrix::from_rows(&[vec![1.0, 2.0], vec![3.0, 4.0]]).unwrap();
        let b = a.mul(&Matrix::identity(2));
        assert_eq!(a, b);
        assert_eq!(a.transpose().row(0), &[1.0, 3.0]);
        assert_eq!(a.mul_vec(&[1.0, 1.0]), vec![3.0, 7.0]);
        assert_eq!(a.select(&[1], &[0, 1]).row(0), &[3.0, 4.0]);
        assert!(Matrix::from_rows(&[vec![1.0], vec![1.0, 2.0]]).is_err());
    }

    #[test]
    fn complex_solve_inverts_a_rotation() {
        // (1+i) x = 2 → x = 1 − i; a 2x2 with pivoting
        let mut m = vec![Complex::new(0.0, 0.0), Complex::new(1.0, 1.0), Complex::new(2.0, 0.0), Complex::new(0.0, 0.0)];
        let mut r = vec![Complex::new(2.0, 0.0), Complex::new(4.0, 0.0)];
        assert!(complex_solve(&mut m, 2, &mut r, 1));
        assert!((r[0] - Complex::new(2.0, 0.0)).norm() < 1e-15);
        assert!((r[1] - Complex::new(1.0, -1.0)).norm() < 1e-15);
        let mut singular = vec![Complex::new(0.0, 0.0); 4];
        assert!(!complex_solve(&mut singular, 2, &mut r, 1));
    }
}
