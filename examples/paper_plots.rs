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

// ---------------------------------------------------------------- Mojzík

/// Mojzík Fig. 4: accumulated absorption (Σ over λo) and re-emission (Σ over λi) of the matrix.
fn mojzik_fig4(dir: &Path, s: &Measured, ranking: Value) -> R<Value> {
    let a = on_grid(&sums(&s.m, true), |i| s.m.ex(i));
    let e = on_grid(&sums(&s.m, false), |o| s.m.em(o));
    let (la, le) = (argmax(&a).0, argmax(&e).0);
    let cs = [
        curve("absorption: Σ over emission", a, colour(1)),
        curve("re-emission: Σ over excitation", e, colour(0)),
    ];
    let (stem, title) = (&s.stem, &s.title);
    let t = format!("Mojzík Fig. 4: Stokes shift of {stem} ({title})");
    println!("Mojzík Fig. 4: {stem} ({title}), absorption peak {la} nm, re-emission peak {le} nm");
    let (min, max) = (290.0, 790.0);
    let ax = wl(Domain { min, max }, top_of(&cs), "Σ of matrix entries");
    plot(dir, "mojzik-fig4-stokes-shift.svg", &t, ax, &cs)?;
    Ok(json!({"file": s.stem, "title": s.title,
        "why": "largest sum of off-diagonal entries among the RIT files titled pink, red, orange \
                or cerise (not yellow), leaving out IXCAXORA whose columns re-emit up to 35x \
                the incident light (a measurement artefact, Hua 7.1); the 3M Post-it is not in it",
        "absorption_peak_nm": la, "reemission_peak_nm": le,
        "offdiagonal_sum": r4(s.mass), "peak_fluorescent_albedo": r4(s.peak_albedo),
        "candidates": ranking}))
}

/// Mojzík Fig. 5: the full reradiation matrix as a heat map, values below 0.006 left out.
fn mojzik_fig5(dir: &Path, s: &Measured) -> R<()> {
    let (stem, t) = (&s.stem, &s.title);
    let title = format!("Mojzík Fig. 5: reradiation matrix of {stem} ({t}), < {NOISE} not drawn");
    let draw = |r: &Area| heatmap(r, &title, &s.m);
    svg(dir, "mojzik-fig5-matrix.svg", (760, 620), draw)
}

/// Mojzík Fig. 6: re-emission spectra (matrix columns, each normalised to its maximum) for up
/// to six excitation wavelengths where the accumulated absorption is at least half its peak.
fn mojzik_fig6(dir: &Path, s: &Measured) -> R<Value> {
    let a = sums(&s.m, true);
    let amax = a.iter().copied().fold(0.0, f64::max);
    let band: Vec<usize> = (0..s.m.n_ex).filter(|&i| a[i] >= 0.5 * amax).collect();
    let k = band.len();
    let cols: Vec<usize> = if k <= 6 {
        band
    } else {
        (0..6).map(|j| band[j * (k - 1) / 5]).collect()
    };
    let column = |j: usize, i: usize| {
        let v: Vec<f64> = (0..s.m.n_em).map(|o| s.m.off(o, i) as f64).collect();
        let max = v.iter().copied().fold(1e-12, f64::max);
        let v: Vec<f64> = v.iter().map(|x| x / max).collect();
        let name = format!("λi = {} nm", s.m.ex(i));
        curve(name, on_grid(&v, |o| s.m.em(o)), colour(j))
    };
    let cs: Vec<Curve> = (0..cols.len()).map(|j| column(j, cols[j])).collect();
    let t = format!("Mojzík Fig. 6: re-emission spectra of {} (columns)", s.stem);
    let ax = [370.0, 790.0, 0.0, 1.1];
    let ax = (ax, ["emission λo (nm)", "re-emission / max"]);
    plot(dir, "mojzik-fig6-reemission.svg", &t, ax, &cs)?;
    Ok(cols.iter().map(|&i| s.m.ex(i)).collect())
}

