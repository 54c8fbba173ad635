//! Pictures (placeholder: being written). `traces_image` renders result traces.

use crate::error::CliError;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct PlotArgs {
    /// Result CSV file(s).
    pub inputs: Vec<PathBuf>,
}

pub fn run(_a: &PlotArgs) -> Result<(), CliError> {
    Err(CliError::Usage("pneumo plot is not available yet".into()))
}

/// Render the given columns of a result over time; PNG or SVG by the path's extension.
pub fn traces_image(_result: &solve::SimResult, _columns: &[usize], _path: &Path) -> Result<Vec<u8>, CliError> {
    Err(CliError::Usage("plots are not available yet".into()))
}
