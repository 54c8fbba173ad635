//! The discrepancy workflow: calibrate the baseline, diagnose its residuals,
//! try every candidate effect of the catalogue, select and name the missing
//! one(s), and show the gap shrink.
//!
//! # Steps
//! 1. **Calibrate**: bounded Levenberg–Marquardt ([`crate::lsq`]) on the
//!    noise-weighted output error over all experiments ([`crate::problem`]),
//!    from the netlist's values, with continuation over the record length
//!    (first 15 %, then 40 %, then all of every record; see
//!    [`FitOptions::horizons`]).
//! 2. **Diagnose** ([`crate::diagnose`]): per channel and per phase of the
//!    cycle, whiteness, correlation with candidate regressors.
//! 3. **Try candidates** (in parallel, rayon). For each applicable effect:
//!    (a) scan a small grid of its parameters with the calibration held at
//!    the current fit, on the first 40 % of the records; (b) from the best
//!    grid point(s) fit calibration and effect parameters together on the
//!    15 % and 40 % records (shape parameters held); (c) *screen*: only
//!    candidates whose ΔIC on the 40 % records beats −`screen_fraction`·ic
//!    (scaled by the share of samples) and reaches `screen_relative` of the
//!    best candidate's go on to (d) the fit on the full records.
//! 4. **Select**: a candidate passes when all hold:
//!    - information criterion: ΔIC = N·ln(χ²_e/χ²_0) + Δk·ln N < −`ic`
//!      (Schwarz's BIC for Gaussian errors of unknown common scale; χ² is
//!      the sum of squared noise-normalised residuals over the N fitted
//!      samples, Δk the number of added parameters);
//!    - its parameters: at least one parameter that has a null value lies
//!      more than `z_null` linearised standard errors from it, and no effect
//!      parameter sits within `bound_margin` (fraction of its fitted range)
//!      of a bound other than its null;
//!    - held-out error: the leave-one-experiment-out normalised RMSE (each
//!      experiment predicted by the parameters refitted without it; median
//!      over experiments, see [`HeldOut`]) drops by at least the fraction
//!      `heldout_gain` below the current model's (computed only for
//!      candidates passing the rest).
//!
//!    Among passing candidates the lowest ΔIC wins, unless the runner-up
//!    explains at least (1 − `ambiguity`) of the winner's χ² reduction:
//!    then the verdict is "ambiguous between A and B" and nothing more is
//!    added. The search repeats greedily from the augmented model (at most
//!    `max_effects` effects; a later round retries only effects that
//!    lowered the IC in the previous one).
//! 5. **Show**: before/after traces and statistics at full data resolution.
//!
//! The default thresholds were calibrated on synthetic data with nothing
//! hidden (see docs/discrepancy.md, "Thresholds").

use crate::diagnose::{diagnose, Diagnosis, Trace};
use crate::effects::{catalogue, Effect, Scale};
use crate::netlist_edit::{param_si, Topology};
use crate::phases::{classify, Phase};
use crate::problem::{
    calibration_params, chi2, effect_params, fit, fit_once, fit_short_stages, fit_staged, sample_channels, CalibSpec, Fit, FitOptions,
    FitParam, Problem, SimSettings, Staged, Target,
};
use graph::FlatNetlist;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

pub use crate::problem::Experiment;

/// Why the workflow could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    #[error("{0}")]
    Setup(String),
    #[error("baseline calibration failed: {0}")]
    Baseline(String),
    #[error("simulation for the report failed: {0}")]
    Report(String),
}

/// Acceptance thresholds of step 4.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Thresholds {
    /// Required decrease of the information criterion.
    pub ic: f64,
    /// Required relative decrease of the held-out normalised RMSE.
    pub heldout_gain: f64,
    /// Required distance of a parameter from its null, in standard errors.
    pub z_null: f64,
    /// Distance from a non-null bound, as a fraction of the fitted range, below which a parameter counts as at the bound.
    pub bound_margin: f64,
    /// Two candidates are ambiguous when the runner-up's χ² reduction is within this fraction of the winner's.
    pub ambiguity: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds { ic: 100.0, heldout_gain: 0.05, z_null: 4.0, bound_margin: 0.005, ambiguity: 0.1 }
    }
}

/// How held-out errors are computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeldOut {
    /// Forward validation: the parameters fitted on the first part of every
    /// record (the last short stage of the continuation, see
    /// [`FitOptions::horizons`]) predict the rest of the records; RMSE of
    /// the normalised residuals there. One extra simulation per model.
    Forward,
    /// Leave one experiment out, by one Gauss–Newton step from the full fit
    /// without experiment k: δ = −(J₋ₖᵀJ₋ₖ)⁻¹J₋ₖᵀr₋ₖ, prediction r_k + J_k·δ
    /// (no extra simulation; only as good as the linearisation).
    Linearized,
    /// Leave one experiment out, refitting without experiment k from the
    /// full fit (at most `max_iter` LM steps), then simulating experiment k;
    /// the median over experiments of their normalised RMSE.
    Refit { max_iter: usize },
}

/// Options of the workflow.
#[derive(Debug, Clone)]
pub struct Options {
    /// Spacing of the samples compared in the fits [s].
    pub fit_interval: f64,
    pub sim: SimSettings,
    pub fit: FitOptions,
    pub thresholds: Thresholds,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// Restrict the catalogue to these names.
    pub effects: Option<Vec<String>>,
    pub heldout: HeldOut,
    /// Compute full-resolution traces and diagnostics.
    pub report: bool,
    /// Step attempts of a candidate's short-record (screening) stages.
    pub screen_iter: usize,
    /// Starting points tried for effects with shape parameters (best of the scan grid).
    pub starts: usize,
    /// A candidate gets its full-record fit only if its short-record ΔIC is
    /// at least this fraction of the best candidate's (both negative).
    pub screen_relative: f64,
    /// A candidate gets its full-record fit only if its ΔIC after the
    /// short-record stage is already below −`screen_fraction`·`thresholds.ic`
    /// (`None`: every candidate gets the full fit).
    pub screen_fraction: Option<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            fit_interval: 4e-3,
            sim: SimSettings::default(),
            fit: FitOptions::default(),
            thresholds: Thresholds::default(),
            max_effects: 2,
            effects: None,
            heldout: HeldOut::Refit { max_iter: 6 },
            report: true,
            screen_iter: 8,
            starts: 2,
            screen_relative: 0.5,
            screen_fraction: Some(1.0),
        }
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
    /// Linearised standard error [SI].
    pub std_error: Option<f64>,
    /// 95 % confidence interval [SI] (symmetric in the fit coordinate).
    pub ci95: Option<(f64, f64)>,
    pub lo: f64,
    pub hi: f64,
    pub at_bound: bool,
}

