//! Box plots of colour differences against the number of Gaussians, in the style of Hua et al.
//! 2022 Figs. 7b and 8b: one box per number of components spanning the quartiles Q1–Q3, a line
//! at the median, the mean as a triangle, and whiskers to the furthest data point within 1.5 IQR
//! of the box (Tukey). Points beyond the whiskers are counted, not drawn.
//!
//! Quantiles interpolate linearly between order statistics (Hyndman & Fan type 7, the default of
//! NumPy and R). Each figure is written as SVG and as PNG, without system fonts
//! ([`super::canvas`]).

pub use super::canvas::TextBitmap;
use super::canvas::{Figure, Raster, de, write_figure};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::text_anchor;
use std::path::Path;

/// The statistics one box shows.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BoxStats {
    pub n: usize,
    pub mean: f64,
    pub q1: f64,
    pub median: f64,
    pub q3: f64,
    /// The smallest data point ≥ Q1 − 1.5 IQR.
    pub whisker_lo: f64,
    /// The largest data point ≤ Q3 + 1.5 IQR.
    pub whisker_hi: f64,
    pub min: f64,
    pub max: f64,
    /// Data points beyond the whiskers.
    pub outliers: usize,
}

/// The p-quantile (0 ≤ p ≤ 1) of sorted data, interpolating linearly between order statistics
/// at h = (n − 1)·p (type 7). `None` for empty data.
pub fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    Some(sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo]))
}

/// Box-plot statistics of `values` (any order; NaN is not allowed). `None` for no data.
pub fn box_stats(values: &[f64]) -> Option<BoxStats> {
    if values.is_empty() {
        return None;
    }
    assert!(values.iter().all(|v| !v.is_nan()), "box_stats: NaN in data");
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    let (q1, median, q3) = (quantile(&s, 0.25)?, quantile(&s, 0.5)?, quantile(&s, 0.75)?);
    let iqr = q3 - q1;
    let (fence_lo, fence_hi) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
    let whisker_lo = *s.iter().find(|&&v| v >= fence_lo)?;
    let whisker_hi = *s.iter().rev().find(|&&v| v <= fence_hi)?;
    let outliers = s.iter().filter(|&&v| v < fence_lo || v > fence_hi).count();
    Some(BoxStats {
        n: s.len(),
        mean: s.iter().sum::<f64>() / s.len() as f64,
        q1,
        median,
        q3,
        whisker_lo,
        whisker_hi,
        min: s[0],
        max: s[s.len() - 1],
        outliers,
    })
}

/// One figure: a box per category (label on the x axis, e.g. the number of Gaussians).
pub struct BoxFigure<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub boxes: &'a [(String, BoxStats)],
}

const SIZE: (u32, u32) = (720, 480);

/// Draw the figure as `<stem>.svg` and `<stem>.png` (each written to a temporary file and
/// renamed). Returns both paths.
pub fn write_box_figure(stem: &Path, fig: &BoxFigure) -> Result<[std::path::PathBuf; 2], String> {
    write_box_figure_sized(stem, fig, SIZE)
}

/// [`write_box_figure`] at `size` pixels (for many boxes, or long labels).
pub fn write_box_figure_sized(
    stem: &Path,
    fig: &BoxFigure,
    size: (u32, u32),
) -> Result<[std::path::PathBuf; 2], String> {
    write_figure(stem, &Sized(fig, size))
}

struct Sized<'a, 'b>(&'a BoxFigure<'b>, (u32, u32));

