//! PNG pictures of a diagram, rendered by resvg — a pure-Rust SVG renderer
//! (tiny-skia underneath, no system libraries), kept by the Linebender
//! organisation and used widely — with text from the bundled DejaVu Sans
//! only (no system fonts are looked up, so a picture is the same on every
//! machine).

use crate::DrawError;

/// Largest picture rendered [pixels]; more is refused up front.
pub const MAX_PIXELS: u64 = 64 << 20;

/// Render `svg` at `scale` pixels per SVG unit into PNG bytes.
pub fn png(svg: &str, scale: f32) -> Result<Vec<u8>, DrawError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(DrawError::Render(format!("scale {scale} must be a positive number")));
    }
    let mut opt = resvg::usvg::Options::default();
    opt.fontdb_mut().load_font_data(crate::text::FONT.to_vec());
    opt.font_family = "DejaVu Sans".to_string();
    let tree = resvg::usvg::Tree::from_str(svg, &opt).map_err(|e| DrawError::Render(e.to_string()))?;
    let size = tree.size();
    let (w, h) = ((size.width() * scale).ceil() as u64, (size.height() * scale).ceil() as u64);
    if w == 0 || h == 0 || w * h > MAX_PIXELS {
        return Err(DrawError::TooLarge { width: w, height: h, max: MAX_PIXELS });
    }
    let mut pixmap =
        resvg::tiny_skia::Pixmap::new(w as u32, h as u32).ok_or(DrawError::TooLarge { width: w, height: h, max: MAX_PIXELS })?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(&tree, resvg::tiny_skia::Transform::from_scale(scale, scale), &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| DrawError::Render(e.to_string()))
}
