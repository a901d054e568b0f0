//! Writing the Gaussian-mixture figures (box plots, Hua Figs. 4–8) as SVG and PNG without
//! system fonts. The SVG's text is laid out with plotters' built-in estimate, as the project's
//! other figures are; the PNG's text is drawn by [`TextBitmap`] with DejaVu Sans compiled into the
//! binary (`data/fonts/`, through [`crate::experiment::figures::text`]), so no system font is
//! read. (Plotters' own `ab_glyph` feature would do this through a process-wide font table, but it
//! makes every plotters text lookup, SVG included, fail until a font is registered, which breaks
//! the experiment figures.)
//!
//! Heat maps and colour strips are [`Raster`]s: a grid of cells painted over the figure, in the
//! SVG as one embedded PNG (a few kB instead of an element per cell), in the PNG cell by cell.

use crate::experiment::figures::text;
use crate::io::output::write_atomic;
use ab_glyph::FontRef;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::{BackendColor, BackendCoord, DrawingErrorKind, text_anchor};
use std::path::{Path, PathBuf};

/// A bitmap backend that draws text with the bundled font (plotters' bitmap backend, built
/// without a font feature, draws none). Everything else goes to the inner backend.
pub struct TextBitmap<'a> {
    inner: BitMapBackend<'a>,
    font: &'static FontRef<'static>,
}

impl<'a> TextBitmap<'a> {
    /// Draw into an RGB8 buffer of `size.0 × size.1` pixels.
    pub fn with_buffer(buf: &'a mut [u8], size: (u32, u32)) -> Result<Self, String> {
        Ok(TextBitmap {
            inner: BitMapBackend::with_buffer(buf, size),
            font: text::font()?,
        })
    }

    /// Layout of `text` at plotters' size `size` (the line height; as plotters' `ab_glyph`
    /// backend): width from the advances and kerning, height the ascent minus the descent.
    fn layout(&self, text: &str, size: f64) -> (f32, f32) {
        text::layout(self.font, text, size as f32)
    }
}

type BitmapError = DrawingErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>;

impl DrawingBackend for TextBitmap<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), BitmapError> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), BitmapError> {
        self.inner.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> Result<(), BitmapError> {
        self.inner.draw_pixel(p, c)
    }
    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
    ) -> Result<(), BitmapError> {
        self.inner.draw_line(a, b, s)
    }
    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
        fill: bool,
    ) -> Result<(), BitmapError> {
        self.inner.draw_rect(a, b, s, fill)
    }
    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        s: &S,
    ) -> Result<(), BitmapError> {
        self.inner.draw_path(path, s)
    }
    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        c: BackendCoord,
        r: u32,
        s: &S,
        fill: bool,
    ) -> Result<(), BitmapError> {
        self.inner.draw_circle(c, r, s, fill)
    }
    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        s: &S,
    ) -> Result<(), BitmapError> {
        self.inner.fill_polygon(vert, s)
    }

    fn estimate_text_size<S: plotters_backend::BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), BitmapError> {
        let (w, h) = self.layout(text, style.size());
        Ok((w.ceil() as u32, h.ceil() as u32))
    }

    /// Text anchored and rotated as plotters' default `draw_text`, each glyph's coverage
    /// blended into the bitmap.
    fn draw_text<S: plotters_backend::BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), BitmapError> {
        let colour = style.color();
        if colour.alpha == 0.0 {
            return Ok(());
        }
        let (w, h) = self.layout(text, style.size());
        let dx = match style.anchor().h_pos {
            text_anchor::HPos::Left => 0.0,
            text_anchor::HPos::Center => -w / 2.0,
            text_anchor::HPos::Right => -w,
        };
        let dy = match style.anchor().v_pos {
            text_anchor::VPos::Top => 0.0,
            text_anchor::VPos::Center => -h / 2.0,
            text_anchor::VPos::Bottom => -h,
        };
        let trans = style.transform();
        let mut pixels = Vec::new();
        text::coverage(
            self.font,
            text,
            style.size() as f32,
            (dx, dy),
            |x, y, cov| pixels.push((x, y, cov)),
        );
        for (x, y, cov) in pixels {
            let (x, y) = trans.transform(x, y);
            let c = BackendColor {
                alpha: colour.alpha * cov as f64,
                rgb: colour.rgb,
            };
            self.inner.draw_pixel((pos.0 + x, pos.1 + y), c)?;
        }
        Ok(())
    }
}

/// A grid of `cols × rows` RGB cells (row-major from the top left) stretched over the backend
/// rectangle from `at` of `size` pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Raster {
    pub at: (i32, i32),
    pub size: (u32, u32),
    pub cols: u32,
    pub rows: u32,
    pub rgb: Vec<u8>,
}

impl Raster {
    /// A raster over the backend rectangle with corners `a` and `b` (any order).
    pub fn between(a: (i32, i32), b: (i32, i32), cols: u32, rows: u32, rgb: Vec<u8>) -> Raster {
        let at = (a.0.min(b.0), a.1.min(b.1));
        let size = ((a.0 - b.0).unsigned_abs(), (a.1 - b.1).unsigned_abs());
        Raster {
            at,
            size,
            cols,
            rows,
            rgb,
        }
    }

    fn check(&self) -> Result<(), String> {
        if self.cols == 0
            || self.rows == 0
            || self.rgb.len() != (self.cols * self.rows * 3) as usize
        {
            return Err(format!(
                "raster of {} × {} cells with {} bytes",
                self.cols,
                self.rows,
                self.rgb.len()
            ));
        }
        Ok(())
    }