/// Mojzík eq. 6 below the surface (t ≤ d; the CDF is 1 from d on).
fn eq6(st: f64, ss: f64, d: f64, t: f64) -> f64 {
    if st == 0.0 {
        t * ss / (d * ss + 1.0)
    } else {
        (1.0 - (-t * st).exp()) / (1.0 + (st / ss - 1.0) * (-d * st).exp())
    }
}

/// The ideal CDF at `n` + 1 even steps of [0, d]: collision density ∝ σ̂s·e^(−σ̂t·t) plus the
/// pass-through mass e^(−σ̂t·d), integrated numerically (midpoint rule), not by eq. 6.
fn ideal(st: f64, ss: f64, d: f64, n: usize) -> Vec<f64> {
    let (sub, mut acc, mut cum) = (64, 0.0, vec![0.0]);
    let h = d / (n * sub) as f64;
    for k in 0..n * sub {
        acc += ss * (-(k as f64 + 0.5) * h * st).exp() * h;
        if (k + 1) % sub == 0 {
            cum.push(acc);
        }
    }
    let total = acc + (-d * st).exp();
    cum.iter().map(|c| c / total).collect()
}

/// Sorted distances from the library's free-flight sampler (a pass counts as t = d).
fn flights(mode: Tracking, st: f64, ss: f64, seed: u64) -> Vec<f64> {
    let f = FreeFlight::new(mode, st as f32, ss as f32);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut one = || match f.sample(SURFACE as f32, rng.random::<f32>()) {
        Flight::Collision { t, .. } => t as f64,
        Flight::Pass { .. } => SURFACE,
    };
    let mut t: Vec<f64> = (0..FLIGHTS).map(|_| one()).collect();
    t.sort_by(f64::total_cmp);
    t
}

/// Kolmogorov–Smirnov distance of sorted samples from a CDF `f` below d that jumps to 1 at d.
fn ks(sorted: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    let n = sorted.len() as f64;
    let below = sorted.partition_point(|&t| t < SURFACE);
    let gap = |j: usize, t: f64| ((j as f64 + 1.0) / n - f(t)).max(f(t) - j as f64 / n);
    let k = sorted[..below].iter().enumerate().map(|(j, &t)| gap(j, t));
    let pass = (below as f64 / n - f(SURFACE)).abs();
    k.fold(pass, f64::max)
}

/// A CDF on [0, 12]: `below` at even steps of [0, d], then the jump to 1 at d.
fn with_jump(below: Vec<f64>) -> Pts {
    let n = (below.len() - 1) as f64;
    let mut p = on_grid(&below, |k| (k as f64 * SURFACE / n) as f32);
    p.extend([(SURFACE, 1.0), (12.0, 1.0)]);
    p
}

