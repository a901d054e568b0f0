//! A labelled raster sheet: equally sized image tiles in rows and columns with everything a
//! reader needs drawn into the PNG itself (text from the font compiled into the binary):
//! title lines, a heading above each column, a label at the left of each row, a caption under
//! each tile, and under a row of false-colour maps a colour bar with its title and tick labels.
//!
//! Layout, top to bottom: the title band, the column headings, then per row the tiles, the
//! caption line and the colour bar band. Text that does not fit its column is set smaller
//! (down to 9 px) and then shortened with '…'.

use super::text::{draw_text, text_size};
use image::{Rgb, RgbImage};

/// A colour bar: `map` gives the colour at t ∈ [0, 1] (left to right), `ticks` the labelled
/// positions.
pub struct Bar {
    pub map: fn(f32) -> [u8; 3],
    pub ticks: Vec<(f32, String)>,
    pub title: String,
}

/// One row of tiles.
#[derive(Default)]
pub struct SheetRow {
    /// Lines at the left of the row, the first one larger.
    pub label: Vec<String>,
    /// One per column; `None` leaves the cell empty.
    pub tiles: Vec<Option<RgbImage>>,
    /// One per column (or none): the line under each tile.
    pub captions: Vec<String>,
    /// The colour bar under the row.
    pub bar: Option<Bar>,
}

pub struct Sheet {
    /// Title lines, the first one larger.
    pub title: Vec<String>,
    /// Column headings.
    pub columns: Vec<String>,
    /// Tile size in pixels.
    pub tile: (u32, u32),
    pub rows: Vec<SheetRow>,
}

const WHITE: [u8; 3] = [255, 255, 255];
const BLACK: [u8; 3] = [0, 0, 0];
const GREY: [u8; 3] = [90, 90, 90];
const PAD: u32 = 8;
const GAP: u32 = 4;
const BAR_H: u32 = 14;

/// Text sizes (pixels) for tiles of a given size: larger tiles get larger text.
struct Sizes {
    title: f32,
    head: f32,
    small: f32,
}

fn line_h(px: f32) -> u32 {
    (px * 1.3).ceil() as u32
}

/// Where everything goes.
struct Layout {
    width: u32,
    height: u32,
    left: u32,
    head_y: u32,
    /// Per row: the top of its tiles, of its caption line and of its colour bar band.
    row_y: Vec<(u32, u32, u32)>,
    /// Per row: the left edge and width of its colour bar, and the lines of the bar's title.
    bars: Vec<(u32, u32)>,
    bar_titles: Vec<Vec<String>>,
}

impl Sheet {
    fn sizes(&self) -> Sizes {
        let s = (self.tile.0.max(self.tile.1) as f32 / 320.0).clamp(1.0, 3.0);
        Sizes {
            title: 15.0 * s,
            head: 13.0 * s,
            small: 11.0 * s,
        }
    }

    fn grid_w(&self) -> u32 {
        let n = self.columns.len().max(1) as u32;
        n * self.tile.0 + (n - 1) * GAP
    }

    /// The first column with a tile in `r` (where its colour bar starts) and the bar's width.
    fn bar_span(&self, r: &SheetRow, small: f32) -> (usize, u32) {
        let first = r.tiles.iter().position(Option::is_some).unwrap_or(0);
        let n = self.columns.len().max(1).saturating_sub(first).max(1) as u32;
        let w = n * self.tile.0 + (n - 1) * GAP;
        (first, w.clamp((240.0 * small / 11.0) as u32, 560))
    }

