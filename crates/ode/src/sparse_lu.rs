//! Sparse LU of the iteration matrix `W = I/(hγ) − J` (state block only) for
//! large systems.
//!
//! Method: a symmetric fill-reducing ordering `B = P·W·Pᵀ` (approximate
//! minimum degree on the pattern of `W + Wᵀ`, faer's AMD), computed once for
//! the structure, then at every step a left-looking LU of `B` in the manner
//! of Gilbert & Peierls (SIAM J. Sci. Stat. Comput. 9 (1988) 862–874; as in
//! T. Davis, *Direct Methods for Sparse Linear Systems*, SIAM 2006, §6.3):
//! column k of `L·U` is a sparse triangular solve whose non-zero pattern is
//! found by a depth-first search in the graph of the columns already
//! factored, so the work is proportional to the arithmetic done.
//!
//! Pivoting prefers the diagonal (threshold partial pivoting, the rule of
//! KLU, Davis & Palamadai Natarajan, ACM TOMS 37 (2010) 36): the diagonal
//! entry is kept as pivot while its magnitude is at least [`DIAGONAL_PREFERENCE`]
//! times the largest candidate of its column; otherwise the largest is taken.
//! Magnitudes are compared after scaling each row by its largest entry (as
//! KLU and UMFPACK do by default), because the rows of `W` are in the units
//! of unrelated states (kg/s, K/s, m/s²).
//! The fill-reducing order was computed for diagonal pivots, and for `W`,
//! whose diagonal carries `1/(hγ)`, the diagonal is almost always
//! acceptable. Plain partial pivoting (the largest entry in magnitude, what
//! faer's sparse LU does) compares entries of rows in unrelated units: for N
//! drives on one manifold it picked the manifold's dense row early, and the
//! factors filled in quadratically with N (a factorisation of the 256-drive
//! matrix took 40 % of the run).
//!
//! The structure of `W` is the declared structure of `J` restricted to the
//! state rows, plus the diagonal. After the first factorisation the buffers
//! are sized and no step allocates.

use crate::lu::Singular;
use crate::sparsity::Sparsity;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::SymbolicSparseColMatRef;

/// A candidate pivot on the diagonal is taken if it is at least this
/// fraction of the largest candidate of its column (KLU uses 0.001).
pub(crate) const DIAGONAL_PREFERENCE: f64 = 0.01;

const NONE: usize = usize::MAX;

/// Sparse LU work space for one structure (see the module documentation).
pub(crate) struct SparseLu {
    n: usize,
    /// `B = P W Pᵀ` in compressed columns; `b_src[k]` = position of the
    /// entry in `values`.
    b_start: Vec<usize>,
    b_rows: Vec<usize>,
    b_src: Vec<usize>,
    /// Values of `W` in the order of the structure of `W` (see `from_jacobian`).
    values: Vec<f64>,
    /// For each entry of the Jacobian structure: its position in `values`, or
    /// `NONE` for entries in quadrature rows (not part of `W`).
    from_jacobian: Vec<usize>,
    /// Position of the diagonal entry of each column in `values`.
    diagonal: Vec<usize>,
    /// `perm[k]` = index in `W` of row/column k of `B`.
    perm: Vec<usize>,
    // Factors of B with row pivoting: P_r·B = L·U. L is unit lower triangular
    // (the unit diagonal not stored), rows in pivot order once factored; U
    // upper triangular with its diagonal stored last in each column.
    l_start: Vec<usize>,
    l_rows: Vec<usize>,
    l_vals: Vec<f64>,
    u_start: Vec<usize>,
    u_rows: Vec<usize>,
    u_vals: Vec<f64>,
    /// `pinv[i]` = pivot step of row i of B (NONE while unpivoted).
    pinv: Vec<usize>,
    // work
    x: Vec<f64>,
    stack: Vec<usize>,
    reach: Vec<usize>,
    next_child: Vec<usize>,
    mark: Vec<usize>,
    y: Vec<f64>,
    /// 1 / largest magnitude of each row of B (for the pivot choice).
    row_scale: Vec<f64>,
    factored: bool,
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu").field("n", &self.n).field("nnz", &self.values.len()).field("nnz_lu", &self.factor_nnz()).finish()
    }
}

