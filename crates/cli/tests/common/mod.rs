//! Helpers shared by the end-to-end tests of the `pneumo` binary: the
//! repository root, the PNG signature, and private scratch directories that
//! are removed when the test ends.

// each test crate uses its own subset of these
#![allow(dead_code)]

pub mod numbers;
pub mod quotes;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

pub const PNG_MAGIC: &[u8] = b"\x89PNG\r\n\x1a\n";

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A private directory under the system temp dir, removed on drop.
pub struct Scratch(pub PathBuf);

impl Scratch {
    pub fn new(tag: &str) -> Scratch {
        static N: AtomicU64 = AtomicU64::new(0);
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
        let dir = std::env::temp_dir().join(format!(
            "pneumo-cli-test-{tag}-{}-{}-{nanos}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).expect("create scratch dir");
        Scratch(dir)
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, text).expect("write scratch file");
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run the `pneumo` binary in `dir` with a wall-clock limit of 60 s (a hang
/// fails the test instead of blocking it).
pub fn pneumo_in(dir: &Path, args: &[&str]) -> std::process::Output {
    pneumo_within(dir, args, 60)
}

/// As [`pneumo_in`], with a limit of `seconds` (for the few commands that
/// run a whole discrepancy analysis).
#[allow(dead_code)]
pub fn pneumo_within(dir: &Path, args: &[&str], seconds: u64) -> std::process::Output {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_pneumo"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start pneumo");
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if start.elapsed() > Duration::from_secs(seconds) {
            let _ = child.kill();
            panic!("pneumo {args:?} in {} did not finish within {seconds} s", dir.display());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}