/// Mojzík Fig. 9: CDFs of the distance sampled towards a surface at d = 10 (exponential
/// tracking, eq. 6, the ideal distribution) and of the library's aware-tracking samples.
fn mojzik_fig9(dir: &Path) -> R<Value> {
    let n = 300;
    let ts: Vec<f64> = (0..=n).map(|k| k as f64 * SURFACE / n as f64).collect();
    let grid = |f: &dyn Fn(f64) -> f64| with_jump(ts.iter().map(|&t| f(t)).collect());
    let crit = 1.358 / (FLIGHTS as f64).sqrt();
    let (mut rows, mut panels) = (Vec::new(), Vec::new());
    let pairs = [(0.5, 0.5), (0.1, 0.5), (0.02, 0.5), (0.0, 0.5)];
    for (j, (st, ss)) in pairs.into_iter().enumerate() {
        let aware = flights(Tracking::Aware, st, ss, 42 + j as u64);
        let expo = flights(Tracking::Exponential, st, ss, 4242 + j as u64);
        let f6 = |t: f64| eq6(st, ss, SURFACE, t);
        let fe = |t: f64| 1.0 - (-st * t).exp();
        let (k6, ke) = (ks(&aware, f6), ks(&expo, fe));
        let id = ideal(st, ss, SURFACE, n);
        let id_err = id.iter().zip(&ts).map(|(v, &t)| (v - f6(t)).abs());
        let below = |t: f64| aware.partition_point(|&x| x < t) as f64 / FLIGHTS as f64;
        rows.push(json!({"sigma_t": st, "sigma_s": ss, "samples": FLIGHTS,
            "ks_aware_vs_eq6": r4(k6), "ks_exponential_vs_formula": r4(ke),
            "ks_95pct_critical": r4(crit), "collision_prob_eq6": r4(f6(SURFACE)),
            "collision_prob_library": r4(below(SURFACE)),
            "ideal_vs_eq6_max_diff": id_err.fold(0.0, f64::max)}));
        let cs = vec![
            curve("exponential 1 − e^(−σ̂t·t)", grid(&fe), colour(0)),
            curve("aware (eq. 6)", grid(&f6), colour(1)),
            curve("library aware samples", grid(&below), colour(2)).look(Look::Line(1)),
            curve("ideal ∝ σ̂s·e^(−σ̂t·t) + pass", with_jump(id), GREY).look(Look::Dashed),
        ];
        let t = format!("σ̂t = {st}, σ̂s = {ss}: KS(library, eq. 6) = {k6:.4}");
        println!("Mojzík Fig. 9: {t} (95 % bound {crit:.4})");
        panels.push((t, cs));
    }
    svg(dir, "mojzik-fig9-distance-cdf.svg", (1100, 800), |r| {
        let t = "Mojzík Fig. 9: distance CDFs P(t), surface at d = 10";
        let r = titled(r, t)?;
        let ax = ([0.0, 12.0, 0.0, 1.05], ["distance t", "P(t)"]);
        for (j, (area, (title, cs))) in r.split_evenly((2, 2)).iter().zip(&panels).enumerate() {
            let legend = (j == 0).then_some(SeriesLabelPosition::LowerRight);
            lines(area, title, ax, cs, legend)?;
        }
        Ok(())
    })?;
    Ok(Value::Array(rows))
}

// ---------------------------------------------------------------- Jung

/// Jung Fig. 4.8 (whole table) and Fig. 4.9 (700–780 nm): the library's CIE 1931 2° table.
fn jung_cmf(dir: &Path, name: &str, d: Domain, fig: &str) -> R<()> {
    let cs = [
        curve("x̄", sampled(|l| cmf(l).x as f64, d, 1.0), colour(0)),
        curve("ȳ", sampled(|l| cmf(l).y as f64, d, 1.0), colour(2)),
        curve("z̄", sampled(|l| cmf(l).z as f64, d, 1.0), colour(1)),
    ];
    let (a, b) = (d.min, d.max);
    let t = format!("{fig}: CIE 1931 colour-matching functions ({a}–{b} nm)");
    plot(dir, name, &t, wl(d, top_of(&cs), "value"), &cs)
}

/// The material of the shape named `shape`.
fn material<'s>(scene: &'s Scene, shape: &str) -> R<&'s Material> {
    let s = scene.shapes.iter().find(|s| s.name == shape);
    let m = s.and_then(|s| scene.material(s.material));
    m.ok_or_else(|| {
        format!(
            "{}: no shape '{shape}' with a material",
            scene.file.display()
        )
    })
}

/// The fluorescent-diffuse material of the shape named `shape`.
fn fluorescent<'s>(scene: &'s Scene, shape: &str) -> R<&'s FluorescentDiffuse> {
    match material(scene, shape)? {
        Material::Fluorescent(f) => Ok(f),
        _ => Err(format!(
            "{}: '{shape}' is not fluorescent",
            scene.file.display()
        )),
    }
}

/// The scene's first light's emitted spectrum (scale included).
fn light(scene: &Scene) -> R<&Spectrum> {
    let l = scene.lights.first().map(|l| &l.spectrum);
    l.ok_or_else(|| format!("{}: no light", scene.file.display()))
}

