//! Held-out prediction errors: each experiment predicted by the model
//! refitted without it.
//!
//! # Method
//! For a fit on all experiments (coordinates u, residuals r, Jacobian J),
//! leaving experiment k out changes the parameters by the Gauss–Newton step
//! on the other experiments' rows, δ = −(J₋ₖᵀJ₋ₖ)⁻¹·J₋ₖᵀr₋ₖ (solved by SVD,
//! so that a parameter only experiment k determines keeps its value), kept
//! within the bounds. Experiment k is then *simulated* with u + δ: the
//! prediction itself is nonlinear, only the refit is linearised (exact for a
//! model linear in its parameters, and close when dropping one experiment
//! of several moves the parameters little). Its sensor offsets (and gains)
//! are eliminated from its own data as in the fit — they belong to the
//! logger of that run, which no other experiment can tell.
//!
//! The result is kept per block (experiment × channel) so that the
//! selection can weigh the gain of an effect against what remains.
//! Cost: one simulation per experiment.
//!
//! # A single experiment: a split in time
//! With one experiment (a vessel's blowdown) there is no operating point
//! to leave out, so the record is split at half its duration: the first
//! half is predicted by the model refitted (the same linearised step) on
//! the second, and the second by the model refitted on the first. The
//! held-out errors are the two predictions' errors, per channel. A law that
//! fits the whole record by bending to it predicts one half from the other
//! worse than the right law does (the early, fast part of a blowdown from
//! its slow end, and back).

use crate::effects::Scale;
use crate::fit::Fit;
use crate::problem::Problem;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

/// Held-out χ² of one channel of one experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldBlock {
    pub experiment: usize,
    pub channel: usize,
    /// Σ of squared normalised prediction errors.
    pub chi2: f64,
    pub n: usize,
}

/// Held-out errors of a model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOut {
    pub blocks: Vec<HeldBlock>,
    /// Simulations run.
    pub evaluations: usize,
}

impl HeldOut {
    /// Σχ² over every block.
    pub fn chi2(&self) -> f64 {
        self.blocks.iter().map(|b| b.chi2).sum()
    }
    /// Number of held-out residuals.
    pub fn n(&self) -> usize {
        self.blocks.iter().map(|b| b.n).sum()
    }
    /// Mean square of the normalised prediction errors (1 = noise level).
    pub fn mean_square(&self) -> f64 {
        self.chi2() / self.n().max(1) as f64
    }
    /// Normalised RMSE.
    pub fn rmse(&self) -> f64 {
        self.mean_square().sqrt()
    }
}

/// The Gauss–Newton step that refits on the rows outside `held`.
fn refit_step(f: &Fit, held: &std::ops::Range<usize>, frozen: &[bool]) -> DVector<f64> {
    refit_step_without(f, &|i| held.contains(&i), frozen)
}

/// The Gauss–Newton step that refits on the rows where `held` is false;
/// the parameters marked `frozen` keep their values (their columns are
/// left out, so the minimum-norm solution does not move them).
fn refit_step_without(f: &Fit, held: &dyn Fn(usize) -> bool, frozen: &[bool]) -> DVector<f64> {
    let p = f.u.len();
    let m = f.residuals.len();
    let keep: Vec<usize> = (0..m).filter(|&i| !held(i)).collect();
    let j = DMatrix::from_fn(keep.len(), p, |a, b| if frozen.get(b).copied().unwrap_or(false) { 0.0 } else { f.jacobian[(keep[a], b)] });
    let r = DVector::from_fn(keep.len(), |a, _| f.residuals[keep[a]]);
    let a = j.transpose() * &j;
    let g = j.transpose() * r;
    let tol = a.diagonal().iter().fold(0.0_f64, |x, v| x.max(v.abs())) * 1e-12;
    a.svd(true, true).solve(&(-g), tol).unwrap_or_else(|_| DVector::zeros(p))
}

/// The parameters the linearised refit leaves at their fitted values: those
/// fitted on their distance from a limit ([`Scale::LogGap`], the ISO 6358
/// laminar ratio). The model is far from linear in them — the laminar end
/// acts only in the top thousandth of the pressure ratio — so one
/// Gauss–Newton step moves them far past where a refit would: measured on
/// the shipped discrepancy example, the baseline's held-out RMSE went from
/// 9.49 to 19.48 with them in the step although its calibration was the
/// same (docs/discrepancy.md, "Laminar ratio calibrated").
fn frozen_in_refit(problem: &Problem) -> Vec<bool> {
    problem.params.iter().map(|p| p.scale == Scale::LogGap).collect()
}

