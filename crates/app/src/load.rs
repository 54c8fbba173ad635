//! Reading netlists from disk: the file loader for `graph`, which also
//! remembers every file it read (a netlist and its subsystems), so that no
//! output may overwrite one of them, and [`Source`]: a model's files held in
//! memory, so that it can be loaded again without the file system (on a Dask
//! worker) and named in results by its path and content hash.

use crate::error::AppError;
use graph::{FlatNetlist, Loader};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
        read_input_text(path, "netlist")
    }
    fn max_components(&self) -> usize {
        limits().max_components
    }
}

/// Largest input file [bytes]: a quarter of `--max-memory`, because
/// parsing a file takes a few times its size (JSON values, columns of
/// numbers) beside the text itself.
pub fn max_input_bytes() -> u64 {
    limits().max_memory_mib.saturating_mul(1 << 20) / 4
}

/// Why `meta` is not a file pneumo reads: a directory, a device (such as
/// /dev/zero, which never ends), a named pipe or a socket.
fn not_a_regular_file(meta: &std::fs::Metadata, what: &str) -> Option<String> {
    let ft = meta.file_type();
    if ft.is_file() {
        return None;
    }
    if ft.is_dir() {
        return Some(format!("is a directory, not a {what} file"));
    }
    let kind = special_kind(&ft);
    Some(format!("is {kind}, not a {what} file (pneumo reads regular files only; copy it to a file first)"))
}

#[cfg(unix)]
fn special_kind(ft: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_char_device() {
        "a character device"
    } else if ft.is_block_device() {
        "a block device"
    } else if ft.is_fifo() {
        "a named pipe (FIFO)"
    } else if ft.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "a special file"
}

/// Size in MiB for a message.
fn mib(bytes: u64) -> String {
    units::show::fixed(bytes as f64 / 1048576.0, 1)
}

/// Read an input file — a netlist, a sub-circuit, a manifest, measured
/// data, results to plot or merge; `what` names it in messages. The one
/// reader of the user's files: anything but a regular file is refused by
/// its kind before it is opened (a FIFO would block, /dev/zero never ends),
/// and a file larger than [`max_input_bytes`] before it is read, with the
/// setting that raises the limit.
pub fn read_input(path: &Path, what: &str) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let io = |e: std::io::Error| units::show::text(&e.to_string());
    let check = |meta: &std::fs::Metadata| -> Result<u64, String> {
        if let Some(why) = not_a_regular_file(meta, what) {
            return Err(why);
        }
        let limit = max_input_bytes();
        if meta.len() > limit {
            return Err(format!(
                "is {} MiB, more than the {} MiB a {what} file may have with --max-memory {} MiB (input files get a quarter of it): raise --max-memory",
                mib(meta.len()),
                mib(limit),
                limits().max_memory_mib
            ));
        }
        Ok(limit)
    };
    // the path's type first: opening a FIFO would wait for a writer
    check(&std::fs::metadata(path).map_err(io)?)?;
    let file = std::fs::File::open(path).map_err(io)?;
    // again on what was opened, in case the path changed in between
    let meta = file.metadata().map_err(io)?;
    let limit = check(&meta)?;
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    // a file that grows while it is read stops at the limit
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(format!(
            "grew beyond {} MiB while it was read (the limit for a {what} file with --max-memory {} MiB): raise --max-memory",
            mib(limit),
            limits().max_memory_mib
        ));
    }
    Ok(bytes)
}

/// [`read_input`] for a text file: UTF-8 required.
pub fn read_input_text(path: &Path, what: &str) -> Result<String, String> {
    String::from_utf8(read_input(path, what)?)
        .map_err(|e| format!("is not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()))
}

/// Load a netlist, expand subsystems, apply `--set` overrides; also return
/// every file read.
pub fn netlist_with_files(path: &Path, sets: &[String]) -> Result<(FlatNetlist, Vec<PathBuf>), AppError> {
    let loader = FsLoader::default();
    let mut flat = graph::load(&loader, path)?;
    for s in sets {
        graph::apply_set(&mut flat, s)?;
    }
    Ok((flat, loader.read.into_inner()))
}

/// The netlist files of a model, as read: the path it was loaded from and
/// the text of every file read for it (the netlist, then its subsystems, in
/// the order `graph` asked for them).
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    pub path: PathBuf,
    pub files: Vec<(PathBuf, String)>,
}

/// Serves preset texts by path and, if allowed, reads other paths from the
/// file system; records every file it serves.
struct SourceLoader {
    preset: BTreeMap<PathBuf, String>,
    file_system: bool,
    served: RefCell<Vec<(PathBuf, String)>>,
}

impl Loader for SourceLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        let text = match self.preset.get(path) {
            Some(text) => text.clone(),
            None if self.file_system => read_input_text(path, "netlist")?,
            None => return Err("is not one of the model's files".into()),
        };
        let mut served = self.served.borrow_mut();
        if !served.iter().any(|(p, _)| p == path) {
            served.push((path.to_path_buf(), text.clone()));
        }
        Ok(text)
    }
    fn max_components(&self) -> usize {
        limits().max_components
    }
}

