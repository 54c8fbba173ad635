//! The use-case layer of `pneumo`: loading netlists, running, sweeping,
//! writing outputs, and the command line itself. The `pneumo` binary
//! (`src/main.rs`) is a thin wrapper around [`command::run`]; the Python
//! package (`crates/python`) calls the same modules, so a DataFrame from
//! `pneumo.sweep` and a CSV from `pneumo sweep` come from one code path.
//!
//! The only crate that touches files, terminals and exit codes.

pub mod check;
pub mod command;
pub mod conductance;
pub mod discrepancy;
pub mod draw;
pub mod error;
pub mod load;
pub mod output;
pub mod plot;
pub mod run;
pub mod simulate;
pub mod sweep;

pub use error::CliError;
