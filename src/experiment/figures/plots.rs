//! The plotters figures (SVG backend, no system fonts): convergence plots against time and spp,
//! the scanline plot and the sweep summary. On a log axis whose quantity is the run's budget
//! (seconds of an equal-time run, spp of an spp ladder) every budget has a labelled tick.

use super::colour::luminance;
use super::region_suffix;
use crate::error::Error;
use crate::experiment::config::Scanline;
use crate::experiment::record::{Row, RunInfo, SummaryEntry, read_metrics};
use crate::experiment::sweep::{SweepRecord, compact, final_entries};
use glam::Vec3;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

type R<T> = Result<T, String>;

fn de<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

struct Line {
    name: String,
    /// (x, mean y, min y, max y)
    pts: Vec<(f64, f64, f64, f64)>,
}

/// The budget mode a plot shows: relMSE vs seconds prefers equal-time snapshots, SNR vs spp the
/// spp ladder.
fn plot_mode(rows: &[Row], time_plot: bool) -> &str {
    let want = if time_plot { "time" } else { "spp" };
    if rows.iter().any(|r| r.mode == want) {
        want
    } else {
        rows.first().map_or(want, |r| r.mode.as_str())
    }
}

fn lines(info: &RunInfo, rows: &[Row], region: &str, time_plot: bool) -> Vec<Line> {
    let mode = plot_mode(rows, time_plot);
    let mut out = Vec::new();
    for v in &info.config.variants {
        let mut budgets: Vec<f64> = rows
            .iter()
            .filter(|r| r.variant == v.name && r.mode == mode && r.region == region)
            .map(|r| r.budget)
            .collect();
        budgets.sort_by(f64::total_cmp);
        budgets.dedup();
        let mut pts = Vec::new();
        for b in budgets {
            let g: Vec<&Row> = rows
                .iter()
                .filter(|r| {
                    r.variant == v.name && r.mode == mode && r.region == region && r.budget == b
                })
                .collect();
            let n = g.len() as f64;
            let x = g
                .iter()
                .map(|r| if time_plot { r.seconds } else { r.spp as f64 })
                .sum::<f64>()
                / n;
            let ys: Vec<f64> = g
                .iter()
                .map(|r| if time_plot { r.rel_mse } else { r.snr_db })
                .filter(|y| y.is_finite())
                .collect();
            if ys.is_empty() || x.is_nan() || x <= 0.0 {
                continue;
            }
            let mean = ys.iter().sum::<f64>() / ys.len() as f64;
            let lo = ys.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if time_plot && (lo.is_nan() || lo <= 0.0) {
                continue;
            }
            pts.push((x, mean, lo, hi));
        }
        if !pts.is_empty() {
            out.push(Line {
                name: v.name.clone(),
                pts,
            });
        }
    }
    out
}

/// The budgets of a plot's x axis when its quantity is the budget itself (seconds of the
/// equal-time snapshots, spp of the spp ladder), else none (the axis shows measured values).
fn budget_axis(info: &RunInfo, rows: &[Row], time_plot: bool) -> Vec<f64> {
    let mode = plot_mode(rows, time_plot);
    if mode != if time_plot { "time" } else { "spp" } {
        return Vec::new();
    }
    info.modes
        .iter()
        .find(|m| m.mode.name() == mode)
        .map(|m| m.budgets.clone())
        .unwrap_or_default()
}

