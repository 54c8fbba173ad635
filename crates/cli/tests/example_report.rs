//! The committed example report (models/examples/discrepancy/report/) and
//! the pages that quote it cannot drift apart.
//!
//! In every run: docs/discrepancy.md's "Worked example" table, its
//! simulation counts, README.md's leak conductance and simulation count and
//! docs/python.md's leak estimate are compared with the committed report.md
//! (numbers to the digits shown, within 0.5 %, as in tutorial.rs). The
//! analysis itself takes minutes (≈ 3.5 min of CPU), too long for every CI
//! run, so the check that the committed report is what the code writes now
//! is ignored by default: `cargo test --release -p pneumo-cli --test
//! example_report -- --ignored` reruns the command the Worked example names
//! and compares report.md line by line (all but the wall time).

mod common;

use common::numbers::{half_ulp, mismatch, pieces, Piece};
use common::{repo, Scratch};
use std::process::Command;

const REPORT: &str = "models/examples/discrepancy/report/report.md";

fn read(path: &str) -> String {
    std::fs::read_to_string(repo().join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The numbers of a piece of text, as (value, word).
fn numbers(text: &str) -> Vec<(f64, String)> {
    pieces(text)
        .into_iter()
        .filter_map(|p| match p {
            Piece::Number(x, word) => Some((x, word)),
            Piece::Text(_) => None,
        })
        .collect()
}

/// Fails unless the page's number `word` reads as the report's `value`.
fn agrees(page: &str, what: &str, word: &(f64, String), value: f64) {
    let allowed = half_ulp(&word.1) + 0.005 * word.0.abs();
    assert!((word.0 - value).abs() <= allowed, "{page} is stale: {what} is {} on the page and {value} in the committed {REPORT}", word.1);
}

/// The cells of a Markdown table row.
fn cells(line: &str) -> Vec<&str> {
    line.trim().trim_matches('|').split('|').map(str::trim).collect()
}

/// The estimates of the report's parameter table under `heading`: name → value.
fn estimates(report: &str, heading: &str) -> Vec<(String, f64)> {
    let start = report.find(heading).unwrap_or_else(|| panic!("{REPORT} has no {heading:?}"));
    report[start..]
        .lines()
        .skip_while(|l| !l.starts_with("| parameter |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let c = cells(l);
            (c[0].to_string(), numbers(c[1])[0].0)
        })
        .collect()
}

/// The numbers of the report's line that starts with `prefix` (after it).
fn line_numbers(report: &str, prefix: &str) -> Vec<f64> {
    let line = report.lines().find(|l| l.starts_with(prefix)).unwrap_or_else(|| panic!("{REPORT} has no line {prefix:?}"));
    numbers(&line[prefix.len()..]).into_iter().map(|(x, _)| x).collect()
}

/// The report's simulation count (its last line: "N simulations of all experiments, T s.").
fn simulations(report: &str) -> f64 {
    let line = report.lines().rev().find(|l| l.contains("simulations of all experiments")).expect("the count line");
    numbers(line)[0].0
}

/// The page's text from `start` to `end`, lines joined by spaces.
fn between(page: &str, text: &str, start: &str, end: &str) -> String {
    let joined = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let from = joined.find(start).unwrap_or_else(|| panic!("{page} lost the words {start:?}"));
    let rest = &joined[from + start.len()..];
    let to = rest.find(end).unwrap_or_else(|| panic!("{page}: no {end:?} after {start:?}"));
    rest[..to].to_string()
}

#[test]
fn the_worked_example_quotes_the_committed_report() {
    let report = read(REPORT);
    let page = read("docs/discrepancy.md");
    let section = &page[page.find("## Worked example").expect("Worked example")..];
    let section = &section[..section.find("\n## ").unwrap_or(section.len())];
    let baseline = estimates(&report, "### Calibrated baseline");
    let after = estimates(&report, "### With the missing effect");
    let find = |table: &[(String, f64)], name: &str| {
        table.iter().find(|(n, _)| n == name).map(|(_, x)| *x).unwrap_or_else(|| panic!("{REPORT} has no estimate of {name}"))
    };
    let mut checked = 0;
    for line in section.lines().filter(|l| l.starts_with("| `")) {
        let c = cells(line);
        let name = c[0].split('`').nth(1).expect("a `name`");
        if name == "piston_seal_leak" {
            continue; // the header row
        }
        let base = numbers(c[1]);
        if !base.is_empty() {
            agrees("docs/discrepancy.md", &format!("the calibrated baseline's {name}"), &base[0], find(&baseline, name));
        }
        agrees("docs/discrepancy.md", &format!("{name} with the effect"), &numbers(c[2])[0], find(&after, name));
        checked += 1;
    }
    assert!(checked >= 7, "only {checked} parameter rows of the Worked example checked");
    // the leak's interval: the verdict line "C = 0.29985 L/min/bar, 95 % interval [a, b]"
    let verdict = line_numbers(&report, "- added `piston_seal_leak`: C = ");
    let leak_row = section.lines().find(|l| l.starts_with("| `piston_seal_leak.C`")).expect("the leak row");
    let leak = numbers(cells(leak_row)[2]);
    for (k, what) in [(0, "leak C"), (2, "its interval's low end"), (3, "its interval's high end")] {
        agrees("docs/discrepancy.md", what, &leak[k], verdict[k]);
    }
    // normalised RMSE before and after, in the report's channel order
    let rmse = line_numbers(&report, "Normalised RMSE (1 = sensor noise): ");
    let rmse_row = section.lines().find(|l| l.starts_with("| normalised RMSE head.p / piston.x / rod.p")).expect("the RMSE row");
    let (b, a) = (numbers(cells(rmse_row)[1]), numbers(cells(rmse_row)[2]));
    for k in 0..3 {
        agrees("docs/discrepancy.md", "a baseline RMSE", &b[k], rmse[k]);
        agrees("docs/discrepancy.md", "an RMSE after", &a[k], rmse[3 + k]);
    }
    let held_out = line_numbers(&report, "Held-out RMSE: ");
    let held_row = section.lines().find(|l| l.starts_with("| held-out normalised RMSE")).expect("the held-out row");
    agrees("docs/discrepancy.md", "the held-out RMSE before", &numbers(cells(held_row)[1])[0], held_out[0]);
    agrees("docs/discrepancy.md", "the held-out RMSE after", &numbers(cells(held_row)[2])[0], held_out[1]);
    // "2813 simulations of all four experiments" (Worked example and Speed)
    let n = simulations(&report);
    for start in ["more (every screened ΔIC above zero).", "**Shipped example, current code** (2026-11-27, the laminar ratios"] {
        let text = between("docs/discrepancy.md", &page, start, "simulations");
        let words = numbers(&text.replace(' ', ""));
        agrees("docs/discrepancy.md", "the simulation count", words.last().expect("a count"), n);
    }
}

#[test]
fn readme_and_python_guide_quote_the_committed_report() {
    let report = read(REPORT);
    let verdict = line_numbers(&report, "- added `piston_seal_leak`: C = ");
    let readme = read("README.md");
    let c = numbers(&between("README.md", &readme, "it finds the hidden seal leak (C =", "against"));
    agrees("README.md", "the leak's C", &c[0], verdict[0]);
    let count = numbers(&between("README.md", &readme, "it ran", "simulations").replace(' ', ""));
    agrees("README.md", "the simulation count", &count[0], simulations(&report));
    // python.md prints the estimate and its interval with pandas' six
    // digits: each must read as the report's, to the report's digits
    let python = read("docs/python.md");
    let shown = numbers(&between("docs/python.md", &python, "\"ci95_high_in_unit\"]] value_in_unit", "Name:"));
    assert_eq!(shown.len(), 3, "value, low and high end: {shown:?}");
    for (word, (k, what)) in shown.iter().zip([(0, "value"), (2, "low end"), (3, "high end")]) {
        let report_word = format!("{}", verdict[k]);
        assert!(
            (word.0 - verdict[k]).abs() <= 0.5e-6 + half_ulp(&report_word),
            "docs/python.md is stale: the leak's {what} is {} there and {report_word} in the committed {REPORT}",
            word.1
        );
    }
}

/// Reruns the Worked example's command (minutes) and compares the report it
/// writes with the committed one, line by line.
#[test]
#[ignore]
fn the_committed_report_is_what_the_code_writes() {
    let dir = Scratch::new("example-report");
    std::os::unix::fs::symlink(repo().join("models").canonicalize().expect("models"), dir.path("models")).expect("link models");
    let out = Command::new(env!("CARGO_BIN_EXE_pneumo"))
        .args([
            "discrepancy",
            "models/meter_out.json",
            "--experiments",
            "models/examples/discrepancy/experiments.json",
            "--report",
            "report",
        ])
        .current_dir(&dir.0)
        .output()
        .expect("run pneumo");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let fresh = std::fs::read_to_string(dir.path("report").join("report.md")).expect("report.md");
    let committed = read(REPORT);
    let (f, c): (Vec<&str>, Vec<&str>) = (fresh.lines().collect(), committed.lines().collect());
    assert_eq!(f.len(), c.len(), "the committed {REPORT} has {} lines, the code writes {}:\n{fresh}", c.len(), f.len());
    for (c, f) in c.iter().zip(&f) {
        // the last line's wall time is the machine's; its simulation count is the code's
        let (c, f) = match (c.split_once(" simulations of all experiments, "), f.split_once(" simulations of all experiments, ")) {
            (Some((c, _)), Some((f, _))) => (c, f),
            _ => (*c, *f),
        };
        if let Some(why) = mismatch(c, f) {
            panic!("the committed {REPORT} is stale ({why}); regenerate it with the command of docs/discrepancy.md, Worked example\n committed: {c}\n now:       {f}");
        }
    }
}
