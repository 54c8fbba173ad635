//! Calibration and discrepancy analysis: fit a circuit model to measured
//! cylinder data, find where and when it is wrong, and name the physical
//! effect it is missing (the workflow behind `pneumo discrepancy`).
//!
//! Modules:
//! - [`lsq`]: bounded Levenberg–Marquardt least squares.
//! - [`discharge`]: sonic conductance from a discharge (paper Eq. 36).
//! - [`data`]: measured CSV tables and sensor-noise estimates.
//! - [`netlist_edit`]: reading and editing flat netlists (SI values, roles).
//! - [`effects`]: the catalogue of candidate missing effects.
//! - [`problem`]: experiments, fitted parameters, noise-weighted residuals.
//! - [`manifest`]: the experiments manifest of `pneumo discrepancy`.
//! - [`phases`]: phases of the actuator cycle.
//! - [`diagnose`]: residual statistics per channel and phase, whiteness,
//!   correlation with regressors.
//! - [`workflow`]: calibrate → diagnose → try candidates → select → report.
//! - [`synth`]: synthetic measurements with a hidden effect (tests, example).
//!
//! Everything is SI. Files are not touched here: callers pass text and
//! parsed netlists.

pub mod data;
pub mod diagnose;
pub mod discharge;
pub mod effects;
pub mod lsq;
pub mod manifest;
pub mod netlist_edit;
pub mod phases;
pub mod problem;
pub mod synth;
pub mod workflow;

pub use problem::{CalibSpec, Experiment};
pub use workflow::{run, IdentifyError, Options, Outcome, Summary, Thresholds};
