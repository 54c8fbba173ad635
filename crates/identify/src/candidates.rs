//! Trying one candidate effect on top of the current model: starting points
//! from the effect's scan grid, the short-record stages, the screen, the
//! full-record fit and the parameter test. The information-criterion,
//! held-out and floor tests that compare candidates are in
//! [`crate::selection`].
//!
//! # Steps (phase A: [`prepare`])
//! 1. **Scan** the effect's parameter grid with the calibration held at the
//!    current fit, on the first part of the records (the last short horizon).
//! 2. From the best grid point (the best `starts` for effects with shape
//!    parameters) fit calibration and effect parameters together on the short
//!    records (shape parameters held); the best result is kept. A short
//!    stage whose result raises the next horizon's χ² more than
//!    [`crate::fit::STAGE_WRECKS`]-fold is dropped, the next stage starting
//!    where it began ([`crate::fit::fit_short_stages`]).
//! 3. Its **short-record ΔIC** against the current model (both fitted on the
//!    same short records; effective sample sizes, [`crate::stats`]) decides
//!    the screen.
//!
//! # Before phase A: the projected scan ([`projected_scan`])
//! Fitting every candidate is what a round costs, so candidates are first
//! ranked cheaply. On the screening horizon, at the current model's
//! short-record optimum θ̂ with residuals r₀ and the Jacobian J of its
//! calibration (one finite-difference column per parameter, computed once
//! per round), each point g of an effect's scan grid is simulated once,
//! r_g = r(θ̂, g), and the calibration's best linear answer to it is
//! projected out: r'_g = r_g − J(JᵀJ)⁺Jᵀr_g (the Gauss–Newton step of the
//! calibration from θ̂). The effect's score is the best ΔIC of r'_g
//! against r₀ on effective sample sizes ([`crate::stats::delta_ic`]). A
//! missing effect that the calibration had bent to mimic scores well, as
//! the projection undoes the bending to first order; one the calibration
//! can imitate scores near zero. Only the best few candidates (and only
//! those scoring below zero) are prepared and fitted ([`crate::selection`]).
//! Cost: one simulation per calibration parameter and per grid point, on
//! the short records.
//!
//! # Early stop of the screen
//! Step 2 is a Levenberg–Marquardt fit of 8 step attempts per stage, each
//! accepted step followed by one finite-difference Jacobian (one simulation
//! per parameter): most of a round's cost, and most of it spent creeping
//! near a point that will not pass. On the screening horizon the fit stops
//! at an iterate where it has stalled short of the screen
//! ([`ScreenStop`], [`crate::lsq::least_squares_until`]): the minimum of its
//! Gauss–Newton model ‖r + J·h‖² over the free parameters (bounds ignored)
//! would lower the short-record ΔIC by less than `ic` and leave it at or
//! above [`GIVE_UP_DIC`] = 0, both ΔICs counting the blocks by the
//! iterate's effective sample sizes (the prospect's residuals would
//! otherwise be weighted by their own autocorrelation, a different
//! criterion: [`ScreenStop`] says what that cost). Why a candidate that would have passed the
//! screen (ΔIC < −`ic`) still passes: each remaining Levenberg–Marquardt
//! step is a damped, bounded step of that same model, whose decrease it
//! predicts; to pass, the remaining steps would have to beat the model's
//! own minimum by more than `ic` while it promised less than `ic` more — a
//! linear model wrong by more than its whole promise. This is an argument
//! to first order, not a proof; checked on the nominal null, valve-delay
//! and seal-leak cases, where every candidate that passed the screen before
//! passes with the same ΔIC to the last digit (docs/discrepancy.md). A
//! candidate that does not stop runs exactly as before. Far from its
//! optimum, where the model's minimum is well below the iterate, the fit
//! goes on: a first version that stopped whenever the minimum did not pass
//! cut off `stribeck_friction` and `supply_droop` in the second round of
//! the valve-delay case (they start the screening stage thousands above
//! the reference and reach −1 854 and −714 by iterating). A stopped start
//! scores what it reached, so the ΔIC reported for a screened-out
//! candidate is where its screen stopped. An effect without parameters
//! (`real_gas`) is screened by a refit of the calibration on the screening
//! horizon from the current model's short-record optimum, without the
//! early stop: switched on, the effect first raises χ² and the
//! calibration must move to show what it gives, which the linear prospect
//! of the first iterate does not foresee (nominal `real_gas` seed 2:
//! stopped at short-record ΔIC +203, it goes on to a full-record −3 044
//! and is named); it is one fit of at most `screen_iter` step attempts.
//!
//! # Projected starts
//! A calibration bent to imitate a missing effect makes every start above
//! begin in that basin: at its optimum the effect's true size *raises* χ²
//! (the bending already does the effect's work), the scan ranks the
//! effect's weakest grid point first, and from rate 0 the calibration and
//! the effect must move together along a curved valley that the screen's
//! few iterations do not cross (the adiabatic model's wall heat exchange,
//! docs/discrepancy.md "Screen stop on one set of sizes"). The projected
//! scan above already knows the calibration's first-order answer to each
//! grid point g: δu = −J⁺ r(θ̂, g), the Gauss–Newton step of the
//! calibration from θ̂ in the fit's scaled coordinates
//! ([`ProjectionBase::answer`]). So in every round (the current model's
//! calibration, with the effects named so far, is the one bent), a
//! candidate that the screen would drop (short-record ΔIC not below
//! −`ic`) while its projected score is below −`ic` gets one more start
//! ([`retry_projected`]; given to every candidate so scored, it changed
//! the fit of candidates that passed anyway — a valve delay fitted into
//! another optimum with a spurious second effect after it, a leak behind a
//! named delay that lost its name — measured): θ̂ + δu at its
//! best projected grid point (each parameter clamped to its bounds), the
//! effect at that point —
//! the effect and the unbent calibration moved together, as the valley
//! runs. An effect with shape parameters (the seal leak's law, the
//! Stribeck velocity, the supply line's volume) gets one such start per
//! shape value whose best point scores below −`ic`, as its ordinary starts
//! are one per shape value ([`pick_starts`]): the linear answer can rank a
//! law best that the nonlinear fit cannot reach (an orifice leak behind a
//! named delay, projected best as the linear law at 1 L/(min·bar), is
//! found from the orifice law's own best point; docs/discrepancy.md
//! "Projected starts per shape value"). Each is fitted through the
//! short-record stages like the other starts and the best is kept only if
//! it scores better by the screen's criterion, so a linear answer that
//! overshoots costs its fit and nothing else. Cost per round: the
//! calibration's Jacobian on the first short horizon (one simulation per
//! parameter), one short simulation per grid point of each candidate, and
//! one short-record fit per shape value of each candidate so started
//! (`Options::projected_start`, on by default; measured in
//! docs/discrepancy.md "Projected starts").
//!
//! # Recentred starts
//! The calibration can bend its form parameters (ISO 6358 indices, a
//! check valve's cracking pressure, laminar ratios) to imitate a missing
//! effect: a low subsonic index and a smaller valve slow the filling after
//! each switch as a valve delay does. Every start above then begins in
//! that basin, and the effect fits at its null. So each candidate gets one
//! more start ([`recentred`]): the current model's calibration with every
//! parameter that has a prior back at its prior centre (the netlist's
//! value), the effect at its best point of a scan of its grid from there
//! (one simulation per grid point on the short records), those parameters
//! held at their centres on the short records ([`hold_priors`]; left free
//! they bend back) and freed by the full-record fit; the best start is
//! kept by the screen's criterion as any other. The comparison stays fair because
//! the current model is given the same start at the beginning of each
//! round ([`crate::selection`], `recentre`): its short-record refit from
//! there replaces the short-record reference when its prior-penalised
//! cost is lower, and is continued on the full records, kept when the
//! full-record cost falls too — a better calibration is never credited to
//! an effect. That refit is a reference, not a start: every candidate's
//! starts (`prepare`'s `from`) are built from the current model's
//! optimum as it was before it (started from the refit, the valve delay
//! of nominal leak + delay 5 stopped at χ² 1.86 M instead of 0.66 M and
//! the leak behind it was lost; docs/discrepancy.md, "Candidates started
//! from the calibration, not from the round's reference", and "The
//! footprint test", which stops the spurious followers these starts let
//! in behind a Stribeck law). An effect
//! without parameters (`real_gas`) gets the start as
//! a refit of the calibration on the screening horizon from the recentred
//! values, those parameters held. On by default since 2026-11-29
//! (`Options::recentre`; docs/discrepancy.md, "Recentred starts on by
//! default").
//!
//! # Phase B: [`fit_full`], [`refit_fresh`], [`judge`]
//! The full-record fit from the short-record solution, restarted while it
//! stops far above the noise and each restart still helps. If the round's
//! best candidate by this fit's ΔIC still stops far above the noise (χ²
//! above twice the number of samples), it is fitted once more from a
//! **fresh start** ([`fresh_start`], called by [`crate::selection`]):
//! every calibration parameter back at the calibration's own start, the
//! effect at the value just fitted, through the baseline calibration's
//! stages (first 15 % and 40 % of the records, then all of them); the fit
//! with the lower prior-penalised cost is kept. Every start above begins
//! at the current model's optimum, and a calibration that has bent its
//! form parameters (ISO 6358 indices, the check valve's cracking pressure,
//! laminar ratios) and its friction to imitate the missing effect holds the
//! continuation in that basin: the effect then fits at a fraction of its
//! size (a seal leak at a fifth of the truth, measured). The baseline was
//! calibrated from the same start, so the comparison stays like with like.
//! Cost: one staged calibration (≈ 500–1 000 simulations, measured) per round, for
//! one candidate only (given to every candidate so stopped, it doubled
//! the run time of a seal-leak case); `Options::fresh_start` turns it off.
//! Then the parameter test: at least one parameter with a null value lies more than
//! `z_null` correlation-aware standard errors from it (its 95 % interval
//! excludes the null by a margin), and no parameter with a null sits at a
//! bound other than that null.