/// A model (baseline or augmented) after fitting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelSummary {
    pub effects: Vec<String>,
    pub params: Vec<Estimate>,
    /// Σ(r/σ)² over the fitted samples.
    pub chi2: f64,
    /// Number of fitted residuals.
    pub n: usize,
    pub ic: f64,
    /// Leave-one-experiment-out normalised RMSE.
    pub heldout_rmse: f64,
    /// RMSE per channel at full resolution [SI].
    pub rmse: BTreeMap<String, f64>,
    /// Normalised RMSE per channel (1 = noise level).
    pub rmse_normalized: BTreeMap<String, f64>,
    pub diagnosis: Diagnosis,
    /// Whether the least-squares fit met a convergence test, and which.
    pub converged: bool,
    pub fit_message: String,
    pub fit_evaluations: usize,
}

/// One candidate tried.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    pub round: usize,
    pub effect: String,
    /// Effect parameters [SI].
    pub params: BTreeMap<String, f64>,
    pub estimates: Vec<Estimate>,
    pub heldout_rmse: f64,
    pub delta_ic: f64,
    pub chi2: f64,
    /// Fraction of the excess χ² (above its noise-only value N) removed.
    pub gap_explained: f64,
    pub accepted: bool,
    /// Why it was not accepted (empty when it passed every test).
    pub reasons: Vec<String>,
    pub evaluations: usize,
    /// How the candidate's least-squares fit ended.
    pub fit_message: String,
    /// Stopped after the short-record stage (its ΔIC is then an upper bound
    /// of what the full fit would give).
    pub screened_out: bool,
}

/// An effect added to the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Selected {
    pub effect: String,
    pub params: BTreeMap<String, f64>,
}

/// The workflow's result in numbers (the `--json` output).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub baseline: ModelSummary,
    pub candidates: Vec<Candidate>,
    pub selected: Vec<Selected>,
    pub verdict: String,
    /// Names when the last round was ambiguous.
    pub ambiguous: Vec<String>,
    pub after: ModelSummary,
    pub thresholds: Thresholds,
    /// Noise level used per experiment and channel [SI].
    pub noise: BTreeMap<String, BTreeMap<String, f64>>,
    /// Simulations of all experiments run by the fits.
    pub evaluations: usize,
    /// Wall time of the whole workflow and of its steps [s].
    pub seconds: f64,
    pub timing: BTreeMap<String, f64>,
}

/// Everything the workflow produced.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub summary: Summary,
    /// The baseline netlist with the calibrated values written in.
    pub baseline_netlist: FlatNetlist,
    /// (label, netlist): the final model, and each ambiguous alternative.
    pub augmented: Vec<(String, FlatNetlist)>,
    /// Full-resolution traces of the calibrated baseline and of the final model.
    pub before: Vec<Trace>,
    pub after: Vec<Trace>,
}

/// A fitted model structure.
#[derive(Clone)]
struct Structure<'a> {
    effects: Vec<&'a dyn Effect>,
    params: Vec<FitParam>,
    fit: Fit,
    heldout: f64,
    /// Best χ² known on the last short-record stage (the screening reference).
    chi2_short: Option<f64>,
    /// Parameters after the short-record stages (forward held-out prediction).
    values_short: Option<Vec<f64>>,
}

/// Compute a structure's held-out RMSE if not done yet; returns simulations spent.
fn ensure_heldout(base: &FlatNetlist, experiments: &[Experiment], s: &mut Structure, opts: &Options) -> Result<usize, String> {
    if s.heldout.is_finite() {
        return Ok(0);
    }
    let problem = Problem::new(base, experiments, s.effects.clone(), s.params.clone(), opts.sim, opts.fit_interval);
    let (h, e) = heldout(&problem, &s.fit, s.values_short.as_deref(), opts)?;
    s.heldout = h;
    Ok(e)
}

/// The short-record horizon used for screening (the last short stage).
fn screen_horizon(opts: &Options) -> Option<f64> {
    opts.fit.horizons.iter().copied().filter(|h| *h > 0.0 && *h < 1.0).fold(None, |m: Option<f64>, h| Some(m.map_or(h, |x| x.max(h))))
}

/// min(stage χ², χ² of the final values) on the screening horizon.
fn short_reference(problem: &Problem, staged: Option<f64>, values: &[f64], opts: &Options) -> Option<f64> {
    let h = screen_horizon(opts)?;
    let at_final = chi2(&problem.truncated(h), values).ok();
    match (staged, at_final) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

fn ic(chi2: f64, n: usize, k: usize) -> f64 {
    let n = n as f64;
    n * (chi2 / n).max(f64::MIN_POSITIVE).ln() + k as f64 * n.ln()
}

fn display(value: f64, unit: &str) -> Option<f64> {
    if unit.is_empty() {
        return Some(value);
    }
    units::to_unit(value, unit).ok().filter(|v| v.is_finite())
}

fn estimates(params: &[FitParam], f: &Fit) -> Vec<Estimate> {
    params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let su = f.std_u.as_ref().and_then(|s| s.get(i).copied()).filter(|s| s.is_finite());
            let v = f.values[i];
            let (se, ci) = match su {
                Some(s) => {
                    let (a, b) = (p.from_u(f.u[i] - 1.96 * s), p.from_u(f.u[i] + 1.96 * s));
                    let se = match p.scale {
                        Scale::Linear => s * p.typical,
                        Scale::Log => s * v.abs(),
                    };
                    (Some(se), Some((a.min(b), a.max(b))))
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
                lo: p.lo,
                hi: p.hi,
                at_bound: f.at_bound.get(i).copied().unwrap_or(false),
            }
        })
        .collect()
}