impl SparseLu {
    /// Work space for the `ns` state columns of `pattern`; `None` if the
    /// ordering cannot be computed (the caller then factors densely).
    pub(crate) fn new(pattern: &Sparsity, ns: usize) -> Option<SparseLu> {
        // structure of W (state rows, diagonal added), sorted per column
        let mut col_start = Vec::with_capacity(ns + 1);
        let mut rows = Vec::new();
        let mut from_jacobian = vec![NONE; pattern.nnz()];
        let mut diagonal = vec![0; ns];
        col_start.push(0);
        for j in 0..ns {
            let mut placed_diagonal = false;
            for (k, &r) in pattern.column_range(j).zip(pattern.column(j)) {
                if r >= ns {
                    continue;
                }
                if !placed_diagonal && r > j {
                    diagonal[j] = rows.len();
                    rows.push(j);
                    placed_diagonal = true;
                }
                if r == j {
                    diagonal[j] = rows.len();
                    placed_diagonal = true;
                }
                from_jacobian[k] = rows.len();
                rows.push(r);
            }
            if !placed_diagonal {
                diagonal[j] = rows.len();
                rows.push(j);
            }
            col_start.push(rows.len());
        }
        // fill-reducing symmetric order
        let mut perm = vec![0usize; ns];
        let mut perm_inv = vec![0usize; ns];
        if ns > 0 {
            let structure = SymbolicSparseColMatRef::new_checked(ns, ns, &col_start, None, &rows);
            let mut memory = MemBuffer::try_new(amd::order_scratch::<usize>(ns, rows.len())).ok()?;
            amd::order(&mut perm, &mut perm_inv, structure, amd::Control::default(), MemStack::new(&mut memory)).ok()?;
        }
        // B = P W Pᵀ: column k of B is column perm[k] of W with rows renamed
        let mut b_start = Vec::with_capacity(ns + 1);
        let mut b_rows = Vec::with_capacity(rows.len());
        let mut b_src = Vec::with_capacity(rows.len());
        b_start.push(0);
        for k in 0..ns {
            let j = perm[k];
            for pos in col_start[j]..col_start[j + 1] {
                b_rows.push(perm_inv[rows[pos]]);
                b_src.push(pos);
            }
            b_start.push(b_rows.len());
        }
        let nnz = rows.len();
        Some(SparseLu {
            n: ns,
            b_start,
            b_rows,
            b_src,
            values: vec![0.0; nnz],
            from_jacobian,
            diagonal,
            perm,
            l_start: Vec::with_capacity(ns + 1),
            l_rows: Vec::with_capacity(nnz),
            l_vals: Vec::with_capacity(nnz),
            u_start: Vec::with_capacity(ns + 1),
            u_rows: Vec::with_capacity(nnz),
            u_vals: Vec::with_capacity(nnz),
            pinv: vec![NONE; ns],
            x: vec![0.0; ns],
            stack: Vec::with_capacity(ns),
            reach: Vec::with_capacity(ns),
            next_child: vec![0; ns],
            mark: vec![NONE; ns],
            y: vec![0.0; ns],
            row_scale: vec![0.0; ns],
            factored: false,
        })
    }

    /// Entries of the last factors (L without its unit diagonal, and U).
    pub(crate) fn factor_nnz(&self) -> usize {
        self.l_rows.len() + self.u_rows.len()
    }

    /// Form `W = I/(hγ) − J` from the Jacobian's entries and factor it.
    pub(crate) fn factor(&mut self, jacobian: &[f64], inv_hg: f64) -> Result<(), Singular> {
        self.factored = false;
        self.values.fill(0.0);
        for (k, &pos) in self.from_jacobian.iter().enumerate() {
            if pos != NONE {
                self.values[pos] = -jacobian[k];
            }
        }
        for &d in &self.diagonal {
            self.values[d] += inv_hg;
        }
        if self.values.iter().any(|v| !v.is_finite()) {
            return Err(Singular);
        }
        self.factor_values()?;
        self.factored = true;
        Ok(())
    }