use crate::effects::{scan_grid, Effect, Resolution, Scale};
use crate::fit::{block_stats, chi2, fit_once, fit_short_stages, fit_staged, screen_horizon, Fit, FitOptions, ScreenStop, Staged};
use crate::heldout::HeldOut;
use crate::options::Options;
use crate::params::{effect_params, FitParam, Target};
use crate::problem::Problem;
use crate::stats::{delta_ic, BlockStats};

use graph::FlatNetlist;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// The short-record reference of a model: parameters and block statistics
/// on the screening horizon.
#[derive(Debug, Clone)]
pub struct Short {
    pub values: Vec<f64>,
    pub stats: BlockStats,
}

/// A fitted model structure.
#[derive(Clone)]
pub struct Structure<'a> {
    pub effects: Vec<&'a dyn Effect>,
    pub params: Vec<FitParam>,
    pub fit: Fit,
    /// Held-out errors, once computed.
    pub heldout: Option<HeldOut>,
    /// The screening reference, if known.
    pub short: Option<Short>,
}

impl Structure<'_> {
    /// "baseline" or "a+b".
    pub fn label(&self) -> String {
        if self.effects.is_empty() {
            "baseline".into()
        } else {
            self.names().join("+")
        }
    }
    /// Names of the effects, in order.
    pub fn names(&self) -> Vec<String> {
        self.effects.iter().map(|e| e.name().to_string()).collect()
    }
}

/// The fitting problem of a structure.
pub fn problem_for<'a>(
    base: &'a FlatNetlist,
    experiments: &'a [crate::experiment::Experiment],
    effects: Vec<&'a dyn Effect>,
    params: Vec<FitParam>,
    opts: &Options,
) -> Problem<'a> {
    Problem::new(base, experiments, effects, params, opts.sim, opts.sensors, opts.fit_interval)
}

/// The better of a short-stage fit and the final values evaluated on the
/// screening horizon: the reference a candidate must beat on short records.
pub fn short_reference(problem: &Problem, staged: Option<&Fit>, values: &[f64], opts: &Options) -> Option<Short> {
    let h = screen_horizon(&opts.fit)?;
    let short = problem.truncated(h);
    let at_final = short.residuals(values).ok().map(|r| Short { values: values.to_vec(), stats: block_stats(&short, &r) });
    let staged = staged.map(|f| Short { values: f.values.clone(), stats: f.stats.clone() });
    better_short(staged, at_final)
}

/// The baseline's calibration, from `start`.
///
/// A form parameter fitted on its distance from a limit ([`Scale::LogGap`],
/// the ISO 6358 laminar ratio) adds a direction in which Levenberg–Marquardt
/// can leave the basin the nested calibration (that parameter at its
/// netlist value, the prior's centre) would have found: measured on the
/// shipped discrepancy example, the direct calibration with the laminar
/// ratios free ended at normalised RMSEs 6.87 / 13.34 / 5.20 against
/// 4.14 / 11.84 / 4.58 without them (docs/discrepancy.md, "Laminar ratio
/// calibrated"). So, when the calibration has such parameters, the baseline
/// is calibrated twice — directly, and as a continuation: the nested model
/// first (those parameters held at their starting values), then all
/// parameters freed from its optimum on the full records — and the
/// calibration with the lower prior-penalised cost ([`penalised_cost`]) is
/// kept. The continuation can only lower the nested model's cost (each
/// accepted step of the fit does), so the kept calibration is never worse
/// than the nested one, nor than the direct one. Cost: about one more
/// calibration, only for models that have such parameters.
pub fn calibrate_baseline(problem: &Problem, start: &[f64], opts: &FitOptions) -> Result<Staged, String> {
    let direct = fit_staged(problem, start, opts)?;
    let loose: Vec<usize> =
        problem.params.iter().enumerate().filter(|(_, p)| p.scale == Scale::LogGap && p.prior.is_some()).map(|(i, _)| i).collect();
    let Some(direct_fit) = direct.fit.as_ref() else { return Ok(direct) };
    if loose.is_empty() {
        return Ok(direct);
    }
    let mut nested = problem.clone();
    for &i in &loose {
        nested.params[i].lo = start[i];
        nested.params[i].hi = start[i];
    }
    let inner = fit_staged(&nested, start, opts)?;
    let Some(inner_fit) = inner.fit.as_ref() else { return Ok(direct) };
    let freed = fit_once(problem, &inner_fit.values, opts)?;
    let evaluations = direct.evaluations + inner.evaluations + freed.evaluations;
    let cost = |f: &Fit| penalised_cost(&problem.params, &f.values, &f.stats);
    if cost(direct_fit) <= cost(&freed) {
        Ok(Staged { evaluations, ..direct })
    } else {
        Ok(Staged { fit: Some(freed), short: inner.short, evaluations })
    }
}

/// The short-record reference with the lower χ² (either, when one is missing).
pub fn better_short(a: Option<Short>, b: Option<Short>) -> Option<Short> {
    match (a, b) {
        (Some(a), Some(b)) => Some(if a.stats.chi2_total() <= b.stats.chi2_total() { a } else { b }),
        (a, b) => a.or(b),
    }
}

/// A fitted parameter, as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    pub name: String,
    /// SI value.
    pub value: f64,
    pub unit: String,
    /// Value in `unit` (when the unit converts).
    pub shown: Option<f64>,
    /// Linearised, correlation-aware standard error [SI].
    pub std_error: Option<f64>,
    /// 95 % confidence interval [SI] (symmetric in the fit coordinate),
    /// clipped to the bounds; for a parameter at a bound, one-sided: from
    /// that bound to the 95 % limit on the other side.
    pub ci95: Option<(f64, f64)>,
    /// `ci95` in `unit` (when the unit converts), beside `shown`.
    pub shown_ci95: Option<(f64, f64)>,
    pub lo: f64,
    pub hi: f64,
    pub at_bound: bool,
}

fn display(value: f64, unit: &str) -> Option<f64> {
    if unit.is_empty() {
        return Some(value);
    }
    units::to_unit(value, unit).ok().filter(|v| v.is_finite())
}

/// The 95 % interval of a parameter at `v` (fit coordinate `u`, standard
/// error `s` in it), within its bounds. At a bound the estimate is not
/// normally distributed around its value: the interval runs from the bound
/// to the one-sided 95 % limit (1.645 s) on the other side.
fn interval(p: &FitParam, u: f64, s: f64, v: f64, at_bound: bool) -> (f64, f64) {
    let clip = |x: f64| if x.is_nan() { x } else { x.clamp(p.lo.min(p.hi), p.hi.max(p.lo)) };
    if at_bound {
        let (a, b) = (clip(p.from_u(u - 1.645 * s)), clip(p.from_u(u + 1.645 * s)));
        let at_lo = (v - p.lo).abs() <= (p.hi - v).abs();
        return if at_lo { (p.lo, a.max(b)) } else { (a.min(b), p.hi) };
    }
    let (a, b) = (clip(p.from_u(u - 1.96 * s)), clip(p.from_u(u + 1.96 * s)));
    (a.min(b), a.max(b))
}

