//! ARCHITECTURE.md stays true: every path it names exists.
//!
//! Paths in backticks under a "## `crates/NAME`" heading that start with
//! `src/`, `tests/`, `benches/` or `examples/` are relative to that crate
//! (or, failing that, to the repository root); other backticked paths that
//! start with a top-level folder are relative to the repository root.

use std::path::Path;

#[test]
fn every_path_in_the_codemap_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
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
            } else if ["crates/", "models/", "tests/", "docs/", ".ci/"].iter().any(|p| token.starts_with(p)) {
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
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let names: Vec<String> = blocks::registry::TYPES.iter().map(|t| format!("\"{}\"", t.name)).collect();
    let mut found = Vec::new();
    for krate in ["graph", "solve"] {
        let dir = root.join("crates").join(krate).join("src");
        for entry in std::fs::read_dir(&dir).expect("src readable") {
            let path = entry.expect("entry").path();
            if path.extension().and_then(|e| e.to_str()) != Some("rs") {
                continue;
            }
            let text = std::fs::read_to_string(&path).expect("source readable");
            // the code before the unit tests, without comments
            let code = text.split("#[cfg(test)]").next().unwrap_or("");
            for (i, line) in code.lines().enumerate() {
                let line = line.split("//").next().unwrap_or("");
                for n in &names {
                    if line.contains(n.as_str()) {
                        found.push(format!("{}:{}: {n}", path.display(), i + 1));
                    }
                }
            }
        }
    }
    assert!(found.is_empty(), "graph/solve name block types: {found:?}");
}
