//! ARCHITECTURE.md stays true: every path it names exists, and the shape it
//! describes holds — the use cases live in `crates/app`, which knows no
//! argument parser and no terminal; the command line is a thin shell; the
//! Python package reaches the command-line crate only for `python -m pneumo`.
//!
//! Paths in backticks under a "## `crates/NAME`" heading that start with
//! `src/`, `tests/`, `benches/` or `examples/` are relative to that crate
//! (or, failing that, to the repository root); other backticked paths that
//! start with a top-level folder are relative to the repository root.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The dependency names in the `[dependencies]` table of a crate's Cargo.toml.
fn dependencies(krate: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root().join("crates").join(krate).join("Cargo.toml")).expect("Cargo.toml readable");
    let mut inside = false;
    let mut names = Vec::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == "[dependencies]";
        } else if inside && !line.is_empty() && !line.starts_with('#') {
            let name = line.split(['=', '.']).next().unwrap_or("").trim();
            names.push(name.to_string());
        }
    }
    names
}

/// The code of every `.rs` file under `crates/<krate>/src`, before its unit
/// tests and without comments: (path, line number, line).
fn code_lines(krate: &str) -> Vec<(PathBuf, usize, String)> {
    fn walk(dir: &Path, files: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("src readable") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                walk(&path, files);
            } else if path.extension().and_then(|e| e.to_str()) == Some("rs") {
                files.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&root().join("crates").join(krate).join("src"), &mut files);
    let mut lines = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).expect("source readable");
        let code = text.split("#[cfg(test)]").next().unwrap_or("").to_string();
        for (i, line) in code.lines().enumerate() {
            let line = line.split("//").next().unwrap_or("");
            lines.push((path.clone(), i + 1, line.to_string()));
        }
    }
    lines
}

#[test]
fn every_path_in_the_codemap_exists() {
    let root = root();
    let text = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md is readable");
    let mut crate_dir: Option<String> = None;
    let mut missing = Vec::new();
    let mut checked = 0;
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("## ") {
            crate_dir = rest.split('`').nth(1).filter(|s| s.starts_with("crates/")).map(str::to_string);
        }
        for (i, token) in line.split('`').enumerate() {
            if i % 2 == 0 || token.contains(' ') {
                continue;
            }
            let in_crate = ["src/", "tests/", "benches/", "examples/"].iter().any(|p| token.starts_with(p));
            let path = if let (true, Some(dir)) = (in_crate, &crate_dir) {
                // `tests/data/` under a crate heading may still mean the repository's
                let local = root.join(dir).join(token);
                if local.exists() || token.starts_with("src/") {
                    local
                } else {
                    root.join(token)
                }
            } else if token.starts_with("src/") {
                continue;
            } else if ["crates/", "models/", "tests/", "docs/", ".ci/", "scripts/"].iter().any(|p| token.starts_with(p)) {
                root.join(token)
            } else {
                continue;
            };
            checked += 1;
            if !path.exists() {
                missing.push(token.to_string());
            }
        }
    }
    assert!(checked > 30, "the codemap names only {checked} paths: did its format change?");
    assert!(missing.is_empty(), "ARCHITECTURE.md names paths that do not exist: {missing:?}");
}

/// `graph` and `solve` read only the block contract: their code (tests
/// aside) never names a block type ("chamber", "valve_5_2", …) in a string,
/// so adding a block never touches them.
#[test]
fn graph_and_solve_never_name_a_block_type() {
    let names: Vec<String> = blocks::registry::TYPES.iter().map(|t| format!("\"{}\"", t.name)).collect();
    let mut found = Vec::new();
    for krate in ["graph", "solve"] {
        for (path, n, line) in code_lines(krate) {
            for name in &names {
                if line.contains(name.as_str()) {
                    found.push(format!("{}:{n}: {name}", path.display()));
                }
            }
        }
    }
    assert!(found.is_empty(), "graph/solve name block types: {found:?}");
}

/// The use-case layer knows no argument parser and no terminal: `pneumo-app`
/// does not depend on clap or a progress bar, and its code prints nothing.
#[test]
fn the_use_case_layer_parses_no_arguments_and_prints_nothing() {
    let deps = dependencies("app");
    assert!(deps.iter().any(|d| d == "pneumo-solve"), "the dependency reader found {deps:?}: did Cargo.toml's format change?");
    for banned in ["clap", "indicatif", "libc", "pyo3", "pneumo-cli"] {
        assert!(!deps.iter().any(|d| d == banned), "crates/app depends on {banned}");
    }
    let found: Vec<String> = code_lines("app")
        .into_iter()
        .filter(|(_, _, l)| {
            ["print!(", "println!(", "eprint!(", "eprintln!(", "clap::", "std::process::exit"].iter().any(|p| l.contains(p))
        })
        .map(|(p, n, l)| format!("{}:{n}: {}", p.display(), l.trim()))
        .collect();
    assert!(found.is_empty(), "crates/app prints or parses arguments: {found:?}");
}

/// The command line is a thin shell: its own dependencies are the app, the
/// netlist crate (for its schema and warnings), clap, JSON, a progress bar
/// and libc; it reads and writes no file itself (the app does).
#[test]
fn the_command_line_is_a_thin_shell() {
    let allowed = ["pneumo-app", "pneumo-graph", "clap", "serde_json", "indicatif", "libc"];
    let deps = dependencies("cli");
    assert!(deps.iter().any(|d| d == "pneumo-app"), "the dependency reader found {deps:?}: did Cargo.toml's format change?");
    let extra: Vec<&String> = deps.iter().filter(|d| !allowed.contains(&d.as_str())).collect();
    assert!(extra.is_empty(), "crates/cli depends on {extra:?}: use cases belong in crates/app");
    let found: Vec<String> = code_lines("cli")
        .into_iter()
        .filter(|(_, _, l)| ["std::fs", "File::", "Transaction", "solve::", "identify::", "plotters"].iter().any(|p| l.contains(p)))
        .map(|(p, n, l)| format!("{}:{n}: {}", p.display(), l.trim()))
        .collect();
    assert!(found.is_empty(), "crates/cli does use-case work itself: {found:?}");
}

/// Python calls the use cases in `pneumo_app`; it reaches `pneumo_cli` only
/// through `command::run`, for `python -m pneumo`.
#[test]
fn python_uses_the_command_line_crate_only_for_python_m_pneumo() {
    let deps = dependencies("python");
    assert!(deps.iter().any(|d| d == "pneumo-app"), "crates/python does not depend on pneumo-app: {deps:?}");
    let lines = code_lines("python");
    let uses: Vec<String> = lines
        .iter()
        .filter(|(_, _, l)| l.contains("pneumo_cli"))
        .filter(|(_, _, l)| l.matches("pneumo_cli").count() != l.matches("pneumo_cli::command::run(").count())
        .map(|(p, n, l)| format!("{}:{n}: {}", p.display(), l.trim()))
        .collect();
    assert!(uses.is_empty(), "crates/python uses pneumo_cli beyond command::run: {uses:?}");
    assert!(
        lines.iter().any(|(_, _, l)| l.contains("pneumo_app::")),
        "crates/python names no pneumo_app item: did the source layout change?"
    );
}
