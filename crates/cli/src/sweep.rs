//! Parameter sweeps (placeholder: being written).

use crate::error::CliError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SweepArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Shard outputs to join.
    pub inputs: Vec<PathBuf>,
}

pub fn run(_a: &SweepArgs) -> Result<(), CliError> {
    Err(CliError::Usage("pneumo sweep is not available yet".into()))
}

pub fn merge(_a: &MergeArgs) -> Result<(), CliError> {
    Err(CliError::Usage("pneumo merge is not available yet".into()))
}