/// Estimates with intervals of every parameter of a fit.
pub fn estimates(params: &[FitParam], f: &Fit) -> Vec<Estimate> {
    params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let su = f.std_u.as_ref().and_then(|s| s.get(i).copied()).filter(|s| s.is_finite());
            let v = f.values[i];
            let at_bound = f.at_bound.get(i).copied().unwrap_or(false);
            let (se, ci) = match su {
                Some(s) => {
                    let se = match p.scale {
                        Scale::Linear => s * p.typical,
                        Scale::Log => s * v.abs(),
                        Scale::LogGap => s * (1.0 - v).abs(),
                    };
                    (Some(se), Some(interval(p, f.u[i], s, v, at_bound)))
                }
                None => (None, None),
            };
            Estimate {
                name: p.name.clone(),
                value: v,
                unit: p.unit.clone(),
                shown: display(v, &p.unit),
                std_error: se,
                ci95: ci,
                shown_ci95: ci.and_then(|(a, b)| Some((display(a, &p.unit)?, display(b, &p.unit)?))),
                lo: p.lo,
                hi: p.hi,
                at_bound,
            }
        })
        .collect()
}

/// One candidate tried, as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    pub round: usize,
    pub effect: String,
    /// Effect parameters [SI].
    pub params: BTreeMap<String, f64>,
    pub estimates: Vec<Estimate>,
    /// ΔIC on effective sample sizes against the current model (on the
    /// short records when screened out).
    pub delta_ic: f64,
    pub chi2: f64,
    /// Held-out normalised RMSE of the model with the effect.
    pub heldout_rmse: f64,
    /// Held-out mean square removed, in noise variances.
    pub heldout_gain: f64,
    /// Held-out gain divided by the held-out remainder above the noise (the floor test).
    pub floor_ratio: f64,
    /// Held-out gain as a fraction of the current model's held-out mean square.
    pub heldout_relative: f64,
    /// Fraction of the current model's excess χ² (above N) removed.
    pub gap_explained: f64,
    /// ΔIC of the generic correction with as many parameters, fitted on the
    /// same data (the sham test, [`crate::sham`]); NaN when not computed.
    pub sham_delta_ic: f64,
    pub accepted: bool,
    /// Why it was not accepted (empty when it passed every test).
    pub reasons: Vec<String>,
    /// The tests it failed, by name: `fit`, `screen`, `parameter`, `bound`,
    /// `information_criterion`, `heldout_gain`, `model_form_floor`,
    /// `practical_size`, `sham`, `remainder`.
    pub failed: Vec<String>,
    /// Remarks that do not reject it (a shape parameter at a bound).
    pub notes: Vec<String>,
    pub evaluations: usize,
    /// How the candidate's least-squares fit ended.
    pub fit_message: String,
    /// Stopped after the short-record stage.
    pub screened_out: bool,
}

impl Candidate {
    /// Record a failed test and why.
    pub fn fail(&mut self, test: &str, why: String) {
        if !self.failed.iter().any(|t| t == test) {
            self.failed.push(test.to_string());
        }
        self.reasons.push(why);
    }

    /// A candidate of `round` before any test.
    pub fn new(round: usize, effect: &str) -> Self {
        Candidate {
            round,
            effect: effect.to_string(),
            params: BTreeMap::new(),
            estimates: vec![],
            delta_ic: f64::NAN,
            chi2: f64::NAN,
            heldout_rmse: f64::NAN,
            heldout_gain: f64::NAN,
            floor_ratio: f64::NAN,
            heldout_relative: f64::NAN,
            gap_explained: 0.0,
            sham_delta_ic: f64::NAN,
            accepted: false,
            reasons: vec![],
            failed: vec![],
            notes: vec![],
            evaluations: 0,
            fit_message: String::new(),
            screened_out: false,
        }
    }
}

/// A candidate after phase A.
pub struct Prepared<'a> {
    pub effects: Vec<&'a dyn Effect>,
    pub params: Vec<FitParam>,
    pub added: Vec<FitParam>,
    pub problem: Problem<'a>,
    /// The best short-record result over the starting points.
    pub short: Option<Staged>,
    /// ΔIC against the current model on the short records.
    pub short_dic: f64,
    pub cand: Candidate,
}

/// Which round a candidate is prepared for, and whether as the first
/// round's rescue (started from the current model's short-record optimum).
#[derive(Debug, Clone, Copy)]
pub struct Pass {
    pub round: usize,
    pub rescue: bool,
}

/// Short name of an effect parameter: without the effect's name
/// ("piston_seal_leak.C" → "C", a user effect's "bypass.leak.k" → "leak.k";
/// effect names have no dot).
pub fn short_name(p: &FitParam) -> String {
    p.name.split_once('.').map_or(p.name.as_str(), |(_, rest)| rest).to_string()
}