impl Source {
    /// Load the netlist at `path` (and its subsystems) from the file system.
    pub fn read(path: &Path) -> Result<(FlatNetlist, Source), AppError> {
        Self::load_with(path, BTreeMap::new(), true)
    }

    /// Load a netlist given as text, named `path` in messages; subsystem
    /// files it names are read relative to `path`'s folder.
    pub fn from_text(text: &str, path: &Path) -> Result<(FlatNetlist, Source), AppError> {
        Self::load_with(path, BTreeMap::from([(path.to_path_buf(), text.to_string())]), true)
    }

    /// Load the model again from the texts held (no file is read).
    pub fn load(&self) -> Result<FlatNetlist, AppError> {
        Ok(Self::load_with(&self.path, self.files.iter().cloned().collect(), false)?.0)
    }

    fn load_with(path: &Path, preset: BTreeMap<PathBuf, String>, file_system: bool) -> Result<(FlatNetlist, Source), AppError> {
        let loader = SourceLoader { preset, file_system, served: RefCell::new(Vec::new()) };
        let flat = graph::load(&loader, path)?;
        Ok((flat, Source { path: path.to_path_buf(), files: loader.served.into_inner() }))
    }

    /// The path as given, for result files (`model` column).
    pub fn name(&self) -> String {
        graph::escape(&self.path.display().to_string())
    }

    /// SHA-256 (hex) of the bytes of every file read, concatenated in the
    /// order they were read: for a netlist without subsystems, what
    /// `sha256sum model.json` prints.
    pub fn sha256(&self) -> String {
        use sha2::{Digest, Sha256};
        let mut hasher = Sha256::new();
        for (_, text) in &self.files {
            hasher.update(text.as_bytes());
        }
        hasher.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn models() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
    }

    #[test]
    fn a_source_loads_again_without_the_file_system_and_hashes_its_files() {
        // the meter-out circuit with its cylinder read from a file next to it, not the built-in
        let dir = std::env::temp_dir().join(format!("pneumo-load-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("lib")).unwrap();
        std::fs::copy(models().join("lib/cylinder.json"), dir.join("lib/cylinder.json")).unwrap();
        let parent = std::fs::read_to_string(models().join("meter_out_subsystem.json")).unwrap();
        let parent = parent.replace(r#""type": "cylinder""#, r#""type": "subsystem", "file": "lib/cylinder.json""#);
        let path = dir.join("meter_out_subsystem.json");
        std::fs::write(&path, parent).unwrap();
        let (flat, source) = Source::read(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(source.files.len() >= 2, "the subsystem file is held too: {:?}", source.files.iter().map(|f| &f.0).collect::<Vec<_>>());
        assert_eq!(source.files[0].0, path);
        assert_eq!(source.load().unwrap(), flat);
        // a file that is not held is not read from disk
        let mut partial = source.clone();
        partial.files.truncate(1);
        let e = partial.load().unwrap_err().to_string();
        assert!(e.contains("not one of the model's files"), "{e}");
        // the hash of a one-file model is that of its bytes (sha256sum); a known vector
        let one = Source { path: "m.json".into(), files: vec![("m.json".into(), "abc".into())] };
        assert_eq!(one.sha256(), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
        // it changes with any file's content
        let mut other = source.clone();
        other.files[1].1.push(' ');
        assert_ne!(other.sha256(), source.sha256());
    }

    #[test]
    fn a_netlist_given_as_text_is_held_under_its_name() {
        let path = models().join("meter_out.json");
        let text = std::fs::read_to_string(&path).unwrap();
        let named = models().join("from_text.json");
        let (flat, source) = Source::from_text(&text, &named).unwrap();
        assert_eq!(flat.components.len(), Source::read(&path).unwrap().0.components.len());
        assert_eq!(source.files, vec![(named, text)]);
    }
}