fn heldout_linearized(problem: &Problem, f: &Fit) -> f64 {
    let rows: Vec<std::ops::Range<usize>> = problem.layout().into_iter().map(|(_, r)| r).collect();
    linearized_rows(f, &rows)
}

/// Linearised leave-one-block-out RMSE for blocks of rows of the residual vector.
fn linearized_rows(f: &Fit, rows: &[std::ops::Range<usize>]) -> f64 {
    let free: Vec<usize> = (0..f.u.len()).filter(|&j| !f.at_bound.get(j).copied().unwrap_or(false)).collect();
    let r = &f.residuals;
    let m = r.len();
    let nf = free.len();
    let jf = DMatrix::from_fn(m, nf, |i, j| f.jacobian[(i, free[j])]);
    let rv = DVector::from_column_slice(r);
    let a_full = jf.transpose() * &jf;
    let g_full = jf.transpose() * &rv;
    let ridge = 1e-10 * a_full.trace().max(f64::MIN_POSITIVE);
    let (mut sq, mut n) = (0.0, 0usize);
    for block in rows {
        let jk = jf.rows(block.start, block.len()).into_owned();
        let rk = rv.rows(block.start, block.len()).into_owned();
        if nf == 0 {
            sq += rk.norm_squared();
            n += rk.len();
            continue;
        }
        let mut a = &a_full - jk.transpose() * &jk;
        for d in 0..nf {
            a[(d, d)] += ridge;
        }
        let g = &g_full - jk.transpose() * &rk;
        let delta = match a.clone().cholesky() {
            Some(ch) => ch.solve(&(-g)),
            None => a.svd(true, true).solve(&(-g), 1e-12).unwrap_or_else(|_| DVector::zeros(nf)),
        };
        let pred = &rk + &jk * delta;
        sq += pred.norm_squared();
        n += pred.len();
    }
    if n == 0 {
        0.0
    } else {
        (sq / n as f64).sqrt()
    }
}

fn heldout_refit(problem: &Problem, f: &Fit, opts: &FitOptions, max_iter: usize) -> Result<(f64, usize), String> {
    let all = problem.included();
    if all.len() < 2 {
        return Ok(((f.chi2 / f.residuals.len().max(1) as f64).sqrt(), 0));
    }
    let folds: Vec<Result<(f64, usize, usize), String>> = all
        .par_iter()
        .map(|&k| {
            let mut p = problem.with_included(all.iter().copied().filter(|&j| j != k).collect());
            let o = FitOptions { max_iter, horizons: vec![1.0], ..opts.clone() };
            let g = if p.params.is_empty() { None } else { Some(fit(&p, &f.values, &o)?) };
            let values = g.as_ref().map(|g| g.values.clone()).unwrap_or_default();
            p.included = Some(vec![k]);
            let rk = p.residuals(&values)?;
            Ok((rk.iter().map(|x| x * x).sum::<f64>(), rk.len(), g.map(|g| g.evaluations).unwrap_or(0)))
        })
        .collect();
    // the median over folds of each held-out experiment's normalised RMSE:
    // one fold whose simulation goes astray (e.g. a stall near the
    // breakaway limit) does not decide the comparison alone
    let mut per_fold = Vec::new();
    let mut ev = 0;
    for fold in folds {
        let (s, k, e) = fold?;
        per_fold.push((s / k.max(1) as f64).sqrt());
        ev += e;
    }
    Ok((crate::data::median(&mut per_fold).unwrap_or(f64::NAN), ev))
}

/// What a round concludes from the candidates that passed every test.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Decision {
    None,
    /// Add the candidate with this index.
    Select(usize),
    /// The best two explain the gap equally.
    Ambiguous(usize, usize),
}

/// Pick among passing candidates given as (ΔIC, χ²): the lowest ΔIC wins
/// unless the runner-up's χ² reduction is within `ambiguity` (a fraction) of
/// the winner's.
fn decide(passing: &[(f64, f64)], chi2_current: f64, ambiguity: f64) -> Decision {
    let mut order: Vec<usize> = (0..passing.len()).collect();
    order.sort_by(|&a, &b| passing[a].0.total_cmp(&passing[b].0));
    match order.as_slice() {
        [] => Decision::None,
        [a] => Decision::Select(*a),
        [a, b, ..] => {
            let gain = |i: usize| chi2_current - passing[i].1;
            if gain(*b) >= (1.0 - ambiguity) * gain(*a) {
                Decision::Ambiguous(*a, *b)
            } else {
                Decision::Select(*a)
            }
        }
    }
}