    fn layout(&self) -> Result<Layout, String> {
        let z = self.sizes();
        let mut width = 0u32;
        let mut y = PAD;
        for (i, t) in self.title.iter().enumerate() {
            let px = if i == 0 { z.title } else { z.small + 1.0 };
            width = width.max(text_size(t, px)?.0 + 2 * PAD);
            y += line_h(px);
        }
        y += 4;
        let mut left = 0;
        for r in &self.rows {
            for (i, l) in r.label.iter().enumerate() {
                let px = if i == 0 { z.head } else { z.small };
                left = left.max(text_size(l, px)?.0 + 2 * PAD);
            }
        }
        let left = left.max(PAD);
        width = width.max(left + self.grid_w() + PAD);
        let mut bars = Vec::new();
        for r in &self.rows {
            let (first, w) = self.bar_span(r, z.small);
            let x = left + first as u32 * (self.tile.0 + GAP);
            width = width.max(x + w + 2 * PAD);
            bars.push((x, w));
        }
        let head_y = y;
        if self.columns.iter().any(|c| !c.is_empty()) {
            y += line_h(z.head) + 2;
        }
        let mut row_y = Vec::new();
        let mut bar_titles = Vec::new();
        for (r, &(bx, _)) in self.rows.iter().zip(&bars) {
            let tiles = y;
            y += self.tile.1;
            let caption = y;
            if r.captions.iter().any(|c| !c.is_empty()) {
                y += line_h(z.small) + 2;
            }
            let bar = y;
            let lines = match &r.bar {
                Some(b) => wrap(&b.title, z.small, width - bx - PAD)?,
                None => Vec::new(),
            };
            if r.bar.is_some() {
                y += 6 + (lines.len() as u32 + 1) * line_h(z.small) + BAR_H + 8;
            }
            bar_titles.push(lines);
            row_y.push((tiles, caption, bar));
            y += GAP;
        }
        Ok(Layout {
            width,
            height: y - GAP + PAD,
            left,
            head_y,
            row_y,
            bars,
            bar_titles,
        })
    }

    /// The sheet's size in pixels, without drawing it.
    pub fn size(&self) -> Result<(u32, u32), String> {
        let l = self.layout()?;
        Ok((l.width, l.height))
    }

    /// Draw the sheet.
    pub fn render(&self) -> Result<RgbImage, String> {
        let l = self.layout()?;
        let z = self.sizes();
        let mut img = RgbImage::from_pixel(l.width, l.height, Rgb(WHITE));
        let mut y = PAD;
        for (i, t) in self.title.iter().enumerate() {
            let px = if i == 0 { z.title } else { z.small + 1.0 };
            draw_text(&mut img, t, px, (PAD as i32, y as i32), BLACK)?;
            y += line_h(px);
        }
        let tw = self.tile.0;
        let col_x = |j: usize| l.left + j as u32 * (tw + GAP);
        for (j, c) in self.columns.iter().enumerate() {
            centred(&mut img, c, z.head, (col_x(j), tw), l.head_y, BLACK)?;
        }
        for (i, (r, &(ty, cy, by))) in self.rows.iter().zip(&l.row_y).enumerate() {
            let mut ly = ty;
            for (k, t) in r.label.iter().enumerate() {
                let px = if k == 0 { z.head } else { z.small };
                let colour = if k == 0 { BLACK } else { GREY };
                draw_text(&mut img, t, px, (PAD as i32, ly as i32), colour)?;
                ly += line_h(px);
            }
            for (j, t) in r.tiles.iter().enumerate() {
                if let Some(t) = t {
                    image::imageops::replace(&mut img, t, col_x(j) as i64, ty as i64);
                }
            }
            for (j, c) in r.captions.iter().enumerate() {
                centred(&mut img, c, z.small, (col_x(j), tw), cy + 1, BLACK)?;
            }
            if let Some(b) = &r.bar {
                let (bx, bw) = l.bars[i];
                draw_bar(&mut img, b, &l.bar_titles[i], (bx, by + 6, bw), z.small)?;
            }
        }
        Ok(img)
    }
}

/// `text` at size `px` set to fit `max_w` pixels: smaller down to 9 px (or `px` when that is
/// smaller), then shortened with '…'.
fn fit(text: &str, px: f32, max_w: u32) -> Result<(String, f32), String> {
    fit_down_to(text, px, px.min(9.0), max_w)
}

/// `text` at size `px` set to fit `max_w` pixels: smaller down to `min_px`, then shortened with
/// '…'.
fn fit_down_to(text: &str, px: f32, min_px: f32, max_w: u32) -> Result<(String, f32), String> {
    let mut p = px;
    loop {
        if text_size(text, p)?.0 <= max_w {
            return Ok((text.to_string(), p));
        }
        if p <= min_px {
            break;
        }
        p = (p - 1.0).max(min_px);
    }
    let chars: Vec<char> = text.chars().collect();
    for n in (0..chars.len()).rev() {
        let s: String = chars[..n].iter().collect::<String>() + "…";
        if text_size(&s, p)?.0 <= max_w {
            return Ok((s, p));
        }
    }
    Ok((String::new(), p))
}

