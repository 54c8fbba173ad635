//! Selection: which candidate effects are named, by a greedy search over
//! rounds followed by a backward check.
//!
//! # Tests of a candidate B against the current model A
//! A candidate passes when all of these hold:
//! 1. **parameters** ([`crate::candidates::judge`]): a parameter with a null
//!    value lies more than `z_null` correlation-aware standard errors from it;
//! 2. **information criterion**: ΔIC on effective sample sizes
//!    ([`crate::stats::delta_ic`]) below −`ic`;
//! 3. **held-out gain**: with held-out mean squares MS_A, MS_B of the
//!    leave-one-experiment-out predictions ([`crate::heldout`], noise-
//!    normalised, 1 = noise level), G = MS_A − MS_B is at least the fraction
//!    `heldout_gain` of MS_A;
//! 4. **model-form floor**: G is at least `floor_ratio` times what B still
//!    leaves above the noise on held-out data, R = max(MS_B − 1, `floor_min`).
//!    Any two honest implementations of the same machine differ by small
//!    modelling choices that no catalogue effect describes; a candidate fitted
//!    to such a difference removes a part of it and leaves a remainder of the
//!    same order, while a real missing effect removes far more than what
//!    remains;
//! 5. **practical size** ([`crate::candidates::below_least_size`]): the
//!    effect reaches the least size of practical consequence it declares
//!    ([`crate::effects::Effect::least_size`]) — a valve delay at least the
//!    response time between a limit switch's trip and the valve's command
//!    that the model does not describe (`Options::switch_latency`, 1 ms).
//!    Below it the fit is the rig's switching timing as much as the
//!    valve's; the verdict says so ("below practical size"), it is not named.
//!    And, for every effect, its **footprint** ([`crate::footprint`]) —
//!    the largest change it makes to a recorded channel, the rest of the
//!    fitted model held, beyond what a shift in time within that timing
//!    resolution explains — reaches the channel's sensor accuracy on at
//!    least one channel (`Thresholds::footprint`);
//! 6. **sham** ([`crate::sham`]): B's ΔIC is below that of a generic
//!    correction with as many parameters (per-phase biases and time shifts
//!    of the channels, shared by all experiments, with a linear refit of the
//!    calibration) fitted on the same data — an effect that explains no
//!    more than a generic correction of its size is not what the data show.
//!
//! Among passing candidates the one with the lowest ΔIC is added, unless the
//! runner-up's held-out gain is within `ambiguity` of the winner's: then the
//! verdict is "ambiguous between A and B" and the search stops. A round
//! screens candidates on the short records first (see
//! [`crate::candidates`]): only those whose short-record ΔIC is below −`ic`
//! and at least `screen_relative` of the best one's, and at most
//! `screen_keep` of them, get a full fit. When none passes the screen while
//! the current model leaves a significant remainder (a channel above
//! `remainder_rmse` at the fitted samples), the best of them on the short
//! records gets its full fit anyway and faces every test below (the
//! screen's fallback, since 2026-11-27): an effect whose evidence lies late
//! in the records — wall heat exchange after the strokes — can lose on the
//! first part of the records to a calibration bent to imitate it.
//! Later rounds retry every effect not yet in the model (one added effect
//! can unmask another).
//!
//! A selected model is polished before the next round (`polish`): the
//! candidate fits that chose it were cut short, and the next round's nested
//! candidates must not be credited with a better calibration of it.
//!
//! # After an effect is named
//! A later round declares "ambiguous between A and B" only when what the
//! named effects leave is itself significant: a channel whose normalised
//! RMSE at the fitted samples ([`fitted_rmse`]) is above `remainder_rmse`,
//! the threshold of the report's unexplained remainder. Two candidates that
//! each lower a remainder already within that threshold do not make the
//! named effects uncertain; the search stops with them, and the two are
//! recorded as failing the `remainder` test ([`decide_after`]). A single
//! candidate that passes every test is still named (it is what an unmasked
//! second effect, a leak behind a valve delay, looks like).
//!
//! # Backward check
//! With two or more effects named, each is removed in turn from the final
//! model (refitted without it) and kept only if the final model passes the
//! held-out and floor tests (3, 4) against that reduced model. An effect
//! named first that a later one made unnecessary is dropped.

use crate::candidates::{better_short, penalised_cost, recentred, short_reference, Short};
use crate::candidates::{
    calibration_jacobian, fit_full, judge, prepare, problem_for, projected_scan, refit_fresh, retry_projected, screened, Candidate, Fitted,
    Pass, ProjectedScore, Structure,
};
use crate::effects::Effect;
use crate::experiment::Experiment;
use crate::fit::{fit_once, fit_short_stages, screen_horizon, FitOptions};
use crate::heldout::{leave_one_out, HeldOut};
use crate::options::{Options, Thresholds};
use crate::params::{FitParam, Target};
use crate::stats::BlockStats;
use graph::FlatNetlist;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// An effect added to the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Selected {
    pub effect: String,
    pub params: BTreeMap<String, f64>,
}

