//! The footprint of an added effect: how far it moves each recorded
//! channel at the fitted samples, the rest of the fitted model held, beyond
//! what the instruments resolve. At each sample the change counts as
//! min over |s| ≤ τ of |y_with(t_i + s) − y_without(t_i)|, in units of the
//! channel's sensor accuracy σ_acc (the σ of its offset prior,
//! [`crate::experiment::SensorPrior`]: 0.5 % of an EN 837-1 full scale for
//! a pressure, 1.5 K for a thermocouple, ...); τ is the timing resolution
//! of the switching instants (`Options::switch_latency`, 1 ms, the valve
//! delay's least size). The footprint of a channel is the largest such
//! ratio. Without the shift a change of a switching instant by a fraction
//! of a sample would count as the height of the pressure edge: on the
//! meter-out circuit a 0.01 L/(min·bar) seal leak moves the head pressure
//! by 0.64 bar at one sample of a valve switch and by about 1 kPa
//! everywhere else (the test below). Both simulations write output every
//! τ/4 at most, so that the shifted trajectory follows an edge.
//!
//! It is the second half of the practical-size test (test 5 of
//! [`crate::selection`]) and applies to every effect: a fit can lower χ²
//! by thousands with a change that stays inside every instrument's
//! resolution everywhere — many samples of a small, systematic difference
//! add up — and such a change is what the rig's transducers (non-linearity,
//! hysteresis, the gain and offset the prior allows), its switching timing,
//! or a modelling choice no catalogue effect describes can make by
//! themselves. An engineer cannot act on an effect whose whole consequence
//! lies within the instruments' resolution, so it is not named
//! (docs/discrepancy.md, "The footprint test").

use crate::problem::{sample_channels, Problem, Sampler};
use rayon::prelude::*;

/// Shifts tried on each side of zero, τ/SHIFTS apart.
const SHIFTS: usize = 4;

/// One channel's footprint.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Footprint {
    /// Model signal ("head.p").
    pub signal: String,
    /// Largest change beyond a shift in time within τ, in units of
    /// `accuracy`, over every included experiment's fitted samples.
    pub ratio: f64,
    /// Largest |change| without shift [SI], wherever it is.
    pub largest: f64,
    /// The channel's sensor accuracy (offset prior σ) [SI]; the smallest
    /// over the experiments that record it.
    pub accuracy: f64,
}

/// The footprint of the last `added` parameters' effect — the last effect
/// of `problem` — at the SI `values`: every included experiment simulated
/// with and without that effect; `tau` [s] is the timing resolution.
/// Channels without a finite, positive accuracy are left out (nothing to
/// measure against).
pub fn of_last_effect(problem: &Problem, values: &[f64], added: usize, tau: f64) -> Result<Vec<Footprint>, String> {
    if problem.effects.is_empty() || added > values.len() || problem.params.len() != values.len() {
        return Err("footprint: no added effect to measure".into());
    }
    let first = values.len() - added;
    let without = Problem {
        effects: problem.effects[..problem.effects.len() - 1].to_vec(),
        params: problem.params[..first].to_vec(),
        ..problem.clone()
    };
    let tau = if tau.is_finite() { tau.max(0.0) } else { 0.0 };
    let per_experiment: Vec<Vec<Footprint>> = problem
        .included()
        .par_iter()
        .map(|&k| {
            let e = &problem.experiments[k];
            let samples = &problem.samples[k];
            // output fine enough to follow a pressure edge through the shifts
            let interval = if tau > 0.0 { problem.intervals[k].min(tau / SHIFTS as f64) } else { problem.intervals[k] };
            let with = problem.simulate(k, values, interval)?;
            let sampler = Sampler::new(&with, e, samples)?;
            let steps = if tau > 0.0 { SHIFTS as i64 } else { 0 };
            let shifted: Vec<Vec<Vec<Option<f64>>>> = (-steps..=steps).map(|j| sampler.at(tau * j as f64 / SHIFTS as f64, false)).collect();
            let b = sample_channels(&without.simulate(k, &values[..first], interval)?, e, samples)?;
            Ok(e.channels
                .iter()
                .enumerate()
                .filter_map(|(c, ch)| {
                    let accuracy = ch.prior.as_ref().map(|p| p.offset_sd)?;
                    (accuracy > 0.0 && accuracy.is_finite()).then(|| {
                        let a: Vec<&[Option<f64>]> = shifted.iter().map(|s| s[c].as_slice()).collect();
                        let (beyond, largest) = change(&a, &b[c]);
                        Footprint { signal: ch.signal.clone(), ratio: beyond / accuracy, largest, accuracy }
                    })
                })
                .collect())
        })
        .collect::<Result<_, String>>()?;
    Ok(merge(per_experiment.into_iter().flatten()))
}

