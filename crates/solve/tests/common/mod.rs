//! Helpers shared by the whole-pipeline reference tests (`tests/reference.rs`).
//!
//! Purpose: run a netlist through the same chain the command line uses —
//! JSON text → `graph::expand::parse`/`flatten` (subsystems, `--set`) →
//! `graph::build` (wiring, causality) → `solve::Model` → `solve::simulate` —
//! and read the result back as time series.
//!
//! Nothing here implements physics: the closed forms live next to each test
//! so that a reader sees the derivation beside the assertion. Units are SI
//! throughout (Pa, K, kg, m, s), as in the result columns.
#![allow(dead_code)] // each test binary uses a different subset

use graph::{FlatNetlist, Loader};
use solve::{SimOptions, SimResult};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Netlist files held in memory, keyed by path.
#[derive(Debug, Default)]
pub struct MemLoader(pub HashMap<PathBuf, String>);

impl Loader for MemLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        self.0.get(path).cloned().ok_or_else(|| format!("no such file {}", path.display()))
    }
}

/// Netlist files read from disk (for the shipped models).
#[derive(Debug, Default)]
pub struct FsLoader;

impl Loader for FsLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

/// The repository's `models/` directory.
pub fn models_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

/// The repository root (the documentation pages' paths start there).
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The pages' number rule and quote finder, one copy shared with the
/// command line's docs checks: a test compares the figures a page quotes
/// with what it computes (`quotes::Page::says`).
#[path = "../../../cli/tests/common/numbers.rs"]
pub mod numbers;
#[path = "../../../cli/tests/common/quotes.rs"]
pub mod quotes;

/// Parse and flatten an inline netlist (no subsystem files).
pub fn flat_from_json(netlist: &serde_json::Value) -> FlatNetlist {
    let text = serde_json::to_string_pretty(netlist).expect("a json! value always serialises");
    let parsed = graph::expand::parse(&text, "inline").unwrap_or_else(|e| panic!("parse: {e}"));
    graph::expand::flatten(&MemLoader::default(), &parsed, Path::new(""), 0).unwrap_or_else(|e| panic!("flatten: {e}"))
}

/// Load a shipped model from `models/` and apply `--set` style overrides.
pub fn flat_from_model(file: &str, sets: &[&str]) -> FlatNetlist {
    let mut flat = graph::load(&FsLoader, &models_dir().join(file)).unwrap_or_else(|e| panic!("load {file}: {e}"));
    for s in sets {
        graph::apply_set(&mut flat, s).unwrap_or_else(|e| panic!("--set {s}: {e}"));
    }
    flat
}

/// Build and simulate with the netlist's own settings (as `pneumo simulate` does).
pub fn run(flat: &FlatNetlist) -> SimResult {
    run_with(flat, |_| {})
}

/// Build and simulate, letting the caller adjust the options first.
pub fn run_with(flat: &FlatNetlist, adjust: impl FnOnce(&mut SimOptions)) -> SimResult {
    let circuit = graph::build(flat).unwrap_or_else(|e| panic!("build: {e}"));
    let mut opts = solve::options_from(&circuit.simulation).unwrap_or_else(|e| panic!("settings: {e}"));
    adjust(&mut opts);
    let mut model = solve::Model::new(circuit);
    solve::simulate(&mut model, &opts).unwrap_or_else(|e| panic!("simulate: {e}"))
}

/// A result column as (t, value) pairs; panics with the known names if absent.
pub fn series(res: &SimResult, name: &str) -> Vec<(f64, f64)> {
    res.series(name).unwrap_or_else(|| panic!("no column {name} (have: {})", res.columns.join(", ")))
}

/// Last defined value of a column.
pub fn last(res: &SimResult, name: &str) -> f64 {
    series(res, name).last().map(|&(_, v)| v).unwrap_or_else(|| panic!("column {name} is empty"))
}

/// Linear interpolation of a series at time `t` (inside its span).
pub fn at(s: &[(f64, f64)], t: f64) -> f64 {
    let i = s.partition_point(|&(ti, _)| ti < t);
    assert!(i < s.len(), "t = {t} is after the last sample {}", s[s.len() - 1].0);
    if i == 0 || s[i].0 == t {
        return s[i].1;
    }
    let (t0, v0) = s[i - 1];
    let (t1, v1) = s[i];
    v0 + (v1 - v0) * (t - t0) / (t1 - t0)
}

/// Times where `v(t) - level` changes sign, by linear interpolation between samples.
pub fn crossings(s: &[(f64, f64)], level: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for w in s.windows(2) {
        let (a, b) = (w[0].1 - level, w[1].1 - level);
        if a != 0.0 && (a < 0.0) != (b < 0.0) && w[1].0 > w[0].0 {
            out.push(w[0].0 + (w[1].0 - w[0].0) * a / (a - b));
        }
    }
    out
}

/// Relative difference |a − b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// A flattened netlist built into a model with its simulation settings, as
/// the command line builds it (the Jacobian tests start every run here).
pub fn model_of(flat: &FlatNetlist) -> (solve::Model, SimOptions) {
    let circuit = graph::build(flat).unwrap_or_else(|e| panic!("build: {e}"));
    let opts = solve::options_from(&circuit.simulation).unwrap_or_else(|e| panic!("settings: {e}"));
    (solve::Model::new(circuit), opts)
}