/// Run the workflow on `base` (the model as given) and the experiments.
/// `calibrate` lists the baseline parameters to fit (see
/// [`crate::problem::default_calibration`]).
pub fn run(base: &FlatNetlist, experiments: &[Experiment], calibrate: &[CalibSpec], opts: &Options) -> Result<Outcome, IdentifyError> {
    let clock = std::time::Instant::now();
    if experiments.is_empty() {
        return Err(IdentifyError::Setup("no experiments".into()));
    }
    let all = catalogue();
    if let Some(names) = &opts.effects {
        for n in names {
            if !all.iter().any(|e| e.name() == n) {
                return Err(IdentifyError::Setup(format!("unknown effect \"{n}\" (known: {})", crate::effects::names().join(", "))));
            }
        }
    }
    let pool: Vec<&dyn Effect> =
        all.iter().map(|e| e.as_ref()).filter(|e| opts.effects.as_ref().is_none_or(|v| v.iter().any(|n| n == e.name()))).collect();
    let calib = calibration_params(base, experiments, calibrate).map_err(IdentifyError::Setup)?;
    let mut evaluations = 0usize;

    // 1. baseline
    let p0 = Problem::new(base, experiments, vec![], calib.clone(), opts.sim, opts.fit_interval);
    // check the channels against the model once, with a clear message
    p0.residuals(&calib.iter().map(|p| p.start).collect::<Vec<_>>()).map_err(IdentifyError::Setup)?;
    let start: Vec<f64> = calib.iter().map(|p| p.start).collect();
    let staged0 = fit_staged(&p0, &start, &opts.fit, None).map_err(IdentifyError::Baseline)?;
    evaluations += staged0.evaluations;
    let f0 = staged0.fit.ok_or_else(|| IdentifyError::Baseline("no full-record stage".into()))?;
    let short0 = short_reference(&p0, staged0.chi2_short, &f0.values, opts);
    let mut timing = BTreeMap::new();
    timing.insert("calibration".to_string(), clock.elapsed().as_secs_f64());
    let n_res = f0.residuals.len();
    // held-out errors are computed only when a candidate needs the comparison
    let mut baseline = Structure {
        effects: vec![],
        params: calib.clone(),
        fit: f0,
        heldout: f64::NAN,
        chi2_short: short0,
        values_short: staged0.values_short,
    };

    // 3-4. candidates, greedily
    let mut current = baseline.clone();
    let mut candidates = Vec::new();
    let mut selected = Vec::new();
    let mut ambiguous: Vec<String> = Vec::new();
    let mut alternatives: Vec<Structure> = Vec::new();
    for round in 1..=opts.max_effects {
        let probe = Problem::new(base, experiments, current.effects.clone(), current.params.clone(), opts.sim, opts.fit_interval)
            .netlist(0, &current.fit.values)
            .map_err(IdentifyError::Setup)?;
        // after the first round, only effects that improved the previous
        // round's model somewhat (ΔIC < 0) are tried again (greedy pruning)
        let helped =
            |name: &str| round == 1 || candidates.iter().any(|c: &Candidate| c.round == round - 1 && c.effect == name && c.delta_ic < 0.0);
        let tried: Vec<&dyn Effect> = pool
            .iter()
            .copied()
            .filter(|e| !current.effects.iter().any(|c| c.name() == e.name()) && e.applies_to(&probe) && helped(e.name()))
            .collect();
        if tried.is_empty() {
            break;
        }
        let round_clock = std::time::Instant::now();
        // phase A for every candidate, then phase B for those that pass the
        // screen: an absolute improvement on the first part of the records,
        // and at least `screen_relative` of the best candidate's improvement
        let mut preps: Vec<Prepared> =
            tried.par_iter().map(|e| prepare(base, experiments, &current, *e, Pass { round, rescue: false }, n_res, opts)).collect();
        let mut best_short = best_short_dic(&preps);
        // Rescue (first round): the baseline's calibration on the full
        // records stopped without converging and no candidate improved on the
        // first part of the records. Then the candidates, started from that
        // calibration, may simply not have reached the baseline's own
        // short-record optimum in the screening budget (a strong missing
        // effect drags the calibration away on the full records); start them
        // from that optimum instead.
        if current.effects.is_empty() && !current.fit.converged && best_short >= 0.0 && current.values_short.is_some() {
            preps = tried.par_iter().map(|e| prepare(base, experiments, &current, *e, Pass { round, rescue: true }, n_res, opts)).collect();
            best_short = best_short_dic(&preps);
        }
        let results: Vec<(Option<Structure>, Candidate)> = preps
            .into_par_iter()
            .map(|p| {
                if p.short.is_none() {
                    return (None, p.cand);
                }
                if opts.screen_fraction.is_some() {
                    if p.short_dic.is_nan() || p.short_dic >= p.screen_at {
                        let why = format!(
                            "screened out: ΔIC = {:.1} on the first part of the records is not below {:.1}",
                            p.short_dic, p.screen_at
                        );
                        return (None, screened(p, why));
                    }
                    if best_short < 0.0 && p.short_dic > opts.screen_relative * best_short {
                        let why = format!(
                            "screened out: ΔIC = {:.1} on the first part of the records is less than {} of the best candidate's {:.1}",
                            p.short_dic, opts.screen_relative, best_short
                        );
                        return (None, screened(p, why));
                    }
                }
                finish(&current, p, n_res, opts)
            })
            .collect();
        timing.insert(format!("round {round}"), round_clock.elapsed().as_secs_f64());
        // held-out test for the candidates that passed everything else
        let mut results = results;
        if results.iter().any(|(s, c)| s.is_some() && c.accepted) {
            let e = ensure_heldout(base, experiments, &mut current, opts).map_err(IdentifyError::Baseline)?;
            evaluations += e;
            if current.effects.is_empty() {
                baseline.heldout = current.heldout;
            }
            let reference = current.heldout;
            results.par_iter_mut().for_each(|(s, c)| {
                let Some(s) = s.as_mut().filter(|_| c.accepted) else { return };
                match ensure_heldout(base, experiments, s, opts) {
                    Ok(e) => c.evaluations += e,
                    Err(e) => c.reasons.push(format!("held-out prediction failed: {e}")),
                }
                c.heldout_rmse = s.heldout;
                let gain = opts.thresholds.heldout_gain;
                if s.heldout.is_nan() || s.heldout > reference * (1.0 - gain) {
                    c.reasons.push(format!("held-out RMSE {:.3} not below {reference:.3} × (1 − {gain})", s.heldout));
                }
                c.accepted = c.reasons.is_empty();
            });
        }
        let mut passing: Vec<(Structure, Candidate)> = Vec::new();
        for (s, c) in results {
            evaluations += c.evaluations;
            if let (Some(s), true) = (s.clone(), c.accepted) {
                passing.push((s, c.clone()));
            }
            candidates.push(c);
        }
        if passing.is_empty() {
            break;
        }
        passing.sort_by(|a, b| a.1.delta_ic.total_cmp(&b.1.delta_ic));
        let scores: Vec<(f64, f64)> = passing.iter().map(|(_, c)| (c.delta_ic, c.chi2)).collect();
        if let Decision::Ambiguous(a, b) = decide(&scores, current.fit.chi2, opts.thresholds.ambiguity) {
            ambiguous = vec![passing[a].1.effect.clone(), passing[b].1.effect.clone()];
            alternatives = vec![passing[a].0.clone(), passing[b].0.clone()];
            break;
        }
        let (s, c) = passing.swap_remove(0);
        selected.push(Selected { effect: c.effect.clone(), params: c.params.clone() });
        current = s;
    }

    let verdict = if !ambiguous.is_empty() {
        let prefix = if selected.is_empty() {
            String::new()
        } else {
            format!(
                "missing effect{}: {}; then ",
                if selected.len() > 1 { "s" } else { "" },
                selected.iter().map(|s| s.effect.as_str()).collect::<Vec<_>>().join(", ")
            )
        };
        format!("{prefix}ambiguous between {} and {}", ambiguous[0], ambiguous[1])
    } else if selected.is_empty() {
        "no missing effect found".to_string()
    } else {
        format!(
            "missing effect{}: {}",
            if selected.len() > 1 { "s" } else { "" },
            selected.iter().map(|s| s.effect.as_str()).collect::<Vec<_>>().join(", then ")
        )
    };

    // 5. report
    let report_clock = std::time::Instant::now();
    let (before, baseline_summary) = summarize(base, experiments, &baseline, n_res, None, opts)?;
    let phases: Vec<Vec<Phase>> = before.iter().map(|t| t.phases.clone()).collect();
    let (after, after_summary) = if selected.is_empty() {
        (before.clone(), baseline_summary.clone())
    } else {
        summarize(base, experiments, &current, n_res, Some(&phases), opts)?
    };
    let mut augmented = vec![(label(&current), written_netlist(base, experiments, &current)?)];
    for alt in &alternatives {
        augmented.push((label(alt), written_netlist(base, experiments, alt)?));
    }
    timing.insert("report".to_string(), report_clock.elapsed().as_secs_f64());
    let noise = experiments.iter().map(|e| (e.name.clone(), e.channels.iter().map(|c| (c.signal.clone(), c.sigma)).collect())).collect();
    let summary = Summary {
        baseline: baseline_summary,
        candidates,
        selected,
        verdict,
        ambiguous,
        after: after_summary,
        thresholds: opts.thresholds,
        noise,
        evaluations,
        seconds: clock.elapsed().as_secs_f64(),
        timing,
    };
    Ok(Outcome { summary, baseline_netlist: written_netlist(base, experiments, &baseline)?, augmented, before, after })
}