pub fn convergence(
    info: &RunInfo,
    rows: &[Row],
    region: &str,
    time_plot: bool,
    path: &Path,
) -> R<()> {
    let ls = lines(info, rows, region, time_plot);
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(de)?;
    let title = format!(
        "{}: {} ({})",
        info.config.name,
        if time_plot {
            "relMSE vs time"
        } else {
            "SNR vs spp"
        },
        region
    );
    let all: Vec<&(f64, f64, f64, f64)> = ls.iter().flat_map(|l| &l.pts).collect();
    if all.is_empty() {
        return no_data(&root, &title);
    }
    let budgets = budget_axis(info, rows, time_plot);
    let xs = all.iter().map(|p| p.0).chain(budgets.iter().copied());
    let x0 = xs.clone().fold(f64::INFINITY, f64::min) / 1.2;
    let x1 = xs.fold(0.0, f64::max) * 1.2;
    let x_ticks = if budgets.is_empty() {
        let (lo, hi) = all.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
        measured_ticks(lo, hi, x0, x1)
    } else {
        budget_ticks(&budgets)
    };
    let y0 = all.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
    let y1 = all.iter().map(|p| p.3).fold(f64::NEG_INFINITY, f64::max);
    let mut chart = ChartBuilder::on(&root);
    chart
        .caption(&title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    let x_axis = (x0..x1).log_scale().with_key_points(x_ticks);
    if time_plot {
        let mut c = chart
            .build_cartesian_2d(
                x_axis,
                (y0 / 1.5..y1 * 1.5)
                    .log_scale()
                    .with_key_points(log_ticks(y0 / 1.5, y1 * 1.5)),
            )
            .map_err(de)?;
        c.configure_mesh()
            .x_desc("seconds")
            .y_desc("relMSE")
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(de)?;
        draw_lines(&mut c, &ls, SeriesLabelPosition::LowerLeft)?;
    } else {
        let pad = ((y1 - y0) * 0.1).max(0.5);
        let mut c = chart
            .build_cartesian_2d(x_axis, (y0 - pad)..(y1 + pad))
            .map_err(de)?;
        c.configure_mesh()
            .x_desc("samples per pixel")
            .y_desc("SNR (dB)")
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(de)?;
        draw_lines(&mut c, &ls, SeriesLabelPosition::UpperLeft)?;
    }
    root.present().map_err(de)?;
    Ok(())
}

pub fn scanline(
    info: &RunInfo,
    reference: Option<&[Vec3]>,
    imgs: &[(String, Vec<Vec3>)],
    s: Scanline,
    label: &str,
    path: &Path,
) -> R<()> {
    let (w, h) = (info.width, info.height);
    let (n, at): (u32, Box<dyn Fn(u32) -> usize>) = match (s.row, s.column) {
        (Some(r), _) => (w, Box::new(move |i| (r * w + i) as usize)),
        (_, Some(c)) => (h, Box::new(move |i| (i * w + c) as usize)),
        _ => return Err("scanline needs a row or a column".into()),
    };
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    if let Some(r) = reference {
        series.push((
            "reference".into(),
            (0..n).map(|i| (i as f64, luminance(r[at(i)]))).collect(),
        ));
    }
    for (name, img) in imgs {
        series.push((
            name.clone(),
            (0..n).map(|i| (i as f64, luminance(img[at(i)]))).collect(),
        ));
    }
    let ymax = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let ymin = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(0.0, f64::min);
    let root = SVGBackend::new(path, (720, 400)).into_drawing_area();
    root.fill(&WHITE).map_err(de)?;
    let what = match (s.row, s.column) {
        (Some(r), _) => format!("row {r}"),
        (_, Some(c)) => format!("column {c}"),
        _ => unreachable!(),
    };
    let mut c = ChartBuilder::on(&root)
        .caption(
            format!("{}: luminance along {what}, {label}", info.config.name),
            ("sans-serif", 16),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..(n as f64 - 1.0).max(1.0), ymin..ymax)
        .map_err(de)?;
    c.configure_mesh()
        .x_desc("pixel")
        .y_desc("Y (linear)")
        .draw()
        .map_err(de)?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let col = if i == 0 && reference.is_some() {
            BLACK.to_rgba()
        } else {
            Palette99::pick(i - reference.is_some() as usize).to_rgba()
        };
        c.draw_series(LineSeries::new(
            pts.iter().copied().filter(|p| p.1.is_finite()),
            col.stroke_width(if i == 0 { 2 } else { 1 }),
        ))
        .map_err(de)?
        .label(name.clone())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(de)?;
    root.present().map_err(de)?;
    Ok(())
}

/// Compact tick label for log axes: whole numbers below 10⁹ in full (spp budgets), else 3
/// significant digits, scientific outside [1e-3, 1e4) (`5e-4`, `2.5e-5`).
pub fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if v.fract() == 0.0 && a < 1e9 {
        return format!("{v:.0}");
    }
    if !(1e-3..1e4).contains(&a) {
        // 5e-4 rather than 5.0e-4, 2.5e-5 as it is.
        return format!("{v:.1e}").replace(".0e", "e");
    }
    let digits = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Tick positions for a log axis: 1-2-5 per decade, or every integer multiple when the range
/// spans less than about a decade.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo) {
        return vec![];
    }
    let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let pick = |ms: &[f64]| -> Vec<f64> {
        (d0..=d1)
            .flat_map(|d| ms.iter().map(move |m| m * 10f64.powi(d)))
            .filter(|v| *v >= lo && *v <= hi)
            .collect()
    };
    let t = pick(&[1.0, 2.0, 5.0]);
    if t.len() >= 3 {
        t
    } else {
        pick(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    }
}