/// Phase A (see the module header). `from` is the current model's
/// calibration the candidate starts from: its full-record optimum before
/// the round's recentred refit (module header, "Recentred starts").
pub fn prepare<'a>(
    base: &'a FlatNetlist,
    experiments: &'a [crate::experiment::Experiment],
    current: &Structure<'a>,
    from: &[f64],
    effect: &'a dyn Effect,
    pass: Pass,
    opts: &Options,
) -> Prepared<'a> {
    let slot = current.effects.len();
    let mut effects = current.effects.clone();
    effects.push(effect);
    let added = effect_params(effect, slot);
    let mut params = current.params.clone();
    params.extend(added.iter().cloned());
    let mut start = from.to_vec();
    start.extend(added.iter().map(|p| p.start));
    let problem = problem_for(base, experiments, effects.clone(), params.clone(), opts);
    let mut cand = Candidate::new(pass.round, effect.name());
    let horizon = screen_horizon(&opts.fit).unwrap_or(1.0);
    let grid = scan_grid(&effect.params());
    let mut starts = vec![start];
    if !added.is_empty() && grid.len() > 1 {
        let scan_problem = problem.truncated(horizon);
        let base_values = match (pass.rescue, &current.short) {
            (true, Some(s)) => s.values.as_slice(),
            _ => from,
        };
        let mut scored: Vec<(f64, Vec<f64>)> = grid
            .par_iter()
            .filter_map(|g| {
                let mut v = base_values.to_vec();
                v.extend(g.iter().copied());
                Some((chi2(&scan_problem, &v).ok()?, v))
            })
            .collect();
        cand.evaluations += grid.len();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        let picked = pick_starts(scored, &added, opts.starts);
        if !picked.is_empty() {
            starts = picked;
        }
    }
    // the recentred start (module header, "Recentred starts"): the
    // calibration's form parameters back at their prior centres, the
    // effect at its best scan point
    // (the grid scanned again there: at a bent calibration the best grid
    // point is the effect's weakest, which the bending already imitates)
    let mut recentred_start = false;
    if opts.recentre && !pass.rescue {
        if let Some(centred) = recentred(&current.params, from) {
            let mut from = centred.clone();
            from.extend(added.iter().map(|p| p.start));
            if !added.is_empty() && grid.len() > 1 {
                let scan_problem = problem.truncated(horizon);
                let best = grid
                    .par_iter()
                    .filter_map(|g| {
                        let mut v = centred.clone();
                        v.extend(g.iter().copied());
                        Some((chi2(&scan_problem, &v).ok()?, v))
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                cand.evaluations += grid.len();
                if let Some((_, v)) = best {
                    from = v;
                }
            }
            starts.push(from);
            recentred_start = true;
        }
    }
    let fit_opts = if pass.rescue {
        FitOptions {
            horizons: screen_horizon(&opts.fit).into_iter().collect(),
            screen: screen_stop(current, added.len(), opts),
            ..opts.fit.clone()
        }
    } else {
        screen_fit_options(current, added.len(), opts)
    };
    // An effect without parameters is screened from the current model's
    // short-record optimum only (below), not refitted from its full-record values.
    let nests = added.iter().all(|p| p.null.is_some()) && current.short.is_some();
    let mut shorts: Vec<Result<Staged, String>> = if added.is_empty() && nests {
        Vec::new()
    } else {
        // the recentred start (the last) holds its form parameters at their
        // prior centres on the short records: left free there they bend
        // back into the basin it was meant to leave; the full-record fit
        // frees them
        let held = recentred_start.then(|| hold_priors(&problem, starts.last().expect("the recentred start")));
        let last = starts.len() - 1;
        starts
            .par_iter()
            .enumerate()
            .map(|(i, st)| match (&held, i == last) {
                (Some(h), true) => fit_short_stages(h, st, &fit_opts),
                _ => fit_short_stages(&problem, st, &fit_opts),
            })
            .collect()
    };
    // The candidate nests the current model (every added parameter at its
    // null value gives the current model back): one more start, the current
    // model's own short-record optimum with the effect switched off, fitted
    // on the screening horizon only. Least squares never ends above its
    // start, so the candidate's short-record χ² is at most the reference's
    // and a nested candidate cannot score a positive short-record ΔIC
    // beyond its parameter penalty (the continuation from the full-record
    // values can settle in another, worse minimum of the position-triggered
    // cycles). Effects with a shape parameter (no null) get no such start:
    // tried for supply_droop, stribeck_friction and piston_seal_leak it cost
    // 11 % more simulations on the valve-delay case, whose second-round
    // candidates then iterate from it (docs/discrepancy.md, "Run time").
    // An effect without parameters starts there too, with the effect on:
    // its screen is a refit of the calibration on the screening horizon
    // from the current optimum, without the early stop (module header,
    // "Early stop of the screen").
    if let (Some(reference), true) = (&current.short, nests) {
        let mut nested = reference.values.clone();
        nested.extend(added.iter().map(|p| p.null.unwrap_or(p.start)));
        let mut last_stage = FitOptions { horizons: vec![horizon], ..fit_opts.clone() };
        if added.is_empty() {
            last_stage.screen = None;
        }
        shorts.push(fit_short_stages(&problem, &nested, &last_stage));
        // an effect without parameters gets its recentred start the same
        // way: the refit on the screening horizon, from the calibration's
        // form parameters at their prior centres, held there
        if added.is_empty() && recentred_start {
            let from = starts.last().expect("the recentred start");
            shorts.push(fit_short_stages(&hold_priors(&problem, from), from, &last_stage));
        }
    }
    cand.evaluations += shorts.iter().map(|r| r.as_ref().map_or(0, |s| s.evaluations)).sum::<usize>();
    let mut errors: Vec<String> = shorts.iter().filter_map(|r| r.as_ref().err().cloned()).collect();
    // the best start by the screen's own criterion: the short-record ΔIC
    // against the current model (per-block, on effective sizes), which can
    // rank two fits differently from their total χ²; χ² without a reference
    let score = |s: &Staged| -> f64 {
        let Some(b) = s.short.as_ref() else { return f64::INFINITY };
        match &current.short {
            Some(a) if a.stats.n == b.stats.n => delta_ic(&a.stats.chi2, &b.stats.chi2, &b.stats.n_eff(), 0),
            _ => b.chi2,
        }
    };
    let short = shorts.into_iter().filter_map(|r| r.ok()).min_by(|a, b| score(a).total_cmp(&score(b)));
    if short.is_none() {
        errors.dedup();
        cand.fail("fit", format!("fit failed: {}", errors.join("; ")));
    }
    let short_dic = short.as_ref().and_then(|s| short_delta_ic(current, s, added.len())).unwrap_or(f64::NAN);
    if let Some(s) = short.as_ref() {
        note_effect_values(&mut cand, &params, &added, s);
    }
    Prepared { effects, params, added, problem, short, short_dic, cand }
}

/// The screen's early stop against the current model's short-record fit
/// (module header, "Early stop"); `None` without one.
fn screen_stop(current: &Structure<'_>, added: usize, opts: &Options) -> Option<ScreenStop> {
    current.short.as_ref().map(|s| ScreenStop {
        reference: s.stats.clone(),
        added: added as isize,
        threshold: GIVE_UP_DIC,
        stall: opts.thresholds.ic,
    })
}

/// The screen's fit options: `opts.screen_iter` iterations per stage and
/// the early stop against the current model.
fn screen_fit_options(current: &Structure<'_>, added: usize, opts: &Options) -> FitOptions {
    FitOptions { stage_max_iter: opts.screen_iter, screen: screen_stop(current, added, opts), ..opts.fit.clone() }
}

/// A screen's short-record ΔIC against the current model (per block, on
/// effective sample sizes, `added` parameters penalised); `None` when
/// either has no short-record result or their records differ in length.
fn short_delta_ic(current: &Structure<'_>, staged: &Staged, added: usize) -> Option<f64> {
    let (a, b) = (current.short.as_ref()?, staged.short.as_ref()?);
    (a.stats.n == b.stats.n).then(|| delta_ic(&a.stats.chi2, &b.stats.chi2, &b.stats.n_eff(), added as isize))
}

/// The effect's parameters at a screen's short-record optimum, written
/// into the candidate's row by their short names.
fn note_effect_values(cand: &mut Candidate, params: &[FitParam], added: &[FitParam], staged: &Staged) {
    if let Some(v) = staged.values_short() {
        let first = params.len() - added.len();
        for (q, x) in added.iter().zip(&v[first..]) {
            cand.params.insert(short_name(q), *x);
        }
    }
}

/// The projected starts of a candidate the screen would drop (module
/// header, "Projected starts"): its short-record stages once more from
/// each of `starts` (the calibration's Gauss–Newton answer to the effect at
/// the best projected grid point of each shape value), the best of them
/// kept when its short-record ΔIC is lower than the candidate's best so
/// far. A candidate without a short-record result is returned as it came,
/// and so are starts of the wrong length.
pub fn retry_projected<'a>(current: &Structure<'a>, mut p: Prepared<'a>, starts: &[Vec<f64>], opts: &Options) -> Prepared<'a> {
    let starts: Vec<&Vec<f64>> = starts.iter().filter(|s| s.len() == p.params.len()).collect();
    if current.short.is_none() || p.short.is_none() || starts.is_empty() {
        return p;
    }
    let fit_opts = screen_fit_options(current, p.added.len(), opts);
    let fits: Vec<Result<Staged, String>> = starts.par_iter().map(|start| fit_short_stages(&p.problem, start, &fit_opts)).collect();
    let mut best: Option<(f64, Staged)> = None;
    for fit in fits {
        let staged = match fit {
            Ok(staged) => staged,
            Err(e) => {
                p.cand.notes.push(format!("the projected start's screen failed: {e}"));
                continue;
            }
        };
        p.cand.evaluations += staged.evaluations;
        if let Some(dic) = short_delta_ic(current, &staged, p.added.len()) {
            if best.as_ref().is_none_or(|(b, _)| dic < *b) {
                best = Some((dic, staged));
            }
        }
    }
    let Some((dic, staged)) = best else { return p };
    if dic < p.short_dic || p.short_dic.is_nan() {
        p.cand.notes.push(format!("screened from the projected start (short-record ΔIC {:.1} → {dic:.1})", p.short_dic));
        note_effect_values(&mut p.cand, &p.params, &p.added, &staged);
        p.short = Some(staged);
        p.short_dic = dic;
    }
    p
}

/// `values` with every calibration parameter that has a prior (the form
/// parameters of [`crate::params::default_calibration`], a manifest's
/// priors, a vessel's initial state) back at its prior centre, clamped to
/// its bounds; `None` when none of them moved from it. Effect parameters
/// are left as they are.
pub fn recentred(params: &[FitParam], values: &[f64]) -> Option<Vec<f64>> {
    let mut out = values.to_vec();
    let mut moved = false;
    for (p, v) in params.iter().zip(out.iter_mut()) {
        if let (Some(prior), false) = (p.prior, p.is_effect()) {
            let c = prior.center.clamp(p.lo.min(p.hi), p.hi.max(p.lo));
            moved |= *v != c;
            *v = c;
        }
    }
    moved.then_some(out)
}

/// `problem` with every calibration parameter that has a prior held at its
/// value in `values` (bounds lo = hi), as shape parameters are held in the
/// short-record stages.
pub fn hold_priors<'a>(problem: &Problem<'a>, values: &[f64]) -> Problem<'a> {
    let mut held = problem.clone();
    for (p, v) in held.params.iter_mut().zip(values) {
        if p.prior.is_some() && !p.is_effect() {
            p.lo = *v;
            p.hi = *v;
        }
    }
    held
}

/// The prior-penalised cost of a fit at `values`: the data and sensor
/// rows' χ² (`stats`) plus the squared prior rows of the parameters that
/// have a prior — what the least squares minimises, so that two starts of
/// the same model are ranked by the fit's own objective.
pub fn penalised_cost(params: &[FitParam], values: &[f64], stats: &BlockStats) -> f64 {
    let prior: f64 = params.iter().zip(values).filter_map(|(p, v)| p.prior_row(*v)).map(|r| r * r).sum();
    stats.chi2_total() + prior
}

