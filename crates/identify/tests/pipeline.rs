//! The discrepancy workflow is a one-way pipeline (see the crate header in
//! `src/lib.rs`): a module's code (comments and `#[cfg(test)]` parts aside)
//! names only modules of its own or an earlier stage.

use std::path::Path;

/// Stage of every module; modules outside the pipeline are absent.
const STAGES: &[(&str, usize)] = &[
    ("rng", 1),
    ("stats", 1),
    ("data", 1),
    ("experiment", 1),
    ("netlist_edit", 1),
    ("effects", 1),
    ("phases", 1),
    ("params", 2),
    ("nuisance", 2),
    ("reuse", 2),
    ("problem", 2),
    ("fit", 2),
    ("options", 3),
    ("heldout", 3),
    ("footprint", 3),
    ("candidates", 3),
    ("selection", 4),
    ("sham", 4),
    ("diagnose", 5),
    ("report", 5),
    ("workflow", 5),
    ("manifest", 5),
];

fn stage(module: &str) -> Option<usize> {
    STAGES.iter().find(|(m, _)| *m == module).map(|(_, s)| *s)
}

/// `crate::NAME` references in the non-test code of `text`.
fn references(text: &str) -> Vec<String> {
    let code = text.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = Vec::new();
    for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
        let mut rest = line;
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + 7..];
            let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            out.push(name);
        }
    }
    out
}

#[test]
fn modules_use_only_earlier_stages() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files: Vec<(String, std::path::PathBuf)> = Vec::new();
    for entry in std::fs::read_dir(&src).expect("src is readable") {
        let p = entry.expect("entry").path();
        if p.extension().is_some_and(|e| e == "rs") {
            files.push((p.file_stem().unwrap().to_string_lossy().into_owned(), p));
        }
    }
    for entry in std::fs::read_dir(src.join("effects")).expect("src/effects is readable") {
        files.push(("effects".into(), entry.expect("entry").path()));
    }
    let mut wrong = Vec::new();
    let mut checked = 0;
    for (module, path) in &files {
        let Some(own) = stage(module) else { continue };
        let text = std::fs::read_to_string(path).expect("readable");
        for r in references(&text) {
            checked += 1;
            match stage(&r) {
                Some(s) if s <= own => {}
                Some(s) => wrong.push(format!("{} (stage {own}) uses {r} (stage {s})", path.display())),
                None if ["lsq", "discharge"].contains(&r.as_str()) => {}
                None => wrong.push(format!("{} uses {r}, outside the pipeline", path.display())),
            }
        }
    }
    assert!(checked > 20, "only {checked} references found: did the layout change?");
    assert!(wrong.is_empty(), "backward references:\n{}", wrong.join("\n"));
}
