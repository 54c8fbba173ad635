//! `pneumo discrepancy` (placeholder: being written).

use crate::error::CliError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct DiscrepancyArgs {
    /// Input file.
    pub input: Option<PathBuf>,
}

pub fn run(_a: &DiscrepancyArgs) -> Result<(), CliError> {
    Err(CliError::Usage("pneumo discrepancy is not available yet".into()))
}
