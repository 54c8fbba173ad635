//! Writing SVG: the one place where text from a netlist enters markup.
//!
//! Every string that comes from a netlist, a subsystem file or a parameter
//! (ids, names, descriptions, file names, sequencer conditions) reaches the
//! SVG through [`text`] or [`attr`]: markup characters become entities,
//! line breaks and tabs become spaces (labels are single lines), characters
//! XML 1.0 forbids or that are invisible controls (NUL and the other C0 and C1
//! controls, U+FFFE/U+FFFF) become U+FFFD, and
//! bidirectional overrides, which could make a label read differently from
//! what it says, are dropped. Numbers are printed with at most two decimals
//! so that the output is byte-for-byte deterministic.

/// `s` as XML character data (element text).
pub fn text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            '\t' | '\n' | '\r' => out.push(' '),
            c if forbidden(c) => out.push('\u{fffd}'),
            c if bidi_control(c) => {}
            c => out.push(c),
        }
    }
    out
}

/// `s` as the value of an attribute written between double quotes.
pub fn attr(s: &str) -> String {
    text(s)
}

/// Characters that may not appear in an XML 1.0 document, even escaped.
fn forbidden(c: char) -> bool {
    let u = c as u32;
    u < 0x20 || matches!(u, 0xFFFE | 0xFFFF) || (0x7F..=0x9F).contains(&u)
}

/// Bidirectional embedding and override controls (U+202A..U+202E, U+2066..U+2069).
fn bidi_control(c: char) -> bool {
    matches!(c as u32, 0x202A..=0x202E | 0x2066..=0x2069 | 0x200E | 0x200F)
}

/// A number for an attribute: integers without decimals, else at most two.
pub fn num(x: f64) -> String {
    if !x.is_finite() {
        return "0".into();
    }
    let r = (x * 100.0).round() / 100.0;
    if r == r.trunc() {
        format!("{}", r as i64)
    } else {
        let s = format!("{r:.2}");
        s.trim_end_matches('0').to_string()
    }
}

/// Shorten `s` to at most `max` characters, ending in "…" when cut.
pub fn shorten(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        return s.to_string();
    }
    let mut out: String = s.chars().take(max.saturating_sub(1)).collect();
    out.push('…');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markup_and_forbidden_characters_are_neutralised() {
        assert_eq!(text("<script>alert('x')</script>"), "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;");
        assert_eq!(text("a & \"b\""), "a &amp; &quot;b&quot;");
        assert_eq!(text("x\u{0}y\u{1b}[31m\u{7}"), "x\u{fffd}y\u{fffd}[31m\u{fffd}");
        assert_eq!(text("line\nbreak"), "line break");
        assert_eq!(text("]]>"), "]]&gt;");
        assert_eq!(text("abc\u{202e}def"), "abcdef");
        assert_eq!(text("Ø45 × 450 mm"), "Ø45 × 450 mm");
    }

    #[test]
    fn numbers_are_short_and_stable() {
        assert_eq!(num(10.0), "10");
        assert_eq!(num(-2.5), "-2.5");
        assert_eq!(num(1.0 / 3.0), "0.33");
        assert_eq!(num(f64::NAN), "0");
        assert_eq!(num(-0.001), "0");
    }

    #[test]
    fn shorten_cuts_with_an_ellipsis() {
        assert_eq!(shorten("abcdef", 4), "abc…");
        assert_eq!(shorten("abc", 4), "abc");
    }
}