fn label(s: &Structure) -> String {
    if s.effects.is_empty() {
        "baseline".into()
    } else {
        s.effects.iter().map(|e| e.name()).collect::<Vec<_>>().join("+")
    }
}

fn heldout(problem: &Problem, f: &Fit, values_short: Option<&[f64]>, opts: &Options) -> Result<(f64, usize), String> {
    match (opts.heldout, values_short, screen_horizon(opts)) {
        (HeldOut::Forward, Some(v), Some(h)) => {
            let r = problem.tail(h).residuals(v)?;
            Ok(((r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt(), 1))
        }
        (HeldOut::Refit { max_iter }, _, _) => heldout_refit(problem, f, &opts.fit, max_iter),
        _ => Ok((heldout_linearized(problem, f), 0)),
    }
}

/// A candidate after the scan and the short-record stages (phase A).
struct Prepared<'a> {
    effects: Vec<&'a dyn Effect>,
    params: Vec<FitParam>,
    added: Vec<FitParam>,
    problem: Problem<'a>,
    /// The best short-record result over the starting points.
    short: Option<Staged>,
    /// ΔIC against the current model on the first part of the records.
    short_dic: f64,
    /// The screening threshold on `short_dic`.
    screen_at: f64,
    cand: Candidate,
}

/// The lowest finite short-record ΔIC of the prepared candidates (∞ if none).
fn best_short_dic(preps: &[Prepared]) -> f64 {
    preps.iter().map(|p| p.short_dic).filter(|d| d.is_finite()).fold(f64::INFINITY, f64::min)
}

/// Which round a candidate is prepared for, and whether as the first round's
/// rescue (started from the baseline's short-record optimum).
#[derive(Debug, Clone, Copy)]
struct Pass {
    round: usize,
    rescue: bool,
}

