//! The data plots of Mojzík et al. 2018 and Jung 2017, redrawn from stokes' own data and code as
//! SVG (plotters, "sans-serif" text, no system fonts), with the key numbers in `summary.json`.
//!
//!     cargo run --release --example paper_plots -- OUT_DIR [--walls WALLS.exr]
//!
//! With `--walls`, a render of scenes/fluorescent-walls.json at its full size, it also draws the
//! scanlines of Jung Fig. 7.3 from it.

use plotters::coord::{Shift, types::RangedCoordf64};
use plotters::prelude::*;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};
use std::path::Path;
use std::process::ExitCode;
use stokes::io::{input, output};
use stokes::material::reradiation::BfcMatrix;
use stokes::material::{Bbrrdf, FluorescentDiffuse, Material};
use stokes::medium::{Flight, FreeFlight, Tracking};
use stokes::scene::Scene;
use stokes::spectrum::cie::{CMF_DOMAIN, cmf};
use stokes::spectrum::{Domain, Spectrum, xyz_to_linear_srgb};

mod jung;
mod mojzik;

use jung::*;
use mojzik::*;

type R<T> = Result<T, String>;
type Pts = Vec<(f64, f64)>;
type Area<'b> = DrawingArea<SVGBackend<'b>, Shift>;
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;
type Legend = Option<SeriesLabelPosition>;

/// Values below this are left out of the heat maps as measurement noise (Mojzík Fig. 5).
const NOISE: f64 = 0.006;
/// Distances sampled per (σ̂t, σ̂s) pair for the empirical CDFs of Fig. 9.
const FLIGHTS: usize = 100_000;
/// Distance to the surface in Mojzík Fig. 9.
const SURFACE: f64 = 10.0;
const GREY: RGBColor = RGBColor(120, 120, 120);
const UR: Legend = Some(SeriesLabelPosition::UpperRight);

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (out, walls) = match args.as_slice() {
        [out] => (out, None),
        [out, flag, w] if flag == "--walls" => (out, Some(Path::new(w))),
        _ => {
            eprintln!("usage: cargo run --release --example paper_plots -- OUT_DIR [--walls EXR]");
            return ExitCode::from(2);
        }
    };
    match run(Path::new(out), walls) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("paper_plots: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(out: &Path, walls_exr: Option<&Path>) -> R<()> {
    let mk = |e| format!("cannot create the folder '{}': {e}", out.display());
    std::fs::create_dir_all(out).map_err(mk)?;
    output::check_folder(out)?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let all = load_bfcs(&root.join("data/bispectral"))?;
    let (fl, ranking) = pick(&all, warm)?;
    let (paper, _) = pick(&all, |t| t.contains("white") && t.contains("paper"))?;
    let load = |p: &str| Scene::load(&root.join(p)).map_err(|e| e.to_string());
    let (walls, spheres) = (
        load("scenes/fluorescent-walls.json")?,
        load("scenes/green-spheres.json")?,
    );
    let f = fluorescent(&spheres, "fluorescent_sphere")?;
    mojzik_fig5(out, fl)?;
    jung_cmf(out, "jung-fig4-8-cmf.svg", CMF_DOMAIN, "Jung Fig. 4.8")?;
    let (min, max) = (700.0, 780.0);
    let red = Domain { min, max };
    jung_cmf(out, "jung-fig4-9-cmf-red.svg", red, "Jung Fig. 4.9")?;
    jung_fig7_2(out, &walls)?;
    jung_fig7_9(out, &spheres, f)?;
    let scanlines = match walls_exr {
        Some(p) => jung_fig7_3(out, &walls, p)?,
        None => Value::Null,
    };
    let s = json!({
        "jung_fig7_3_scanlines": scanlines,
        "mojzik_fig4_material": mojzik_fig4(out, fl, ranking)?,
        "mojzik_fig6_excitation_nm": mojzik_fig6(out, fl)?,
        "mojzik_fig9_distance_cdf": mojzik_fig9(out)?,
        "jung_fig7_11b_reflectivity": jung_fig7_11b(out, f, spheres.domain)?,
        "jung_fig7_11a_chromaticity": jung_fig7_11a(out, &spheres)?,
        "jung_fig5_1_matrices": jung_fig5_1(out, fl, paper)?,
    });
    let text = serde_json::to_string_pretty(&s).map_err(|e| e.to_string())?;
    output::write_bytes(&out.join("summary.json"), format!("{text}\n").as_bytes())?;
    report(out)
}

