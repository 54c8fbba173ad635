//! The discrepancy workflow, end to end: calibrate the baseline, search the
//! catalogue for missing effects, report. The stages, each a module that
//! only uses the ones before it:
//!
//! 1. data and experiments: [`crate::data`], [`crate::experiment`];
//! 2. the fitting problem: [`crate::params`], [`crate::problem`] (sensor
//!    nuisance parameters eliminated by [`crate::nuisance`]), [`crate::fit`]
//!    (with the correlation-aware statistics of [`crate::stats`]);
//! 3. candidates: [`crate::candidates`], held-out errors [`crate::heldout`];
//! 4. selection: [`crate::selection`] (information criterion, parameter,
//!    held-out and model-form floor tests; backward check);
//! 5. report: [`crate::report`] (traces, diagnosis, remainder, verdict).
//!
//! This module only runs them in order, times them and reports progress.

use crate::candidates::{calibrate_baseline, problem_for, short_reference, Structure};
use crate::effects::{catalogue, Effect};
use crate::experiment::Experiment;
use crate::options::Options;
use crate::params::{calibration_params, CalibSpec, Target};
use crate::phases::Phase;
use crate::report::{remainders, summarize, verdict, written_netlist, Outcome, Summary};
use crate::selection::{ensure_heldout, search};
use graph::FlatNetlist;
use std::collections::BTreeMap;

/// Why the workflow could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    #[error("{0}")]
    Setup(String),
    #[error("baseline calibration failed: {0}")]
    Baseline(String),
    #[error("search for missing effects failed: {0}")]
    Search(String),
    #[error("simulation for the report failed: {0}")]
    Report(String),
}

/// Most integration steps of `max_step` one simulation of an experiment
/// may plan: a run makes thousands of simulations of each experiment.
pub const MAX_EXPERIMENT_STEPS: f64 = 1e6;
/// Most rows one simulation of an experiment may record.
pub const MAX_EXPERIMENT_ROWS: f64 = 1e7;

/// Refuse an experiment whose simulation cannot fit, before any work: its
/// duration in steps of the fits' `max_step`, and in recorded rows.
fn check_size(e: &Experiment, opts: &Options) -> Result<(), IdentifyError> {
    use units::show::{num, sig};
    let duration = e.duration();
    let steps = duration / opts.sim.max_step;
    let interval = opts.fit_interval.min(e.median_interval());
    let rows = duration / interval;
    let name = units::show::text(&e.name);
    if steps.is_nan() || steps > MAX_EXPERIMENT_STEPS {
        return Err(IdentifyError::Setup(format!(
            "experiment \"{name}\": its last sample is at t = {} s; a simulation of it would take at least {} steps of {} s, more than the {} a discrepancy run allows per experiment: check its time column and time_origin",
            num(duration),
            if steps.is_finite() { sig(steps, 3) } else { "1e308".into() },
            num(opts.sim.max_step),
            num(MAX_EXPERIMENT_STEPS)
        )));
    }
    if rows.is_nan() || rows > MAX_EXPERIMENT_ROWS {
        return Err(IdentifyError::Setup(format!(
            "experiment \"{name}\": {} s sampled every {} s would record {} rows per simulation, more than the {} a discrepancy run allows: check its time column",
            num(duration),
            num(interval),
            sig(rows, 3),
            num(MAX_EXPERIMENT_ROWS)
        )));
    }
    Ok(())
}

