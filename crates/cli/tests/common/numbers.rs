//! Numbers as documentation pages write them: a line of a page against the
//! line a program printed, text exactly and numbers to the digits shown
//! within 0.5 % (a solver change may move the last digit). Used by the
//! docs checks (tutorial.rs runs the pages' commands, example_report.rs
//! compares pages with the committed example report).

/// A line's pieces: text runs and numbers.
#[derive(Debug, PartialEq)]
pub enum Piece {
    Text(String),
    Number(f64, String),
}

/// The numbers of a line, in order (its text left out).
#[allow(dead_code)] // not every test binary that includes this file uses it
pub fn numbers_in(line: &str) -> Vec<f64> {
    pieces(line)
        .into_iter()
        .filter_map(|p| match p {
            Piece::Number(x, _) => Some(x),
            Piece::Text(_) => None,
        })
        .collect()
}

pub fn pieces(line: &str) -> Vec<Piece> {
    let mut out = Vec::new();
    let mut text = String::new();
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let starts_number =
            chars[i].is_ascii_digit() && (i == 0 || !(chars[i - 1].is_alphanumeric() || chars[i - 1] == '_' || chars[i - 1] == '.'));
        if starts_number {
            let mut j = i;
            while j < chars.len()
                && (chars[j].is_ascii_digit() || chars[j] == '.' || chars[j] == 'e' || (chars[j] == '-' && chars[j - 1] == 'e'))
            {
                j += 1;
            }
            let word: String = chars[i..j].iter().collect();
            let word = word.trim_end_matches('.').to_string();
            if let Ok(x) = word.parse::<f64>() {
                if text.ends_with('-') {
                    text.pop();
                    out.push(Piece::Text(std::mem::take(&mut text)));
                    out.push(Piece::Number(-x, format!("-{word}")));
                } else {
                    out.push(Piece::Text(std::mem::take(&mut text)));
                    out.push(Piece::Number(x, word.clone()));
                }
                i += word.chars().count();
                continue;
            }
        }
        text.push(chars[i]);
        i += 1;
    }
    out.push(Piece::Text(text));
    out.retain(|p| !matches!(p, Piece::Text(t) if t.is_empty()));
    out
}

/// Half a unit of the last digit a number is written with.
pub fn half_ulp(word: &str) -> f64 {
    let mantissa = word.split(['e', 'E']).next().unwrap_or(word);
    let exponent: i32 = word.split(['e', 'E']).nth(1).and_then(|e| e.parse().ok()).unwrap_or(0);
    let decimals = mantissa.split('.').nth(1).map_or(0, str::len) as i32;
    0.5 * 10f64.powi(exponent - decimals)
}

/// Why `actual` does not read as `expected`, if it does not.
pub fn mismatch(expected: &str, actual: &str) -> Option<String> {
    let (expected, actual) = match expected.strip_suffix('…') {
        Some(prefix) => {
            let n = prefix.chars().count();
            (prefix.to_string(), actual.chars().take(n).collect::<String>())
        }
        None => (expected.to_string(), actual.to_string()),
    };
    let (e, a) = (pieces(&expected), pieces(&actual));
    if e.len() != a.len() {
        return Some(format!("shape differs: {e:?} vs {a:?}"));
    }
    for (e, a) in e.iter().zip(&a) {
        match (e, a) {
            (Piece::Text(x), Piece::Text(y)) if x == y => {}
            (Piece::Number(x, word), Piece::Number(y, _)) => {
                let allowed = half_ulp(word) + 0.005 * x.abs();
                if (x - y).abs() > allowed {
                    return Some(format!("{word} on the page, {y} from the run (allowed ±{allowed:e})"));
                }
            }
            _ => return Some(format!("{e:?} vs {a:?}")),
        }
    }
    None
}