/// Phase A: scan the effect's grid for starting points and run the
/// short-record stages of the fit from the best of them.
fn prepare<'a>(
    base: &'a FlatNetlist,
    experiments: &'a [Experiment],
    current: &Structure<'a>,
    effect: &'a dyn Effect,
    pass: Pass,
    n_res: usize,
    opts: &Options,
) -> Prepared<'a> {
    let Pass { round, rescue } = pass;
    let slot = current.effects.len();
    let mut effects = current.effects.clone();
    effects.push(effect);
    let added = effect_params(effect, slot);
    let mut params = current.params.clone();
    params.extend(added.iter().cloned());
    let mut start = current.fit.values.clone();
    start.extend(added.iter().map(|p| p.start));
    let problem = Problem::new(base, experiments, effects.clone(), params.clone(), opts.sim, opts.fit_interval);
    let mut cand = Candidate {
        round,
        effect: effect.name().to_string(),
        params: BTreeMap::new(),
        estimates: vec![],
        heldout_rmse: f64::NAN,
        delta_ic: f64::NAN,
        chi2: f64::NAN,
        gap_explained: 0.0,
        accepted: false,
        reasons: vec![],
        evaluations: 0,
        fit_message: String::new(),
        screened_out: false,
    };
    // starting points: the best of the effect's scan grid, calibration held at
    // the current fit, scored on the first part of the records (the last
    // short stage: long enough to show slow effects, short enough that cycle
    // timing errors have not accumulated)
    let grid = crate::effects::scan_grid(&effect.params());
    let mut starts = vec![start];
    if !added.is_empty() && grid.len() > 1 {
        let scan_problem = problem.truncated(screen_horizon(opts).unwrap_or(1.0));
        let base_values = match (rescue, &current.values_short) {
            (true, Some(v)) => v,
            _ => &current.fit.values,
        };
        let mut scored: Vec<(f64, Vec<f64>)> = grid
            .par_iter()
            .filter_map(|g| {
                let mut v = base_values.clone();
                v.extend(g.iter().copied());
                Some((chi2(&scan_problem, &v).ok()?, v))
            })
            .collect();
        cand.evaluations += grid.len();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        // effects with shape parameters (held during the short stages) start
        // from the best few grid points; the best after the short stages goes on
        let n_starts = if added.iter().any(|p| p.null.is_none()) { opts.starts.max(1) } else { 1 };
        let picked: Vec<Vec<f64>> = scored.into_iter().take(n_starts).map(|(_, v)| v).collect();
        if !picked.is_empty() {
            starts = picked;
        }
    }
    let fit_opts = if rescue {
        // from the current model's own short-record optimum: only the last
        // short stage, with the calibration's iteration budget
        FitOptions { horizons: screen_horizon(opts).into_iter().collect(), ..opts.fit.clone() }
    } else {
        FitOptions { stage_max_iter: opts.screen_iter, ..opts.fit.clone() }
    };
    let shorts: Vec<Result<Staged, String>> = starts.par_iter().map(|st| fit_short_stages(&problem, st, &fit_opts)).collect();
    cand.evaluations += shorts.iter().map(|r| r.as_ref().map_or(0, |s| s.evaluations)).sum::<usize>();
    let mut errors: Vec<String> = shorts.iter().filter_map(|r| r.as_ref().err().cloned()).collect();
    let short = shorts.into_iter().filter_map(|r| r.ok()).min_by(|a, b| {
        let key = |s: &Staged| s.chi2_short.unwrap_or(f64::INFINITY);
        key(a).total_cmp(&key(b))
    });
    if short.is_none() {
        errors.dedup();
        cand.reasons.push(format!("fit failed: {}", errors.join("; ")));
    }
    // The screen compares the candidate and the current model on the first
    // part of the records, both fitted there.
    let n_short = screen_horizon(opts).map(|h| problem.truncated(h).layout().last().map_or(0, |(_, r)| r.end)).unwrap_or(0);
    let short_dic = match (short.as_ref().and_then(|s| s.chi2_short), current.chi2_short) {
        (Some(c), Some(r)) if n_short > 0 => ic(c, n_short, params.len()) - ic(r, n_short, current.params.len()),
        _ => f64::NAN,
    };
    let screen_at = -opts.thresholds.ic * opts.screen_fraction.unwrap_or(0.0) * n_short as f64 / n_res.max(1) as f64;
    if let Some(v) = short.as_ref().and_then(|s| s.values_short.as_ref()) {
        let first = params.len() - added.len();
        for (p, x) in added.iter().zip(&v[first..]) {
            cand.params.insert(p.name.rsplit('.').next().unwrap_or(&p.name).to_string(), *x);
        }
    }
    Prepared { effects, params, added, problem, short, short_dic, screen_at, cand }
}

/// A candidate stopped after phase A.
fn screened(mut p: Prepared, why: String) -> Candidate {
    p.cand.screened_out = true;
    p.cand.delta_ic = p.short_dic;
    p.cand.fit_message = "screened out after the short-record stages".into();
    p.cand.reasons.push(why);
    p.cand
}

/// χ²/N above which a candidate's full-record fit is restarted.
const RESTART_CHI2_PER_SAMPLE: f64 = 2.0;
/// At most this many restarts of a candidate's full-record fit.
const MAX_RESTARTS: usize = 4;

