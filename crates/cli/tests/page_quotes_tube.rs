//! docs/blocks.md's tube-convergence tables against the study's committed
//! output, docs/data/tube_convergence.txt (what
//! `cargo run --release -p pneumo-cli --example tube_convergence -- out.csv 40`
//! prints, less its last line): the rows that take tens of seconds (N = 10
//! and 20 at 0.1 of air's viscosity, N = 20 and the line of N = 40 at air's
//! viscosity, every error against N = 40) are read from the file, the page's
//! rule of thumb from its rows. The cheap rows are rerun by page_quotes.rs;
//! the ignored test here (`-- --ignored`, about a minute) reruns the whole
//! study and compares the committed file with what the code gives now
//! (numbers by the shared rule, common/numbers.rs: to the digits shown,
//! within 0.5 %). The page's rows must be the file's, character for
//! character.

mod common;

/// The tube study of docs/blocks.md, included to rerun it.
#[path = "../examples/tube_convergence.rs"]
#[allow(dead_code)]
mod tube_convergence;

use common::numbers::{mismatch, numbers_in as numbers};
use common::quotes::Page;

const STUDY: &str = "docs/data/tube_convergence.txt";

fn committed() -> Vec<String> {
    std::fs::read_to_string(common::repo().join(STUDY)).unwrap_or_else(|e| panic!("{STUDY}: {e}")).lines().map(str::to_string).collect()
}

/// The data rows of a Markdown table's lines (first cell a number), trimmed,
/// the typographic minus read as -.
fn data_rows<'a>(lines: impl Iterator<Item = &'a str>) -> Vec<String> {
    lines.map(|l| l.trim().replace('−', "-")).filter(|l| l.starts_with("| ") && l[2..].starts_with(|c: char| c.is_ascii_digit())).collect()
}

#[test]
fn blocks_md_s_tube_tables_are_the_committed_study_s() {
    let study = committed();
    let text = std::fs::read_to_string(common::repo().join("docs/blocks.md")).expect("docs/blocks.md");
    let from = text.find("**Convergence with N**").expect("docs/blocks.md lost its tube convergence paragraph");
    let to = from + text[from..].find("Rule of thumb").expect("docs/blocks.md lost its rule of thumb");
    let page_rows = data_rows(text[from..to].lines());
    let study_rows = data_rows(study.iter().map(String::as_str));
    assert_eq!(study_rows.len(), 8, "{STUDY}: the two tables' rows, N = 2, 5, 10, 20 each");
    assert_eq!(page_rows.len(), study_rows.len(), "docs/blocks.md shows the study's rows: {page_rows:?}");
    // the page copies the file's rows: character for character (the typographic minus aside)
    for (page, study) in page_rows.iter().zip(&study_rows) {
        assert_eq!(page, study, "docs/blocks.md is stale against {STUDY}");
    }
    // "against the line of N = 40 (arrival 14.689 ms, return 43.370 ms, plateau 0.1495 bar)"
    let reference = study.iter().find(|l| l.starts_with("Air's viscosity")).expect("the reference line");
    let [_, finest, arrival, back, plateau] = numbers(reference)[..] else { panic!("{reference}") };
    let page = Page::read("docs/blocks.md");
    page.says("against the line of N =", &[Some(finest), Some(arrival), Some(back), Some(plateau)]);
    page.says("`cargo run --release -p pneumo-cli --example tube_convergence -- out.csv", &[Some(finest)]);
    // "Rule of thumb: N ≈ 10 segments for the wave's timing within 2–3 % and its level within
    // 0.2 %; N = 20 for about 1 %." (air's viscosity, against N = 40)
    let air = |n: f64| -> Vec<f64> {
        let row = study_rows[4..].iter().map(|r| numbers(r)).find(|r| r[0] == n).expect("a row of the second table");
        row
    };
    let rule = page.numbers_after("Rule of thumb: N ≈", 6);
    let timing = |r: &[f64]| r[2].abs().max(r[4].abs());
    let (n10, n20) = (air(rule[0].0), air(rule[4].0));
    assert!(timing(&n10) <= rule[2].0, "docs/blocks.md: N = 10 times the wave within {} %, the study gives {}", rule[2].1, timing(&n10));
    assert!(n10[6].abs() <= rule[3].0, "docs/blocks.md: N = 10 levels within {} %, the study gives {}", rule[3].1, n10[6]);
    assert!(
        timing(&n20) <= rule[5].0 + 0.05,
        "docs/blocks.md: N = 20 times the wave within about {} %, the study gives {}",
        rule[5].1,
        timing(&n20)
    );
}

#[test]
#[ignore = "reruns the tube study, about a minute of CPU: cargo test --release -p pneumo-cli --test page_quotes_tube -- --ignored"]
fn committed_tube_study_is_what_the_code_gives() {
    let study = committed();
    let (lines, _) = tube_convergence::study(40);
    assert_eq!(lines.len(), study.len(), "{STUDY} has {} lines, the study prints {}:\n{}", study.len(), lines.len(), lines.join("\n"));
    for (written, now) in study.iter().zip(&lines) {
        if let Some(why) = mismatch(written, now) {
            panic!("{STUDY} is stale: {why}\ncommitted: {written}\n      now: {now}\nregenerate: cargo run --release -p pneumo-cli --example tube_convergence -- out.csv 40 | head -n -2 > {STUDY}");
        }
    }
}