/// What the search concluded.
pub struct Search<'a> {
    /// The model with the named effects (the baseline when none).
    pub model: Structure<'a>,
    pub candidates: Vec<Candidate>,
    pub selected: Vec<Selected>,
    /// Names when the last round was ambiguous, and their models.
    pub ambiguous: Vec<String>,
    pub alternatives: Vec<Structure<'a>>,
    /// Effects removed by the backward check, with the reason.
    pub dropped: Vec<(String, String)>,
    /// The baseline's held-out errors (when computed).
    pub baseline_heldout: Option<HeldOut>,
    /// Per channel: the final model's normalised RMSE at the fitted samples ([`fitted_rmse`]).
    pub fitted_rmse: BTreeMap<String, f64>,
    pub evaluations: usize,
    pub timing: BTreeMap<String, f64>,
}

/// Held-out comparison of a model B against a model A.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// MS_A − MS_B [noise variances].
    pub gain: f64,
    /// max(MS_B − 1, floor_min).
    pub remainder: f64,
    /// gain / remainder.
    pub ratio: f64,
    /// gain / MS_A.
    pub relative: f64,
}

/// Compare held-out errors (see the module header).
pub fn compare(a: &HeldOut, b: &HeldOut, th: &Thresholds) -> Comparison {
    let (ma, mb) = (a.mean_square(), b.mean_square());
    let gain = ma - mb;
    let remainder = (mb - 1.0).max(th.floor_min);
    Comparison { gain, remainder, ratio: gain / remainder, relative: if ma > 0.0 { gain / ma } else { 0.0 } }
}

/// Which of tests 3 and 4 a comparison fails, and why (empty when it passes).
pub fn heldout_failures(c: &Comparison, th: &Thresholds) -> Vec<(&'static str, String)> {
    let mut out = Vec::new();
    if c.relative.is_nan() || c.relative < th.heldout_gain {
        out.push((
            "heldout_gain",
            format!("held-out mean square lowered by {:.1} % (needs {:.0} %)", 100.0 * c.relative, 100.0 * th.heldout_gain),
        ));
    }
    if c.ratio.is_nan() || c.ratio < th.floor_ratio {
        out.push((
            "model_form_floor",
            format!(
                "below the model-form floor: held-out gain {:.3} is {:.2} × the remainder {:.3} it leaves (needs {})",
                c.gain, c.ratio, c.remainder, th.floor_ratio
            ),
        ));
    }
    out
}

/// Why a comparison fails tests 3 and 4 (empty when it passes).
pub fn heldout_reasons(c: &Comparison, th: &Thresholds) -> Vec<String> {
    heldout_failures(c, th).into_iter().map(|(_, why)| why).collect()
}

/// What a round concludes from the candidates that passed every test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    None,
    /// Add the candidate with this index.
    Select(usize),
    /// The best two explain the gap equally.
    Ambiguous(usize, usize),
}

/// Pick among passing candidates given as (ΔIC, held-out gain): the lowest
/// ΔIC wins unless the runner-up's gain is within `ambiguity` of the winner's.
pub fn decide(passing: &[(f64, f64)], ambiguity: f64) -> Decision {
    let mut order: Vec<usize> = (0..passing.len()).collect();
    order.sort_by(|&a, &b| passing[a].0.total_cmp(&passing[b].0));
    match order.as_slice() {
        [] => Decision::None,
        [a] => Decision::Select(*a),
        [a, b, ..] => {
            if passing[*b].1 >= (1.0 - ambiguity) * passing[*a].1 {
                Decision::Ambiguous(*a, *b)
            } else {
                Decision::Select(*a)
            }
        }
    }
}

/// [`decide`] for a round after `named` effects: an ambiguity there is
/// declared only when what the named effects leave is `significant`
/// ([`significant`]); otherwise the round concludes nothing.
pub fn decide_after(passing: &[(f64, f64)], th: &Thresholds, named: usize, significant: bool) -> Decision {
    match decide(passing, th.ambiguity) {
        Decision::Ambiguous(..) if named > 0 && !significant => Decision::None,
        d => d,
    }
}

