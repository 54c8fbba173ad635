//! Reading netlists from disk and building runnable models.

use crate::error::CliError;
use graph::{FlatNetlist, Loader};
use std::path::Path;

/// Reads netlist files from the file system.
pub struct FsLoader;

impl Loader for FsLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

/// Load a netlist, expand subsystems, apply `--set` overrides.
pub fn flat_netlist(path: &Path, sets: &[String]) -> Result<FlatNetlist, CliError> {
    let mut flat = graph::load(&FsLoader, path)?;
    for s in sets {
        graph::apply_set(&mut flat, s)?;
    }
    Ok(flat)
}
