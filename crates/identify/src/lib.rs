//! Calibration and discrepancy analysis: fit a circuit model to measured
//! cylinder data, find where and when it is wrong, and name the physical
//! effect it is missing (the workflow behind `pneumo discrepancy`).
//!
//! The discrepancy workflow is a pipeline; each module uses only the ones
//! listed before it (checked by `tests/pipeline.rs`):
//!
//! 1. **data and experiments** — [`rng`] (test and example random numbers),
//!    [`stats`] (correlated residuals: effective sample size, information
//!    criterion, covariance), [`data`] (measured CSV, noise estimate),
//!    [`experiment`] (channels on simulation time), [`netlist_edit`],
//!    [`effects`] (the catalogue), [`phases`] (where in the cycle a sample
//!    lies), [`manifest`]'s inputs;
//! 2. **the fitting problem** — [`params`] (fitted parameters), [`nuisance`]
//!    (sensor offsets and gains), [`problem`] (simulation and residuals),
//!    [`fit`] (least squares with continuation and honest statistics);
//! 3. **candidates** — [`options`], [`heldout`] (leave-one-experiment-out
//!    predictions), [`footprint`] (an effect's largest change against the
//!    sensors' accuracy), [`candidates`] (trying one effect);
//! 4. **selection** — [`selection`] (the tests, the model-form floor, the
//!    greedy search and its backward check), [`sham`] (the generic
//!    correction a candidate must beat);
//! 5. **report** — [`diagnose`], [`report`] (traces, remainder,
//!    verdict), and [`workflow`], which runs the stages in order;
//!    [`manifest`] turns a manifest file into the workflow's inputs.
//!
//! Outside the pipeline: [`lsq`] (bounded Levenberg–Marquardt),
//! [`discharge`] (conductance from a discharge, paper Eq. 36) and [`synth`]
//! (synthetic measurements from our own model, for tests; nothing depends
//! on it).
//!
//! Everything is SI. Files are not touched here: callers pass text and
//! parsed netlists.

pub mod candidates;
pub mod data;
pub mod diagnose;
pub mod discharge;
pub mod effects;
pub mod experiment;
pub mod fit;
pub mod footprint;
pub mod heldout;
pub mod lsq;
pub mod manifest;
pub mod netlist_edit;
pub mod nuisance;
pub mod options;
pub mod params;
pub mod phases;
pub mod problem;
pub mod report;
pub mod reuse;
pub mod rng;
pub mod selection;
pub mod sham;
pub mod stats;
pub mod synth;
pub mod workflow;

pub use experiment::Experiment;
pub use options::{Options, Thresholds};
pub use params::CalibSpec;
pub use report::{Outcome, Summary};
pub use workflow::{run, IdentifyError};
