//! Labels in DejaVu Sans (embedded; licence in assets/fonts/DejaVuSans-LICENSE.txt), rasterised
//! with ab_glyph and blended into linear images: the mode and time on `--compare` panels.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use glam::Vec3;

use super::Image;

/// DejaVu Sans (Debian's fonts-dejavu-core), used for labels and bench plots.
pub static DEJAVU_SANS: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

fn font() -> FontRef<'static> {
    // The embedded font is a valid TrueType file; a test parses it.
    FontRef::try_from_slice(DEJAVU_SANS).expect("embedded DejaVu Sans parses")
}

/// The width in pixels of `text` at a font size of `size_px` pixels.
pub fn text_width(text: &str, size_px: f32) -> f32 {
    let font = font();
    let f = font.as_scaled(PxScale::from(size_px));
    let mut x = 0.0;
    let mut prev = None;
    for ch in text.chars() {
        let id = f.glyph_id(ch);
        if let Some(p) = prev {
            x += f.kern(p, id);
        }
        x += f.h_advance(id);
        prev = Some(id);
    }
    x
}

/// Draw `text` with its top-left corner at `(x, y)`, `size_px` pixels tall (ascent to descent),
/// anti-aliased: each pixel is blended toward `color` by the glyph's coverage.
pub fn draw_text(img: &mut Image, text: &str, x: u32, y: u32, size_px: f32, color: Vec3) {
    let font = font();
    let f = font.as_scaled(PxScale::from(size_px));
    let baseline = y as f32 + f.ascent();
    let mut caret = x as f32;
    let mut prev = None;
    for ch in text.chars() {
        let id = f.glyph_id(ch);
        if let Some(p) = prev {
            caret += f.kern(p, id);
        }
        let glyph = id.with_scale_and_position(PxScale::from(size_px), point(caret, baseline));
        caret += f.h_advance(id);
        prev = Some(id);
        let Some(outlined) = font.outline_glyph(glyph) else {
            continue; // a space
        };
        let b = outlined.px_bounds();
        outlined.draw(|gx, gy, cov| {
            let (px, py) = (b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64);
            if px >= 0 && py >= 0 && (px as u32) < img.width && (py as u32) < img.height {
                let (px, py) = (px as u32, py as u32);
                let c = img.get(px, py);
                img.set(px, py, c + (color - c) * cov.clamp(0.0, 1.0));
            }
        });
    }
}

/// A label on a dark box, readable on any image.
pub fn draw_label(img: &mut Image, text: &str, x: u32, y: u32, size_px: f32) {
    let (w, h) = (text_width(text, size_px).ceil() as u32 + 8, (size_px * 1.25).ceil() as u32 + 4);
    for yy in y..(y + h).min(img.height) {
        for xx in x..(x + w).min(img.width) {
            let c = img.get(xx, yy);
            img.set(xx, yy, c * 0.35);
        }
    }
    draw_text(img, text, x + 4, y + 2, size_px, Vec3::splat(0.95));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn g_and_9_are_different_glyphs() {
        let draw = |s: &str| {
            let mut img = Image::new(40, 40);
            draw_text(&mut img, s, 2, 2, 28.0, Vec3::ONE);
            img.pixels
        };
        assert_ne!(draw("g"), draw("9"));
        assert!(draw("g").iter().any(|p| p.x > 0.5));
    }
}
