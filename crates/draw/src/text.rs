//! Text metrics for the layout: advance widths of the bundled DejaVu Sans
//! (assets/fonts, Bitstream Vera licence), the font the PNG renderer is
//! given and the SVG names first, so labels are measured as they are drawn.

use std::sync::OnceLock;

/// The bundled font (also handed to the PNG renderer).
pub static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// The family name the SVG asks for, with generic fallbacks for viewers.
pub const FAMILY: &str = "DejaVu Sans, Verdana, sans-serif";

fn face() -> Option<&'static ttf_parser::Face<'static>> {
    static FACE: OnceLock<Option<ttf_parser::Face<'static>>> = OnceLock::new();
    FACE.get_or_init(|| ttf_parser::Face::parse(FONT, 0).ok()).as_ref()
}

/// Width of `s` drawn at `size` px [px]. Characters the font lacks count
/// as wide as "M" (they are drawn with a fallback glyph of about that size).
pub fn width(s: &str, size: f64) -> f64 {
    let Some(face) = face() else {
        return s.chars().count() as f64 * size * 0.62;
    };
    let per_em = f64::from(face.units_per_em());
    let advance = |c: char| face.glyph_index(c).and_then(|g| face.glyph_hor_advance(g)).map(f64::from);
    let fallback = advance('M').unwrap_or(per_em * 0.8);
    s.chars().map(|c| advance(c).unwrap_or(fallback)).sum::<f64>() * size / per_em
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_grow_with_text_and_size() {
        let a = width("valve", 10.0);
        assert!(a > 20.0 && a < 40.0, "{a}");
        assert!((width("valve", 20.0) - 2.0 * a).abs() < 1e-9);
        assert!(width("WWW", 10.0) > width("iii", 10.0));
        assert_eq!(width("", 10.0), 0.0);
        // a character the font lacks still takes room
        assert!(width("\u{10FFFD}", 10.0) > 5.0);
    }
}