/// Phase B: the full-record fit and the acceptance tests.
fn finish<'a>(current: &Structure<'a>, prep: Prepared<'a>, n_res: usize, opts: &Options) -> (Option<Structure<'a>>, Candidate) {
    let Prepared { effects, params, added, problem, short, mut cand, .. } = prep;
    let Some(short) = short else { return (None, cand) };
    let fit_opts = FitOptions { stage_max_iter: opts.screen_iter, ..opts.fit.clone() };
    let from =
        short.values_short.clone().unwrap_or_else(|| current.fit.values.iter().copied().chain(added.iter().map(|p| p.start)).collect());
    let mut f = match fit_once(&problem, &from, &fit_opts) {
        Ok(f) => f,
        Err(e) => {
            cand.reasons.push(format!("fit failed: {e}"));
            return (None, cand);
        }
    };
    cand.evaluations += f.evaluations;
    // Restart while the fit stops far above the noise level (χ²/N > 2) and
    // each restart still lowers χ² by more than 1 %:
    // near an event (the stick → slip switch of a breakaway) the
    // finite-difference Jacobian is poor, Levenberg–Marquardt rejects step
    // after step and its step test ends the fit where it stands; a fresh
    // start (new Jacobian, reset damping) usually goes on.
    for _ in 0..MAX_RESTARTS {
        if f.chi2 <= RESTART_CHI2_PER_SAMPLE * n_res as f64 {
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
    let th = &opts.thresholds;
    let first = params.len() - added.len();
    cand.fit_message = f.message.clone();
    cand.chi2 = f.chi2;
    cand.delta_ic = ic(f.chi2, n_res, params.len()) - ic(current.fit.chi2, n_res, current.params.len());
    let excess = current.fit.chi2 - n_res as f64;
    cand.gap_explained = if excess > 0.0 { (current.fit.chi2 - f.chi2) / excess } else { 0.0 };
    let est = estimates(&params, &f);
    cand.estimates = est[first..].to_vec();
    cand.params.clear();
    for (p, e) in added.iter().zip(&cand.estimates) {
        cand.params.insert(p.name.rsplit('.').next().unwrap_or(&p.name).to_string(), e.value);
    }
    if cand.delta_ic >= -th.ic {
        cand.reasons.push(format!("information criterion: ΔIC = {:.1} is not below -{}", cand.delta_ic, th.ic));
    }
    // parameters: away from null, not at a non-null bound
    let with_null: Vec<usize> = (first..params.len()).filter(|&i| params[i].null.is_some()).collect();
    if !with_null.is_empty() {
        let mut best_z: f64 = 0.0;
        for &i in &with_null {
            let p = &params[i];
            let u_null = p.to_u(p.null.unwrap_or(0.0));
            if let Some(s) = f.std_u.as_ref().and_then(|s| s.get(i).copied()).filter(|s| *s > 0.0 && s.is_finite()) {
                best_z = best_z.max((f.u[i] - u_null).abs() / s);
            }
        }
        if f.std_u.is_none() {
            cand.reasons.push("parameters not identifiable (singular covariance)".into());
        } else if best_z < th.z_null {
            cand.reasons.push(format!("parameter within {best_z:.1} standard errors of its null value (needs {})", th.z_null));
        }
    }
    for (i, p) in params.iter().enumerate().skip(first) {
        let (ulo, uhi) = (p.to_u(p.lo), p.to_u(p.hi));
        let margin = th.bound_margin * (uhi - ulo);
        for (b, ub) in [(p.lo, ulo), (p.hi, uhi)] {
            if (f.u[i] - ub).abs() <= margin && p.null != Some(b) {
                cand.reasons.push(format!("{} at its bound {}", p.name, b));
            }
        }
    }
    cand.accepted = cand.reasons.is_empty();
    let chi2_short = short_reference(&problem, short.chi2_short, &f.values, opts);
    let s = Structure { effects, params, fit: f, heldout: f64::NAN, chi2_short, values_short: short.values_short };
    (Some(s), cand)
}

/// Regressors for the residual correlations, from a simulation sampled at the data times.
fn regressors(result: &solve::SimResult, e: &Experiment, topo: &Topology) -> Vec<(String, Vec<f64>)> {
    let samples: Vec<usize> = (0..e.times.len()).collect();
    let col = |name: &str| -> Option<Vec<f64>> {
        let c = result.column(name)?;
        let values: Vec<Option<f64>> = result.rows.iter().map(|r| r[c]).collect();
        Some(samples.iter().map(|&i| crate::synth::interpolate(&result.times, &values, e.times[i]).unwrap_or(0.0)).collect())
    };
    let mut out = Vec::new();
    let rate = |v: &[f64]| -> Vec<f64> {
        (0..v.len())
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(v.len() - 1));
                let dt = e.times[b] - e.times[a];
                if dt > 0.0 {
                    (v[b] - v[a]) / dt
                } else {
                    0.0
                }
            })
            .collect()
    };
    if let (Some(h), Some(r)) = (&topo.head, &topo.rod) {
        if let (Some(p1), Some(p2)) = (col(&format!("{h}.p")), col(&format!("{r}.p"))) {
            out.push(("p_head - p_rod".to_string(), p1.iter().zip(&p2).map(|(a, b)| a - b).collect()));
            out.push(("dp_head/dt".to_string(), rate(&p1)));
            out.push(("dp_rod/dt".to_string(), rate(&p2)));
        }
        if let Some(t1) = col(&format!("{h}.T")) {
            let t0 = t1.first().copied().unwrap_or(0.0);
            out.push(("T_head - T_initial".to_string(), t1.iter().map(|t| t - t0).collect()));
        }
    }
    if let Some(p) = &topo.piston {
        if let Some(v) = col(&format!("{p}.v")) {
            out.push(("low speed exp(-(v/20 mm/s)^2)".to_string(), v.iter().map(|v| (-(v / 0.02).powi(2)).exp()).collect()));
            out.push(("velocity".to_string(), v));
        }
    }
    if let Some(c) = topo.command.as_deref().and_then(col) {
        let mut last = f64::NEG_INFINITY;
        let mut since = Vec::with_capacity(c.len());
        for i in 0..c.len() {
            if i > 0 && (c[i] >= 0.5) != (c[i - 1] >= 0.5) {
                last = e.times[i];
            }
            since.push((-(e.times[i] - last) / 0.05).exp());
        }
        out.push(("recent switch exp(-dt/50 ms)".to_string(), since));
    }
    out
}

/// Full-resolution traces and statistics of a fitted structure.
fn summarize(
    base: &FlatNetlist,
    experiments: &[Experiment],
    s: &Structure,
    n_res: usize,
    phases: Option<&[Vec<Phase>]>,
    opts: &Options,
) -> Result<(Vec<Trace>, ModelSummary), IdentifyError> {
    let problem = Problem::new(base, experiments, s.effects.clone(), s.params.clone(), opts.sim, opts.fit_interval);
    let topo = Topology::of(base);
    let stroke = topo.piston.as_deref().and_then(|p| param_si(base, p, "stroke").ok()).unwrap_or(1.0);
    let traces: Vec<Trace> = if opts.report {
        (0..experiments.len())
            .into_par_iter()
            .map(|k| {
                let e = &experiments[k];
                let result = problem.simulate(k, &s.fit.values, e.median_interval())?;
                let all: Vec<usize> = (0..e.times.len()).collect();
                let simulated = sample_channels(&result, e, &all)?;
                let ph = match phases {
                    Some(p) => p[k].clone(),
                    None => {
                        let get = |name: Option<String>| -> Vec<f64> {
                            let Some(c) = name.and_then(|n| result.column(&n)) else { return vec![0.0; e.times.len()] };
                            let values: Vec<Option<f64>> = result.rows.iter().map(|r| r[c]).collect();
                            e.times.iter().map(|&t| crate::synth::interpolate(&result.times, &values, t).unwrap_or(0.0)).collect()
                        };
                        let cmd = get(topo.command.clone());
                        let x = get(topo.piston.as_ref().map(|p| format!("{p}.x")));
                        classify(&e.times, &cmd, &x, stroke)
                    }
                };
                Ok(Trace {
                    name: e.name.clone(),
                    times: e.times.clone(),
                    signals: e.channels.iter().map(|c| c.signal.clone()).collect(),
                    sigma: e.channels.iter().map(|c| c.sigma).collect(),
                    measured: e.channels.iter().map(|c| c.values.clone()).collect(),
                    simulated,
                    phases: ph,
                    regressors: regressors(&result, e, &topo),
                })
            })
            .collect::<Result<_, String>>()
            .map_err(IdentifyError::Report)?
    } else {
        Vec::new()
    };
    let diagnosis = diagnose(&traces);
    let summary = ModelSummary {
        effects: s.effects.iter().map(|e| e.name().to_string()).collect(),
        params: estimates(&s.params, &s.fit),
        chi2: s.fit.chi2,
        n: n_res,
        ic: ic(s.fit.chi2, n_res, s.params.len()),
        heldout_rmse: s.heldout,
        rmse: diagnosis.channels.iter().map(|(k, v)| (k.clone(), v.rmse)).collect(),
        rmse_normalized: diagnosis.channels.iter().map(|(k, v)| (k.clone(), v.rmse_normalized)).collect(),
        diagnosis,
        converged: s.fit.converged,
        fit_message: s.fit.message.clone(),
        fit_evaluations: s.fit.evaluations,
    };
    Ok((traces, summary))
}