/// The factor that scales a spectrum to peak 1 on `d`.
fn to_peak(s: &Spectrum, d: Domain) -> f64 {
    1.0 / s.max_value(d).max(1e-30) as f64
}

/// Jung Fig. 7.2: absorption and emission of the fluorescent walls, the light's emission and
/// the back wall's reflectance, as loaded from scenes/fluorescent-walls.json.
fn jung_fig7_2(dir: &Path, scene: &Scene) -> R<()> {
    let d = scene.domain;
    let (mut top, mut bottom) = (Vec::new(), Vec::new());
    let walls = ["floor", "left", "ceiling", "right"];
    for (j, wall) in walls.into_iter().enumerate() {
        let f = fluorescent(scene, wall)?;
        let (a, e) = (sp(&f.a, 1.0, d), sp(&f.e, 1.0, d));
        top.push(curve(format!("{wall}: absorption a"), a, colour(j)));
        bottom.push(curve(format!("{wall}: emission e"), e, colour(j)));
    }
    let (e, k) = (light(scene)?, to_peak(light(scene)?, d));
    top.push(curve(format!("light emission ×{k:.3}"), sp(e, k, d), BLACK).look(Look::Dashed));
    let back = material(scene, "back")?;
    let r = sampled(|l| back.diagonal(l) as f64, d, 1.0);
    top.push(curve("back wall reflectance", r, GREY).look(Look::Dashed));
    svg(dir, "jung-fig7-2-walls-spectra.svg", (1000, 760), |r| {
        let t = "Jung Fig. 7.2: spectra of scenes/fluorescent-walls.json";
        let (a, b) = titled(r, t)?.split_vertically(370);
        let t = "absorption (peak 1), light emission (scaled to peak 1), back wall reflectance";
        lines(&a, t, wl(d, 1.45, "value"), &top, UR)?;
        let ax = wl(d, top_of(&bottom), "emission (1/nm)");
        lines(&b, "emission of the walls (unit area)", ax, &bottom, UR)
    })
}

/// Jung Fig. 7.9a/c: the green-spheres fluorescent material (r, a, e) and the light's spectrum.
fn jung_fig7_9(dir: &Path, scene: &Scene, f: &FluorescentDiffuse) -> R<()> {
    let (d, light) = (scene.domain, light(scene)?);
    let (k, kl) = (to_peak(&f.e, d), to_peak(light, d));
    let (r, e) = (sp(&f.r, 1.0, d), sp(&f.e, k, d));
    let cs = [
        curve("reflectance r (ColorChecker 11)", r, colour(2)),
        curve("absorption a", sp(&f.a, 1.0, d), colour(1)),
        curve(format!("emission e ×{k:.1} (1/nm)"), e, colour(0)),
        curve(format!("light (D65) ×{kl:.3}"), sp(light, kl, d), BLACK).look(Look::Dashed),
    ];
    let t = "Jung Fig. 7.9a/c: fluorescent material and light of scenes/green-spheres.json";
    plot(dir, "jung-fig7-9-spectra.svg", t, wl(d, 1.2, "value"), &cs)
}

/// Exitant radiance at λo of a BBRRDF lit by `light`: diagonal·E(λo) + ∫ ρ(λi → λo)·E(λi) dλi
/// (midpoint rule, 0.5 nm).
fn exitant(m: &impl Bbrrdf, light: &Spectrum, d: Domain, lo: f32) -> f64 {
    let n = (d.width() * 2.0).round() as usize;
    let li = |k: usize| d.min + (k as f32 + 0.5) * d.width() / n as f32;
    let term = |k: usize| (m.kernel(li(k), lo) * light.eval(li(k))) as f64;
    let shifted: f64 = (0..n).map(term).sum();
    m.diagonal(lo) as f64 * light.eval(lo) as f64 + shifted * d.width() as f64 / n as f64
}

