//! One rule for what a message shows: numbers readable at any magnitude and
//! echoed input escaped and shortened. Every error and warning of pneumo that
//! prints a number or quotes the user's text goes through here, so that one
//! line stays one short line whatever the input held (`1e300`, not 300
//! digits; `5e-324`, not a line of zeros; 100 kB of pasted digits shown as
//! their start and their length).
//!
//! ```
//! use units::show::{num, fixed, text};
//! assert_eq!(num(4e5), "400000");
//! assert_eq!(num(0.25), "0.25");
//! assert_eq!(num(1e300), "1e300");
//! assert_eq!(num(5e-324), "5e-324");
//! assert_eq!(fixed(0.98, 4), "0.9800");
//! assert_eq!(fixed(1e300, 4), "1.0000e300");
//! assert_eq!(text("a\u{1b}[2Jb"), "a\\u{1b}[2Jb");
//! let long = "1".repeat(100_000);
//! assert_eq!(text(&long), format!("{}… (100000 characters)", "1".repeat(20)));
//! ```

use std::fmt::Write;

/// Magnitudes shown without an exponent: [1e-4, 1e7).
fn plain_range(x: f64) -> bool {
    x == 0.0 || (1e-4..1e7).contains(&x.abs())
}

/// A number as entered or stored: its shortest form that reads back to the
/// same `f64` (at most 17 significant digits), with an exponent outside
/// [1e-4, 1e7): `400000`, `0.25`, `1e300`, `5e-324`, `inf`, `NaN`.
pub fn num(x: f64) -> String {
    if !x.is_finite() || plain_range(x) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A computed number with `decimals` digits after the point, as `{:.N}`
/// prints it for ordinary magnitudes (`0.9800`); a magnitude that would need
/// more than a few digits before the point, or that would show as zero, gets
/// an exponent with the same number of decimals (`1.0000e300`, `5.0000e-324`).
pub fn fixed(x: f64, decimals: usize) -> String {
    let shows_as_zero = x != 0.0 && x.abs() < 0.5 * 10f64.powi(-(decimals.min(300) as i32));
    if !x.is_finite() || (x.abs() < 1e7 && !shows_as_zero) {
        format!("{x:.decimals$}")
    } else {
        format!("{x:.decimals$e}")
    }
}

/// A computed number to `digits` significant digits, without trailing
/// zeros, for prose: `51.205`, `10.2926`, `0.0012`, `1.5e-9`, `2.4e12`
/// (an exponent outside [1e-4, 1e7), as [`num`]). A value from arithmetic
/// (`51.20499999999999`) then prints as a person would write it.
pub fn sig(x: f64, digits: usize) -> String {
    let digits = digits.clamp(1, 17);
    if !x.is_finite() || x == 0.0 {
        return num(x);
    }
    if !plain_range(x) {
        let s = format!("{:.*e}", digits - 1, x);
        let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
        return format!("{}e{exponent}", trim_zeros(mantissa));
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    trim_zeros(&format!("{x:.decimals$}")).to_string()
}

/// `1.2300` → `1.23`, `2.000` → `2`, `150` stays.
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Characters of echoed text kept before it is shortened.
pub const TEXT_KEPT: usize = 60;
/// Longest echoed text shown whole [characters].
pub const TEXT_MAX: usize = 200;

/// Characters that change how the rest of a line reads: control characters
/// (line breaks, terminal escapes) and invisible formatting (bidirectional
/// overrides, zero-width characters, the byte-order mark, line separators).
pub fn is_hidden(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{ad}' | '\u{61c}' | '\u{180e}' | '\u{200b}'..='\u{200f}' | '\u{2028}'..='\u{202e}' | '\u{2060}'..='\u{206f}' | '\u{feff}'
        )
}

/// A whole message as one line: hidden characters ([`is_hidden`]) shown as
/// `\u{..}`, nothing shortened (the input it quotes went through [`text`]).
pub fn line(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    for c in message.chars() {
        if is_hidden(c) {
            let _ = write!(out, "\\u{{{:x}}}", u32::from(c));
        } else {
            out.push(c);
        }
    }
    out
}

/// Text from the input, for a message: hidden characters ([`is_hidden`])
/// shown as `\u{..}`; more than [`TEXT_MAX`] characters (or more than
/// 2·[`TEXT_MAX`] bytes once escaped) shortened to the
/// first [`TEXT_KEPT`] (the first 20 when those hold a run of more than 20
/// digits: a number is never spelled out in dozens of them), an ellipsis
/// and the original length.
pub fn text(s: &str) -> String {
    let mut out = String::with_capacity(s.len().min(4 * TEXT_MAX));
    // long in characters, or in bytes once escaped (control characters shown
    // as `\u{..}` and multi-byte letters can make 200 characters 1 kB)
    let long = s.chars().nth(TEXT_MAX).is_some() || line(s).len() > 2 * TEXT_MAX;
    let keep = if long { TEXT_KEPT } else { TEXT_MAX };
    let mut kept: String = s.chars().take(keep).collect();
    if long && longest_digit_run(&kept) > BRIEF_KEPT {
        // a number spelled out in digits is named by its start, as `brief` does
        kept = s.chars().take(BRIEF_KEPT).collect();
    }
    out.push_str(&line(&kept));
    if long {
        let _ = write!(out, "… ({} characters)", s.chars().count());
    }
    out
}

/// Characters [`brief`] keeps of a longer text, and [`text`] of a long
/// one whose start is a run of digits.
const BRIEF_KEPT: usize = 20;

/// Longest run of ASCII digits in `s`.
fn longest_digit_run(s: &str) -> usize {
    s.split(|c: char| !c.is_ascii_digit()).map(str::len).max().unwrap_or(0)
}

/// Text from the input quoted briefly, as [`text`] does but keeping only
/// the first 20 characters of anything longer than 24 (a number spelled out
/// in thousands of digits is named by its start and length, not re-printed).
pub fn brief(s: &str) -> String {
    if s.chars().nth(24).is_none() {
        return line(s);
    }
    let kept: String = s.chars().take(BRIEF_KEPT).collect();
    format!("{}… ({} characters)", line(&kept), s.chars().count())
}

/// A message made by another library (a JSON parser's "invalid type:
/// string \"…\", expected …", "unknown variant `…`") that quotes the input:
/// every part between double quotes or backquotes goes through [`text`]
/// (escaped and shortened), the rest through [`line`]. A quote left open
/// shortens what follows it likewise.
pub fn quoting(message: &str) -> String {
    let mut out = String::with_capacity(message.len().min(8 * TEXT_MAX));
    let mut rest = message;
    while let Some(open) = rest.find(['"', '`']) {
        let quote = rest[open..].chars().next().unwrap_or('"');
        out.push_str(&line(&rest[..open]));
        out.push(quote);
        let inner = &rest[open + 1..];
        let mut escaped = false;
        let close = inner.char_indices().find(|&(_, c)| {
            let ends = c == quote && !escaped;
            escaped = quote == '"' && c == '\\' && !escaped;
            ends
        });
        match close {
            Some((end, _)) => {
                out.push_str(&text(&inner[..end]));
                out.push(quote);
                rest = &inner[end + 1..];
            }
            None => {
                out.push_str(&text(inner));
                rest = "";
            }
        }
    }
    out.push_str(&line(rest));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_of_every_magnitude_stay_short_and_read_back() {
        for x in [0.0, -0.0, 1.0, -4e5, 0.1 + 0.2, 1e300, -1e300, 5e-324, f64::MAX, f64::MIN_POSITIVE, 1e-4, 9.99e6, 1e7, 123456.789] {
            let s = num(x);
            assert!(s.len() <= 24, "{x:e}: {s}");
            assert_eq!(s.parse::<f64>().unwrap(), x, "{s} reads back");
        }
        assert_eq!(num(f64::INFINITY), "inf");
        assert_eq!(num(f64::NAN), "NaN");
        assert_eq!(num(1e7), "1e7");
        assert_eq!(num(-2.5e-5), "-2.5e-5");
    }

    #[test]
    fn sig_rounds_computed_values_to_readable_digits() {
        assert_eq!(sig(51.20499999999999, 6), "51.205");
        assert_eq!(sig(26.755000000000003, 6), "26.755");
        assert_eq!(sig(10.292569971107952, 6), "10.2926");
        assert_eq!(sig(-0.0012345678, 3), "-0.00123");
        assert_eq!(sig(150.0, 6), "150");
        assert_eq!(sig(99999.96, 6), "100000");
        assert_eq!(sig(1.5e-9, 6), "1.5e-9");
        assert_eq!(sig(2.4e300, 3), "2.4e300");
        assert_eq!(sig(0.0, 6), "0");
        assert_eq!(sig(f64::NAN, 6), "NaN");
        for x in [1e300, -5e-324, f64::MAX, 123456.789, 0.1 + 0.2] {
            let s = sig(x, 6);
            assert!(s.len() <= 14, "{x:e}: {s}");
            let back: f64 = s.parse().unwrap();
            assert!((back - x).abs() <= 5e-6 * x.abs(), "{s} is {x:e} to 6 digits");
        }
    }

    #[test]
    fn fixed_keeps_ordinary_values_and_bounds_extreme_ones() {
        assert_eq!(fixed(0.1111, 4), "0.1111");
        assert_eq!(fixed(-12.3456, 1), "-12.3");
        assert_eq!(fixed(0.0, 3), "0.000");
        assert_eq!(fixed(5e-324, 4), "4.9407e-324");
        assert_eq!(fixed(-1e300, 1), "-1.0e300");
        assert_eq!(fixed(1.2e-9, 3), "1.200e-9");
        for x in [1e300, -1e300, 5e-324, f64::MAX, 1e-30, 123.0] {
            assert!(fixed(x, 4).len() <= 16, "{x:e}: {}", fixed(x, 4));
        }
    }

    #[test]
    fn echoed_text_is_escaped_and_shortened_with_its_length() {
        assert_eq!(text("supply.p"), "supply.p");
        assert_eq!(text("a\nb\u{202e}c"), "a\\u{a}b\\u{202e}c");
        let whole = "x".repeat(TEXT_MAX);
        assert_eq!(text(&whole), whole);
        let long = format!("{}\u{1b}", "é".repeat(TEXT_MAX));
        let shown = text(&long);
        assert!(shown.ends_with(&format!("… ({} characters)", TEXT_MAX + 1)), "{shown}");
        assert!(shown.chars().count() < TEXT_KEPT + 30, "{shown}");
        // 150 characters that escape to 500 bytes are shortened too
        let wide = "\u{e9}\u{2603}\u{1}".repeat(50);
        assert_eq!(text(&wide), format!("{}… (150 characters)", line(&wide.chars().take(TEXT_KEPT).collect::<String>())));
        // escapes of the kept part never grow without bound
        assert!(text(&"\u{1b}".repeat(10_000)).len() < 10 * TEXT_KEPT, "{}", text(&"\u{1b}".repeat(10_000)));
    }

    #[test]
    fn quoted_input_inside_a_library_message_is_shortened() {
        let digits = "9".repeat(400);
        let m = quoting(&format!("invalid type: string \"{digits}\", expected a sequence"));
        assert_eq!(m, format!("invalid type: string \"{}… (400 characters)\", expected a sequence", "9".repeat(BRIEF_KEPT)));
        let words = "ab ".repeat(100);
        assert_eq!(quoting(&format!("`{words}`")), format!("`{}… (300 characters)`", &words[..TEXT_KEPT]));
        let m = quoting(&format!("unknown variant `{digits}`, expected `given` or `rest`"));
        assert!(m.starts_with("unknown variant `999") && m.ends_with("(400 characters)`, expected `given` or `rest`"), "{m}");
        // an escaped quote stays inside its string; a quote left open is shortened too
        assert_eq!(quoting(r#"string "a\"b", expected x"#), r#"string "a\"b", expected x"#);
        assert!(quoting(&format!("bad \"{digits}")).ends_with("(400 characters)"));
        assert_eq!(quoting("no\nquotes"), "no\\u{a}quotes");
    }
}