/// Per channel, pooled over experiments: the normalised RMSE √(Σr²/n) of a
/// fit's data rows. `signals[b]` names the channel of block b (the blocks of
/// [`crate::problem::Problem::blocks`], in the order of `stats`).
pub fn fitted_rmse(signals: &[String], stats: &BlockStats) -> BTreeMap<String, f64> {
    let mut sums: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for (name, (chi2, n)) in signals.iter().zip(stats.chi2.iter().zip(&stats.n)) {
        let e = sums.entry(name.clone()).or_insert((0.0, 0));
        e.0 += chi2;
        e.1 += n;
    }
    sums.into_iter().filter(|(_, (_, n))| *n > 0).map(|(k, (c, n))| (k, (c / n as f64).sqrt())).collect()
}

/// Whether what a model leaves is itself significant: a channel above
/// `remainder_rmse`, the threshold of the report's unexplained remainder.
pub fn significant(rmse: &BTreeMap<String, f64>, th: &Thresholds) -> bool {
    rmse.values().any(|&r| r > th.remainder_rmse)
}

/// [`fitted_rmse`] of a fitted structure.
fn structure_rmse(base: &FlatNetlist, experiments: &[Experiment], s: &Structure, opts: &Options) -> BTreeMap<String, f64> {
    let problem = problem_for(base, experiments, s.effects.clone(), s.params.clone(), opts);
    let signals: Vec<String> = problem.blocks().iter().map(|b| experiments[b.experiment].channels[b.channel].signal.clone()).collect();
    fitted_rmse(&signals, &s.fit.stats)
}

/// Compute a structure's held-out errors if not known yet; returns simulations spent.
pub fn ensure_heldout(base: &FlatNetlist, experiments: &[Experiment], s: &mut Structure, opts: &Options) -> Result<usize, String> {
    if s.heldout.is_some() {
        return Ok(0);
    }
    let problem = problem_for(base, experiments, s.effects.clone(), s.params.clone(), opts);
    let h = leave_one_out(&problem, &s.fit)?;
    let e = h.evaluations;
    s.heldout = Some(h);
    Ok(e)
}

/// The structure without its effect number `i`, refitted on the full records.
fn without<'a>(
    base: &'a FlatNetlist,
    experiments: &'a [Experiment],
    s: &Structure<'a>,
    i: usize,
    opts: &Options,
) -> Result<Structure<'a>, String> {
    let mut effects = s.effects.clone();
    effects.remove(i);
    let mut params: Vec<FitParam> = Vec::new();
    let mut values = Vec::new();
    for (p, v) in s.params.iter().zip(&s.fit.values) {
        match p.target {
            Target::Effect { slot, .. } if slot == i => continue,
            Target::Effect { slot, k } => {
                let mut q = p.clone();
                q.target = Target::Effect { slot: if slot > i { slot - 1 } else { slot }, k };
                params.push(q);
            }
            _ => params.push(p.clone()),
        }
        values.push(*v);
    }
    let problem = problem_for(base, experiments, effects.clone(), params.clone(), opts);
    let f = fit_once(&problem, &values, &FitOptions { max_iter: opts.screen_iter, ..opts.fit.clone() })?;
    Ok(Structure { effects, params, fit: f, heldout: None, short: None })
}

/// Refit a model that has just gained an effect once more, from its own
/// short-record optimum: the short-record stage continued on the screening
/// horizon, then the full records. The candidate fits that chose it were
/// cut short (`screen_iter`), and the position-triggered cycles leave local
/// minima; without this, the next round's candidates — which nest the model
/// and start from that same optimum — would "improve" on it with their
/// effect at its null and be credited with the better calibration. Kept
/// only if the full-record χ² falls. Returns the simulations spent.
fn polish(base: &FlatNetlist, experiments: &[Experiment], s: &mut Structure, opts: &Options) -> Result<usize, String> {
    let (Some(short), Some(h)) = (s.short.clone(), screen_horizon(&opts.fit)) else { return Ok(0) };
    let problem = problem_for(base, experiments, s.effects.clone(), s.params.clone(), opts);
    let stage = fit_short_stages(&problem, &short.values, &FitOptions { horizons: vec![h], ..opts.fit.clone() })?;
    let from = stage.values_short().map(<[f64]>::to_vec).unwrap_or(short.values);
    let f = fit_once(&problem, &from, &opts.fit)?;
    let spent = stage.evaluations + f.evaluations;
    if f.chi2 < s.fit.chi2 {
        let reference = short_reference(&problem, stage.short.as_ref(), &f.values, opts);
        s.short = better_short(reference, s.short.take());
        s.fit = f;
        s.heldout = None;
    }
    Ok(spent)
}

