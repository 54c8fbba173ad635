//! The structure of a Jacobian `∂f/∂y` that a system declares
//! ([`crate::OdeSystem::jacobian_sparsity`]), and the grouping of its columns
//! for finite differences.
//!
//! Storage is compressed by columns (CSC): column `j` holds the rows
//! `rows[col_start[j]..col_start[j + 1]]`, sorted and without repeats. Only
//! the state columns are stored (the trailing quadrature columns are zero by
//! definition, see [`crate::OdeSystem::n_quadrature`]); rows cover the whole
//! system, quadratures included.
//!
//! Column grouping (Curtis, Powell & Reid, "On the estimation of sparse
//! Jacobian matrices", J. Inst. Maths Applics 13 (1974) 117–119): columns that
//! share no row can be perturbed together, one evaluation of `f` per group.
//! Groups are formed greedily in column order (each column takes the first
//! group none of whose columns touches one of its rows), which is the
//! sequential colouring of the column-intersection graph.

use std::ops::Range;

/// Structure of the state columns of `∂f/∂y` (see the module documentation).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sparsity {
    n_rows: usize,
    col_start: Vec<usize>,
    rows: Vec<usize>,
}

/// A declared structure that cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("Jacobian structure: {0}")]
pub struct SparsityError(pub String);

impl Sparsity {
    /// Structure with `columns[j]` = rows where column `j` may be non-zero (any
    /// order, repeats allowed), in a system of `n_rows` equations.
    pub fn from_columns(n_rows: usize, columns: &[Vec<usize>]) -> Result<Sparsity, SparsityError> {
        if columns.len() > n_rows {
            return Err(SparsityError(format!("{} columns for a system of {n_rows} equations", columns.len())));
        }
        let mut col_start = Vec::with_capacity(columns.len() + 1);
        let mut rows = Vec::new();
        col_start.push(0);
        for (j, col) in columns.iter().enumerate() {
            let mut c = col.clone();
            c.sort_unstable();
            c.dedup();
            if let Some(&r) = c.last() {
                if r >= n_rows {
                    return Err(SparsityError(format!("column {j} names row {r} of a system of {n_rows} equations")));
                }
            }
            rows.extend_from_slice(&c);
            col_start.push(rows.len());
        }
        Ok(Sparsity { n_rows, col_start, rows })
    }

    /// Number of rows (the system dimension).
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Number of stored (state) columns.
    pub fn n_columns(&self) -> usize {
        self.col_start.len() - 1
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.rows.len()
    }

    /// Rows of column `j`, sorted.
    pub fn column(&self, j: usize) -> &[usize] {
        &self.rows[self.col_start[j]..self.col_start[j + 1]]
    }

    /// Positions of column `j`'s entries in the value array.
    pub fn column_range(&self, j: usize) -> Range<usize> {
        self.col_start[j]..self.col_start[j + 1]
    }

    /// Column pointers (length `n_columns + 1`).
    pub fn col_start(&self) -> &[usize] {
        &self.col_start
    }

    /// Row indices of all entries, column by column.
    pub fn rows(&self) -> &[usize] {
        &self.rows
    }

    /// Groups of columns that share no row (Curtis–Powell–Reid), in the order
    /// the greedy colouring opened them; each column appears in exactly one.
    pub fn column_groups(&self) -> Vec<Vec<usize>> {
        let n_cols = self.n_columns();
        // columns touching each row
        let mut row_cols: Vec<Vec<usize>> = vec![Vec::new(); self.n_rows];
        for j in 0..n_cols {
            for &r in self.column(j) {
                row_cols[r].push(j);
            }
        }
        let mut color = vec![usize::MAX; n_cols];
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut mark: Vec<usize> = Vec::new(); // mark[g] == j+1: group g is forbidden for column j
        for j in 0..n_cols {
            for &r in self.column(j) {
                for &k in &row_cols[r] {
                    if color[k] != usize::MAX {
                        mark[color[k]] = j + 1;
                    }
                }
            }
            let g = (0..groups.len()).find(|&g| mark[g] != j + 1).unwrap_or(groups.len());
            if g == groups.len() {
                groups.push(Vec::new());
                mark.push(0);
            }
            groups[g].push(j);
            color[j] = g;
        }
        groups
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_sorted_deduplicated_and_checked() {
        let s = Sparsity::from_columns(3, &[vec![2, 0, 2], vec![], vec![1]]).unwrap();
        assert_eq!(s.column(0), &[0, 2]);
        assert!(s.column(1).is_empty());
        assert_eq!(s.nnz(), 3);
        assert!(Sparsity::from_columns(2, &[vec![2]]).is_err());
        assert!(Sparsity::from_columns(1, &[vec![0], vec![0]]).is_err());
    }

    #[test]
    fn groups_never_share_a_row_and_a_tridiagonal_needs_three() {
        let n: usize = 50;
        let cols: Vec<Vec<usize>> = (0..n).map(|j| [j.wrapping_sub(1), j, j + 1].into_iter().filter(|&r| r < n).collect()).collect();
        let s = Sparsity::from_columns(n, &cols).unwrap();
        let groups = s.column_groups();
        assert_eq!(groups.len(), 3);
        let mut seen = vec![0; n];
        for g in &groups {
            let mut rows = vec![false; n];
            for &j in g {
                seen[j] += 1;
                for &r in s.column(j) {
                    assert!(!rows[r], "row {r} shared inside a group");
                    rows[r] = true;
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
    }

    #[test]
    fn a_dense_row_forces_one_column_per_group() {
        // arrow: row 0 touches every column
        let n = 10;
        let cols: Vec<Vec<usize>> = (0..n).map(|j| vec![0, j]).collect();
        let s = Sparsity::from_columns(n, &cols).unwrap();
        assert_eq!(s.column_groups().len(), n);
    }
}
