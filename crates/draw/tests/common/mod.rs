//! Helpers of the drawing tests: the file loader and the models folder.

// each test crate uses its own subset of these
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// Netlist files straight from the file system.
pub struct Fs;
impl graph::Loader for Fs {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

pub fn models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
}