impl Figure for Sized<'_, '_> {
    fn size(&self) -> (u32, u32) {
        self.1
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<Vec<Raster>, String> {
        draw(root, self.0).map(|()| Vec::new())
    }
}

/// The x axis of a box plot: `n` slots centred on 0, 1, …, n − 1 over [−0.5, n − 0.5], with a
/// tick at each centre only (plotters' f64 axis would pick its own "nice" ticks).
struct Slots(usize);

impl Ranged for Slots {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let t = (v + 0.5) / self.0 as f64;
        limit.0 + (t * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<H: plotters::coord::ranged1d::KeyPointHint>(&self, _hint: H) -> Vec<f64> {
        (0..self.0).map(|i| i as f64).collect()
    }

    fn range(&self) -> std::ops::Range<f64> {
        -0.5..self.0 as f64 - 0.5
    }
}

/// The chart on any plotters backend.
fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &BoxFigure) -> Result<(), String> {
    root.fill(&WHITE).map_err(de)?;
    let n = fig.boxes.len();
    if n == 0 {
        root.titled(&format!("{}: no data", fig.title), ("sans-serif", 18))
            .map_err(de)?;
        return Ok(());
    }
    let top = fig
        .boxes
        .iter()
        .map(|(_, b)| b.whisker_hi.max(b.mean))
        .fold(0.0, f64::max);
    let top = if top > 0.0 && top.is_finite() {
        top * 1.15
    } else {
        1.0
    };
    let mut c = ChartBuilder::on(root)
        .caption(fig.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(Slots(n), 0.0..top)
        .map_err(de)?;
    let labels: Vec<String> = fig.boxes.iter().map(|(l, _)| l.clone()).collect();
    c.configure_mesh()
        .disable_x_mesh()
        .light_line_style(WHITE.mix(0.0))
        .x_desc(fig.x_desc)
        .y_desc(fig.y_desc)
        .x_label_formatter(&|v| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.2}"))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(de)?;
    let colour = RGBColor(31, 119, 180);
    let line = colour.stroke_width(2);
    for (i, (_, b)) in fig.boxes.iter().enumerate() {
        let x = i as f64;
        let (hw, cap) = (0.3, 0.12);
        let shapes = vec![
            PathElement::new(vec![(x, b.q3), (x, b.whisker_hi)], line),
            PathElement::new(vec![(x, b.q1), (x, b.whisker_lo)], line),
            PathElement::new(vec![(x - cap, b.whisker_hi), (x + cap, b.whisker_hi)], line),
            PathElement::new(vec![(x - cap, b.whisker_lo), (x + cap, b.whisker_lo)], line),
        ];
        c.draw_series(shapes).map_err(de)?;
        c.draw_series([
            Rectangle::new([(x - hw, b.q1), (x + hw, b.q3)], colour.mix(0.25).filled()),
            Rectangle::new([(x - hw, b.q1), (x + hw, b.q3)], line),
        ])
        .map_err(de)?;
        c.draw_series([PathElement::new(
            vec![(x - hw, b.median), (x + hw, b.median)],
            RGBColor(214, 39, 40).stroke_width(3),
        )])
        .map_err(de)?;
        c.draw_series([TriangleMarker::new(
            (x, b.mean),
            7,
            RGBColor(44, 160, 44).filled(),
        )])
        .map_err(de)?;
    }
    let legend = TextStyle::from(("sans-serif", 13).into_font()).pos(text_anchor::Pos::new(
        text_anchor::HPos::Right,
        text_anchor::VPos::Top,
    ));
    c.draw_series([EmptyElement::at((n as f64 - 0.5, top))
        + Text::new(
            "box Q1–Q3, red line median, ▲ mean, whiskers to the last point within 1.5 IQR",
            (-8, 6),
            legend,
        )])
    .map_err(de)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let s = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&s, 0.0), Some(1.0));
        assert_eq!(quantile(&s, 1.0), Some(4.0));
        assert_eq!(quantile(&s, 0.5), Some(2.5));
        assert_eq!(quantile(&s, 0.25), Some(1.75));
        assert_eq!(quantile(&s, 0.75), Some(3.25));
        assert_eq!(quantile(&[7.0], 0.3), Some(7.0));
        assert_eq!(quantile(&[], 0.5), None);
    }

    #[test]
    fn box_of_known_data() {
        // Sorted: 1..=10 and 30. n = 11: Q1 at h = 2.5 → 3.5, median 6, Q3 at h = 7.5 → 8.5,
        // IQR 5, fences −4 and 16: 30 is an outlier, the upper whisker ends at 10.
        let v = [30.0, 5.0, 1.0, 2.0, 9.0, 3.0, 4.0, 6.0, 7.0, 8.0, 10.0];
        let b = box_stats(&v).unwrap();
        assert_eq!((b.q1, b.median, b.q3), (3.5, 6.0, 8.5));
        assert_eq!((b.whisker_lo, b.whisker_hi), (1.0, 10.0));
        assert_eq!((b.min, b.max, b.outliers, b.n), (1.0, 30.0, 1, 11));
        assert!((b.mean - 85.0 / 11.0).abs() < 1e-12);
        // A low outlier too: −20 → sorted −20, 1..=10, 30 (n = 12): Q1 at h = 2.75 → 2.75,
        // Q3 at h = 8.25 → 8.25, IQR 5.5, fences −5.5 and 16.5.
        let mut w = v.to_vec();
        w.push(-20.0);
        let b = box_stats(&w).unwrap();
        assert_eq!((b.q1, b.median, b.q3), (2.75, 5.5, 8.25));
        assert_eq!((b.whisker_lo, b.whisker_hi, b.outliers), (1.0, 10.0, 2));
    }

    #[test]
    fn box_of_constant_and_empty_data() {
        let b = box_stats(&[0.0; 5]).unwrap();
        assert_eq!(
            (b.q1, b.median, b.q3, b.whisker_lo, b.whisker_hi),
            (0.0, 0.0, 0.0, 0.0, 0.0)
        );
        assert_eq!(b.outliers, 0);
        assert!(box_stats(&[]).is_none());
    }

    #[test]
    fn figures_are_written_with_text() {
        let dir = std::env::temp_dir().join(format!("stokes-boxplot-{}", std::process::id()));
        let boxes: Vec<(String, BoxStats)> = [2usize, 4, 8]
            .iter()
            .map(|&k| {
                let v: Vec<f64> = (0..50)
                    .map(|i| (i as f64 * 0.37).sin().abs() / k as f64)
                    .collect();
                (k.to_string(), box_stats(&v).unwrap())
            })
            .collect();
        let fig = BoxFigure {
            title: "test",
            x_desc: "number of Gaussians",
            y_desc: "ΔE00",
            boxes: &boxes,
        };
        let [svg, png] = write_box_figure(&dir.join("box"), &fig).unwrap();
        let s = std::fs::read_to_string(&svg).unwrap();
        assert!(
            s.contains("number of Gaussians") && s.contains("\n8\n"),
            "axis labels in SVG"
        );
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), SIZE);
        // Text was rasterised: the caption band (above the plot) has dark pixels.
        let dark = (0..SIZE.0)
            .flat_map(|x| (0..30).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0.iter().all(|&c| c < 100))
            .count();
        assert!(dark > 20, "caption pixels: {dark}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
