//! Text for raster figures, drawn with DejaVu Sans compiled into the binary
//! (`data/fonts/DejaVuSans.ttf`), so no system font is ever read: the font, the layout of one
//! line, each pixel's glyph coverage, and drawing a line onto an RGB8 image. Used by the
//! experiment figures and by the PNG backend of the Gaussian-mixture box plots.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use std::sync::OnceLock;

static DEJAVU_SANS: &[u8] = include_bytes!("../../../data/fonts/DejaVuSans.ttf");

/// The bundled DejaVu Sans.
pub fn font() -> Result<&'static FontRef<'static>, String> {
    static F: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    F.get_or_init(|| FontRef::try_from_slice(DEJAVU_SANS).ok())
        .as_ref()
        .ok_or_else(|| "the bundled font data/fonts/DejaVuSans.ttf is not valid".to_string())
}

/// Width (advances and kerning) and height (ascent − descent) of one line of `text` at pixel
/// size `px` (the line height, as plotters counts a font size).
pub fn layout(font: &FontRef<'static>, text: &str, px: f32) -> (f32, f32) {
    let f = font.as_scaled(PxScale::from(px));
    let mut w = 0.0;
    let mut prev = None;
    for c in text.chars() {
        let g = f.glyph_id(c);
        if let Some(p) = prev {
            w += f.kern(p, g);
        }
        w += f.h_advance(g);
        prev = Some(g);
    }
    (w, f.ascent() - f.descent())
}

/// Call `put(x, y, coverage)` for every pixel the glyphs of one line of `text` at size `px`
/// touch, with the line box's top-left corner at `origin` (the baseline lies one ascent below).
pub fn coverage(
    font: &FontRef<'static>,
    text: &str,
    px: f32,
    origin: (f32, f32),
    mut put: impl FnMut(i32, i32, f32),
) {
    let f = font.as_scaled(PxScale::from(px));
    let (mut caret, mut prev) = (0.0f32, None);
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = prev {
            caret += f.kern(p, id);
        }
        let glyph =
            id.with_scale_and_position(f.scale(), point(origin.0 + caret, origin.1 + f.ascent()));
        if let Some(o) = font.outline_glyph(glyph) {
            let b = o.px_bounds();
            o.draw(|x, y, cov| {
                put(
                    b.min.x as i32 + x as i32,
                    b.min.y as i32 + y as i32,
                    cov.clamp(0.0, 1.0),
                )
            });
        }
        caret += f.h_advance(id);
        prev = Some(id);
    }
}

/// Width and height in whole pixels of one line of `text` at size `px`.
pub fn text_size(text: &str, px: f32) -> Result<(u32, u32), String> {
    let (w, h) = layout(font()?, text, px);
    Ok((w.ceil() as u32, h.ceil() as u32))
}

/// Blend `colour` into pixel (x, y) of `img` with weight `a`; pixels outside are skipped.
fn blend(img: &mut image::RgbImage, x: i32, y: i32, colour: [u8; 3], a: f32) {
    if x < 0 || y < 0 || x as u32 >= img.width() || y as u32 >= img.height() || a <= 0.0 {
        return;
    }
    let p = img.get_pixel_mut(x as u32, y as u32);
    for (d, s) in p.0.iter_mut().zip(colour) {
        *d = (*d as f32 * (1.0 - a) + s as f32 * a).round() as u8;
    }
}

/// Draw one line of `text` at size `px` in `colour` with its line box's top-left corner at
/// (x, y), reading left to right; clipped to the image. Returns the line's width.
pub fn draw_text(
    img: &mut image::RgbImage,
    text: &str,
    px: f32,
    (x, y): (i32, i32),
    colour: [u8; 3],
) -> Result<u32, String> {
    let font = font()?;
    coverage(font, text, px, (0.0, 0.0), |gx, gy, a| {
        blend(img, x + gx, y + gy, colour, a)
    });
    Ok(layout(font, text, px).0.ceil() as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_darkens_pixels_inside_its_box_only() {
        let mut img = image::RgbImage::from_pixel(120, 40, image::Rgb([255, 255, 255]));
        let w = draw_text(&mut img, "Hg 40 s", 16.0, (10, 5), [0, 0, 0]).unwrap();
        let (tw, th) = text_size("Hg 40 s", 16.0).unwrap();
        assert_eq!(w, tw);
        assert!(tw > 30 && th >= 16, "{tw}×{th}");
        let mut dark = 0;
        for (x, y, p) in img.enumerate_pixels() {
            if p.0[0] < 128 {
                dark += 1;
                assert!(
                    (9..=10 + tw + 1).contains(&x) && (4..=5 + th + 1).contains(&y),
                    "({x}, {y}) outside the text box"
                );
            }
        }
        assert!(dark > 40, "{dark} dark pixels");
    }
}