/// Jung Fig. 7.11b: exitant/incident ratio of the fluorescent BBRRDF under a constant light,
/// through the library's kernel, checked against (1 − c·a)·r + Φ·c·e·∫a.
fn jung_fig7_11b(dir: &Path, f: &FluorescentDiffuse, d: Domain) -> R<Value> {
    let ratio = sampled(|l| exitant(f, &Spectrum::Constant(1.0), d, l), d, 0.5);
    let int_a = f.a.integral(d.min, d.max);
    let (c, phi) = (f.c as f64, f.phi as f64);
    let closed = |l: f32| {
        let (r, a, e) = (f.r.eval(l) as f64, f.a.eval(l) as f64, f.e.eval(l) as f64);
        (1.0 - c * a) * r + phi * c * e * int_a
    };
    let err = ratio.iter().map(|&(l, v)| (v - closed(l as f32)).abs());
    let err = err.fold(0.0, f64::max);
    let (lmax, vmax) = argmax(&ratio);
    let mut above: Vec<[f64; 2]> = Vec::new();
    for w in ratio.windows(2).filter(|w| w[1].1 > 1.0) {
        match above.last_mut() {
            Some(r) if r[1] == w[0].0 => r[1] = w[1].0,
            _ => above.push([w[1].0, w[1].0]),
        }
    }
    let one = vec![(d.min as f64, 1.0), (d.max as f64, 1.0)];
    let cs = [
        curve("exitant / incident, fluorescent", ratio, colour(0)),
        curve("plain reflectance r", sp(&f.r, 1.0, d), colour(2)),
        curve("", one, BLACK).look(Look::Dashed),
    ];
    let t = format!("max {vmax:.3} at {lmax} nm, above 1 on {above:?} nm");
    println!("Jung Fig. 7.11b: exitant/incident {t}");
    let t = format!("Jung Fig. 7.11b: reflectivity under constant light ({t})");
    let ax = wl(d, top_of(&cs), "exitant / incident");
    plot(dir, "jung-fig7-11b-reflectivity.svg", &t, ax, &cs)?;
    let v = json!({"max_ratio": r4(vmax), "at_nm": lmax, "ranges_above_1_nm": above,
        "integral_a_nm": r4(int_a), "kernel_vs_closed_form_max_diff": err,
        "thesis": "around 570 nm for measured fluorescein; ours is designed Gaussians"});
    Ok(v)
}

/// (x, y) chromaticity of XYZ.
fn xy(c: glam::Vec3) -> (f64, f64) {
    let s = (c.x + c.y + c.z) as f64;
    (c.x as f64 / s, c.y as f64 / s)
}

/// Jung Fig. 7.11a: chromaticities of the light leaving the fluorescent and the plain sphere
/// under the scene's light (computed spectrally, through the BBRRDFs) in the CIE xy diagram.
fn jung_fig7_11a(dir: &Path, scene: &Scene) -> R<Value> {
    let (d, e, obs) = (scene.domain, light(scene)?, &scene.observer);
    let range = format!("spectral locus {}–{} nm", obs.range.min, obs.range.max);
    let mut locus: Pts = sampled(|_| 0.0, obs.range, 1.0);
    locus.iter_mut().for_each(|p| *p = xy(cmf(p.0 as f32)));
    locus.push(locus[0]);
    let srgb = vec![(0.64, 0.33), (0.30, 0.60), (0.15, 0.06), (0.64, 0.33)];
    let locus = curve(range, locus, BLACK).look(Look::Line(1));
    let mut cs = vec![locus, curve("sRGB gamut", srgb, GREY)];
    let mut out = serde_json::Map::new();
    let names = ["fluorescent_sphere", "plain_sphere", "light"];
    for (j, name) in names.into_iter().enumerate() {
        let xyz = if name == "light" {
            obs.spectrum_to_xyz(e)
        } else {
            let m = material(scene, name)?;
            obs.function_to_xyz(|l| exitant(m, e, d, l))
        };
        let (rgb, p) = (xyz_to_linear_srgb(xyz / xyz.y), xy(xyz));
        let neg = rgb.min_element() < 0.0;
        let rgb = rgb.to_array().map(|c| r4(c as f64));
        let v = json!({"xy": [r4(p.0), r4(p.1)], "linear_srgb_y1": rgb, "negative_channel": neg});
        println!("Jung Fig. 7.11a: {name}: linear sRGB (Y = 1) {rgb:?}, negative: {neg}");
        out.insert(name.into(), v);
        let dot = curve(name.replace('_', " "), vec![p], colour([2, 4, 7][j]));
        cs.push(dot.look(Look::Dots));
    }
    let t = "Jung Fig. 7.11a: chromaticity of the green spheres under the scene's light";
    let ax = ([0.0, 0.8, 0.0, 0.9], ["x", "y"]);
    let draw = |r: &Area| lines(r, t, ax, &cs, UR);
    svg(dir, "jung-fig7-11a-chromaticity.svg", (720, 720), draw)?;
    Ok(Value::Object(out))
}