    /// The cells as a PNG file's bytes.
    fn png(&self) -> Result<Vec<u8>, String> {
        use image::ImageEncoder;
        let mut out = Vec::new();
        image::codecs::png::PngEncoder::new(&mut out)
            .write_image(
                &self.rgb,
                self.cols,
                self.rows,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| format!("raster PNG: {e}"))?;
        Ok(out)
    }

    /// The SVG element showing the raster.
    fn svg_image(&self) -> Result<String, String> {
        Ok(format!(
            "<image x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" preserveAspectRatio=\"none\" \
             style=\"image-rendering:pixelated;image-rendering:crisp-edges\" \
             href=\"data:image/png;base64,{}\"/>\n",
            self.at.0,
            self.at.1,
            self.size.0,
            self.size.1,
            crate::experiment::report::base64(&self.png()?)
        ))
    }

    /// Paint the cells into an RGB8 image of `dims` (nearest cell per pixel).
    fn paint(&self, rgb: &mut [u8], dims: (u32, u32)) {
        for py in 0..self.size.1 {
            let y = self.at.1 + py as i32;
            if y < 0 || y >= dims.1 as i32 {
                continue;
            }
            let r = (py as u64 * self.rows as u64 / self.size.1 as u64) as usize;
            for px in 0..self.size.0 {
                let x = self.at.0 + px as i32;
                if x < 0 || x >= dims.0 as i32 {
                    continue;
                }
                let c = (px as u64 * self.cols as u64 / self.size.0 as u64) as usize;
                let src = (r * self.cols as usize + c) * 3;
                let dst = (y as usize * dims.0 as usize + x as usize) * 3;
                rgb[dst..dst + 3].copy_from_slice(&self.rgb[src..src + 3]);
            }
        }
    }
}

/// A figure that draws itself on any plotters backend; the rasters it returns are painted over
/// the drawing.
pub trait Figure {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<Vec<Raster>, String>;
}

pub(crate) fn de<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Draw `fig` as `<stem>.svg` and `<stem>.png` (each written to a temporary file and renamed).
/// Returns both paths.
pub fn write_figure(stem: &Path, fig: &impl Figure) -> Result<[PathBuf; 2], String> {
    let size = fig.size();
    let svg_path = stem.with_extension("svg");
    let mut svg = String::new();
    let rasters = {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        let r = fig.draw(&root)?;
        root.present().map_err(de)?;
        r
    };
    if !rasters.is_empty() {
        let end = svg.rfind("</svg>").ok_or("plot: the SVG has no end tag")?;
        let mut images = String::new();
        for r in &rasters {
            r.check()?;
            images += &r.svg_image()?;
        }
        svg.insert_str(end, &images);
    }
    crate::io::output::write_bytes(&svg_path, svg.as_bytes())?;
    let png_path = stem.with_extension("png");
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    let rasters = {
        let root = TextBitmap::with_buffer(&mut rgb, size)?.into_drawing_area();
        let r = fig.draw(&root)?;
        root.present().map_err(de)?;
        r
    };
    for r in &rasters {
        r.check()?;
        r.paint(&mut rgb, size);
    }
    write_atomic(&png_path, |tmp| {
        use image::ImageEncoder;
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        let cannot = |e: String| format!("cannot write PNG '{}': {e}", png_path.display());
        let file = std::fs::File::create(tmp).map_err(|e| cannot(e.to_string()))?;
        let mut w = std::io::BufWriter::new(file);
        PngEncoder::new_with_quality(&mut w, CompressionType::Best, FilterType::Adaptive)
            .write_image(&rgb, size.0, size.1, image::ExtendedColorType::Rgb8)
            .map_err(|e| cannot(e.to_string()))?;
        std::io::Write::flush(&mut w).map_err(|e| cannot(e.to_string()))
    })?;
    Ok([svg_path, png_path])
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Checker;

    impl Figure for Checker {
        fn size(&self) -> (u32, u32) {
            (200, 100)
        }
        fn draw<DB: DrawingBackend>(
            &self,
            root: &DrawingArea<DB, Shift>,
        ) -> Result<Vec<Raster>, String> {
            root.fill(&WHITE).map_err(de)?;
            root.titled("cells", ("sans-serif", 14)).map_err(de)?;
            // 2 × 1 cells: red, blue, over x 100..200, y 50..100.
            Ok(vec![Raster::between(
                (200, 100),
                (100, 50),
                2,
                1,
                vec![255, 0, 0, 0, 0, 255],
            )])
        }
    }

    #[test]
    fn rasters_are_embedded_in_the_svg_and_painted_into_the_png() {
        let dir = std::env::temp_dir().join(format!("stokes-canvas-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [svg, png] = write_figure(&dir.join("c"), &Checker).unwrap();
        let s = std::fs::read_to_string(&svg).unwrap();
        assert!(s.contains("<image x=\"100\" y=\"50\" width=\"100\" height=\"50\""));
        assert!(
            s.contains("data:image/png;base64,iVBORw0KGgo"),
            "a PNG signature"
        );
        assert!(s.trim_end().ends_with("</svg>"));
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (200, 100));
        assert_eq!(img.get_pixel(120, 70).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(199, 99).0, [0, 0, 255]);
        assert_eq!(img.get_pixel(50, 70).0, [255, 255, 255]);
        let bad = Raster::between((0, 0), (10, 10), 2, 2, vec![0; 3]);
        assert!(bad.check().is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
