//! The use-case layer of `pneumo`: what every front end calls — the
//! `pneumo` command (`crates/cli`), the Python package (`crates/python`), an
//! FMU runtime or a report generator. Loading netlists with their files and
//! overrides ([`load`]), one run with its budgets and rest state ([`run`]),
//! outputs written as one transaction and the summary JSON ([`output`]),
//! and one module per use case: [`check`], [`simulate`], [`sweep`] (and
//! merge), [`plot`], [`conductance`], [`discrepancy`], [`linearize`], [`sensitivity`] (a run with parameter sensitivities), [`draw`], [`report`],
//! [`fmu`] (export as an FMI 2.0 Co-Simulation FMU). Use cases take plain
//! option structs and return values or text; a front end parses its own
//! arguments, prints, and maps [`AppError`] to its exit status or exception.
//!
//! The only crate that reads and writes the user's files.
//! Never knows: argument parsing, terminals (progress bars, stdout), Python.

pub mod check;
pub mod conductance;
pub mod discrepancy;
pub mod draw;
pub mod error;
pub mod fmu;
pub mod linearize;
pub mod load;
pub mod output;
pub mod plot;
pub mod report;
pub mod run;
pub mod sensitivity;
pub mod simulate;
pub mod sweep;
pub mod written_model;

pub use error::AppError;