    /// Left-looking LU of B with diagonal-preferring threshold pivoting.
    fn factor_values(&mut self) -> Result<(), Singular> {
        let n = self.n;
        self.l_start.clear();
        self.l_rows.clear();
        self.l_vals.clear();
        self.u_start.clear();
        self.u_rows.clear();
        self.u_vals.clear();
        self.pinv.fill(NONE);
        self.mark.fill(NONE);
        self.row_scale.fill(0.0);
        for (p, &r) in self.b_rows.iter().enumerate() {
            self.row_scale[r] = self.row_scale[r].max(self.values[self.b_src[p]].abs());
        }
        for s in self.row_scale.iter_mut() {
            *s = if *s > 0.0 { 1.0 / *s } else { 1.0 };
        }
        self.l_start.push(0);
        self.u_start.push(0);
        for k in 0..n {
            // pattern of x = L \ B[:, k]: rows reached from B's column k
            self.reach_of_column(k);
            for &i in &self.reach {
                self.x[i] = 0.0;
            }
            for p in self.b_start[k]..self.b_start[k + 1] {
                self.x[self.b_rows[p]] = self.values[self.b_src[p]];
            }
            // sparse triangular solve in topological order (reach is reversed post-order)
            for idx in (0..self.reach.len()).rev() {
                let j = self.reach[idx];
                let col = self.pinv[j];
                if col == NONE {
                    continue;
                }
                let xj = self.x[j];
                if xj == 0.0 {
                    continue;
                }
                for p in self.l_start[col]..self.l_start[col + 1] {
                    self.x[self.l_rows[p]] -= self.l_vals[p] * xj;
                }
            }
            // U entries above the diagonal, and the pivot among unpivoted rows
            let mut best = NONE;
            let mut best_abs = -1.0;
            let mut diag_abs = -1.0;
            for &i in &self.reach {
                let v = self.x[i];
                if self.pinv[i] != NONE {
                    self.u_rows.push(self.pinv[i]);
                    self.u_vals.push(v);
                } else {
                    let a = v.abs() * self.row_scale[i];
                    if a > best_abs {
                        best_abs = a;
                        best = i;
                    }
                    if i == k {
                        diag_abs = a;
                    }
                }
            }
            if best == NONE || best_abs <= 0.0 || !best_abs.is_finite() {
                return Err(Singular);
            }
            let pivot_row = if diag_abs >= DIAGONAL_PREFERENCE * best_abs { k } else { best };
            let pivot = self.x[pivot_row];
            self.pinv[pivot_row] = k;
            self.u_rows.push(k);
            self.u_vals.push(pivot);
            self.u_start.push(self.u_rows.len());
            for &i in &self.reach {
                if self.pinv[i] == NONE {
                    self.l_rows.push(i);
                    self.l_vals.push(self.x[i] / pivot);
                }
            }
            self.l_start.push(self.l_rows.len());
        }
        // L's rows into pivot order: P_r B = L U
        for r in self.l_rows.iter_mut() {
            *r = self.pinv[*r];
        }
        Ok(())
    }

    /// Rows of B reached from column k's entries through the columns of L
    /// factored so far (a row that is some column's pivot leads to that
    /// column's rows), in reverse topological order, into `self.reach`.
    fn reach_of_column(&mut self, k: usize) {
        self.reach.clear();
        for p in self.b_start[k]..self.b_start[k + 1] {
            let start = self.b_rows[p];
            if self.mark[start] == k {
                continue;
            }
            // iterative depth-first search from `start`
            self.mark[start] = k;
            self.stack.push(start);
            self.next_child[start] = self.child_range(start).0;
            while let Some(&j) = self.stack.last() {
                let (_, end) = self.child_range(j);
                let mut descended = false;
                while self.next_child[j] < end {
                    let child = self.l_rows[self.next_child[j]];
                    self.next_child[j] += 1;
                    if self.mark[child] != k {
                        self.mark[child] = k;
                        self.next_child[child] = self.child_range(child).0;
                        self.stack.push(child);
                        descended = true;
                        break;
                    }
                }
                if !descended {
                    self.stack.pop();
                    self.reach.push(j);
                }
            }
        }
    }

    /// Positions in `l_rows` of the children of row `j` in the graph of L:
    /// the rows of the column it is pivot of (none while unpivoted). During
    /// the factorisation `l_rows` holds rows of B, not yet pivot steps.
    fn child_range(&self, j: usize) -> (usize, usize) {
        match self.pinv[j] {
            NONE => (0, 0),
            col => (self.l_start[col], self.l_start[col + 1]),
        }
    }

