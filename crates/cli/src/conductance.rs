//! `pneumo conductance` (placeholder: being written).

use crate::error::CliError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct ConductanceArgs {
    /// Input file.
    pub input: Option<PathBuf>,
}

pub fn run(_a: &ConductanceArgs) -> Result<(), CliError> {
    Err(CliError::Usage("pneumo conductance is not available yet".into()))
}
