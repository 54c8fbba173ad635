//! Reading netlists from disk: the file loader for `graph`, which also
//! remembers every file it read (a netlist and its subsystems), so that no
//! output may overwrite one of them.

use crate::error::CliError;
use graph::{FlatNetlist, Loader};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// Largest netlist file read [bytes]; a bigger one (or a device such as
/// /dev/zero) is refused before it is read.
pub const MAX_NETLIST_BYTES: u64 = 16 << 20;

/// Largest measured-data file read [bytes] (about 10⁷ samples of a few channels).
pub const MAX_DATA_BYTES: u64 = 1 << 30;

/// Default of `--max-memory` [MiB].
pub const DEFAULT_MAX_MEMORY_MIB: u64 = 1024;

/// Resource limits of this process (global options).
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    pub max_components: usize,
    pub max_memory_mib: u64,
}

static LIMITS: std::sync::OnceLock<Limits> = std::sync::OnceLock::new();

/// Set the limits once, from the command line.
pub fn set_limits(l: Limits) {
    let _ = LIMITS.set(l);
}

/// The limits in force.
pub fn limits() -> Limits {
    LIMITS
        .get()
        .copied()
        .unwrap_or(Limits { max_components: graph::expand::DEFAULT_MAX_COMPONENTS, max_memory_mib: DEFAULT_MAX_MEMORY_MIB })
}

/// Reads netlist files from the file system and records their paths.
#[derive(Default)]
pub struct FsLoader {
    pub read: RefCell<Vec<PathBuf>>,
}

impl Loader for FsLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        self.read.borrow_mut().push(path.to_path_buf());
        read_text(path, MAX_NETLIST_BYTES, "netlist")
    }
    fn max_components(&self) -> usize {
        limits().max_components
    }
}

/// Read a text file of at most `limit` bytes; `what` names it in the message.
pub fn read_text(path: &Path, limit: u64, what: &str) -> Result<String, String> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let meta = file.metadata().map_err(|e| e.to_string())?;
    if meta.is_dir() {
        return Err("is a directory".into());
    }
    let mut bytes = Vec::new();
    // read one byte more than allowed to see whether there is more (devices report no size)
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(format!("is larger than {} MiB, the limit for a {what} file", limit >> 20));
    }
    String::from_utf8(bytes).map_err(|e| format!("is not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()))
}

/// Load a netlist, expand subsystems, apply `--set` overrides; also return
/// every file read.
pub fn netlist_with_files(path: &Path, sets: &[String]) -> Result<(FlatNetlist, Vec<PathBuf>), CliError> {
    let loader = FsLoader::default();
    let mut flat = graph::load(&loader, path)?;
    for s in sets {
        graph::apply_set(&mut flat, s)?;
    }
    Ok((flat, loader.read.into_inner()))
}
