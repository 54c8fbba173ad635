//! Numbers a page's prose quotes, checked against the values a test
//! computes: the page's words are joined by single spaces, a phrase is
//! found in them, and the numbers written after it must read as the test's
//! values under the shared number rule (numbers.rs: to the digits shown,
//! within 0.5 %). A test that quotes a page this way keeps the page true.

use super::numbers::{half_ulp, pieces, Piece};
use super::repo;

/// A documentation page, its words joined by single spaces.
pub struct Page {
    name: String,
    raw: String,
    text: String,
}

impl Page {
    /// Read `name` (a path from the repository root, e.g. "docs/circuits.md").
    pub fn read(name: &str) -> Page {
        let raw = std::fs::read_to_string(repo().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        Page::of(name.to_string(), raw)
    }

    fn of(name: String, raw: String) -> Page {
        let text = raw.split_whitespace().collect::<Vec<_>>().join(" ");
        Page { name, raw, text }
    }

    /// The section whose heading line starts with `heading` ("### Vertical
    /// lift"), up to the next heading.
    pub fn section(&self, heading: &str) -> Page {
        let start =
            self.raw.lines().position(|l| l.starts_with(heading)).unwrap_or_else(|| panic!("{} has no heading {heading:?}", self.name));
        let lines: Vec<&str> = self.raw.lines().skip(start).collect();
        let end = lines.iter().skip(1).position(|l| l.starts_with('#')).map_or(lines.len(), |k| k + 1);
        Page::of(format!("{} (section {heading:?})", self.name), lines[..end].join("\n"))
    }

    /// The lines of the page's ```` ```text ```` blocks, in order (the
    /// outputs the docs checks compare with runs).
    pub fn output_lines(&self) -> Vec<String> {
        // Some(is_text) inside a fenced block
        let mut block: Option<bool> = None;
        let mut out = Vec::new();
        for line in self.raw.lines() {
            match (block, line.trim_start().strip_prefix("```")) {
                (None, Some(info)) => block = Some(info.trim() == "text"),
                (Some(_), Some(_)) => block = None,
                (Some(true), None) => out.push(line.to_string()),
                _ => {}
            }
        }
        out
    }

    /// The first `n` numbers written after the first occurrence of `phrase`
    /// (its words joined by single spaces), as (value, word as written).
    pub fn numbers_after(&self, phrase: &str, n: usize) -> Vec<(f64, String)> {
        let phrase = phrase.split_whitespace().collect::<Vec<_>>().join(" ");
        let from = self.text.find(&phrase).unwrap_or_else(|| panic!("{} lost the words {phrase:?}", self.name));
        let found: Vec<(f64, String)> = pieces(&self.text[from + phrase.len()..])
            .into_iter()
            .filter_map(|p| match p {
                Piece::Number(x, word) => Some((x, word)),
                Piece::Text(_) => None,
            })
            .take(n)
            .collect();
        assert_eq!(found.len(), n, "{}: fewer than {n} numbers after {phrase:?}", self.name);
        found
    }

    /// Fails unless the numbers written after `phrase` read as `values`, in
    /// order (`None`: a number that is an input or a tolerance, not checked).
    pub fn says(&self, phrase: &str, values: &[Option<f64>]) {
        for ((written, word), value) in self.numbers_after(phrase, values.len()).iter().zip(values) {
            let Some(value) = *value else { continue };
            let allowed = half_ulp(word) + 0.005 * written.abs();
            assert!(
                (written - value).abs() <= allowed,
                "{} is stale: after {phrase:?} it says {word}, the code gives {value} (allowed ±{allowed:e})",
                self.name
            );
        }
    }
}