/// Most budget ticks on one axis: a longer ladder is thinned (its first and last budget kept).
const MAX_BUDGET_TICKS: usize = 16;

/// Ticks of a log axis whose quantity is the budget: every budget (distinct, positive), each
/// labelled. A ladder of more than [`MAX_BUDGET_TICKS`] budgets keeps an evenly spaced subset
/// with its first and last budget, since the labels would overlap.
pub fn budget_ticks(budgets: &[f64]) -> Vec<f64> {
    let mut b: Vec<f64> = budgets
        .iter()
        .copied()
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    b.sort_by(f64::total_cmp);
    b.dedup();
    if b.len() <= MAX_BUDGET_TICKS {
        return b;
    }
    let n = b.len() - 1;
    let k = MAX_BUDGET_TICKS - 1;
    let mut out: Vec<f64> = (0..=k).map(|i| b[(i * n + k / 2) / k]).collect();
    out.dedup();
    out
}

/// Ticks of a log axis of measured values over [lo, hi] (the data) within the axis range
/// [x0, x1]: the 1-2-5 ticks, plus the data's ends when no tick lies within a factor 1.3 of
/// them, so the first and last point always have a labelled value near them.
fn measured_ticks(lo: f64, hi: f64, x0: f64, x1: f64) -> Vec<f64> {
    let mut t = log_ticks(x0, x1);
    for end in [lo, hi] {
        if end > 0.0 && !t.iter().any(|v| (v / end).max(end / v) < 1.3) {
            t.push(end);
        }
    }
    t.sort_by(f64::total_cmp);
    t
}

/// The sweep's summary: final-budget SNR (mean line, min–max band over repeats) per variant
/// against the swept value, `figures/snr-vs-sweep[-region].svg`, from each value's
/// `metrics.csv`. The values are evenly spaced and labelled with their text, so a value may be
/// any JSON.
pub fn sweep_summary(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let info = RunInfo::read(dir)?;
    let rec = SweepRecord::read(dir)?;
    let fig = dir.join("figures");
    std::fs::create_dir_all(&fig)
        .map_err(|e| Error::runtime(format!("cannot create '{}': {e}", fig.display())))?;
    let mut finals = Vec::new();
    for p in &rec.points {
        finals.push(final_entries(&read_metrics(
            &dir.join(&p.dir).join("metrics.csv"),
        )?));
    }
    let mut regions: Vec<String> = Vec::new();
    for e in finals.iter().flatten() {
        if !regions.contains(&e.region) {
            regions.push(e.region.clone());
        }
    }
    let mut out = Vec::new();
    for region in &regions {
        let suffix = region_suffix(region);
        let p = fig.join(format!("snr-vs-sweep{suffix}.svg"));
        let ls = sweep_lines(&finals, region);
        let labels: Vec<String> = rec
            .points
            .iter()
            .map(|p| short(&compact(&p.value)))
            .collect();
        let title = format!(
            "{}: SNR at the final budget vs {} ({region})",
            info.config.name, rec.label
        );
        sweep_plot(&ls, &labels, &rec.label, &title, &p).map_err(Error::runtime)?;
        out.push(p);
    }
    Ok(out)
}

/// One line per variant (and mode, when there are two) through the values' final-budget SNR.
fn sweep_lines(finals: &[Vec<SummaryEntry>], region: &str) -> Vec<Line> {
    let modes: Vec<&str> = {
        let mut m: Vec<&str> = finals.iter().flatten().map(|e| e.mode.as_str()).collect();
        m.sort();
        m.dedup();
        m
    };
    let mut out: Vec<Line> = Vec::new();
    for (i, entries) in finals.iter().enumerate() {
        for e in entries.iter().filter(|e| e.region == region) {
            let s = e.snr_db;
            if !s.mean.is_finite() {
                continue;
            }
            let name = if modes.len() > 1 {
                format!("{} ({})", e.variant, e.mode)
            } else {
                e.variant.clone()
            };
            let pt = (i as f64, s.mean, s.min, s.max);
            match out.iter_mut().find(|l| l.name == name) {
                Some(l) => l.pts.push(pt),
                None => out.push(Line {
                    name,
                    pts: vec![pt],
                }),
            }
        }
    }
    out
}