/// The files written, with their sizes, on stdout.
fn report(out: &Path) -> R<()> {
    let list = std::fs::read_dir(out).map_err(|e| format!("'{}': {e}", out.display()))?;
    let mut files: Vec<_> = list.flatten().map(|e| e.path()).collect();
    files.sort();
    for p in files {
        let n = p.file_name().unwrap_or_default().to_string_lossy();
        if n == "summary.json" || n.starts_with("mojzik-fig") || n.starts_with("jung-fig") {
            let len = std::fs::metadata(&p).map_or(0, |m| m.len());
            println!("{len:>8} bytes  {}", p.display());
        }
    }
    Ok(())
}

// ---------------------------------------------------------------- measured matrices

/// A measured BFC matrix, its file stem and title (the file's second comment line), and sums.
struct Measured {
    stem: String,
    title: String,
    m: BfcMatrix,
    /// Σ of the off-diagonal entries (Σ over columns of ∫ρ dλo).
    mass: f64,
    /// Largest fluorescent albedo of a column, max over λi of ∫ρ dλo.
    peak_albedo: f64,
}

/// Σ of the off-diagonal entries per excitation column (`by_column`: the accumulated
/// absorption) or per emission row (the accumulated re-emission).
fn sums(m: &BfcMatrix, by_column: bool) -> Vec<f64> {
    let (n, k) = [(m.n_em, m.n_ex), (m.n_ex, m.n_em)][by_column as usize];
    let at = |a, b| if by_column { m.off(b, a) } else { m.off(a, b) } as f64;
    (0..n).map(|a| (0..k).map(|b| at(a, b)).sum()).collect()
}

/// Every BFC file of `dir` and `dir/rit` (a stem seen twice is the same measurement).
fn load_bfcs(dir: &Path) -> R<Vec<Measured>> {
    let mut files = Vec::new();
    for sub in [dir.to_path_buf(), dir.join("rit")] {
        let list = std::fs::read_dir(&sub).map_err(|e| format!("'{}': {e}", sub.display()))?;
        let paths = list.flatten().map(|e| e.path());
        files.extend(paths.filter(|p| output::has_extension(p, "bfc")));
    }
    files.sort();
    let mut out: Vec<Measured> = Vec::new();
    for p in files {
        let stem = p.file_stem().unwrap_or_default().to_string_lossy();
        let stem = stem.to_string();
        if out.iter().any(|x| x.stem == stem) {
            continue;
        }
        let text = input::read_text(&p, input::BFC)?;
        let m = BfcMatrix::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?;
        let mut comments = text.lines().filter_map(|l| l.trim().strip_prefix(';'));
        let title = comments.nth(1).unwrap_or("").trim().to_string();
        let a = sums(&m, true);
        let (mass, peak_albedo) = (a.iter().sum(), a.iter().copied().fold(0.0, f64::max));
        let x = Measured {
            stem,
            title,
            m,
            mass,
            peak_albedo,
        };
        out.push(x);
    }
    if out.is_empty() {
        return Err(format!("no BFC files in '{}'", dir.display()));
    }
    Ok(out)
}

/// Whether a lower-case title names pink, red, orange or cerise, and not yellow.
fn warm(t: &str) -> bool {
    let w: Vec<&str> = t.split(|c: char| !c.is_ascii_alphanumeric()).collect();
    let has = |k: &&str| w.contains(k);
    ["pink", "red", "orange", "cerise"].iter().any(has) && !has(&"yellow")
}

/// The most fluorescent matrix whose lower-case title passes `keep`, among the plausible ones
/// (no column re-emits more than it receives: IXCAXORA, an artefact Hua §7.1 leave out, does),
/// and the five best candidates.
fn pick(all: &[Measured], keep: impl Fn(&str) -> bool) -> R<(&Measured, Value)> {
    let mut c: Vec<&Measured> = all.iter().filter(|m| m.peak_albedo <= 1.0).collect();
    c.retain(|m| keep(&m.title.to_lowercase()));
    c.sort_by(|a, b| b.mass.total_cmp(&a.mass));
    let rank = c.iter().take(5).map(|m| {
        json!({"file": m.stem, "title": m.title, "offdiagonal_sum": r4(m.mass),
               "peak_fluorescent_albedo": r4(m.peak_albedo)})
    });
    let rank = Value::Array(rank.collect());
    let best = c.first().ok_or("no matching BFC file")?;
    Ok((best, rank))
}

// ---------------------------------------------------------------- drawing helpers

fn de<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Rounded to 4 decimals for the summary.
fn r4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