/// `text` at size `px` broken at spaces into lines of at most `max_w` pixels (a word longer
/// than that is fitted on a line of its own).
fn wrap(text: &str, px: f32, max_w: u32) -> Result<Vec<String>, String> {
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in text.split(' ') {
        let candidate = if cur.is_empty() {
            word.to_string()
        } else {
            format!("{cur} {word}")
        };
        if cur.is_empty() || text_size(&candidate, px)?.0 <= max_w {
            cur = candidate;
        } else {
            lines.push(std::mem::take(&mut cur));
            cur = word.to_string();
        }
    }
    lines.push(cur);
    lines
        .into_iter()
        .map(|l| fit_down_to(&l, px, px, max_w).map(|(t, _)| t))
        .collect()
}

/// `text` centred in the span (x, w) with its top at `y`, fitted to the span.
fn centred(
    img: &mut RgbImage,
    text: &str,
    px: f32,
    (x, w): (u32, u32),
    y: u32,
    colour: [u8; 3],
) -> Result<(), String> {
    if text.is_empty() {
        return Ok(());
    }
    let (t, p) = fit(text, px, w)?;
    let tw = text_size(&t, p)?.0;
    let x0 = x as i32 + (w as i32 - tw as i32) / 2;
    draw_text(img, &t, p, (x0, y as i32), colour)?;
    Ok(())
}

/// The colour bar: its title lines, the bar `w` pixels wide with a grey frame, tick marks and
/// tick labels under it (kept inside the image).
fn draw_bar(
    img: &mut RgbImage,
    b: &Bar,
    title: &[String],
    (x, y, w): (u32, u32, u32),
    px: f32,
) -> Result<(), String> {
    let mut top = y;
    for t in title {
        draw_text(img, t, px, (x as i32, top as i32), BLACK)?;
        top += line_h(px);
    }
    for i in 0..w {
        let c = (b.map)(i as f32 / (w - 1).max(1) as f32);
        for j in 0..BAR_H {
            img.put_pixel(x + i, top + j, Rgb(c));
        }
    }
    for i in 0..w {
        img.put_pixel(x + i, top, Rgb(GREY));
        img.put_pixel(x + i, top + BAR_H - 1, Rgb(GREY));
    }
    for j in 0..BAR_H {
        img.put_pixel(x, top + j, Rgb(GREY));
        img.put_pixel(x + w - 1, top + j, Rgb(GREY));
    }
    for (t, label) in &b.ticks {
        let tx = x + (t.clamp(0.0, 1.0) * (w - 1) as f32).round() as u32;
        for j in 0..4 {
            img.put_pixel(tx, top + BAR_H + j, Rgb(BLACK));
        }
        let lw = text_size(label, px)?.0;
        let lx =
            (tx as i32 - lw as i32 / 2).clamp(2, img.width().saturating_sub(lw + 2).max(2) as i32);
        draw_text(img, label, px, (lx, (top + BAR_H + 4) as i32), BLACK)?;
    }
    Ok(())
}