    /// Solve `W x = b` in place with the last factorisation.
    pub(crate) fn solve(&mut self, b: &mut [f64]) {
        debug_assert!(self.factored && b.len() == self.n);
        let n = self.n;
        // y = P_r P b (row k of B is row perm[k] of W)
        for k in 0..n {
            self.y[self.pinv[k]] = b[self.perm[k]];
        }
        // L y' = y (unit lower, column oriented)
        for col in 0..n {
            let v = self.y[col];
            if v != 0.0 {
                for p in self.l_start[col]..self.l_start[col + 1] {
                    self.y[self.l_rows[p]] -= self.l_vals[p] * v;
                }
            }
        }
        // U z = y' (diagonal stored last in each column)
        for col in (0..n).rev() {
            let end = self.u_start[col + 1];
            let v = self.y[col] / self.u_vals[end - 1];
            self.y[col] = v;
            if v != 0.0 {
                for p in self.u_start[col]..end - 1 {
                    self.y[self.u_rows[p]] -= self.u_vals[p] * v;
                }
            }
        }
        // x = Pᵀ z
        for k in 0..n {
            b[self.perm[k]] = self.y[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dense matrix of a structure's W = I/(hγ) − J for checking.
    fn dense_w(pattern: &Sparsity, jac: &[f64], inv_hg: f64, n: usize) -> Vec<Vec<f64>> {
        let mut w = vec![vec![0.0; n]; n];
        for j in 0..n {
            for (k, &r) in pattern.column_range(j).zip(pattern.column(j)) {
                if r < n {
                    w[r][j] -= jac[k];
                }
            }
            w[j][j] += inv_hg;
        }
        w
    }

    fn residual(w: &[Vec<f64>], x: &[f64], b: &[f64]) -> f64 {
        (0..b.len()).map(|i| (w[i].iter().zip(x).map(|(a, v)| a * v).sum::<f64>() - b[i]).abs()).fold(0.0, f64::max)
    }

    #[test]
    fn solves_an_arrow_matrix_without_fill() {
        // a manifold (state 0) coupled to every drive (states 1..n): its row and
        // column are dense, the rest diagonal — LU in the right order has no fill
        let n = 400;
        let cols: Vec<Vec<usize>> = (0..n).map(|j| if j == 0 { (0..n).collect() } else { vec![0, j] }).collect();
        let pattern = Sparsity::from_columns(n, &cols).unwrap();
        // large entries in the manifold's row: plain partial pivoting would pivot on it
        let jac: Vec<f64> = (0..n)
            .flat_map(|j| {
                pattern
                    .column(j)
                    .iter()
                    .map(move |&r| {
                        if r == 0 && j > 0 {
                            1e6
                        } else if r == j {
                            -3.0
                        } else {
                            0.5
                        }
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut lu = SparseLu::new(&pattern, n).unwrap();
        lu.factor(&jac, 10.0).unwrap();
        assert!(lu.factor_nnz() <= 3 * n + 2, "fill: {} entries in L and U", lu.factor_nnz());
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x = b.clone();
        lu.solve(&mut x);
        let w = dense_w(&pattern, &jac, 10.0, n);
        // relative to the size of W's entries (1e6) and of x
        let scale = 1e6 * x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        assert!(residual(&w, &x, &b) < 1e-14 * scale, "residual {}", residual(&w, &x, &b));
    }

    #[test]
    fn pivots_off_the_diagonal_when_it_is_too_small() {
        // W = [[0, 1], [1, 0]] (J = I/(hγ) − W with inv_hg = 1): the diagonal is zero
        let pattern = Sparsity::from_columns(2, &[vec![0, 1], vec![0, 1]]).unwrap();
        let jac = [1.0, -1.0, -1.0, 1.0];
        let mut lu = SparseLu::new(&pattern, 2).unwrap();
        lu.factor(&jac, 1.0).unwrap();
        let mut x = vec![2.0, 3.0];
        lu.solve(&mut x);
        assert!((x[0] - 3.0).abs() < 1e-14 && (x[1] - 2.0).abs() < 1e-14, "{x:?}");
    }

    #[test]
    fn random_sparse_systems_agree_with_their_residual() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        };
        for n in [5usize, 40, 120] {
            let cols: Vec<Vec<usize>> = (0..n).map(|j| (0..n).filter(|&i| i == j || rnd() > 0.42).collect()).collect();
            let pattern = Sparsity::from_columns(n, &cols).unwrap();
            let jac: Vec<f64> = (0..pattern.nnz()).map(|_| 4.0 * rnd()).collect();
            let mut lu = SparseLu::new(&pattern, n).unwrap();
            lu.factor(&jac, 0.3).unwrap();
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut x = b.clone();
            lu.solve(&mut x);
            let w = dense_w(&pattern, &jac, 0.3, n);
            assert!(residual(&w, &x, &b) < 1e-9, "n = {n}: residual {}", residual(&w, &x, &b));
        }
    }

    #[test]
    fn a_singular_matrix_is_reported() {
        let pattern = Sparsity::from_columns(2, &[vec![0, 1], vec![0, 1]]).unwrap();
        // W = [[1, 1], [1, 1]]
        let jac = [0.0, -1.0, -1.0, 0.0];
        let mut lu = SparseLu::new(&pattern, 2).unwrap();
        assert_eq!(lu.factor(&jac, 1.0), Err(Singular));
    }
}