/// The structure as one netlist: global calibrated values written in,
/// effects applied with their fitted values (per-setting calibration values
/// stay with the experiments and are listed in the report).
fn written_netlist(base: &FlatNetlist, experiments: &[Experiment], s: &Structure) -> Result<FlatNetlist, IdentifyError> {
    let mut params = s.params.clone();
    let mut values = s.fit.values.clone();
    // drop per-experiment calibration parameters
    let keep: Vec<bool> = params.iter().map(|p| !matches!(&p.target, Target::Netlist { experiments: Some(_), .. })).collect();
    let mut k = 0;
    params.retain(|_| {
        k += 1;
        keep[k - 1]
    });
    let mut k = 0;
    values.retain(|_| {
        k += 1;
        keep[k - 1]
    });
    let probe = Experiment { name: "netlist".into(), sets: vec![], times: vec![0.0], channels: vec![], time_origin: 0.0 };
    let exps = [probe];
    let _ = experiments;
    let p = Problem::new(base, &exps, s.effects.clone(), params, SimSettings::default(), 1.0);
    p.netlist(0, &values).map_err(IdentifyError::Report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn information_criterion_by_hand() {
        // N ln(χ²/N) + k ln N
        let v = ic(2000.0, 1000, 3);
        assert!((v - (1000.0 * 2f64.ln() + 3.0 * 1000f64.ln())).abs() < 1e-9);
        // an added parameter that does not reduce χ² costs ln N
        assert!((ic(1000.0, 1000, 4) - ic(1000.0, 1000, 3) - 1000f64.ln()).abs() < 1e-9);
    }

    #[test]
    fn the_best_wins_unless_the_runner_up_explains_as_much() {
        // current χ² 10 000; candidates (ΔIC, χ²)
        assert_eq!(decide(&[], 1e4, 0.1), Decision::None);
        assert_eq!(decide(&[(-500.0, 9000.0)], 1e4, 0.1), Decision::Select(0));
        // gains 8000 and 2000: clear winner (index 1 has the lower ΔIC)
        assert_eq!(decide(&[(-900.0, 8000.0), (-9000.0, 2000.0)], 1e4, 0.1), Decision::Select(1));
        // gains 8000 and 7500: within 10 % → ambiguous, best first
        assert_eq!(decide(&[(-8000.0, 2500.0), (-8500.0, 2000.0)], 1e4, 0.1), Decision::Ambiguous(1, 0));
        // the same pair with a 5 % ambiguity margin is decided
        assert_eq!(decide(&[(-8000.0, 2500.0), (-8500.0, 2000.0)], 1e4, 0.05), Decision::Select(1));
    }

    #[test]
    fn linearized_heldout_is_exact_for_a_linear_model() {
        // Residual r(u) = A u − y is linear: the one Gauss–Newton step is the exact refit.
        // Two "experiments" of 3 rows each, one parameter: y = a·x with x = row index.
        let xs = [1.0, 2.0, 3.0, 1.0, 2.0, 3.0];
        let ys = [1.1, 2.0, 3.1, 2.0, 4.1, 5.9];
        let a_full: f64 = xs.iter().zip(&ys).map(|(x, y)| x * y).sum::<f64>() / xs.iter().map(|x| x * x).sum::<f64>();
        let residuals: Vec<f64> = xs.iter().zip(&ys).map(|(x, y)| a_full * x - y).collect();
        let jac = DMatrix::from_fn(6, 1, |i, _| xs[i]);
        let f = Fit {
            u: vec![a_full],
            values: vec![a_full],
            std_u: None,
            residuals,
            jacobian: jac,
            chi2: 0.0,
            at_bound: vec![false],
            converged: true,
            evaluations: 0,
            iterations: 0,
            message: String::new(),
        };
        // by hand: fit each half alone and predict the other
        let fit_on = |r: std::ops::Range<usize>| -> f64 {
            xs[r.clone()].iter().zip(&ys[r.clone()]).map(|(x, y)| x * y).sum::<f64>() / xs[r].iter().map(|x| x * x).sum::<f64>()
        };
        let (a1, a2) = (fit_on(3..6), fit_on(0..3));
        let sq: f64 = (0..3).map(|i| (a1 * xs[i] - ys[i]).powi(2)).sum::<f64>() + (3..6).map(|i| (a2 * xs[i] - ys[i]).powi(2)).sum::<f64>();
        let expected = (sq / 6.0).sqrt();
        let got = linearized_rows(&f, &[0..3, 3..6]);
        assert!((got - expected).abs() < 1e-9, "{got} vs {expected}");
    }
}