/// A tile of `w`×`h` source pixels enlarged `zoom` times (nearest neighbour), `f(x, y)` giving
/// the colour of source pixel (x, y).
pub fn tile(w: u32, h: u32, zoom: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> RgbImage {
    RgbImage::from_fn(w * zoom, h * zoom, |x, y| Rgb(f(x / zoom, y / zoom)))
}

/// The enlargement that makes an image of `w`×`h` pixels at least `min` pixels on its longer
/// side (at most 8×).
pub fn zoom_for(w: u32, h: u32, min: u32) -> u32 {
    min.div_ceil(w.max(h).max(1)).clamp(1, 8)
}

/// A small SVG that shows `png` (the complete, labelled figure) at its size, with the sheet's
/// text as the SVG's title and description (for search and screen readers).
pub fn svg_wrapper(sheet: &Sheet, png: &str, (w, h): (u32, u32)) -> String {
    let esc = |s: &str| {
        s.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
    };
    let mut desc: Vec<String> = sheet.title.iter().skip(1).cloned().collect();
    desc.push(format!("columns: {}", sheet.columns.join(", ")));
    for r in &sheet.rows {
        if !r.label.is_empty() {
            desc.push(format!("row: {}", r.label.join(" ")));
        }
        if let Some(b) = &r.bar {
            desc.push(format!("colour bar: {}", b.title));
        }
    }
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\" width=\"{w}\" height=\"{h}\">\n<title>{}</title>\n<desc>{}</desc>\n<image x=\"0\" y=\"0\" width=\"{w}\" height=\"{h}\" xlink:href=\"{png}\" href=\"{png}\"/>\n</svg>\n",
        esc(sheet.title.first().map(String::as_str).unwrap_or("")),
        esc(&desc.join("\n"))
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dark(img: &RgbImage, xs: std::ops::Range<u32>, ys: std::ops::Range<u32>) -> usize {
        ys.flat_map(|y| xs.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0.iter().all(|&c| c < 110))
            .count()
    }

    #[test]
    fn sheet_draws_headings_labels_captions_and_a_labelled_bar() {
        let grey = RgbImage::from_pixel(100, 80, Rgb([128, 128, 128]));
        let sheet = Sheet {
            title: vec!["walls: equal time 40 s".into(), "reference".into()],
            columns: vec!["pt-mono".into(), "bdpt-allbins".into()],
            tile: (100, 80),
            rows: vec![SheetRow {
                label: vec!["40 s".into(), "equal time".into()],
                tiles: vec![Some(grey.clone()), Some(grey)],
                captions: vec!["SNR 12.5 dB".into(), String::new()],
                bar: Some(Bar {
                    map: |t| [(t * 255.0) as u8; 3],
                    ticks: vec![(0.0, "0.001".into()), (1.0, "1".into())],
                    title: "relative error".into(),
                }),
            }],
        };
        let l = sheet.layout().unwrap();
        let img = sheet.render().unwrap();
        assert_eq!(img.dimensions(), (l.width, l.height));
        let (ty, cy, by) = l.row_y[0];
        for j in 0..2 {
            let x = l.left + j * (100 + GAP);
            assert!(dark(&img, x..x + 100, l.head_y..ty) > 15, "heading {j}");
            // The tile itself is untouched.
            assert_eq!(img.get_pixel(x + 50, ty + 40).0, [128, 128, 128]);
        }
        assert!(dark(&img, 0..l.left, ty..ty + 20) > 15, "row label");
        assert!(dark(&img, l.left..l.left + 100, cy..by) > 15, "caption");
        let x1 = l.left + 100 + GAP;
        assert_eq!(dark(&img, x1..x1 + 100, cy..by), 0, "no caption");
        assert!(dark(&img, 0..l.width, 0..l.head_y) > 30, "title");
        // The bar: its title, the ramp from black to white, a label under each end.
        let (bx, bw) = l.bars[0];
        let top = by + 6 + line_h(11.0);
        assert!(dark(&img, bx..bx + bw, by..top) > 15, "bar title");
        assert!(img.get_pixel(bx + 1, top + 5).0.iter().all(|&c| c < 4));
        assert!(
            img.get_pixel(bx + bw - 2, top + 5)
                .0
                .iter()
                .all(|&c| c > 251)
        );
        let labels = top + BAR_H + 4..top + BAR_H + 4 + line_h(11.0);
        assert!(dark(&img, bx.saturating_sub(20)..bx + 20, labels.clone()) > 5);
        assert!(dark(&img, bx + bw - 20..(bx + bw + 20).min(l.width), labels) > 3);
    }

    #[test]
    fn long_text_is_fitted_to_its_column() {
        let (t, p) = fit("a very long heading for a narrow column", 13.0, 60).unwrap();
        assert!(t.ends_with('…') && p >= 9.0, "{t} {p}");
        assert!(text_size(&t, p).unwrap().0 <= 60);
        let lines = wrap("one two three four five six seven", 11.0, 60).unwrap();
        assert!(lines.len() > 2);
        assert!(lines.iter().all(|l| text_size(l, 11.0).unwrap().0 <= 60));
    }
}
