//! Experiments a parameter change does not reach are not simulated again.
//!
//! A finite-difference Jacobian column moves one fit coordinate. A
//! calibration parameter fitted per operating point (the throttle's
//! `flow_control.C@26 L/min/bar`, a vessel's initial pressure per record:
//! [`crate::params::Target::Netlist`] with a list of experiments) changes
//! the netlist of those experiments only; the rows of every other
//! experiment are those of the point the column starts from. [`RowCache`]
//! keeps the per-experiment rows of the last evaluations of one fit, and
//! [`crate::problem::Problem::residuals_reusing`] takes an experiment's rows
//! from a kept point whenever every coordinate in which the two points
//! differ leaves that experiment's netlist unchanged.
//!
//! The result is the same bit for bit: an experiment's rows are a pure
//! function of its netlist (one simulation, deterministic), and the kept
//! rows come from the same netlist. Only the number of simulations falls
//! (`problem::simulation_count`); the fit's evaluation count, which the
//! reports give as "simulations", counts residual evaluations and does not
//! change (docs/performance.md, "Experiments a column does not reach").

use std::sync::Mutex;

/// Rows of recent evaluations, per experiment, for one fit.
pub struct RowCache {
    kept: Mutex<Vec<Kept>>,
    capacity: usize,
}

/// One evaluation: its fit coordinates and the rows of each included
/// experiment, in the order of [`crate::problem::Problem::included`].
struct Kept {
    u: Vec<f64>,
    parts: Vec<Vec<f64>>,
}

impl RowCache {
    /// A cache for a fit of `n` coordinates: it keeps the last 2·n + 2
    /// evaluations, enough for a point and every column of its Jacobian
    /// (forward and backward), whatever order parallel columns end in.
    pub fn for_coordinates(n: usize) -> RowCache {
        RowCache { kept: Mutex::new(Vec::new()), capacity: 2 * n + 2 }
    }

    /// For each of `experiments` (the number of included experiments), the
    /// rows of a kept evaluation that may stand for `u`: one whose
    /// coordinates differ from `u` only where `reaches(j, i)` is false for
    /// the experiment's position `i`. `None` where no kept point qualifies.
    pub fn lookup(&self, u: &[f64], experiments: usize, reaches: impl Fn(usize, usize) -> bool) -> Vec<Option<Vec<f64>>> {
        let mut out = vec![None; experiments];
        let kept = match self.kept.lock() {
            Ok(k) => k,
            // a poisoned lock only means another thread panicked while
            // holding it; the cache is an optimisation, so simulate
            Err(_) => return out,
        };
        for entry in kept.iter().rev() {
            if entry.u.len() != u.len() || entry.parts.len() != experiments {
                continue;
            }
            let differing: Vec<usize> = (0..u.len()).filter(|&j| entry.u[j].to_bits() != u[j].to_bits()).collect();
            for (i, slot) in out.iter_mut().enumerate() {
                if slot.is_none() && differing.iter().all(|&j| !reaches(j, i)) {
                    *slot = Some(entry.parts[i].clone());
                }
            }
            if out.iter().all(Option::is_some) {
                break;
            }
        }
        out
    }

    /// Keep the rows of an evaluation at `u` (the oldest kept one goes
    /// when the cache is full).
    pub fn keep(&self, u: &[f64], parts: &[Vec<f64>]) {
        if let Ok(mut kept) = self.kept.lock() {
            if kept.len() >= self.capacity {
                kept.remove(0);
            }
            kept.push(Kept { u: u.to_vec(), parts: parts.to_vec() });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_taken_only_where_no_differing_coordinate_reaches() {
        let cache = RowCache::for_coordinates(2);
        cache.keep(&[1.0, 2.0], &[vec![10.0], vec![20.0]]);
        // coordinate 0 reaches experiment 0 only, coordinate 1 both
        let reaches = |j: usize, i: usize| j == 1 || i == 0;
        let got = cache.lookup(&[1.5, 2.0], 2, reaches);
        assert_eq!(got, vec![None, Some(vec![20.0])]);
        let got = cache.lookup(&[1.0, 2.5], 2, reaches);
        assert_eq!(got, vec![None, None]);
        let got = cache.lookup(&[1.0, 2.0], 2, reaches);
        assert_eq!(got, vec![Some(vec![10.0]), Some(vec![20.0])]);
    }

    #[test]
    fn the_oldest_evaluation_goes_when_full() {
        let cache = RowCache::for_coordinates(1); // keeps 4
        for k in 0..5 {
            cache.keep(&[k as f64], &[vec![k as f64]]);
        }
        let none = |_: usize, _: usize| true;
        assert_eq!(cache.lookup(&[0.0], 1, none), vec![None]);
        assert_eq!(cache.lookup(&[4.0], 1, none), vec![Some(vec![4.0])]);
    }
}