/// What the projected scan says of one effect.
#[derive(Debug, Clone)]
pub struct ProjectedScore {
    /// The best ΔIC over the effect's scan grid (+∞ when no point ran).
    pub dic: f64,
    /// Simulations run.
    pub sims: usize,
    /// The projected starts, best first, each with its projected ΔIC: for
    /// each combination of the effect's shape values (one for an effect
    /// without shape parameters) the best grid point, the calibration moved
    /// by its Gauss–Newton answer to that point's residuals, the effect's
    /// parameters at the point (module header, "Projected starts").
    pub starts: Vec<(f64, Vec<f64>)>,
}

/// The projected-scan score of `effect` on top of `current` (see the module
/// header). `reference` is [`calibration_jacobian`] of the current model.
pub fn projected_scan(
    base: &FlatNetlist,
    experiments: &[crate::experiment::Experiment],
    current: &Structure,
    effect: &dyn Effect,
    reference: &ProjectionBase,
    opts: &Options,
) -> ProjectedScore {
    let slot = current.effects.len();
    let mut effects = current.effects.clone();
    effects.push(effect);
    let added = effect_params(effect, slot);
    let mut params = current.params.clone();
    params.extend(added.iter().cloned());
    let problem = problem_for(base, experiments, effects, params, opts).truncated(reference.horizon);
    let mut grid = scan_grid(&effect.params());
    if added.is_empty() {
        grid = vec![vec![]];
    }
    let scores: Vec<(f64, Option<Vec<f64>>)> = grid
        .par_iter()
        .map(|g| {
            let mut v = reference.values.clone();
            v.extend(g.iter().copied());
            let Ok(r) = problem.residuals(&v) else { return (f64::INFINITY, None) };
            if r.len() != reference.residuals.len() {
                return (f64::INFINITY, None);
            }
            let projected = reference.project(&r);
            let stats = block_stats(&problem, &projected);
            let dic = delta_ic(&reference.stats.chi2, &stats.chi2, &stats.n_eff(), added.len() as isize);
            let mut start = reference.answer(&current.params, &r);
            start.extend(g.iter().copied());
            (dic, Some(start))
        })
        .collect();
    let mut scored: Vec<(f64, Vec<f64>)> =
        scores.into_iter().filter_map(|(d, start)| Some((d, start?))).filter(|(d, _)| d.is_finite()).collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let dic = scored.first().map_or(f64::INFINITY, |(d, _)| *d);
    ProjectedScore { dic, sims: grid.len(), starts: best_per_shape(scored, &added) }
}

/// The best of `scored` (sorted, best first; each point the whole parameter
/// vector, the effect's `added` parameters last) for each combination of
/// the effect's shape values (parameters without a null, held on the short
/// records, so each shape value is its own sub-problem: [`pick_starts`]),
/// best first; the best point alone for an effect without shape parameters.
fn best_per_shape(scored: Scored, added: &[FitParam]) -> Scored {
    split_by_shape(scored, added).0
}

/// Scan points, each the whole parameter vector with its score.
type Scored = Vec<(f64, Vec<f64>)>;

/// `scored` (sorted, best first) split into the best point of each
/// combination of shape values, best first, and the rest in order.
fn split_by_shape(scored: Scored, added: &[FitParam]) -> (Scored, Scored) {
    let first = scored.first().map_or(0, |(_, v)| v.len() - added.len());
    let shape: Vec<usize> = added.iter().enumerate().filter(|(_, p)| p.null.is_none()).map(|(i, _)| first + i).collect();
    let mut seen: Vec<Vec<u64>> = Vec::new();
    let (mut best, mut rest) = (Vec::new(), Vec::new());
    for (d, v) in scored {
        let key: Vec<u64> = shape.iter().map(|&i| v[i].to_bits()).collect();
        if seen.contains(&key) {
            rest.push((d, v));
        } else {
            seen.push(key);
            best.push((d, v));
        }
    }
    (best, rest)
}

/// What the projected scan of a round needs from the current model: its
/// short-record values, residuals and statistics, and the projector onto
/// its calibration's Jacobian.
pub struct ProjectionBase {
    pub horizon: f64,
    pub values: Vec<f64>,
    pub residuals: Vec<f64>,
    pub stats: BlockStats,
    /// Orthonormal basis of the Jacobian's column space.
    basis: nalgebra::DMatrix<f64>,
    /// The Jacobian's pseudo-inverse J⁺ (one row per column of J) …
    pinv: nalgebra::DMatrix<f64>,
    /// … and the calibration parameter of each column (in the fit's scaled
    /// coordinates; fixed parameters have none).
    columns: Vec<usize>,
}

impl ProjectionBase {
    /// The base at `values` with residuals `residuals` and the Jacobian's
    /// columns, each with the index of its calibration parameter (columns
    /// as long as the residuals). The statistics are left empty for the
    /// caller. `None` when the decomposition fails.
    pub fn new(horizon: f64, values: Vec<f64>, residuals: Vec<f64>, columns: Vec<(usize, Vec<f64>)>) -> Option<Self> {
        let m = residuals.len();
        let (index, cols): (Vec<usize>, Vec<Vec<f64>>) = columns.into_iter().unzip();
        let (basis, pinv) = if cols.is_empty() {
            (nalgebra::DMatrix::zeros(m, 0), nalgebra::DMatrix::zeros(0, m))
        } else {
            let j = nalgebra::DMatrix::from_fn(m, cols.len(), |r, c| cols[c][r]);
            let svd = j.svd(true, true);
            let smax = svd.singular_values.max();
            let keep: Vec<usize> = (0..svd.singular_values.len()).filter(|&i| svd.singular_values[i] > 1e-9 * smax).collect();
            let uu = svd.u?;
            let vt = svd.v_t?;
            let basis = nalgebra::DMatrix::from_fn(m, keep.len(), |r, c| uu[(r, keep[c])]);
            // J⁺ = V Σ⁻¹ Uᵀ over the kept singular values
            let pinv = nalgebra::DMatrix::from_fn(cols.len(), m, |i, r| {
                keep.iter().map(|&k| vt[(k, i)] * uu[(r, k)] / svd.singular_values[k]).sum()
            });
            (basis, pinv)
        };
        Some(ProjectionBase {
            horizon,
            values,
            residuals,
            stats: BlockStats { chi2: vec![], n: vec![], tau: vec![] },
            basis,
            pinv,
            columns: index,
        })
    }

    /// `r` with its component in the calibration's column space removed.
    pub fn project(&self, r: &[f64]) -> Vec<f64> {
        let v = nalgebra::DVector::from_column_slice(r);
        let c = self.basis.transpose() * &v;
        (v - &self.basis * c).iter().copied().collect()
    }

    /// The calibration's Gauss–Newton answer to residuals `r` (same rows
    /// as the reference's): the reference values moved by δu = −J⁺r in the
    /// fit's scaled coordinates, each clamped to its bounds. `params` are
    /// the calibration's parameters, in the reference's order.
    pub fn answer(&self, params: &[FitParam], r: &[f64]) -> Vec<f64> {
        let mut values = self.values.clone();
        if self.pinv.nrows() == 0 || r.len() != self.pinv.ncols() {
            return values;
        }
        let step = -(&self.pinv * nalgebra::DVector::from_column_slice(r));
        for (k, &j) in self.columns.iter().enumerate() {
            let (Some(p), Some(v)) = (params.get(j), values.get_mut(j)) else { continue };
            let u = p.to_u(*v) + step[k];
            if u.is_finite() {
                *v = p.from_u(u).clamp(p.lo, p.hi);
            }
        }
        values
    }
}