/// Jung Fig. 5.1: a strongly fluorescent and a paper-like measured matrix as heat maps
/// (Hullin's red paint and paper are not available).
fn jung_fig5_1(dir: &Path, fl: &Measured, paper: &Measured) -> R<Value> {
    let name = |s: &Measured, what: &str| format!("{what}: {} ({})", s.stem, s.title);
    svg(dir, "jung-fig5-1-matrices.svg", (1400, 600), |r| {
        let t = "Jung Fig. 5.1: reradiation matrices (log colour scale, < 0.006 not drawn)";
        let (a, b) = titled(r, t)?.split_horizontally(700);
        heatmap(&a, &name(fl, "fluorescent"), &fl.m)?;
        heatmap(&b, &name(paper, "paper"), &paper.m)
    })?;
    let (p, t, m) = (&paper.stem, &paper.title, r4(paper.mass));
    println!("Jung Fig. 5.1: {} and {p} ({t})", fl.stem);
    let why = "the RIT file titled white ... paper with the largest sum of off-diagonal entries";
    let v = json!({"fluorescent": fl.stem, "paper": p, "paper_title": t, "paper_why": why,
        "paper_offdiagonal_sum": m});
    Ok(v)
}

// ---------------------------------------------------------------- Jung Fig. 7.3