/// (largest over the samples of the smallest |a_s − b| over the shifted
/// versions a_s, in order of their shift — 0 where a_s − b changes sign
/// between neighbours —, largest |a_0 − b| of the middle, unshifted one)
/// where both are present.
fn change(shifted: &[&[Option<f64>]], b: &[Option<f64>]) -> (f64, f64) {
    let middle = shifted.get(shifted.len() / 2);
    let (mut beyond, mut largest) = (0.0_f64, 0.0_f64);
    for (i, y) in b.iter().enumerate() {
        let Some(y) = y else { continue };
        // the shifted trajectory is continuous in the shift: where the
        // difference changes sign between neighbouring shifts, some shift
        // between them meets the sample exactly
        let d: Vec<f64> = shifted.iter().filter_map(|a| a.get(i).copied().flatten()).map(|x| x - y).collect();
        let crosses = d.windows(2).any(|w| w[0] * w[1] <= 0.0);
        let least = if crosses { 0.0 } else { d.iter().map(|x| x.abs()).fold(f64::INFINITY, f64::min) };
        if least.is_finite() {
            beyond = beyond.max(least);
        }
        if let Some(Some(x)) = middle.and_then(|a| a.get(i)) {
            largest = largest.max((x - y).abs());
        }
    }
    (beyond, largest)
}

/// One footprint per signal, in first-seen order: the largest ratio and
/// change, and the smallest accuracy, over the experiments.
fn merge(all: impl Iterator<Item = Footprint>) -> Vec<Footprint> {
    let mut out: Vec<Footprint> = Vec::new();
    for f in all {
        match out.iter_mut().find(|o| o.signal == f.signal) {
            Some(o) => {
                o.ratio = o.ratio.max(f.ratio);
                o.largest = o.largest.max(f.largest);
                o.accuracy = o.accuracy.min(f.accuracy);
            }
            None => out.push(f),
        }
    }
    out
}

/// Why an effect of these footprints is below practical size: every
/// channel's ratio is below `fraction` (`None` when one reaches it or is
/// not a number, when no channel has an accuracy, or when `fraction` is 0
/// — the test switched off).
pub fn within_accuracy(footprints: &[Footprint], fraction: f64, tau: f64) -> Option<String> {
    // a footprint that could not be measured (NaN) never counts as small
    if fraction <= 0.0 || footprints.is_empty() || footprints.iter().any(|f| f.ratio >= fraction || f.ratio.is_nan()) {
        return None;
    }
    let of = if fraction == 1.0 { "its".to_string() } else { format!("{fraction} of its") };
    Some(format!(
        "practical size: it moves every recorded channel by less than {of} resolution ({}: largest change beyond a shift in time of up to {} ms, in units of the sensor accuracy); not named",
        ratios(footprints),
        crate::params::significant(tau * 1e3, 3)
    ))
}

/// The footprints for a report line.
pub fn describe(footprints: &[Footprint]) -> String {
    format!("footprint: {} (largest change beyond a shift in time within the timing resolution, in sensor accuracies)", ratios(footprints))
}