fn short(s: &str) -> String {
    if s.chars().count() <= 24 {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(23).collect::<String>())
    }
}

/// A plot without points: its title says so.
fn no_data(root: &DrawingArea<SVGBackend, plotters::coord::Shift>, title: &str) -> R<()> {
    root.titled(&format!("{title}: no data"), ("sans-serif", 18))
        .map_err(de)?;
    root.present().map_err(de)
}

fn sweep_plot(ls: &[Line], labels: &[String], xlabel: &str, title: &str, path: &Path) -> R<()> {
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(de)?;
    let all: Vec<&(f64, f64, f64, f64)> = ls.iter().flat_map(|l| &l.pts).collect();
    if all.is_empty() {
        return no_data(&root, title);
    }
    let y0 = all.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
    let y1 = all.iter().map(|p| p.3).fold(f64::NEG_INFINITY, f64::max);
    let pad = ((y1 - y0) * 0.1).max(0.5);
    let n = labels.len();
    let mut c = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..n as f64 - 0.5, (y0 - pad)..(y1 + pad))
        .map_err(de)?;
    c.configure_mesh()
        .x_desc(xlabel)
        .y_desc("SNR (dB)")
        .x_labels(n + 2)
        .x_label_formatter(&|v| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(de)?;
    draw_lines(&mut c, ls, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(de)?;
    Ok(())
}

/// One line per variant with its repeat spread shaded, markers and a legend.
fn draw_lines<'a, DB, X, Y>(
    c: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    ls: &[Line],
    legend: SeriesLabelPosition,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for (i, l) in ls.iter().enumerate() {
        let col = Palette99::pick(i).to_rgba();
        let mut band: Vec<(f64, f64)> = l.pts.iter().map(|p| (p.0, p.3)).collect();
        band.extend(l.pts.iter().rev().map(|p| (p.0, p.2)));
        c.draw_series(std::iter::once(Polygon::new(band, col.mix(0.2))))
            .map_err(de)?;
        c.draw_series(LineSeries::new(
            l.pts.iter().map(|p| (p.0, p.1)),
            col.stroke_width(2),
        ))
        .map_err(de)?
        .label(l.name.clone())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        c.draw_series(
            l.pts
                .iter()
                .map(|p| Circle::new((p.0, p.1), 3, col.filled())),
        )
        .map_err(de)?;
    }
    c.configure_series_labels()
        .position(legend)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(de)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_budget_is_a_labelled_tick() {
        for b in [
            vec![2.5, 5.0, 10.0, 20.0, 40.0],
            vec![1.0, 4.0, 16.0, 64.0, 256.0, 1024.0],
            vec![0.125, 0.25, 0.5],
            vec![16384.0, 65536.0],
        ] {
            let t = budget_ticks(&b);
            assert_eq!(t, b);
            let labels: Vec<String> = t.iter().map(|v| tick(*v)).collect();
            let want: Vec<String> = b.iter().map(|v| v.to_string()).collect();
            assert_eq!(labels, want);
        }
        // A long ladder is thinned but keeps its ends.
        let long: Vec<f64> = (1..=100).map(f64::from).collect();
        let t = budget_ticks(&long);
        assert!(t.len() <= MAX_BUDGET_TICKS);
        assert_eq!((t[0], t[t.len() - 1]), (1.0, 100.0));
    }

    #[test]
    fn tick_labels_are_compact() {
        let labels: Vec<String> = [5e-4, 2.5e-5, 1e-4, 0.002, 0.0125, 2.5, 40.0, 1.5e4]
            .iter()
            .map(|v| tick(*v))
            .collect();
        let want = [
            "5e-4", "2.5e-5", "1e-4", "0.002", "0.0125", "2.5", "40", "15000",
        ];
        assert_eq!(labels, want);
    }

    #[test]
    fn measured_axes_label_the_data_ends() {
        // 1-2-5 ticks over [27, 352] are 50, 100, 200: both ends are added.
        let t = measured_ticks(27.0, 352.0, 27.0 / 1.2, 352.0 * 1.2);
        assert_eq!(t, vec![27.0, 50.0, 100.0, 200.0, 352.0]);
        // An end next to a 1-2-5 tick is not repeated.
        let t = measured_ticks(10.2, 195.0, 10.2 / 1.2, 195.0 * 1.2);
        assert_eq!(t, vec![10.0, 20.0, 50.0, 100.0, 200.0]);
    }
}