/// The projection base of `current` on the screening horizon: residuals at
/// its short-record optimum and the finite-difference Jacobian of its
/// calibration there (one simulation per parameter). Returns it and the
/// simulations run; `None` without a screening horizon or when the
/// simulation fails.
pub fn calibration_jacobian(
    base: &FlatNetlist,
    experiments: &[crate::experiment::Experiment],
    current: &Structure,
    opts: &Options,
) -> Option<(ProjectionBase, usize)> {
    // the first short horizon: before position-triggered strokes alias, where
    // a linear answer of the calibration is a fair stand-in for its refit
    let horizon = opts.fit.horizons.iter().copied().find(|h| *h > 0.0 && *h < 1.0)?;
    let values = current.short.as_ref().map_or_else(|| current.fit.values.clone(), |s| s.values.clone());
    let problem = problem_for(base, experiments, current.effects.clone(), current.params.clone(), opts).truncated(horizon);
    let r0 = problem.residuals(&values).ok()?;
    let u: Vec<f64> = problem.params.iter().zip(&values).map(|(p, &v)| p.to_u(v)).collect();
    let columns: Vec<Option<Vec<f64>>> = (0..u.len())
        .into_par_iter()
        .map(|j| {
            let p = &problem.params[j];
            let (lo, hi) = (p.to_u(p.lo), p.to_u(p.hi));
            if lo >= hi {
                return None;
            }
            let step = opts.fit.fd_step * u[j].abs().max(1.0);
            let h = if u[j] + step <= hi { step } else { -step };
            let mut uu = u.clone();
            uu[j] += h;
            let r = problem.residuals(&problem.values_of(&uu)).ok()?;
            (r.len() == r0.len()).then(|| r.iter().zip(&r0).map(|(a, b)| (a - b) / h).collect())
        })
        .collect();
    let columns: Vec<(usize, Vec<f64>)> = columns.into_iter().enumerate().filter_map(|(j, c)| Some((j, c?))).collect();
    let mut base = ProjectionBase::new(horizon, values, r0, columns)?;
    // the reference is projected too: the calibration's own linear answer is not the effect's
    let projected = base.project(&base.residuals);
    base.stats = block_stats(&problem, &projected);
    Some((base, 1 + u.len()))
}

/// Starting points from a scored scan grid (best first; each point is the
/// whole parameter vector, the effect's `added` parameters last).
///
/// Without shape parameters: the best point. With them: the best point of
/// every combination of shape values, best first, then the next best points
/// up to `starts` in all. Shape parameters are held during the short-record
/// stages, so each shape value is its own sub-problem; and the scan runs at
/// the current calibration, which may have bent to mimic the effect (a
/// supply droop absorbed into friction and throttle), so that the scan ranks
/// the weakest grid point first whatever its shape — one start per shape
/// value keeps the right one in play.
fn pick_starts(scored: Vec<(f64, Vec<f64>)>, added: &[FitParam], starts: usize) -> Vec<Vec<f64>> {
    if added.iter().all(|p| p.null.is_some()) {
        return scored.into_iter().take(1).map(|(_, v)| v).collect();
    }
    let (picked, rest) = split_by_shape(scored, added);
    let more = starts.saturating_sub(picked.len());
    picked.into_iter().chain(rest.into_iter().take(more)).map(|(_, v)| v).collect()
}

/// The screen's early stop: a candidate's screening stage ends at an iterate
/// where even the Gauss–Newton model's minimum would leave its short-record
/// ΔIC at or above this (module header, "Early stop"). The screen needs
/// ΔIC below −`ic` (−10 by default); 0 leaves a margin of `ic` for the
/// error of the linear model.
pub const GIVE_UP_DIC: f64 = 0.0;

/// A candidate stopped after phase A.
pub fn screened(mut p: Prepared, why: String) -> Candidate {
    p.cand.screened_out = true;
    p.cand.delta_ic = p.short_dic;
    p.cand.fit_message = "screened out after the short-record stages".into();
    p.cand.fail("screen", why);
    p.cand
}

/// χ²/N above which a candidate's full-record fit is restarted.
const RESTART_CHI2_PER_SAMPLE: f64 = 2.0;
/// The fresh start of a candidate's full-record fit: every calibration
/// parameter back at the calibration's own start (as the baseline was
/// calibrated), the effects' parameters at `values`.
pub fn fresh_start(params: &[FitParam], values: &[f64]) -> Vec<f64> {
    params.iter().zip(values).map(|(p, v)| if matches!(p.target, Target::Effect { .. }) { *v } else { p.start }).collect()
}

/// At most this many restarts of a candidate's full-record fit.
const MAX_RESTARTS: usize = 3;

/// A candidate fitted on the full records, before its tests (phase B).
pub struct Fitted<'a> {
    pub effects: Vec<&'a dyn Effect>,
    pub params: Vec<FitParam>,
    /// How many of `params` (the last ones) the candidate adds.
    pub added: usize,
    pub problem: Problem<'a>,
    pub short: Staged,
    pub fit: Fit,
    pub cand: Candidate,
}

impl Fitted<'_> {
    /// ΔIC of the full-record fit against the current model.
    pub fn delta_ic(&self, current: &Structure) -> f64 {
        delta_ic(&current.fit.stats.chi2, &self.fit.stats.chi2, &self.fit.stats.n_eff(), self.added as isize)
    }
    /// Whether the fit stops far above the noise (χ²/N above 2).
    pub fn far_above_noise(&self) -> bool {
        self.fit.chi2 > RESTART_CHI2_PER_SAMPLE * self.fit.residuals.len().max(1) as f64
    }
}

/// Phase B's fit: from the short-record solution on the full records,
/// restarted while it stops far above the noise and each restart helps.
pub fn fit_full<'a>(current: &Structure<'a>, prep: Prepared<'a>, opts: &Options) -> Result<Fitted<'a>, Box<Candidate>> {
    let Prepared { effects, params, added, problem, short, mut cand, .. } = prep;
    let Some(short) = short else { return Err(Box::new(cand)) };

    let fit_opts = FitOptions { stage_max_iter: opts.screen_iter, ..opts.fit.clone() };
    let from = short
        .values_short()
        .map(<[f64]>::to_vec)
        .unwrap_or_else(|| current.fit.values.iter().copied().chain(added.iter().map(|p| p.start)).collect());
    let mut f = match fit_once(&problem, &from, &fit_opts) {
        Ok(f) => f,
        Err(e) => {
            cand.fail("fit", format!("fit failed: {e}"));
            return Err(Box::new(cand));
        }
    };
    cand.evaluations += f.evaluations;
    let n_res = f.residuals.len().max(1) as f64;
    // Restart while the fit stops far above the noise level and each restart
    // still lowers χ² by more than 1 %: near an event (the stick → slip switch
    // of a breakaway) the finite-difference Jacobian is poor and
    // Levenberg–Marquardt's step test can end the fit where it stands.
    for _ in 0..MAX_RESTARTS {
        if f.chi2 <= RESTART_CHI2_PER_SAMPLE * n_res {
            break;
        }
        let Ok(g) = fit_once(&problem, &f.values, &fit_opts) else { break };
        cand.evaluations += g.evaluations;
        let progress = g.chi2 < 0.99 * f.chi2;
        if g.chi2 < f.chi2 {
            f = g;
        }
        if !progress {
            break;
        }
    }
    Ok(Fitted { effects, params, added: added.len(), problem, short, fit: f, cand })
}

/// The fresh start (module header, "Phase B"): the candidate fitted again
/// from the calibration's own start with its effects at their fitted
/// values, through the calibration's stages; kept when its prior-penalised
/// cost is lower. A failed fresh fit leaves the candidate as it was.
pub fn refit_fresh(fitted: &mut Fitted, opts: &Options) {
    let fresh = fresh_start(&fitted.params, &fitted.fit.values);
    let Ok(staged) = fit_staged(&fitted.problem, &fresh, &opts.fit) else { return };
    fitted.cand.evaluations += staged.evaluations;
    let Staged { fit: Some(g), short, evaluations } = staged else { return };
    let cost = |x: &Fit| penalised_cost(&fitted.params, &x.values, &x.stats);
    if cost(&g) < cost(&fitted.fit) {
        fitted.cand.notes.push(format!(
            "fitted from the calibration's own start (χ² {:.1}; continued from the current model's optimum it stopped at {:.1})",
            g.chi2, fitted.fit.chi2
        ));
        fitted.fit = g;
        // the short-record reference of the next round and of the polish
        // comes from the same basin
        fitted.short = Staged { fit: None, short, evaluations };
    }
}