/// The current model refitted from its recentred calibration
/// ([`crate::candidates::recentred`]: every parameter with a prior back at
/// its prior centre) on the screening horizon. When that lowers the
/// short-record cost (data and prior rows) below the current reference it
/// becomes the reference the candidates must beat, and it is continued on
/// the full records, kept if the full-record cost falls too. Returns the
/// simulations spent.
fn recentre(base: &FlatNetlist, experiments: &[Experiment], s: &mut Structure, opts: &Options) -> Result<usize, String> {
    let (Some(short), Some(h)) = (s.short.clone(), screen_horizon(&opts.fit)) else { return Ok(0) };
    let Some(from) = recentred(&s.params, &short.values) else { return Ok(0) };
    let problem = problem_for(base, experiments, s.effects.clone(), s.params.clone(), opts);
    let stage = fit_short_stages(&problem, &from, &FitOptions { horizons: vec![h], ..opts.fit.clone() })?;
    let mut spent = stage.evaluations;
    let (Some(values), Some(fit)) = (stage.values_short().map(<[f64]>::to_vec), stage.short.as_ref()) else { return Ok(spent) };
    if penalised_cost(&s.params, &values, &fit.stats) >= penalised_cost(&s.params, &short.values, &short.stats) {
        return Ok(spent);
    }
    s.short = Some(Short { values: values.clone(), stats: fit.stats.clone() });
    let f = fit_once(&problem, &values, &opts.fit)?;
    spent += f.evaluations;
    if f.chi2 < s.fit.chi2 {
        s.fit = f;
        s.heldout = None;
    }
    Ok(spent)
}

/// Whether [`recentre`] changes a structure: true when it moved the
/// short-record reference or the fit (for progress messages and tests).
fn same_reference(a: &Option<Short>, b: &Option<Short>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => a.values == b.values,
        (None, None) => true,
        _ => false,
    }
}

/// The first round's rescue (below) is skipped when a candidate already
/// lowered the short-record criterion by more than this: a strong effect
/// then stands out of the bent calibration on its own (the rescue was
/// needed where the best first-pass candidate gained little).
const RESCUE_UNLESS: f64 = 1000.0;

