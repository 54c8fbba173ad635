//! Sparse LU of the iteration matrix `W = I/(hγ) − J` (state block only) for
//! large systems, by faer's sparse LU: a fill-reducing column ordering
//! (COLAMD) and a symbolic analysis computed once for the structure, then a
//! numeric factorisation with partial pivoting at every step (simplicial
//! Gilbert–Peierls or supernodal, chosen by faer from the structure).
//!
//! Why faer: it is a maintained pure-Rust linear-algebra library with sparse
//! LU, a reusable symbolic factorisation and caller-provided scratch memory,
//! so the step loop does not allocate once the first factorisation has sized
//! faer's buffers; no C toolchain or system library is needed.
//!
//! The structure of `W` is the declared structure of `J` restricted to the
//! state rows, plus the diagonal.

use crate::lu::Singular;
use crate::sparsity::Sparsity;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, NumericLu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

/// Sparse LU work space for one structure (see the module documentation).
pub(crate) struct SparseLu {
    n: usize,
    col_start: Vec<usize>,
    rows: Vec<usize>,
    values: Vec<f64>,
    /// For each entry of the Jacobian structure: its position in `values`, or
    /// `usize::MAX` for entries in quadrature rows (not part of `W`).
    from_jacobian: Vec<usize>,
    /// Position of the diagonal entry of each column in `values`.
    diagonal: Vec<usize>,
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    memory: MemBuffer,
    factored: bool,
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu").field("n", &self.n).field("nnz", &self.rows.len()).finish()
    }
}

impl SparseLu {
    /// Work space for the `ns` state columns of `pattern`; `None` if faer
    /// cannot analyse the structure (the caller then factors densely).
    pub(crate) fn new(pattern: &Sparsity, ns: usize) -> Option<SparseLu> {
        let mut col_start = Vec::with_capacity(ns + 1);
        let mut rows = Vec::new();
        let mut from_jacobian = vec![usize::MAX; pattern.nnz()];
        let mut diagonal = vec![0; ns];
        col_start.push(0);
        for j in 0..ns {
            let range = pattern.column_range(j);
            let mut placed_diagonal = false;
            for (k, &r) in range.clone().zip(pattern.column(j)) {
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
        let structure = SymbolicSparseColMatRef::new_checked(ns, ns, &col_start, None, &rows);
        let symbolic = factorize_symbolic_lu(structure, Default::default()).ok()?;
        let need = symbolic
            .factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let memory = MemBuffer::try_new(need).ok()?;
        let values = vec![0.0; rows.len()];
        Some(SparseLu {
            n: ns,
            col_start,
            rows,
            values,
            from_jacobian,
            diagonal,
            symbolic,
            numeric: NumericLu::new(),
            memory,
            factored: false,
        })
    }

    /// Form `W = I/(hγ) − J` from the Jacobian's entries and factor it.
    pub(crate) fn factor(&mut self, jacobian: &[f64], inv_hg: f64) -> Result<(), Singular> {
        self.factored = false;
        self.values.fill(0.0);
        for (k, &pos) in self.from_jacobian.iter().enumerate() {
            if pos != usize::MAX {
                self.values[pos] = -jacobian[k];
            }
        }
        for &d in &self.diagonal {
            self.values[d] += inv_hg;
        }
        if self.values.iter().any(|v| !v.is_finite()) {
            return Err(Singular);
        }
        let structure = SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_start, None, &self.rows);
        let matrix = SparseColMatRef::new(structure, &self.values);
        let stack = MemStack::new(&mut self.memory);
        let result = self.symbolic.factorize_numeric_lu(&mut self.numeric, matrix, Par::Seq, stack, Default::default()).map(|_| ());
        match result {
            Ok(_) => {
                self.factored = true;
                Ok(())
            }
            Err(_) => Err(Singular),
        }
    }

    /// Solve `W x = b` in place with the last factorisation.
    pub(crate) fn solve(&mut self, b: &mut [f64]) {
        debug_assert!(self.factored && b.len() == self.n);
        let lu = faer::sparse::linalg::lu::LuRef::new_unchecked(&self.symbolic, &self.numeric);
        let rhs = MatMut::from_column_major_slice_mut(b, self.n, 1);
        lu.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.memory));
    }
}