fn ratios(footprints: &[Footprint]) -> String {
    footprints.iter().map(|f| format!("{} {:.2}", f.signal, f.ratio)).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fp(signal: &str, ratio: f64) -> Footprint {
        Footprint { signal: signal.into(), ratio, largest: 1000.0 * ratio, accuracy: 5000.0 }
    }

    /// A 3 s record of the meter-out circuit at 5 bar: both chamber
    /// pressures, on transducers of 0.5 % of a 10 bar full scale (the
    /// default prior, 50 mbar).
    fn record() -> crate::Experiment {
        use crate::experiment::{Channel, SensorPrior};
        let n = 1501;
        let channel = |signal: &str| Channel {
            signal: signal.into(),
            values: vec![Some(0.0); n],
            sigma: 500.0,
            sigma_estimated: false,
            prior: Some(SensorPrior { offset_sd: 5000.0, gain_sd: 0.005, source: "test".into() }),
        };
        crate::Experiment {
            name: "stroke".into(),
            sets: vec!["supply.p=5 bar".into()],
            times: (0..n).map(|i| i as f64 * 2e-3).collect(),
            channels: vec![channel("head.p"), channel("rod.p")],
            time_origin: 0.0,
        }
    }

    #[test]
    fn a_seal_leak_leaves_no_footprint_at_its_null_and_one_that_grows_with_its_size() {
        use crate::effects::{Effect, PistonSealLeak};
        use crate::nuisance::SensorModel;
        use crate::problem::SimSettings;
        let flat = crate::netlist_edit::tests_support::meter_out();
        let exps = vec![record()];
        let leak = PistonSealLeak;
        let effects: Vec<&dyn Effect> = vec![&leak];
        let params = crate::params::effect_params(&leak, 0);
        let settings = SimSettings { rtol: 1e-7, atol: 1e-7, max_step: 0.01 };
        let pr = Problem::new(&flat, &exps, effects, params, settings, SensorModel::default(), 2e-3);
        // C in L/(min·bar), the linear law (λ = 2); τ = 1 ms
        let at = |c: f64, tau: f64| of_last_effect(&pr, &[c * 1e-3 / 60.0 / 1e5, 2.0], 2, tau).unwrap();
        let most = |f: &[Footprint]| f.iter().map(|f| f.ratio).fold(0.0, f64::max);
        // C = 0 adds nothing to the netlist: the same simulation, no change at all
        let none = at(0.0, 1e-3);
        assert_eq!(none.iter().map(|f| f.signal.as_str()).collect::<Vec<_>>(), vec!["head.p", "rod.p"]);
        assert!(none.iter().all(|f| f.largest == 0.0 && f.ratio == 0.0 && f.accuracy == 5000.0), "{none:?}");
        // 0.01 L/(min·bar) moves a valve switch by a fraction of a sample:
        // 0.64 bar at the pressure edge, 13 accuracies when time is not
        // resolved, well within the resolution once a 1 ms shift is allowed
        let small = at(0.01, 1e-3);
        let head = |f: &[Footprint]| f.iter().find(|f| f.signal == "head.p").unwrap().clone();
        assert!(head(&small).largest > 0.4e5, "{small:?}");
        assert!(most(&at(0.01, 0.0)) > 10.0);
        assert!(most(&small) < 1.0, "{small:?}");
        assert!(within_accuracy(&small, 1.0, 1e-3).is_some());
        // away from the edges a small leak is a small perturbation: twice the leak, about twice the footprint
        let growth = most(&at(0.02, 1e-3)) / most(&small);
        assert!((1.6..2.4).contains(&growth), "× {growth}");
        // 0.3 L/(min·bar) (the independent rig's leaks are 0.25–0.45) holds
        // the exhausting rod chamber up by several accuracies; 1 L/(min·bar)
        // against the 13.2 L/(min·bar) meter-out restriction by far more
        let rod = |f: &[Footprint]| f.iter().find(|f| f.signal == "rod.p").unwrap().ratio;
        let (leak, large) = (at(0.3, 1e-3), at(1.0, 1e-3));
        assert!(within_accuracy(&leak, 1.0, 1e-3).is_none() && rod(&leak) > 3.0, "{leak:?}");
        assert!(rod(&large) > 2.0 * rod(&leak), "{large:?}");
    }

    #[test]
    fn merging_keeps_the_largest_change_and_the_finest_accuracy() {
        let m = merge([fp("head.p", 0.1), fp("rod.p", 0.3), Footprint { accuracy: 2500.0, ..fp("head.p", 0.7) }].into_iter());
        assert_eq!(m, vec![Footprint { accuracy: 2500.0, ..fp("head.p", 0.7) }, fp("rod.p", 0.3)]);
    }

    #[test]
    fn the_change_skips_missing_samples_and_allows_for_a_shift_in_time() {
        // unshifted: the largest |Δ|, missing samples skipped
        let a = [Some(1.0), None, Some(5.0)];
        assert_eq!(change(&[&a], &[Some(1.5), Some(100.0), None]), (0.5, 0.5));
        // a sample on an edge: shifts that fall short on either side of it
        // mean one between them meets it; all on one side, the nearest counts
        let b = [Some(0.0), Some(2.0), Some(5.0)];
        let (below, above) = ([Some(0.0), Some(1.0), Some(5.0)], [Some(0.0), Some(4.0), Some(5.0)]);
        assert_eq!(change(&[&below, &below, &above], &b), (0.0, 1.0));
        assert_eq!(change(&[&below, &below, &below], &b), (1.0, 1.0));
        assert_eq!(change(&[&above, &below, &above], &b), (0.0, 1.0));
        assert_eq!(change(&[], &[]), (0.0, 0.0));
    }

    #[test]
    fn an_effect_is_below_practical_size_only_when_every_channel_stays_within_its_resolution() {
        let small = [fp("rod.p", 0.16), fp("piston.x", 0.5)];
        let why = within_accuracy(&small, 1.0, 1e-3).expect("below");
        assert!(why.contains("(rod.p 0.16, piston.x 0.50:") && why.contains("up to 1 ms"), "{why}");
        // one channel beyond its resolution is enough
        assert_eq!(within_accuracy(&[fp("rod.p", 0.16), fp("piston.x", 1.5)], 1.0, 1e-3), None);
        // fraction 0 switches the test off; no channel with an accuracy: nothing to judge
        assert_eq!(within_accuracy(&small, 0.0, 1e-3), None);
        assert_eq!(within_accuracy(&[], 1.0, 1e-3), None);
        assert_eq!(within_accuracy(&[fp("rod.p", 0.16), fp("piston.x", f64::NAN)], 1.0, 1e-3), None);
    }
}
