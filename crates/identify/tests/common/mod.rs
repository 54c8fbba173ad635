//! Helpers the identify tests share with the command line's docs checks: the
//! repository root and the pages' number rule, so that a test compares the
//! figures a page quotes with what it computes (`quotes::Page::says`).
#![allow(dead_code)] // each test binary uses a different subset

use std::path::{Path, PathBuf};

/// The repository root (the documentation pages' paths start there).
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[path = "../../../cli/tests/common/numbers.rs"]
pub mod numbers;
#[path = "../../../cli/tests/common/quotes.rs"]
pub mod quotes;
