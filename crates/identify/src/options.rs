//! Settings of the discrepancy workflow: how fits are run, which sensor
//! errors are eliminated, the acceptance thresholds, and a progress sink.
//! Plain data read by every stage; filled from a manifest
//! ([`crate::manifest`]) or by a caller.

use crate::fit::FitOptions;
use crate::nuisance::SensorModel;
use crate::problem::SimSettings;
use serde::Serialize;
use std::sync::Arc;

/// Acceptance thresholds of the selection ([`crate::selection`]); the
/// docs (docs/discrepancy.md, "Thresholds") say how they were set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Thresholds {
    /// Required decrease of the information criterion on effective sample sizes.
    pub ic: f64,
    /// Required distance of a parameter from its null, in (correlation-aware) standard errors.
    pub z_null: f64,
    /// Distance from a non-null bound, as a fraction of the fitted range,
    /// below which an effect parameter counts as at the bound.
    pub bound_margin: f64,
    /// Required relative decrease of the held-out mean square.
    pub heldout_gain: f64,
    /// The model-form floor test: the held-out gain (in units of the noise
    /// variance) must be at least this multiple of the held-out remainder
    /// above the noise that the model with the effect still leaves.
    pub floor_ratio: f64,
    /// Smallest remainder counted in the floor test (noise variances):
    /// below it the noise level itself is not known better.
    pub floor_min: f64,
    /// Two candidates are ambiguous when the runner-up's held-out gain is
    /// within this fraction of the winner's.
    pub ambiguity: f64,
    /// A channel whose normalised RMSE after the search is above this has an
    /// unexplained remainder, reported with the phase that holds most of it.
    pub remainder_rmse: f64,
    /// The footprint half of the practical-size test ([`crate::footprint`]):
    /// an effect whose largest change to every recorded channel is below
    /// this fraction of the channel's sensor accuracy is not named; 0 turns
    /// it off.
    pub footprint: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            ic: 10.0,
            z_null: 3.0,
            bound_margin: 0.005,
            heldout_gain: 0.05,
            floor_ratio: 2.0,
            floor_min: 0.05,
            ambiguity: 0.1,
            remainder_rmse: 1.5,
            footprint: 1.0,
        }
    }
}

/// Where progress messages go (the library prints nothing itself).
#[derive(Clone, Default)]
pub struct Progress(Option<Sink>);

/// A progress message receiver.
type Sink = Arc<dyn Fn(&str) + Send + Sync>;

impl Progress {
    /// Messages to `f`.
    pub fn to(f: impl Fn(&str) + Send + Sync + 'static) -> Self {
        Progress(Some(Arc::new(f)))
    }
    /// Send one message.
    pub fn say(&self, message: &str) {
        if let Some(f) = &self.0 {
            f(message);
        }
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Progress(sink)" } else { "Progress(none)" })
    }
}

/// Options of the workflow.
#[derive(Debug, Clone)]
pub struct Options {
    /// Spacing of the samples compared in the fits [s].
    pub fit_interval: f64,
    pub sim: SimSettings,
    pub fit: FitOptions,
    /// Sensor errors fitted as nuisance parameters.
    pub sensors: SensorModel,
    pub thresholds: Thresholds,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// Restrict the built-in catalogue to these names.
    pub effects: Option<Vec<String>>,
    /// Effects declared in the manifest, always tried with the catalogue's.
    pub user_effects: Vec<crate::effects::UserEffect>,
    /// Compute full-resolution traces and diagnostics.
    pub report: bool,
    /// Step attempts of a candidate's short-record (screening) stages.
    pub screen_iter: usize,
    /// Starting points tried for effects with shape parameters: the best scan
    /// point of each combination of shape values, and further best points up
    /// to this many in all.
    pub starts: usize,
    /// A candidate gets its full-record fit only if its short-record ΔIC is
    /// at least this fraction of the best candidate's (both negative) …
    pub screen_relative: f64,
    /// … and only the best `screen_keep` candidates of a round do.
    pub screen_keep: usize,
    /// Only the best this many candidates of the projected scan
    /// ([`crate::candidates::projected_scan`]), and only those whose score
    /// is below 0, are prepared at all; 0 (the default) = no projected scan,
    /// every candidate is prepared. Opt-in: on the nominal dead-volume case
    /// it ranked `dead_volume` fifth of six with a positive score and so
    /// pruned the right answer (docs/discrepancy.md).
    pub screen_prepare: usize,
    /// Response time between a limit switch's trip and the valve's command
    /// that the model does not describe (the switch's own switching time and
    /// the controller's input filter and scan) [s]; 0 = none. A valve delay
    /// below it is not named ([`crate::effects::LeastSize`]; default 1 ms,
    /// docs/discrepancy.md "Thresholds").
    pub switch_latency: f64,
    /// The sham test ([`crate::sham`], test 6 of [`crate::selection`]): a
    /// candidate must beat a generic per-phase correction with as many
    /// parameters fitted on the same data. On by default.
    pub sham: bool,
    /// Recentred starts ([`crate::candidates::recentred`]): every
    /// candidate is also started with the calibration's form parameters
    /// (those with a prior) back at their prior centres, and each round's
    /// current model is refitted from there too, the lower penalised cost
    /// kept as the reference the candidates are judged against (their
    /// starts stay built from the calibration before that refit). On by
    /// default since 2026-11-29: on data of the model's own
    /// form the calibrated form parameters and sensor gains imitate part of
    /// a missing wall heat exchange or dead volume, and the effect's other
    /// starts then end at its null (docs/discrepancy.md, "Recentred starts
    /// on by default"). Costs one more short-record fit per candidate and
    /// round.
    pub recentre: bool,
    /// Fresh starts ([`crate::candidates::refit_fresh`]): the round's best
    /// candidate, when its full-record fit continued from the current
    /// model's optimum stops far above the noise, is also fitted from the
    /// calibration's own start with the effect in (the staged fit of the
    /// baseline's calibration), the lower prior-penalised cost kept. On by
    /// default: a calibration bent to imitate a missing effect holds the
    /// continuation in its basin (docs/discrepancy.md, "Fresh starts");
    /// costs one calibration per round.
    pub fresh_start: bool,
    /// Projected starts ([`crate::candidates::retry_projected`], module
    /// header of [`crate::candidates`]): in every round, a candidate
    /// the screen would drop whose projected-scan ΔIC is below −`ic` is
    /// screened once more from the calibration's Gauss–Newton answer to
    /// the effect at its best projected grid point of each shape value
    /// (docs/discrepancy.md, "Projected starts"); costs the projected scan
    /// (one short-record simulation per calibration parameter and grid
    /// point) and one more short-record fit per shape value of each such
    /// candidate.
    pub projected_start: bool,
    pub progress: Progress,
}

impl Options {
    /// What the data can resolve, for the effects' least sizes.
    pub fn resolution(&self) -> crate::effects::Resolution {
        crate::effects::Resolution { switch_latency: self.switch_latency }
    }
}

impl Default for Options {
    fn default() -> Self {
        Options {
            fit_interval: 4e-3,
            sim: SimSettings::default(),
            fit: FitOptions::default(),
            sensors: SensorModel::default(),
            thresholds: Thresholds::default(),
            max_effects: 2,
            effects: None,
            user_effects: Vec::new(),
            report: true,
            screen_iter: 8,
            starts: 2,
            screen_relative: 0.2,
            screen_keep: 3,
            screen_prepare: 0,
            switch_latency: 1e-3,
            sham: true,
            recentre: true,
            fresh_start: true,
            projected_start: true,
            progress: Progress::default(),
        }
    }
}