/// Run the workflow on `base` (the model as given) and the experiments.
/// `calibrate` lists the baseline parameters to fit (see
/// [`crate::params::default_calibration`]).
pub fn run(base: &FlatNetlist, experiments: &[Experiment], calibrate: &[CalibSpec], opts: &Options) -> Result<Outcome, IdentifyError> {
    let clock = std::time::Instant::now();
    if experiments.is_empty() {
        return Err(IdentifyError::Setup("no experiments".into()));
    }
    for e in experiments {
        check_size(e, opts)?;
    }
    let all = catalogue();
    let declared = |n: &str| opts.user_effects.iter().any(|u| u.name == n);
    if let Some(names) = &opts.effects {
        for n in names {
            if !all.iter().any(|e| e.name() == n) && !declared(n) {
                return Err(IdentifyError::Setup(format!("unknown effect \"{n}\" (known: {})", crate::effects::names().join(", "))));
            }
        }
    }
    // the built-ins `effects` names (all by default), then every declared effect
    let pool: Vec<&dyn Effect> = all
        .iter()
        .map(|e| e.as_ref())
        .filter(|e| opts.effects.as_ref().is_none_or(|v| v.iter().any(|n| n == e.name())))
        .chain(opts.user_effects.iter().map(|u| u as &dyn Effect))
        .collect();
    // every channel gets its sensor prior (the default of its quantity unless given)
    let units = crate::manifest::signal_units(base).map_err(IdentifyError::Setup)?;
    let mut owned = experiments.to_vec();
    crate::experiment::assign_default_priors(&mut owned, |s| units.get(s).cloned().unwrap_or_default());
    let experiments = &owned[..];
    let mut calib = calibration_params(base, experiments, calibrate).map_err(IdentifyError::Setup)?;
    // a vessel's initial state from the data's first samples (unless calibrated as asked)
    for p in crate::params::initial_state_params(base, experiments) {
        let taken = calib.iter().any(|c| matches!((&c.target, &p.target), (Target::Netlist { id: a, param: b, .. }, Target::Netlist { id: c, param: d, .. }) if a == c && b == d));
        if !taken {
            calib.push(p);
        }
    }
    let mut timing = BTreeMap::new();

    // 1–2. the baseline's calibration
    let p0 = problem_for(base, experiments, vec![], calib.clone(), opts);
    let start: Vec<f64> = calib.iter().map(|p| p.start).collect();
    // check the channels against the model once, with a clear message
    p0.residuals(&start).map_err(IdentifyError::Setup)?;
    opts.progress.say(&format!(
        "calibrating {} parameter{} on {} experiment{} ({} fitted samples)",
        calib.len(),
        if calib.len() == 1 { "" } else { "s" },
        experiments.len(),
        if experiments.len() == 1 { "" } else { "s" },
        p0.len()
    ));
    let staged = calibrate_baseline(&p0, &start, &opts.fit).map_err(IdentifyError::Baseline)?;
    let mut evaluations = staged.evaluations;
    let f0 = staged.fit.clone().ok_or_else(|| IdentifyError::Baseline("no full-record stage".into()))?;
    let short0 = short_reference(&p0, staged.short.as_ref(), &f0.values, opts);
    opts.progress.say(&format!("calibrated: χ²/N = {:.2}, {} simulations", f0.chi2 / f0.residuals.len().max(1) as f64, evaluations));
    timing.insert("calibration".to_string(), clock.elapsed().as_secs_f64());
    let mut baseline = Structure { effects: vec![], params: calib, fit: f0, heldout: None, short: short0 };

    // 3–4. candidates and selection
    let found = search(base, experiments, &pool, baseline.clone(), opts).map_err(IdentifyError::Search)?;
    evaluations += found.evaluations;
    timing.extend(found.timing.clone());
    baseline.heldout = found.baseline_heldout.clone();
    if baseline.heldout.is_none() {
        evaluations += ensure_heldout(base, experiments, &mut baseline, opts).map_err(IdentifyError::Search)?;
    }
    let mut model = found.model.clone();
    if model.effects.is_empty() {
        model.heldout = baseline.heldout.clone();
    } else {
        evaluations += ensure_heldout(base, experiments, &mut model, opts).map_err(IdentifyError::Search)?;
    }

    // 5. report
    let report_clock = std::time::Instant::now();
    opts.progress.say("writing the report: full-resolution simulations");
    let (before, baseline_summary) = summarize(base, experiments, &baseline, None, opts).map_err(IdentifyError::Report)?;
    let phases: Vec<Vec<Phase>> = before.iter().map(|t| t.phases.clone()).collect();
    let (after, after_summary) = if model.effects.is_empty() {
        (before.clone(), baseline_summary.clone())
    } else {
        summarize(base, experiments, &model, Some(&phases), opts).map_err(IdentifyError::Report)?
    };
    let remainder = remainders(&after_summary, &opts.thresholds);
    let mut augmented = vec![(model.label(), written_netlist(base, &model).map_err(IdentifyError::Report)?)];
    for alt in &found.alternatives {
        augmented.push((alt.label(), written_netlist(base, alt).map_err(IdentifyError::Report)?));
    }
    timing.insert("report".to_string(), report_clock.elapsed().as_secs_f64());
    let noise = experiments.iter().map(|e| (e.name.clone(), e.channels.iter().map(|c| (c.signal.clone(), c.sigma)).collect())).collect();
    // what the final model leaves is significant when the report finds a
    // remainder at full resolution, or (report or not) a channel at the
    // fitted samples is above the same threshold
    let significant = !remainder.is_empty() || crate::selection::significant(&found.fitted_rmse, &opts.thresholds);
    let (verdict_text, grade) = verdict(&found.selected, &found.ambiguous, &remainder, &found.candidates, significant);
    let summary = Summary {
        baseline: baseline_summary,
        candidates: found.candidates,
        verdict: verdict_text,
        grade,
        selected: found.selected,
        ambiguous: found.ambiguous,
        dropped: found.dropped,
        remainder,
        fitted_rmse: found.fitted_rmse,
        after: after_summary,
        thresholds: opts.thresholds,
        sensor_model: opts.sensors,
        noise,
        evaluations,
        seconds: clock.elapsed().as_secs_f64(),
        timing,
    };
    let baseline_netlist = written_netlist(base, &baseline).map_err(IdentifyError::Report)?;
    Ok(Outcome { summary, baseline_netlist, augmented, before, after })
}