/// Phase B's tests: ΔIC, the share of the gap explained, the parameter,
/// bound and practical-size tests.
pub fn judge<'a>(current: &Structure<'a>, fitted: Fitted<'a>, opts: &Options) -> (Option<Structure<'a>>, Candidate) {
    let dic = fitted.delta_ic(current);
    let Fitted { effects, params, added, problem, short, fit: f, mut cand } = fitted;
    let n_res = f.residuals.len().max(1) as f64;
    let first = params.len() - added;
    let th = &opts.thresholds;
    cand.fit_message = f.message.clone();
    cand.chi2 = f.chi2;
    cand.delta_ic = dic;
    let excess = current.fit.chi2 - n_res;
    cand.gap_explained = if excess > 0.0 { (current.fit.chi2 - f.chi2) / excess } else { 0.0 };
    let est = estimates(&params, &f);
    cand.estimates = est[first..].to_vec();
    cand.params = params[first..].iter().zip(&cand.estimates).map(|(p, e)| (short_name(p), e.value)).collect();
    // the parameter test
    let with_null: Vec<usize> = (first..params.len()).filter(|&i| params[i].null.is_some()).collect();
    if !with_null.is_empty() {
        match &f.std_u {
            None => cand.fail("parameter", "parameters not identifiable (singular covariance)".into()),
            Some(std) => {
                let best_z = with_null
                    .iter()
                    .filter_map(|&i| {
                        let p = &params[i];
                        let s = std[i];
                        (s > 0.0 && s.is_finite()).then(|| (f.u[i] - p.to_u(p.null.unwrap_or(0.0))).abs() / s)
                    })
                    .fold(0.0_f64, f64::max);
                if best_z < th.z_null {
                    cand.fail(
                        "parameter",
                        format!(
                            "parameter within {best_z:.1} standard errors of its null value (needs {}; correlation-aware errors)",
                            th.z_null
                        ),
                    );
                }
            }
        }
    }
    for (i, p) in params.iter().enumerate().skip(first) {
        let (ulo, uhi) = (p.to_u(p.lo), p.to_u(p.hi));
        let margin = th.bound_margin * (uhi - ulo);
        for (b, ub) in [(p.lo, ulo), (p.hi, uhi)] {
            if (f.u[i] - ub).abs() <= margin && p.null != Some(b) {
                if p.null.is_some() {
                    cand.fail("bound", format!("{} at its bound {}", p.name, b));
                } else {
                    cand.notes.push(format!("shape parameter {} at its bound {}", p.name, b));
                }
            }
        }
    }
    // the practical-size test (test 5 of crate::selection)
    if let Some(effect) = effects.last() {
        if let Some(why) = below_least_size(*effect, &f.values[first..], &opts.resolution()) {
            cand.fail("practical_size", why);
        }
    }
    // its footprint against the sensors' accuracy (the same test's other half, crate::footprint)
    if th.footprint > 0.0 && !cand.failed.iter().any(|t| t == "practical_size") {
        let tau = opts.switch_latency;
        let footprint = crate::footprint::of_last_effect(&problem, &f.values, added, tau);
        // two simulations of each experiment (with and without the effect)
        cand.evaluations += 2 * problem.included().len();
        match footprint {
            Ok(fp) => {
                cand.notes.push(crate::footprint::describe(&fp));
                if let Some(why) = crate::footprint::within_accuracy(&fp, th.footprint, tau) {
                    cand.fail("practical_size", why);
                }
            }
            Err(e) => cand.notes.push(format!("footprint not measured: {e}")),
        }
    }
    let short_ref = short_reference(&problem, short.short.as_ref(), &f.values, opts);
    let s = Structure { effects, params, fit: f, heldout: None, short: short_ref };
    (Some(s), cand)
}