/// Leave-one-experiment-out prediction errors of a fit of `problem` (see
/// the module header). With a single experiment (or no parameters) these
/// are the fit's own residuals.
pub fn leave_one_out(problem: &Problem, f: &Fit) -> Result<HeldOut, String> {
    let blocks = problem.blocks();
    let in_sample = || HeldOut {
        blocks: blocks
            .iter()
            .map(|b| HeldBlock {
                experiment: b.experiment,
                channel: b.channel,
                chi2: f.residuals[b.rows.clone()].iter().map(|x| x * x).sum(),
                n: b.rows.len(),
            })
            .collect(),
        evaluations: 0,
    };
    let layout = problem.layout();
    if f.u.is_empty() {
        return Ok(in_sample());
    }
    if layout.len() == 1 {
        return split_in_time(problem, f, &blocks);
    }
    if layout.len() < 2 {
        return Ok(in_sample());
    }
    let lo: Vec<f64> = problem.params.iter().map(|p| p.to_u(p.lo)).collect();
    let hi: Vec<f64> = problem.params.iter().map(|p| p.to_u(p.hi)).collect();
    let frozen = frozen_in_refit(problem);
    let folds: Vec<Result<Vec<HeldBlock>, String>> = layout
        .par_iter()
        .map(|(k, rows)| {
            let delta = refit_step(f, rows, &frozen);
            let u: Vec<f64> = (0..f.u.len()).map(|i| (f.u[i] + delta[i]).clamp(lo[i], hi[i])).collect();
            let values = problem.values_of(&u);
            let result = problem.simulate(*k, &values, problem.intervals[*k])?;
            let (r, _) = problem.residuals_from(*k, &result)?;
            let mut at = 0;
            let mut out = Vec::new();
            for b in blocks.iter().filter(|b| b.experiment == *k) {
                let n = b.rows.len();
                out.push(HeldBlock { experiment: *k, channel: b.channel, chi2: r[at..at + n].iter().map(|x| x * x).sum(), n });
                at += n;
            }
            Ok(out)
        })
        .collect();
    let mut out = Vec::new();
    for fold in folds {
        out.extend(fold?);
    }
    Ok(HeldOut { blocks: out, evaluations: layout.len() })
}

/// Held-out errors of a single experiment by a split of its record at
/// half its duration (see the module header).
fn split_in_time(problem: &Problem, f: &Fit, blocks: &[crate::problem::Block]) -> Result<HeldOut, String> {
    let k = blocks.first().map_or(0, |b| b.experiment);
    let e = &problem.experiments[k];
    let mid = 0.5 * problem.horizon * e.duration();
    // the time of every data row, in the order of the residual vector
    let mut late = vec![false; f.residuals.len()];
    let mut is_data = vec![false; f.residuals.len()];
    for b in blocks {
        let ch = &e.channels[b.channel];
        let times = problem.samples[k].iter().filter(|&&i| ch.values[i].is_some()).map(|&i| e.times[i]);
        for (row, t) in b.rows.clone().zip(times) {
            late[row] = t > mid;
            is_data[row] = true;
        }
    }
    let lo: Vec<f64> = problem.params.iter().map(|p| p.to_u(p.lo)).collect();
    let hi: Vec<f64> = problem.params.iter().map(|p| p.to_u(p.hi)).collect();
    let frozen = frozen_in_refit(problem);
    let mut out: Vec<HeldBlock> = blocks.iter().map(|b| HeldBlock { experiment: k, channel: b.channel, chi2: 0.0, n: 0 }).collect();
    // per fold: (block, χ², rows) of the held half
    type Fold = Result<Vec<(usize, f64, usize)>, String>;
    let folds: Vec<Fold> = [false, true]
        .par_iter()
        .map(|&held_late| {
            let delta = refit_step_without(f, &|i| is_data[i] && late[i] == held_late, &frozen);
            let u: Vec<f64> = (0..f.u.len()).map(|i| (f.u[i] + delta[i]).clamp(lo[i], hi[i])).collect();
            let result = problem.simulate(k, &problem.values_of(&u), problem.intervals[k])?;
            let (r, _) = problem.residuals_from(k, &result)?;
            let mut parts = Vec::new();
            for (j, b) in blocks.iter().enumerate() {
                let rows: Vec<usize> = b.rows.clone().filter(|&i| late[i] == held_late).collect();
                parts.push((j, rows.iter().map(|&i| r[i] * r[i]).sum(), rows.len()));
            }
            Ok(parts)
        })
        .collect();
    for fold in folds {
        for (j, chi2, n) in fold? {
            out[j].chi2 += chi2;
            out[j].n += n;
        }
    }
    Ok(HeldOut { blocks: out, evaluations: 2 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::BlockStats;

    #[test]
    fn the_refit_step_is_exact_for_a_linear_model() {
        // r(u) = a·x − y, two "experiments" of 3 rows: refitting without the
        // first moves a to the least-squares value of the second alone.
        let xs = [1.0, 2.0, 3.0, 1.0, 2.0, 3.0];
        let ys = [1.1, 2.0, 3.1, 2.0, 4.1, 5.9];
        let a_full: f64 = xs.iter().zip(&ys).map(|(x, y)| x * y).sum::<f64>() / xs.iter().map(|x| x * x).sum::<f64>();
        let residuals: Vec<f64> = xs.iter().zip(&ys).map(|(x, y)| a_full * x - y).collect();
        let f = Fit {
            u: vec![a_full],
            values: vec![a_full],
            std_u: None,
            cov_u: None,
            stats: BlockStats { chi2: vec![], n: vec![], tau: vec![] },
            residuals,
            jacobian: DMatrix::from_fn(6, 1, |i, _| xs[i]),
            chi2: 0.0,
            at_bound: vec![false],
            converged: true,
            evaluations: 0,
            iterations: 0,
            message: String::new(),
        };
        let a_second: f64 = (3..6).map(|i| xs[i] * ys[i]).sum::<f64>() / (3..6).map(|i| xs[i] * xs[i]).sum::<f64>();
        let d = refit_step(&f, &(0..3), &[]);
        assert!((a_full + d[0] - a_second).abs() < 1e-12);
        // a frozen parameter keeps its fitted value in the refit
        let d = refit_step(&f, &(0..3), &[true]);
        assert!(a_second != a_full && d[0] == 0.0);
    }
}