/// An axis label without trailing zeros (300, 0.25).
fn num(v: &f64) -> String {
    format!("{}", (v * 1e6).round() / 1e6)
}

/// Render an SVG of `size` through `draw` into `dir/name`.
fn svg(dir: &Path, name: &str, size: (u32, u32), draw: impl FnOnce(&Area) -> R<()>) -> R<()> {
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(de)?;
        draw(&root)?;
        root.present().map_err(de)?;
    }
    output::write_bytes(&dir.join(name), buf.as_bytes())
}

/// `area` below a title.
fn titled<'b>(area: &Area<'b>, title: &str) -> R<Area<'b>> {
    area.titled(title, ("sans-serif", 17)).map_err(de)
}

/// How a curve is drawn.
#[derive(Clone, Copy, PartialEq)]
enum Look {
    Line(u32),
    Dashed,
    Dots,
}

/// A curve: legend name (none if empty), points, colour and look.
struct Curve(String, Pts, RGBColor, Look);

fn curve(name: impl Into<String>, pts: Pts, color: RGBColor) -> Curve {
    Curve(name.into(), pts, color, Look::Line(2))
}

impl Curve {
    fn look(self, look: Look) -> Curve {
        Curve(self.0, self.1, self.2, look)
    }
}

/// Eight distinct colours (ColorBrewer Set1, then black).
fn colour(j: usize) -> RGBColor {
    const C: [u8; 24] = [
        228, 26, 28, 55, 126, 184, 77, 175, 74, 152, 78, 163, 255, 127, 0, 166, 86, 40, 247, 129,
        191, 0, 0, 0,
    ];
    let k = 3 * (j % 8);
    RGBColor(C[k], C[k + 1], C[k + 2])
}

/// Viridis through nine of its colours, at s in [0, 1].
fn viridis(s: f64) -> RGBColor {
    const V: [u8; 27] = [
        68, 1, 84, 71, 44, 122, 59, 81, 139, 44, 113, 142, 33, 144, 141, 39, 173, 129, 92, 200, 99,
        170, 220, 50, 253, 231, 37,
    ];
    let f = s.clamp(0.0, 1.0) * 8.0;
    let (i, t) = ((f as usize).min(7), f.fract());
    let m = |c| (V[3 * i + c] as f64 * (1.0 - t) + V[3 * i + 3 + c] as f64 * t) as u8;
    RGBColor(m(0), m(1), m(2))
}

/// Axes: [x0, x1, y0, y1] and the descriptions of x and y.
type Axes<'s> = ([f64; 4], [&'s str; 2]);

/// Wavelength axes over `d`, y from 0 to `y1`.
fn wl(d: Domain, y1: f64, y: &str) -> Axes<'_> {
    let x = [d.min as f64, d.max as f64, 0.0, y1];
    (x, ["wavelength (nm)", y])
}

/// A chart in `area` with its caption, axes and a light grid.
fn chart<'a, 'b>(area: &'a Area<'b>, title: &str, ax: Axes) -> R<Chart<'a, 'b>> {
    let r = ax.0;
    let mut c = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 15))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(r[0]..r[1], r[2]..r[3])
        .map_err(de)?;
    let mut mesh = c.configure_mesh();
    mesh.x_desc(ax.1[0]).y_desc(ax.1[1]).max_light_lines(1);
    mesh.x_label_formatter(&num).y_label_formatter(&num);
    mesh.draw().map_err(de)?;
    Ok(c)
}

/// A line chart of `cs` (see [`chart`]) with a legend at `legend`, if any.
fn lines(area: &Area, title: &str, ax: Axes, cs: &[Curve], legend: Legend) -> R<()> {
    let mut c = chart(area, title, ax)?;
    for Curve(name, pts, col, look) in cs {
        let (col, pts) = (*col, pts.iter().copied());
        let style = col.stroke_width(if let Look::Line(w) = look { *w } else { 2 });
        let anno = match look {
            Look::Dots => c.draw_series(pts.map(|p| Circle::new(p, 5, col.filled()))),
            Look::Dashed => c.draw_series(DashedLineSeries::new(pts, 6, 4, style)),
            Look::Line(_) => c.draw_series(LineSeries::new(pts, style)),
        };
        let anno = anno.map_err(de)?;
        if name.is_empty() {
            continue;
        }
        let anno = anno.label(name.as_str());
        if *look == Look::Dots {
            anno.legend(move |(x, y)| Circle::new((x + 10, y), 4, col.filled()));
        } else {
            anno.legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        }
    }
    let Some(at) = legend else { return Ok(()) };
    let mut labels = c.configure_series_labels();
    labels.position(at).label_font(("sans-serif", 12));
    labels.border_style(BLACK).background_style(WHITE.mix(0.85));
    labels.draw().map_err(de)
}

