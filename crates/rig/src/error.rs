//! Errors of the rig, as values.
//!
//! Every variant names what is at fault: the parameter and its value for bad
//! input, the simulation time (and, where it helps, the state) for a failure
//! during integration. Nothing in this crate panics on bad input; a panic
//! would be a bug.

use thiserror::Error;

/// Everything that can go wrong when building or running the rig.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RigError {
    /// A parameter is outside its valid range (checked once, before a run).
    #[error("parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Dotted name of the parameter (`rig.bore`, `form.switch.tolerance`, ...).
        name: String,
        /// The offending value.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// The step size fell below the smallest step the integrator accepts.
    #[error("step size {h:e} s too small at t = {t} s (Newton iteration or error test keeps failing); state {state}")]
    StepSizeTooSmall {
        /// Simulation time [s].
        t: f64,
        /// The step size that was refused [s].
        h: f64,
        /// The state where it stopped, with names and units.
        state: String,
    },
    /// The integrator used up `RunSpec::max_steps` step attempts: its step
    /// size collapsed (a discontinuity the error test cannot get past, a
    /// chattering right-hand side) without reaching the minimum step.
    #[error("integration stalled at t = {t} s: {attempts} step attempts (limit {limit}, run.max_steps), step size {h:e} s; state {state}")]
    StepLimit {
        /// Simulation time [s].
        t: f64,
        /// The step size of the last attempt [s].
        h: f64,
        /// Step attempts made (accepted, rejected and abandoned).
        attempts: usize,
        /// The configured limit.
        limit: usize,
        /// The state where it stopped, with names and units.
        state: String,
    },
    /// A state left the physical domain (mass or temperature not positive)
    /// at an accepted point, i.e. not merely inside a Newton iteration.
    #[error("non-physical state at t = {t} s: {what}")]
    NonPhysical {
        /// Simulation time [s].
        t: f64,
        /// Which quantity, with its value.
        what: String,
    },
    /// More discrete events than `RunSpec::max_events` (stick–slip chattering
    /// or a Zeno-like sequence).
    #[error("more than {limit} events by t = {t} s (last: {last})")]
    TooManyEvents {
        /// Simulation time [s].
        t: f64,
        /// The configured limit.
        limit: usize,
        /// Kind of the last event.
        last: String,
    },
    /// Writing a CSV file failed.
    #[error("writing CSV: {0}")]
    Io(String),
}

impl RigError {
    pub(crate) fn invalid(name: &str, value: f64, reason: &'static str) -> Self {
        RigError::InvalidParameter { name: name.to_string(), value, reason }
    }
}
