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

    /// The page from the first line that contains `phrase` to its end (to
    /// tell apart two tables whose rows start alike).
    pub fn after(&self, phrase: &str) -> Page {
        let start =
            self.raw.lines().position(|l| l.contains(phrase)).unwrap_or_else(|| panic!("{} has no line with {phrase:?}", self.name));
        let rest: Vec<&str> = self.raw.lines().skip(start).collect();
        Page::of(format!("{} (after {phrase:?})", self.name), rest.join("\n"))
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
            if let Some(value) = *value {
                self.reads_as(&format!("after {phrase:?}"), *written, word, value);
            }
        }
    }

    /// The Markdown table rows (indented or not) whose first cell is
    /// `first`, in order, each as its cells after the first: the number of
    /// each cell (a typographic minus − read as -) with its word, or None.
    pub fn rows(&self, first: &str) -> Vec<Vec<Option<(f64, String)>>> {
        self.raw
            .lines()
            .map(str::trim)
            .filter(|l| l.starts_with('|'))
            .map(|l| l.trim_matches('|').split('|').map(str::trim).collect::<Vec<_>>())
            .filter(|cells| cells[0] == first)
            .map(|cells| {
                cells[1..]
                    .iter()
                    .map(|cell| {
                        pieces(&cell.replace('−', "-")).into_iter().find_map(|p| match p {
                            Piece::Number(x, word) => Some((x, word)),
                            Piece::Text(_) => None,
                        })
                    })
                    .collect()
            })
            .collect()
    }

    /// Fails unless the cells of a row (from [`Page::rows`]) read as
    /// `values` (`None`: not checked).
    pub fn row_says(&self, what: &str, row: &[Option<(f64, String)>], values: &[Option<f64>]) {
        assert!(row.len() >= values.len(), "{}: the row {what} has {} cells", self.name, row.len());
        for (k, (cell, value)) in row.iter().zip(values).enumerate() {
            let Some(value) = *value else { continue };
            let (written, word) = cell.as_ref().unwrap_or_else(|| panic!("{}: the row {what} has no number in cell {}", self.name, k + 2));
            self.reads_as(&format!("in the row {what}, cell {}", k + 2), *written, word, value);
        }
    }

    fn reads_as(&self, place: &str, written: f64, word: &str, value: f64) {
        let allowed = half_ulp(word) + 0.005 * written.abs();
        assert!(
            (written - value).abs() <= allowed,
            "{} is stale: {place} it says {word}, the code gives {value} (allowed ±{allowed:e})",
            self.name
        );
    }
}