/// Run the greedy search and the backward check from the calibrated baseline.
pub fn search<'a>(
    base: &'a FlatNetlist,
    experiments: &'a [Experiment],
    pool: &[&'a dyn Effect],
    baseline: Structure<'a>,
    opts: &Options,
) -> Result<Search<'a>, String> {
    let th = opts.thresholds;
    let mut out = Search {
        model: baseline.clone(),
        candidates: Vec::new(),
        selected: Vec::new(),
        ambiguous: Vec::new(),
        alternatives: Vec::new(),
        dropped: Vec::new(),
        baseline_heldout: None,
        fitted_rmse: BTreeMap::new(),
        evaluations: 0,
        timing: BTreeMap::new(),
    };
    let mut current = baseline;
    // models along the way, to reuse in the backward check
    let mut path: Vec<Structure<'a>> = Vec::new();
    for round in 1..=opts.max_effects {
        let clock = std::time::Instant::now();
        let probe =
            problem_for(base, experiments, current.effects.clone(), current.params.clone(), opts).netlist(0, &current.fit.values)?;
        // every effect not in the model yet is tried again: one that did not
        // help in the previous round may have been masked by the effect just
        // added (a seal leak hides behind a valve delay that shifts every
        // stroke by more than the leak does)
        let tried: Vec<&dyn Effect> =
            pool.iter().copied().filter(|e| !current.effects.iter().any(|c| c.name() == e.name()) && e.applies_to(&probe)).collect();
        if tried.is_empty() {
            break;
        }
        // the candidates start from the current model's optimum as it is
        // before the round's recentred refit below (crate::candidates,
        // "Recentred starts": that refit is the reference they are judged
        // against, not a start)
        let calibrated = current.fit.values.clone();
        // the current model gets the candidates' recentred start too
        if opts.recentre {
            let before = current.short.clone();
            let chi2 = current.fit.chi2;
            out.evaluations += recentre(base, experiments, &mut current, opts)?;
            if !same_reference(&before, &current.short) {
                opts.progress.say(&format!(
                    "round {round}: the recentred calibration is a better short-record reference{}",
                    if current.fit.chi2 < chi2 {
                        format!(" and full-record fit (χ² {chi2:.1} → {:.1})", current.fit.chi2)
                    } else {
                        String::new()
                    }
                ));
            }
        }
        opts.progress.say(&format!(
            "round {round}: trying {} candidate{} ({})",
            tried.len(),
            if tried.len() == 1 { "" } else { "s" },
            tried.iter().map(|e| e.name()).collect::<Vec<_>>().join(", ")
        ));
        // the projected scan ranks the candidates; only the best few are prepared
        let mut pruned: Vec<Candidate> = Vec::new();
        // projected starts in every round, for the candidates the screen
        // would drop (docs/discrepancy.md "Projected starts (2026-11-28)":
        // given to every candidate in round 2 they cost the leak of a leak +
        // delay pair its fresh refit; given only to the dropped ones they
        // name the laminar leak behind a named delay)
        let projection =
            if opts.screen_prepare > 0 || opts.projected_start { calibration_jacobian(base, experiments, &current, opts) } else { None };
        // each tried effect with its projected start (crate::candidates, "Projected starts")
        let tried: Vec<(&dyn Effect, Vec<Vec<f64>>)> = match projection {
            Some((reference, spent)) => {
                out.evaluations += spent;
                let scored: Vec<ProjectedScore> =
                    tried.par_iter().map(|e| projected_scan(base, experiments, &current, *e, &reference, opts)).collect();
                let mut order: Vec<usize> = (0..tried.len()).collect();
                order.sort_by(|&a, &b| scored[a].dic.total_cmp(&scored[b].dic));
                let mut kept = Vec::new();
                for (rank, &i) in order.iter().enumerate() {
                    let s = &scored[i];
                    if opts.screen_prepare == 0 || (rank < opts.screen_prepare && s.dic < 0.0) {
                        out.evaluations += s.sims;
                        let starts: Vec<Vec<f64>> =
                            s.starts.iter().filter(|(d, _)| opts.projected_start && *d < -th.ic).map(|(_, v)| v.clone()).collect();
                        kept.push((tried[i], starts));
                    } else {
                        let mut c = Candidate::new(round, tried[i].name());
                        c.screened_out = true;
                        c.delta_ic = s.dic;
                        c.evaluations = s.sims;
                        c.fit_message = "screened out by the projected scan".into();
                        c.fail(
                            "screen",
                            format!(
                                "screened out: projected-scan ΔIC {:.1} is not below 0 or not among the best {} of the round",
                                s.dic, opts.screen_prepare
                            ),
                        );
                        pruned.push(c);
                    }
                }
                opts.progress.say(&format!(
                    "  projected scan: {}",
                    order.iter().map(|&i| format!("{} {:.0}", tried[i].name(), scored[i].dic)).collect::<Vec<_>>().join(", ")
                ));
                kept
            }
            _ => tried.into_iter().map(|e| (e, Vec::new())).collect(),
        };
        let mut preps: Vec<_> = tried
            .par_iter()
            .map(|(e, _)| prepare(base, experiments, &current, &calibrated, *e, Pass { round, rescue: false }, opts))
            .collect();
        let best =
            |p: &[crate::candidates::Prepared]| p.iter().map(|p| p.short_dic).filter(|d| d.is_finite()).fold(f64::INFINITY, f64::min);
        let mut best_short = best(&preps);
        // Rescue (first round): the baseline's full-record calibration did not
        // converge; every candidate is prepared again from the baseline's
        // short-record optimum (a strong missing effect drags the
        // full-record calibration away, and a scan at that calibration ranks
        // the effect's weakest grid point first), and the better of its two
        // preparations is kept. Not only when no candidate improved: a wrong
        // candidate can improve a little on the bent calibration, which
        // then screens out the right one by the relative test.
        if current.effects.is_empty()
            && !current.fit.converged
            && current.short.is_some()
            && best_short.partial_cmp(&-RESCUE_UNLESS) != Some(std::cmp::Ordering::Less)
        {
            let again: Vec<_> = tried
                .par_iter()
                .map(|(e, _)| prepare(base, experiments, &current, &calibrated, *e, Pass { round, rescue: true }, opts))
                .collect();
            for (i, p) in again.into_iter().enumerate() {
                let spent = preps[i].cand.evaluations + p.cand.evaluations;
                if p.short_dic < preps[i].short_dic || preps[i].short_dic.is_nan() {
                    preps[i] = p;
                }
                preps[i].cand.evaluations = spent;
            }
            best_short = best(&preps);
        }
        // the projected start (crate::candidates, "Projected starts"): a
        // candidate the screen would drop, while the projected scan says the
        // calibration's linear answer leaves it clearly better, is screened
        // once more from that answer
        if tried.iter().any(|(_, s)| !s.is_empty()) {
            let retried: Vec<_> = preps
                .into_iter()
                .zip(&tried)
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|(p, (_, start))| match start {
                    starts if !starts.is_empty() && (p.short_dic.is_nan() || p.short_dic >= -th.ic) => {
                        retry_projected(&current, p, starts, opts)
                    }
                    _ => p,
                })
                .collect();
            preps = retried;
            best_short = best(&preps);
        }
        // the screen: improvement on the short records, relative to the best, and the best few
        let mut order: Vec<usize> = (0..preps.len()).collect();
        order.sort_by(|&a, &b| preps[a].short_dic.total_cmp(&preps[b].short_dic));
        let rank: Vec<usize> = {
            let mut r = vec![0; preps.len()];
            for (pos, &i) in order.iter().enumerate() {
                r[i] = pos;
            }
            r
        };
        // the screen's fallback: no candidate passed it, yet the current
        // model leaves a significant remainder — the best candidate on the
        // short records still gets its full-record fit (an effect whose
        // evidence lies late in the records, heat exchange after the strokes)
        let none_pass = !preps.iter().any(|p| p.short_dic < -th.ic);
        let fallback = (none_pass && significant(&structure_rmse(base, experiments, &current, opts), &th))
            .then(|| order.iter().copied().find(|&i| preps[i].short.is_some() && preps[i].short_dic.is_finite()))
            .flatten();
        if let Some(i) = fallback {
            opts.progress.say(&format!(
                "  no candidate passed the screen and the model leaves a significant remainder: {} (the best on the first part of the records, ΔIC {:.1}) is fitted on the full records",
                preps[i].cand.effect, preps[i].short_dic
            ));
        }
        let mut fitted: Vec<Result<Fitted<'a>, Box<Candidate>>> = preps
            .into_iter()
            .enumerate()
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|(i, p)| {
                if p.short.is_none() {
                    return Err(Box::new(p.cand));
                }
                let d = p.short_dic;
                if fallback == Some(i) {
                    return fit_full(&current, p, opts);
                }
                if d.is_nan() || d >= -th.ic {
                    let why = format!("screened out: ΔIC = {d:.1} on the first part of the records is not below -{}", th.ic);
                    return Err(Box::new(screened(p, why)));
                }
                if best_short < 0.0 && d > opts.screen_relative * best_short {
                    let why = format!(
                        "screened out: ΔIC = {d:.1} on the first part of the records is less than {} of the best candidate's {best_short:.1}",
                        opts.screen_relative
                    );
                    return Err(Box::new(screened(p, why)));
                }
                if rank[i] >= opts.screen_keep {
                    let why = format!("screened out: only the best {} candidates on the first part of the records are fitted", opts.screen_keep);
                    return Err(Box::new(screened(p, why)));
                }
                fit_full(&current, p, opts)
            })
            .collect();
        // the fresh start (crate::candidates, "Phase B"): the round's best
        // candidate by its full-record ΔIC is fitted again from the
        // calibration's own start when it stops far above the noise
        let best_fitted = fitted
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.as_ref().ok().map(|x| (i, x.delta_ic(&current))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i);
        if let (true, Some(i)) = (opts.fresh_start, best_fitted) {
            if let Ok(x) = fitted[i].as_mut() {
                if x.far_above_noise() {
                    let before = x.fit.chi2;
                    refit_fresh(x, opts);
                    opts.progress.say(&format!(
                        "  {}: refitted from the calibration's own start (χ² {before:.1} → {:.1})",
                        x.cand.effect, x.fit.chi2
                    ));
                }
            }
        }
        let results: Vec<(Option<Structure<'a>>, Candidate)> = fitted
            .into_par_iter()
            .map(|r| match r {
                Ok(x) => judge(&current, x, opts),
                Err(c) => (None, *c),
            })
            .collect();
        let mut results = results;
        for (s, c) in results.iter_mut() {
            if s.is_some() && c.delta_ic >= -th.ic {
                c.fail(
                    "information_criterion",
                    format!("information criterion: ΔIC = {:.1} is not below -{} (effective sample sizes)", c.delta_ic, th.ic),
                );
            }
        }
        // held-out and floor tests for every candidate fitted on the full
        // records (a few simulations each): they decide, and for one that
        // failed another test they grade the verdict (crate::report)
        if results.iter().any(|(s, _)| s.is_some()) {
            out.evaluations += ensure_heldout(base, experiments, &mut current, opts)?;
            if current.effects.is_empty() {
                out.baseline_heldout = current.heldout.clone();
            }
            let reference = current.heldout.clone().ok_or("no held-out reference")?;
            results.par_iter_mut().for_each(|(s, c)| {
                let Some(s) = s.as_mut() else { return };
                match ensure_heldout(base, experiments, s, opts) {
                    Ok(e) => c.evaluations += e,
                    Err(e) => {
                        c.fail("heldout_gain", format!("held-out prediction failed: {e}"));
                        return;
                    }
                }
                let Some(h) = &s.heldout else { return };
                let cmp = compare(&reference, h, &th);
                c.heldout_rmse = h.rmse();
                c.heldout_gain = cmp.gain;
                c.floor_ratio = cmp.ratio;
                c.heldout_relative = cmp.relative;
                for (test, why) in heldout_failures(&cmp, &th) {
                    c.fail(test, why);
                }
            });
        }
        // the sham test (test 6): a generic correction of the same size, fitted
        // once per round on the current model, sets the bar for every candidate
        if opts.sham && results.iter().any(|(s, _)| s.is_some()) {
            let max_k = results.iter().filter_map(|(s, _)| s.as_ref()).map(|s| s.params.len() - current.params.len()).max().unwrap_or(0);
            match crate::sham::fit_sham(base, experiments, &current, max_k, opts) {
                Ok(sham) => {
                    out.evaluations += experiments.len();
                    opts.progress.say(&format!("  sham: {}", sham.columns.join(", ")));
                    for (s, c) in results.iter_mut() {
                        let Some(s) = s.as_ref() else { continue };
                        let k = s.params.len() - current.params.len();
                        c.sham_delta_ic = sham.delta_ic(&current.fit.stats, k).unwrap_or(f64::NAN);
                        if let Some(why) = sham.failure(&current.fit.stats, k, c.delta_ic) {
                            c.fail("sham", why);
                        }
                    }
                }
                Err(e) => opts.progress.say(&format!("  sham: not fitted ({e})")),
            }
        }
        for c in pruned {
            out.evaluations += c.evaluations;
            out.candidates.push(c);
        }
        let mut passing: Vec<(Structure<'a>, Candidate)> = Vec::new();
        for (s, mut c) in results {
            c.accepted = c.reasons.is_empty() && s.is_some();
            out.evaluations += c.evaluations;
            opts.progress.say(&format!(
                "  {}: {}",
                c.effect,
                if c.accepted { "passes every test".to_string() } else { c.reasons.first().cloned().unwrap_or_default() }
            ));
            if let (Some(s), true) = (s, c.accepted) {
                passing.push((s, c.clone()));
            }
            out.candidates.push(c);
        }
        out.timing.insert(format!("round {round}"), clock.elapsed().as_secs_f64());
        let scores: Vec<(f64, f64)> = passing.iter().map(|(_, c)| (c.delta_ic, c.heldout_gain)).collect();
        let left = structure_rmse(base, experiments, &current, opts);
        let decision = decide_after(&scores, &th, current.effects.len(), significant(&left, &th));
        if decision == Decision::None && decide(&scores, th.ambiguity) != Decision::None {
            // two candidates tie on a remainder within the threshold: not an ambiguity of the named effects
            let (channel, worst) = left.iter().max_by(|a, b| a.1.total_cmp(b.1)).map_or(("-", f64::NAN), |(k, v)| (k.as_str(), *v));
            let why = format!(
                "remainder: what the named effects leave is not significant (largest normalised RMSE {worst:.2} in {channel}, threshold {}); passed the other tests on it",
                th.remainder_rmse
            );
            opts.progress.say(&format!("  round {round}: {why}"));
            for c in out.candidates.iter_mut().filter(|c| c.round == round && c.accepted) {
                c.accepted = false;
                c.fail("remainder", why.clone());
            }
        }
        match decision {
            Decision::None => break,
            Decision::Ambiguous(a, b) => {
                out.ambiguous = vec![passing[a].1.effect.clone(), passing[b].1.effect.clone()];
                out.alternatives = vec![passing[a].0.clone(), passing[b].0.clone()];
                break;
            }
            Decision::Select(a) => {
                let (mut s, c) = passing.swap_remove(a);
                // always: the candidate's fit held the form parameters
                out.evaluations += polish(base, experiments, &mut s, opts)?;
                // the effect's parameters as the (possibly polished) model holds them
                let slot = s.effects.len() - 1;
                let params = s
                    .params
                    .iter()
                    .zip(&s.fit.values)
                    .filter(|(p, _)| matches!(p.target, Target::Effect { slot: k, .. } if k == slot))
                    .map(|(p, v)| (crate::candidates::short_name(p), *v))
                    .collect();
                out.selected.push(Selected { effect: c.effect.clone(), params });
                path.push(current);
                current = s;
            }
        }
    }
    // backward check
    if current.effects.len() >= 2 {
        let clock = std::time::Instant::now();
        let mut i = 0;
        while i < current.effects.len() && current.effects.len() >= 2 {
            let name = current.effects[i].name().to_string();
            let mut reduced =
                match path.iter().find(|p| p.effects.len() + 1 == current.effects.len() && p.effects.iter().all(|e| e.name() != name)) {
                    Some(p) => p.clone(),
                    None => without(base, experiments, &current, i, opts)?,
                };
            out.evaluations += reduced.fit.evaluations;
            out.evaluations += ensure_heldout(base, experiments, &mut reduced, opts)?;
            out.evaluations += ensure_heldout(base, experiments, &mut current, opts)?;
            let (Some(hr), Some(hc)) = (&reduced.heldout, &current.heldout) else { break };
            let cmp = compare(hr, hc, &th);
            let reasons = heldout_reasons(&cmp, &th);
            if reasons.is_empty() {
                i += 1;
            } else {
                opts.progress.say(&format!("backward check: {name} dropped ({})", reasons.join("; ")));
                out.dropped.push((name.clone(), reasons.join("; ")));
                out.selected.retain(|s| s.effect != name);
                current = reduced;
            }
        }
        out.timing.insert("backward check".into(), clock.elapsed().as_secs_f64());
    }
    out.fitted_rmse = structure_rmse(base, experiments, &current, opts);
    out.model = current;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heldout::HeldBlock;

    fn held(ms: f64) -> HeldOut {
        HeldOut { blocks: vec![HeldBlock { experiment: 0, channel: 0, chi2: ms * 1000.0, n: 1000 }], evaluations: 0 }
    }

    #[test]
    fn the_best_wins_unless_the_runner_up_explains_as_much() {
        assert_eq!(decide(&[], 0.1), Decision::None);
        assert_eq!(decide(&[(-500.0, 9.0)], 0.1), Decision::Select(0));
        // gains 8 and 2: clear winner (index 1 has the lower ΔIC)
        assert_eq!(decide(&[(-90.0, 2.0), (-900.0, 8.0)], 0.1), Decision::Select(1));
        // gains 8 and 7.5: within 10 % → ambiguous, best first
        assert_eq!(decide(&[(-800.0, 7.5), (-850.0, 8.0)], 0.1), Decision::Ambiguous(1, 0));
        assert_eq!(decide(&[(-800.0, 7.5), (-850.0, 8.0)], 0.05), Decision::Select(1));
    }

    #[test]
    fn after_a_named_effect_a_tie_is_ambiguous_only_on_a_significant_remainder() {
        let th = Thresholds::default();
        // the nominal valve-delay run's second round: two candidates pass
        // with held-out gains within 10 % of each other
        let tie = [(-300.0, 0.30), (-280.0, 0.29)];
        // what the valve delay leaves: position 1.2, pressures near the noise
        let signals: Vec<String> = ["piston.x", "head.p", "piston.x", "head.p"].iter().map(|s| s.to_string()).collect();
        let stats = BlockStats {
            chi2: vec![1.44 * 500.0, 1.05 * 400.0, 1.44 * 300.0, 1.1 * 400.0],
            n: vec![500, 400, 300, 400],
            tau: vec![1.0; 4],
        };
        let left = fitted_rmse(&signals, &stats);
        assert!((left["piston.x"] - 1.2).abs() < 1e-12 && (left["head.p"] - 1.075f64.sqrt()).abs() < 1e-12);
        assert!(!significant(&left, &th));
        assert_eq!(decide_after(&tie, &th, 1, significant(&left, &th)), Decision::None);
        // a remainder above the threshold keeps the ambiguity
        let stats = BlockStats { chi2: vec![9.0 * 500.0, 400.0, 9.0 * 300.0, 400.0], ..stats };
        let left = fitted_rmse(&signals, &stats);
        assert!(significant(&left, &th));
        assert_eq!(decide_after(&tie, &th, 1, true), Decision::Ambiguous(0, 1));
        // with nothing named yet the tie is always ambiguous, and a clear winner is always named
        assert_eq!(decide_after(&tie, &th, 0, false), Decision::Ambiguous(0, 1));
        assert_eq!(decide_after(&[(-300.0, 0.30), (-100.0, 0.1)], &th, 1, false), Decision::Select(0));
    }

    #[test]
    fn the_floor_test_weighs_the_gain_against_the_remainder() {
        let th = Thresholds::default();
        // a real effect: 400 → 1.1 (gain 398.9, remainder 0.1)
        let c = compare(&held(400.0), &held(1.1), &th);
        assert!((c.gain - 398.9).abs() < 1e-9 && (c.remainder - 0.1).abs() < 1e-9);
        assert!(heldout_reasons(&c, &th).is_empty());
        // a model-form difference partly absorbed: 9 → 6 (gain 3, remainder 5)
        let c = compare(&held(9.0), &held(6.0), &th);
        assert!((c.ratio - 0.6).abs() < 1e-12);
        let r = heldout_reasons(&c, &th);
        assert_eq!(r.len(), 1);
        assert!(r[0].contains("floor"), "{r:?}");
        // at the noise level the remainder is floor_min, and a tiny gain fails the relative test
        let c = compare(&held(1.02), &held(1.0), &th);
        assert_eq!(c.remainder, th.floor_min);
        assert!(heldout_reasons(&c, &th).iter().any(|r| r.contains("lowered by")));
    }
}