/// The luminance along one line through each wall of a walls render (Jung Fig. 7.3): a column
/// through the middle of the left and right walls, a row through the ceiling and the floor, and
/// the floor's row reversed (dashed; the thesis's symmetry check). Pixels are assigned to walls
/// by a primary ray through their centres, and the two at each end of a line (which mix the wall
/// with its neighbour) are left out. Returns each wall's halves' means.
fn jung_fig7_3(dir: &Path, scene: &Scene, exr: &Path) -> R<Value> {
    let (w, h, rgb) = stokes::film::output::read_exr(exr)?;
    // a render at another size (`reproduce.sh --quick` renders 64×48): the scene at that size
    let resized;
    let scene = if (w, h) == (scene.camera.width, scene.camera.height) {
        scene
    } else {
        let sets = [
            ("camera.width".to_string(), json!(w)),
            ("camera.height".to_string(), json!(h)),
        ];
        let text = input::read_text(&scene.file, input::SCENE)?;
        let text = stokes::experiment::overrides::apply(
            &text,
            &scene.file,
            &sets,
            stokes::experiment::overrides::Missing::Insert,
        )?;
        resized = Scene::from_str(&scene.file, &text).map_err(|e| e.to_string())?;
        &resized
    };
    let shape_at = |x: u32, y: u32| {
        let ray = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
        let hit = scene.first_visible(&ray)?;
        let p = scene.prims[hit.prim as usize];
        Some(scene.shapes[p.shape as usize].name.as_str())
    };
    let ids: Vec<Option<&str>> = (0..w * h).map(|i| shape_at(i % w, i / w)).collect();
    let lum = |i: u32| {
        let c = rgb[i as usize];
        0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
    };
    let mut panels = Vec::new();
    let mut summary = serde_json::Map::new();
    for (wall, vertical) in [
        ("left", true),
        ("right", true),
        ("ceiling", false),
        ("floor", false),
    ] {
        let pix: Vec<u32> = (0..w * h)
            .filter(|&i| ids[i as usize] == Some(wall))
            .collect();
        if pix.is_empty() {
            return Err(format!(
                "no pixel of '{}' sees the shape '{wall}'",
                exr.display()
            ));
        }
        // the line through the wall's centre of mass
        let (cx, cy) = pix.iter().fold((0.0, 0.0), |(a, b), &i| {
            (a + (i % w) as f64, b + (i / w) as f64)
        });
        let (cx, cy) = (
            (cx / pix.len() as f64) as u32,
            (cy / pix.len() as f64) as u32,
        );
        let line: Pts = if vertical {
            (0..h)
                .filter(|&y| ids[(y * w + cx) as usize] == Some(wall))
                .map(|y| (y as f64, lum(y * w + cx)))
                .collect()
        } else {
            (0..w)
                .filter(|&x| ids[(cy * w + x) as usize] == Some(wall))
                .map(|x| (x as f64, lum(cy * w + x)))
                .collect()
        };
        // the two pixels at each end mix the wall with its neighbour (box filter)
        let line: Pts = if line.len() > 4 {
            line[2..line.len() - 2].to_vec()
        } else {
            line
        };
        let half = line.len() / 2;
        let mean = |p: &[(f64, f64)]| p.iter().map(|q| q.1).sum::<f64>() / p.len().max(1) as f64;
        let (first, second) = (mean(&line[..half]), mean(&line[line.len() - half..]));
        let (a, b) = if vertical {
            ("top_half", "bottom_half")
        } else {
            ("left_half", "right_half")
        };
        let sig = |x: f64| format!("{x:.4e}").parse::<f64>().unwrap_or(x);
        let mut v = json!({ a: sig(first), b: sig(second), "line": if vertical { format!("column {cx}") } else { format!("row {cy}") } });
        if wall == "floor" {
            let n = line.len();
            let asym = (0..n)
                .map(|i| (line[i].1 - line[n - 1 - i].1).abs())
                .sum::<f64>()
                / (n as f64 * mean(&line));
            v["mean_abs_difference_to_reversed_over_mean"] = json!(r4(asym));
        }
        summary.insert(wall.to_string(), v);
        panels.push((wall, vertical, line, if vertical { cx } else { cy }));
    }
    svg(dir, "jung-fig7-3-scanlines.svg", (1000, 760), |root| {
        let root = titled(
            root,
            "Jung Fig. 7.3: luminance along one line through each wall (linear Y)",
        )?;
        for (area, (wall, vertical, line, at)) in root.split_evenly((2, 2)).iter().zip(&panels) {
            let x1 = if *vertical { h } else { w } as f64;
            let y1 = line.iter().map(|p| p.1).fold(0.0, f64::max) * 1.1;
            let xd = if *vertical {
                "image row (top = 0)"
            } else {
                "image column"
            };
            let title = format!(
                "{wall} wall, {} {at}",
                if *vertical { "column" } else { "row" }
            );
            let mut cs = vec![curve(String::new(), line.clone(), colour(1))];
            if *wall == "floor" {
                let n = line.len();
                let rev: Pts = (0..n).map(|i| (line[i].0, line[n - 1 - i].1)).collect();
                cs[0].0 = "row".into();
                cs.push(curve("row reversed", rev, RGBColor(0, 170, 200)).look(Look::Dashed));
            }
            let legend = if *wall == "floor" { UR } else { None };
            lines(
                area,
                &title,
                ([0.0, x1, 0.0, y1.max(1e-9)], [xd, "luminance Y"]),
                &cs,
                legend,
            )?;
        }
        Ok(())
    })?;
    Ok(Value::Object(summary))
}