/// The practical-size test (test 5 of [`crate::selection`]): why an effect
/// fitted at `values` (SI, in the order of [`Effect::params`]) is below
/// every one of its least sizes ([`Effect::least_size`]); `None` when it
/// reaches one of them or declares none.
pub fn below_least_size(effect: &dyn Effect, values: &[f64], resolution: &Resolution) -> Option<String> {
    let sizes = effect.least_size(resolution);
    let params = effect.params();
    let mut why = Vec::new();
    for s in &sizes {
        let (p, v) = (params.get(s.param)?, *values.get(s.param)?);
        if (v - p.null.unwrap_or(0.0)).abs() >= s.size {
            return None;
        }
        let show = |x: f64| match units::to_unit(x, &p.unit) {
            Ok(u) => format!("{} {}", crate::params::significant(u, 3), p.unit),
            Err(_) => format!("{} (SI)", crate::params::significant(x, 3)),
        };
        why.push(format!("{} {} is below the {} {}", p.name, show(v), show(s.size), s.why));
    }
    (!why.is_empty()).then(|| format!("practical size: {}; not named", why.join(", and ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::EffectParam;
    use crate::params::effect_params;

    #[test]
    fn a_valve_delay_below_the_switching_resolution_is_not_of_practical_size() {
        let delay = crate::effects::ValveDelay;
        let resolution = Options::default().resolution();
        assert_eq!(resolution.switch_latency, 1e-3);
        // varied null seed 6: a 0.134 ms "delay" that passed every statistical
        // test, the rig's limit-switch latency (0 … 0.2 ms) absorbed
        let why = below_least_size(&delay, &[0.134e-3], &resolution).expect("below the least size");
        assert!(why.contains("T 0.134 ms is below the 1 ms timing resolution of the switching instant"), "{why}");
        // a solenoid valve's delay (5–30 ms) and one just above the resolution are of practical size
        assert_eq!(below_least_size(&delay, &[15e-3], &resolution), None);
        assert_eq!(below_least_size(&delay, &[1.01e-3], &resolution), None);
        // a rig whose switching is timed to 0.1 ms resolves a 0.134 ms delay; 0 s switches the rule off
        assert_eq!(below_least_size(&delay, &[0.134e-3], &Resolution { switch_latency: 0.1e-3 }), None);
        assert_eq!(below_least_size(&delay, &[0.134e-3], &Resolution { switch_latency: 0.0 }), None);
        // effects without a least size are never held back by it
        assert_eq!(below_least_size(&crate::effects::DeadVolume, &[1e-9, 0.0], &resolution), None);
    }

    #[test]
    fn an_estimate_at_a_bound_gets_a_one_sided_interval_inside_the_bounds() {
        // a log-scaled conductance pushed onto its lower bound, with the
        // standard error a flat direction gives (the interval was
        // [6e-107, 1.6e104] L/min/bar before)
        let p = FitParam {
            name: "piston_seal_leak.C".into(),
            unit: "L/min/bar".into(),
            lo: 1e-15,
            hi: 1e-9,
            start: 1e-12,
            typical: 1e-12,
            scale: Scale::Log,
            null: Some(0.0),
            target: crate::params::Target::Effect { slot: 0, k: 0 },
            prior: None,
        };
        let v = 1e-15;
        let (a, b) = interval(&p, p.to_u(v), 120.0, v, true);
        assert_eq!((a, b), (1e-15, 1e-9));
        let (a, b) = interval(&p, p.to_u(v), 0.5, v, true);
        assert!(a == 1e-15 && b > v && b < 1e-14, "[{a}, {b}]");
        // away from the bounds: symmetric in the fit coordinate, inside the bounds
        let (a, b) = interval(&p, p.to_u(1e-12), 0.1, 1e-12, false);
        assert!((a * b / 1e-24 - 1.0).abs() < 1e-9 && a > 1e-15 && b < 1e-9);
        let (a, b) = interval(&p, p.to_u(5e-10), 3.0, 5e-10, false);
        assert!(b == 1e-9 && a > 1e-15, "clipped: [{a}, {b}]");
    }

    fn calibrated(name: &str, value: f64, prior: Option<(f64, f64)>) -> FitParam {
        FitParam {
            name: name.into(),
            unit: String::new(),
            lo: 0.0,
            hi: 1.0,
            start: value,
            typical: 0.5,
            scale: Scale::Linear,
            null: None,
            target: crate::params::Target::Netlist { id: "dcv".into(), param: name.into(), experiments: None },
            prior: prior.map(|(center, sd)| crate::params::Prior { center, sd }),
        }
    }

    #[test]
    fn the_projected_start_is_the_calibrations_gauss_newton_answer_clamped_to_its_bounds() {
        // three parameters (the second fixed: no column), residuals r = J·d + w
        // with w orthogonal to J's columns: the answer moves the free
        // parameters by −d in scaled coordinates (u = v / typical = 2v) and
        // leaves the fixed one where it was
        let params = vec![calibrated("a", 0.3, None), calibrated("b", 0.5, None), calibrated("c", 0.4, None)];
        let c0 = vec![1.0, 0.0, 1.0, 0.0];
        let c2 = vec![0.0, 1.0, 1.0, 0.0];
        let w = [1.0, 1.0, -1.0, 5.0]; // orthogonal to both columns
        let d = [0.1, -0.2];
        let r: Vec<f64> = (0..4).map(|i| c0[i] * d[0] + c2[i] * d[1] + w[i]).collect();
        let base = ProjectionBase::new(0.15, vec![0.3, 0.5, 0.4], vec![0.0; 4], vec![(0, c0), (2, c2)]).unwrap();
        let v = base.answer(&params, &r);
        assert!((v[0] - (0.3 - 0.1 / 2.0)).abs() < 1e-12, "{v:?}");
        assert_eq!(v[1], 0.5);
        assert!((v[2] - (0.4 + 0.2 / 2.0)).abs() < 1e-12, "{v:?}");
        // the part of r the calibration cannot answer is what the projection keeps
        let kept = base.project(&r);
        for (k, wi) in kept.iter().zip(w) {
            assert!((k - wi).abs() < 1e-12, "{kept:?}");
        }
        // a step beyond a bound stops at the bound
        let far: Vec<f64> = r.iter().map(|x| 100.0 * x).collect();
        let v = base.answer(&params, &far);
        assert_eq!((v[0], v[2]), (0.0, 1.0));
    }

    #[test]
    fn a_fresh_start_takes_the_calibration_back_to_its_own_start_and_keeps_the_effects() {
        // varied piston_seal_leak seed 4: the calibration bent dcv.m (start
        // 0.5) to 0.40; the leak, continued from there, fitted at a fifth of
        // the truth. The fresh start: m at 0.5 again, C at its start 0.44,
        // the named delay and the leak where they were fitted.
        let mut params = vec![calibrated("C", 0.44, None), calibrated("m", 0.5, Some((0.5, 0.1)))];
        params.extend(effect_params(&crate::effects::ValveDelay, 0));
        params.extend(effect_params(&crate::effects::PistonSealLeak, 1));
        let fitted = [0.49, 0.40, 0.0108, 1.05e-11, 0.3];
        assert_eq!(fresh_start(&params, &fitted), vec![0.44, 0.5, 0.0108, 1.05e-11, 0.3]);
        // a baseline without effects goes back to its start entirely
        assert_eq!(fresh_start(&params[..2], &fitted[..2]), vec![0.44, 0.5]);
    }

    #[test]
    fn a_recentred_start_puts_the_form_parameters_back_at_their_prior_centres() {
        // varied valve_delay seed 2: the baseline bent dcv.m to its bound 0.25 (prior 0.5 ± 0.1)
        let mut params = vec![calibrated("C", 0.44, None), calibrated("m", 0.25, Some((0.5, 0.1)))];
        params.push(effect_params(&crate::effects::ValveDelay, 0).remove(0));
        params[2].prior = Some(crate::params::Prior { center: 0.0, sd: 1.0 });
        let v = recentred(&params, &[0.44, 0.25, 0.002]).expect("m moved");
        // the prior-less C and the effect parameter stay, m goes back to 0.5
        assert_eq!(v, vec![0.44, 0.5, 0.002]);
        // nothing to recentre: no second start
        assert_eq!(recentred(&params, &[0.44, 0.5, 0.002]), None);
        // a centre outside the bounds is clamped into them
        params[1].hi = 0.45;
        assert_eq!(recentred(&params, &[0.44, 0.25, 0.0]).unwrap()[1], 0.45);
    }

    #[test]
    fn the_recentred_start_holds_only_the_parameters_with_a_prior() {
        let flat = crate::netlist_edit::tests_support::meter_out();
        let d = crate::experiment::tests::dataset(&["head.p"], 20);
        let e = vec![crate::experiment::Experiment::from_dataset("e", &d, None, vec![], None, &[]).unwrap()];
        let params = crate::params::calibration_params(&flat, &e, &crate::params::default_calibration(&flat)).unwrap();
        let problem = problem_for(&flat, &e, vec![], params.clone(), &Options::default());
        let values: Vec<f64> = params.iter().map(|p| p.start).collect();
        let held = hold_priors(&problem, &values);
        for (p, (q, v)) in params.iter().zip(held.params.iter().zip(&values)) {
            if p.prior.is_some() {
                assert_eq!((q.lo, q.hi), (*v, *v), "{} held", p.name);
            } else {
                assert_eq!((q.lo, q.hi), (p.lo, p.hi), "{} free", p.name);
            }
        }
        assert!(params.iter().any(|p| p.prior.is_some()) && params.iter().any(|p| p.prior.is_none()));
    }

    #[test]
    fn two_starts_are_ranked_by_the_prior_penalised_cost() {
        let params = vec![calibrated("C", 0.44, None), calibrated("m", 0.25, Some((0.5, 0.1)))];
        let stats = |chi2: f64| BlockStats { chi2: vec![chi2], n: vec![100], tau: vec![1.0] };
        // bent: data χ² 100 but m 2.5 σ off (6.25); centred: data χ² 104
        let bent = penalised_cost(&params, &[0.44, 0.25], &stats(100.0));
        let centred = penalised_cost(&params, &[0.44, 0.5], &stats(104.0));
        assert!((bent - 106.25).abs() < 1e-9 && centred == 104.0, "{bent} {centred}");
        assert!(centred < bent, "the data χ² alone would keep the bent start");
    }

    #[derive(Debug)]
    struct Shaped;
    impl Effect for Shaped {
        fn name(&self) -> &'static str {
            "shaped"
        }
        fn summary(&self) -> &'static str {
            "a size with a null and a shape without"
        }
        fn params(&self) -> Vec<EffectParam> {
            vec![
                EffectParam {
                    name: "size".into(),
                    unit: String::new(),
                    lo: 0.0,
                    hi: 1.0,
                    start: 0.5,
                    typical: 0.5,
                    null: Some(0.0),
                    prior: None,
                    scale: Scale::Linear,
                    scan: vec![],
                },
                EffectParam {
                    name: "shape".into(),
                    unit: String::new(),
                    lo: 1.0,
                    hi: 3.0,
                    start: 2.0,
                    typical: 2.0,
                    null: None,
                    prior: None,
                    scale: Scale::Linear,
                    scan: vec![],
                },
            ]
        }
        fn applies_to(&self, _: &FlatNetlist) -> bool {
            true
        }
        fn apply(&self, _: &mut FlatNetlist, _: &[f64]) -> Result<(), crate::effects::EffectError> {
            Ok(())
        }
    }

    #[test]
    fn every_shape_value_gets_a_start_even_when_one_shape_ranks_first_throughout() {
        let added = effect_params(&Shaped, 0);
        // one calibration value, then (size, shape); the scan ranks shape 3 first at every size
        let scored = vec![
            (1.0, vec![9.0, 0.1, 3.0]),
            (2.0, vec![9.0, 0.2, 3.0]),
            (3.0, vec![9.0, 0.1, 2.0]),
            (4.0, vec![9.0, 0.1, 1.0]),
            (5.0, vec![9.0, 0.2, 1.0]),
        ];
        let starts = pick_starts(scored.clone(), &added, 2);
        assert_eq!(starts, vec![vec![9.0, 0.1, 3.0], vec![9.0, 0.1, 2.0], vec![9.0, 0.1, 1.0]]);
        // more starts asked for than shapes: the next best points fill up
        let starts = pick_starts(scored, &added, 4);
        assert_eq!(starts.len(), 4);
        assert_eq!(starts[3], vec![9.0, 0.2, 3.0]);
    }

    #[test]
    fn projected_starts_are_the_best_point_of_each_shape_value_best_first() {
        // the linear answer ranks shape 3 best at every size (as the leak's
        // linear law behind a named delay); the orifice-like shape 1 keeps
        // its own best point, with its own score
        let added = effect_params(&Shaped, 0);
        let scored = vec![
            (-359.0, vec![9.0, 1.0, 3.0]),
            (-284.0, vec![8.0, 0.3, 1.0]),
            (-220.0, vec![7.0, 0.3, 3.0]),
            (-137.0, vec![6.0, 0.3, 2.0]),
            (-94.0, vec![5.0, 0.1, 1.0]),
        ];
        let starts = best_per_shape(scored.clone(), &added);
        assert_eq!(starts, vec![scored[0].clone(), scored[1].clone(), scored[3].clone()]);
        // without shape parameters: the best point alone
        let sized = effect_params(&crate::effects::ValveDelay, 0);
        let one = vec![(-5.0, vec![9.0, 0.02]), (-3.0, vec![9.0, 0.01])];
        assert_eq!(best_per_shape(one.clone(), &sized), vec![one[0].clone()]);
    }
}