/// A single line chart of 900 × 480, legend upper right, written to `dir/name`.
fn plot(dir: &Path, name: &str, title: &str, ax: Axes, cs: &[Curve]) -> R<()> {
    svg(dir, name, (900, 480), |r| lines(r, title, ax, cs, UR))
}

/// `f` at every `step` nm of `d`.
fn sampled(f: impl Fn(f32) -> f64, d: Domain, step: f64) -> Pts {
    let n = (d.width() as f64 / step).round() as usize;
    let at = |k: usize| d.min as f64 + k as f64 * step;
    (0..=n).map(|k| (at(k), f(at(k) as f32))).collect()
}

/// A spectrum times `k` at every nm of `d`.
fn sp(s: &Spectrum, k: f64, d: Domain) -> Pts {
    sampled(|l| s.eval(l) as f64 * k, d, 1.0)
}

/// Values on a grid whose k-th abscissa is `x(k)`.
fn on_grid(v: &[f64], x: impl Fn(usize) -> f32) -> Pts {
    (0..v.len()).map(|k| (x(k) as f64, v[k])).collect()
}

/// The point with the largest value.
fn argmax(p: &[(f64, f64)]) -> (f64, f64) {
    let larger = |b: (f64, f64), &q: &(f64, f64)| if q.1 > b.1 { q } else { b };
    p.iter().fold((0.0, f64::MIN), larger)
}

/// Upper end of a y axis showing every curve (10 % headroom).
fn top_of(cs: &[Curve]) -> f64 {
    let ys = cs.iter().flat_map(|c| c.1.iter().map(|p| p.1));
    1.1 * ys.fold(1e-9, f64::max)
}

/// A reradiation matrix as a heat map, one rectangle per cell of at least [`NOISE`], on a log
/// colour scale, with its colour bar.
fn heatmap(area: &Area, title: &str, m: &BfcMatrix) -> R<()> {
    let vmax = m.d.iter().fold(2.0 * NOISE, |a, &v| a.max(v as f64));
    let (left, bar) = area.split_horizontally(area.dim_in_pixel().0.saturating_sub(90));
    let h = m.step as f64 / 2.0;
    let (x, y) = ((m.ex(0), m.ex(m.n_ex - 1)), (m.em(0), m.em(m.n_em - 1)));
    let r = [x.0, x.1, y.0, y.1].map(|v| v as f64);
    let ax = [r[0] - h, r[1] + h, r[2] - h, r[3] + h];
    let desc = ["excitation λi (nm)", "emission λo (nm)"];
    let mut c = chart(&left, title, (ax, desc))?;
    let s = |v: f64| (v / NOISE).ln() / (vmax / NOISE).ln();
    let cell = |o: usize, i: usize| {
        let (v, x, y) = (m.d[o * m.n_ex + i] as f64, m.ex(i) as f64, m.em(o) as f64);
        let style = viridis(s(v)).filled();
        (v >= NOISE).then(|| Rectangle::new([(x - h, y - h), (x + h, y + h)], style))
    };
    let cells = (0..m.n_em).flat_map(|o| (0..m.n_ex).filter_map(move |i| cell(o, i)));
    c.draw_series(cells).map_err(de)?;
    let key = [0.006, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0];
    let key: Vec<f64> = key.into_iter().filter(|&k| k <= vmax).collect();
    let scale = (NOISE..vmax).log_scale().with_key_points(key);
    let mut b = ChartBuilder::on(&bar);
    b.margin_top(40).margin_bottom(46);
    b.set_label_area_size(LabelAreaPosition::Right, 50);
    let mut b = b.build_cartesian_2d(0.0..1.0, scale).map_err(de)?;
    let mut mesh = b.configure_mesh();
    mesh.disable_mesh().disable_x_axis().y_label_formatter(&num);
    mesh.y_label_style(("sans-serif", 12));
    mesh.draw().map_err(de)?;
    let (n, r) = (48, vmax / NOISE);
    let at = |k: usize| NOISE * r.powf(k as f64 / n as f64);
    let band = |k: usize| viridis((k as f64 + 0.5) / n as f64).filled();
    let bands = (0..n).map(|k| Rectangle::new([(0.0, at(k)), (1.0, at(k + 1))], band(k)));
    b.draw_series(bands).map_err(de)?;
    Ok(())
}
