//! Command implementations behind `main.rs`, kept in the library so tests can call them. Errors
//! are the library's [`Error`]; `main.rs` turns its kind into the exit code.

use crate::Error;
use crate::film::{write_exr, write_png};
use crate::integrator::{
    IntegratorKind, IntegratorOptions, LaneWeighting, LightWavelengths, MisHeuristic,
    RenderSettings,
};
use crate::io::output::{canonical_output, check_output};
use crate::io::text::show_path;
use crate::material::WavelengthSampling;
use crate::medium::Tracking;
use crate::scene::Scene;
use crate::spectrum::cie::CameraWavelengths;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene JSON file.
    pub scene: PathBuf,
    #[arg(long, value_enum, default_value = "pt-mono")]
    pub integrator: IntegratorKind,
    /// Samples per pixel.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Render only samples FROM..TO (TO excluded) of the seed's sample sequence, instead of
    /// --spp. The EXR then carries the film's exact sums, so such shards merge with
    /// `stokes merge` into the image of the whole range.
    #[arg(long, value_name = "FROM..TO", value_parser = parse_samples, conflicts_with_all = ["spp", "time_limit"])]
    pub samples: Option<(u32, u32)>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Stop after the pass during which this many seconds have passed.
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Maximum number of path segments.
    #[arg(long, default_value_t = 8)]
    pub max_depth: u32,
    /// Output OpenEXR (linear sRGB, f32).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write an sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Write render statistics as JSON.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Camera wavelength sampling.
    #[arg(long, value_enum, default_value = "uniform")]
    pub camera_wavelengths: CameraWavelengths,
    /// New-wavelength sampling at fluorescent vertices (Jung 7.1.2).
    #[arg(long, value_enum, default_value = "importance")]
    pub wavelength_sampling: WavelengthSampling,
    /// Hero wavelength lanes (pt-hero).
    #[arg(long, default_value_t = 4)]
    pub lanes: u32,
    /// First wavelength of light sub-paths (BDPT).
    #[arg(long, value_enum, default_value = "emission")]
    pub light_wavelengths: LightWavelengths,
    /// MIS heuristic.
    #[arg(long, value_enum, default_value = "balance")]
    pub mis: MisHeuristic,
    /// Bin width in nm (bdpt-allbins).
    #[arg(long, default_value_t = 5.0)]
    pub bin_width: f32,
    /// Distance tracking in participating media (Mojzík §5): fluorescence-aware (eq. 6), the
    /// max(σ̂t, σ̂s) hot-fix, or classic exponential sampling by σ̂t.
    #[arg(long, value_enum, default_value = "aware")]
    pub tracking: Tracking,
    /// pt-hero in media: weight the lanes by the balance heuristic over every lane's distance
    /// pdfs, or by the hero's distance decisions alone (Mojzík's HWSS, §6.2).
    #[arg(long, value_enum, default_value = "balance")]
    pub lane_weighting: LaneWeighting,
    /// Russian roulette from this many segments on (uni-directional tracers); off by default.
    #[arg(long)]
    pub rr_depth: Option<u32>,
    /// Also write a spectral image of N wavelength bins over the camera's range (OpenEXR in the
    /// layout of Fichet et al. 2021: channels `S0.<λ>nm`, each a bin's mean spectral radiance).
    #[arg(long, value_name = "N")]
    pub spectral: Option<usize>,
    /// Where `--spectral` writes (default: the output's name with `.spectral.exr`).
    #[arg(long, value_name = "PATH", requires = "spectral")]
    pub spectral_output: Option<PathBuf>,
    /// Write each BDPT strategy's weighted contribution as its own EXR into this folder
    /// (`s<i>_t<j>.exr`), and the images of one path length (`vertices<k>.exr`: the strategies
    /// of k vertices summed; Jung Fig. 7.4).
    #[arg(long)]
    pub strategy_images: Option<PathBuf>,
    /// Set a field of the scene before it loads: a dot path and a JSON value, e.g.
    /// `--set media.dye.fluorescence.concentration=0` or `--set 'camera.sensor={"band":[300,380]}'`
    /// (repeatable; a missing last key is inserted). The EXR's scene hash is of the changed text.
    #[arg(long = "set", value_name = "PATH=JSON")]
    pub set: Vec<String>,
    /// Do not print scene warnings.
    #[arg(long)]
    pub quiet: bool,
}

/// The `--set PATH=JSON` arguments as (dot path, value), or an input error naming the argument.
pub fn parse_sets(sets: &[String]) -> Result<Vec<(String, serde_json::Value)>, Error> {
    sets.iter()
        .map(|a| {
            let (k, v) = a.split_once('=').ok_or_else(|| {
                Error::input(format!(
                    "--set '{a}': expected PATH=JSON, e.g. media.dye.fluorescence.concentration=0"
                ))
            })?;
            if k.is_empty() || k.split('.').any(str::is_empty) {
                return Err(Error::input(format!(
                    "--set '{a}': '{k}' is not a dot path of object keys"
                )));
            }
            let v: serde_json::Value = serde_json::from_str(v)
                .map_err(|e| Error::input(format!("--set '{a}': the value is not JSON: {e}")))?;
            Ok((k.to_string(), v))
        })
        .collect()
}

fn parse_samples(s: &str) -> Result<(u32, u32), String> {
    crate::film::shard::parse_range(s)
}

impl RenderArgs {
    /// The samples to render: `--samples`, or `0..--spp`.
    pub fn sample_range(&self) -> (u32, u32) {
        self.samples.unwrap_or((0, self.spp))
    }

    pub fn options(&self) -> IntegratorOptions {
        IntegratorOptions {
            max_depth: self.max_depth,
            camera_wavelengths: self.camera_wavelengths,
            wavelength_sampling: self.wavelength_sampling,
            lanes: self.lanes,
            light_wavelengths: self.light_wavelengths,
            mis: self.mis,
            bin_width: self.bin_width,
            rr_depth: self.rr_depth,
            tracking: self.tracking,
            lane_weighting: self.lane_weighting,
            strategy_images: self.strategy_images.is_some(),
        }
    }
}

/// Load a scene and print its warnings.
pub fn load_scene(path: &Path, quiet: bool) -> Result<Scene, Error> {
    let scene = Scene::load(path)?;
    print_warnings(path, &scene, quiet);
    Ok(scene)
}

/// Print a scene's warnings (their text comes from the scene: control bytes are escaped).
fn print_warnings(path: &Path, scene: &Scene, quiet: bool) {
    if !quiet {
        for w in &scene.warnings {
            eprintln!(
                "warning: {}: {}",
                show_path(path),
                crate::io::text::escape_control(w, false)
            );
        }
    }
}

use crate::experiment::config::{MAX_SECONDS, MAX_SPP, MAX_THREADS};
/// Largest `--exposure` magnitude, stops.
pub const MAX_EXPOSURE: f32 = 64.0;

/// Where `render` writes: the checked output paths (a link resolved to its target).
#[derive(Clone, Debug)]
pub struct RenderOutputs {
    pub exr: PathBuf,
    pub spectral: Option<PathBuf>,
    pub png: Option<PathBuf>,
    pub stats: Option<PathBuf>,
}

pub fn render_cmd_validate(a: &RenderArgs) -> Result<RenderOutputs, Error> {
    if a.spp == 0 || a.spp > MAX_SPP {
        return Err(Error::input(format!(
            "--spp must be 1–{MAX_SPP}, got {}",
            a.spp
        )));
    }
    if let Some((from, to)) = a.samples
        && to - from > MAX_SPP
    {
        return Err(Error::input(format!(
            "--samples {from}..{to} holds {} samples, at most {MAX_SPP} in one render",
            to - from
        )));
    }
    if let Some(t) = a.time_limit
        && !(t > 0.0 && t <= MAX_SECONDS)
    {
        return Err(Error::input(format!(
            "--time-limit must be a positive, finite number of seconds (at most {MAX_SECONDS:e}), got {t}"
        )));
    }
    if let Some(n) = a.threads
        && !(1..=MAX_THREADS).contains(&n)
    {
        return Err(Error::input(format!(
            "--threads must be 1–{MAX_THREADS}, got {n}"
        )));
    }
    if let Some(n) = a.spectral {
        if !(1..=crate::film::spectral::MAX_BINS).contains(&n) {
            return Err(Error::input(format!(
                "--spectral must be 1–{} bins, got {n}",
                crate::film::spectral::MAX_BINS
            )));
        }
        if a.samples.is_some() {
            return Err(Error::input(
                "--spectral cannot be combined with --samples: spectral images of sample ranges \
                 cannot be merged (render the whole range)",
            ));
        }
        a.integrator
            .spectral_support()
            .map_err(|m| Error::input(format!("--spectral: {m}")))?;
    }
    if !(a.exposure.abs() <= MAX_EXPOSURE) {
        return Err(Error::input(format!(
            "--exposure must be a finite number of stops in [-{MAX_EXPOSURE}, {MAX_EXPOSURE}], got {}",
            a.exposure
        )));
    }
    a.options()
        .validate()
        .map_err(|m| Error::input(format!("option {m}")))?;
    parse_sets(&a.set)?;
    check_outputs(a)
}

/// The outputs of `render`, checked before the scene is loaded: `-o` ends in `.exr` and
/// `--png` in `.png` (the format follows the option, so the name must say it), no two outputs
/// are the same file (after resolving `.`, `..` and links), and each one is a regular file or
/// new, with a legal name in a folder that exists and takes a new file
/// ([`crate::io::output::check_output`]). `--strategy-images` is a folder, created if missing,
/// in which no strategy image's name is taken by anything but a regular file.
fn check_outputs(a: &RenderArgs) -> Result<RenderOutputs, Error> {
    if !crate::film::output::has_extension(&a.output, "exr") {
        return Err(Error::input(format!(
            "-o/--output '{}': the image is written as OpenEXR, so its name must end in .exr (use --png for a PNG preview)",
            a.output.display()
        )));
    }
    if let Some(p) = &a.png
        && !crate::film::output::has_extension(p, "png")
    {
        return Err(Error::input(format!(
            "--png '{}': the name of the PNG preview must end in .png",
            p.display()
        )));
    }
    if let Some(p) = &a.spectral_output
        && !crate::film::output::has_extension(p, "exr")
    {
        return Err(Error::input(format!(
            "--spectral-output '{}': the spectral image is written as OpenEXR, so its name must end in .exr",
            p.display()
        )));
    }
    let spectral = a.spectral.map(|_| {
        a.spectral_output
            .clone()
            .unwrap_or_else(|| a.output.with_extension("spectral.exr"))
    });
    let mut outs: Vec<(&str, &Path)> = vec![("-o/--output", &a.output)];
    outs.extend(spectral.as_deref().map(|p| ("--spectral-output", p)));
    outs.extend(a.png.as_deref().map(|p| ("--png", p)));
    outs.extend(a.stats.as_deref().map(|p| ("--stats", p)));
    let mut seen: Vec<(&str, PathBuf)> = Vec::new();
    let mut resolved = Vec::new();
    for (opt, p) in outs {
        let target = check_output(p).map_err(|e| output_error(opt, p, e))?;
        let c = canonical_output(&target);
        if let Some((other, _)) = seen.iter().find(|(_, q)| *q == c) {
            return Err(Error::input(format!(
                "{opt} '{}' is the same file as {other}: give each output its own path",
                show_path(p)
            )));
        }
        seen.push((opt, c));
        resolved.push(target);
    }
    let mut resolved = resolved.into_iter();
    let outputs = RenderOutputs {
        exr: resolved.next().expect("-o is always given"),
        spectral: spectral.as_ref().and_then(|_| resolved.next()),
        png: a.png.as_ref().and_then(|_| resolved.next()),
        stats: a.stats.as_ref().and_then(|_| resolved.next()),
    };
    if let Some(dir) = &a.strategy_images {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create the folder: {e}"))
            .and_then(|()| crate::io::output::check_folder(dir))
            .and_then(|()| strategy_names_free(dir))
            .map_err(|e| Error::input(format!("--strategy-images '{}': {e}", show_path(dir))))?;
        let d = canonical_output(&dir.join("x"));
        if let Some((opt, _)) = seen
            .iter()
            .find(|(_, q)| q.parent() == d.parent() && is_strategy_name(q))
        {
            return Err(Error::input(format!(
                "--strategy-images '{}': {opt} has the name of a strategy image (s<i>_t<j>.exr or vertices<k>.exr) in this folder and would be replaced",
                dir.display()
            )));
        }
    }
    Ok(outputs)
}

/// An error when an entry of `dir` with a strategy image's name is not a regular file (a
/// device, FIFO, folder or link that the image would replace).
fn strategy_names_free(dir: &Path) -> Result<(), String> {
    let rd = std::fs::read_dir(dir).map_err(|e| format!("cannot list the folder: {e}"))?;
    for e in rd.flatten() {
        if is_strategy_name(&e.path()) {
            crate::io::output::refuse_non_regular(&e.path())?;
        }
    }
    Ok(())
}

/// The input error of the output option `opt` given `p`, from the message `e` of its check (which
/// names the path itself when it is about the path, so it is not named twice).
fn output_error(opt: &str, p: &Path, e: String) -> Error {
    if e.starts_with(&format!("'{}'", show_path(p))) {
        Error::input(format!("{opt} {e}"))
    } else {
        Error::input(format!("{opt} '{}': {e}", show_path(p)))
    }
}

/// Whether `p`'s file name is that of a strategy image, `s<i>_t<j>.exr`, or of an image of one
/// path length, `vertices<k>.exr`.
fn is_strategy_name(p: &Path) -> bool {
    let Some(n) = p.file_name().and_then(|n| n.to_str()) else {
        return false;
    };
    let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    let Some(n) = n.strip_suffix(".exr") else {
        return false;
    };
    n.strip_prefix("vertices").is_some_and(digits) || strategy_of(n).is_some()
}

/// (s, t) of a strategy image's name `s<s>_t<t>` (digits only).
fn strategy_of(name: &str) -> Option<(usize, usize)> {
    let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    let (a, b) = name.strip_prefix('s')?.split_once("_t")?;
    (digits(a) && digits(b)).then_some((a.parse().ok()?, b.parse().ok()?))
}

/// The strategy images `s<i>_t<j>` grouped by the number of path vertices i + j, in increasing
/// order: (vertices, indices of the layers).
fn layers_by_vertices(names: &[String]) -> Vec<(usize, Vec<usize>)> {
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, n) in names.iter().enumerate() {
        if let Some((s, t)) = strategy_of(n) {
            groups.entry(s + t).or_default().push(i);
        }
    }
    groups.into_iter().collect()
}

pub fn render(a: &RenderArgs) -> Result<(), Error> {
    let outputs = render_cmd_validate(a)?;
    // The scene's text is read once: what renders is what the EXR's scene hash describes.
    let text = crate::io::input::read_text(&a.scene, crate::io::input::SCENE)
        .map_err(|e| Error::input(format!("cannot read the scene: {e}")))?;
    let sets = parse_sets(&a.set)?;
    let text = if sets.is_empty() {
        text
    } else {
        use crate::experiment::overrides::{Missing, apply};
        apply(&text, &a.scene, &sets, Missing::Insert)
            .map_err(|e| Error::input(format!("--set: {e} in '{}'", show_path(&a.scene))))?
    };
    // the scene's BVH build runs its parallel parts on `--threads` workers too
    let scene = crate::integrator::with_threads(a.threads, || {
        Scene::from_str(&a.scene, &text)
            .map_err(Error::from)
            .inspect(|s| print_warnings(&a.scene, s, a.quiet))
    })
    .map_err(Error::runtime)??;
    let (from, to) = a.sample_range();
    let settings = RenderSettings {
        first_sample: from,
        spp: to - from,
        seed: a.seed,
        threads: a.threads,
        time_limit: a.time_limit,
        progress: true,
        spectral: a.spectral,
    };
    let opts = a.options();
    let out = crate::integrator::render(&scene, a.integrator, &opts, &settings, None)
        .map_err(Error::input)?;
    let (w, h) = (out.film.width, out.film.height);
    let rgb = out.film.rgb();
    let info = crate::integrator::shard_info(
        &a.scene,
        &text,
        a.integrator,
        &opts,
        a.seed,
        (from, from + out.film.spp),
    );
    crate::film::shard::write_film(&outputs.exr, &out.film, &info, a.samples.is_some())
        .map_err(Error::runtime)?;
    if let (Some(p), Some(sf)) = (&outputs.spectral, &out.film.spectral) {
        let mut extra = crate::film::shard::attributes(&info);
        extra.push(("stokes.sensor".to_string(), sensor_label(&scene)));
        let values = sf.values(out.film.spp);
        crate::film::spectral::write_spectral_exr(p, (w, h), &sf.bins, &values, &rgb, &extra)
            .map_err(Error::runtime)?;
    }
    if let Some(p) = &outputs.png {
        write_png(p, w, h, &rgb, a.exposure).map_err(Error::runtime)?;
    }
    if let Some(dir) = &a.strategy_images {
        for (i, name) in out.film.aux_names.iter().enumerate() {
            write_exr(&dir.join(format!("{name}.exr")), w, h, &out.film.aux_rgb(i))
                .map_err(Error::runtime)?;
        }
        // images of one path length (Jung Fig. 7.4): the strategies of k vertices summed
        for (k, layers) in layers_by_vertices(&out.film.aux_names) {
            let mut img = vec![glam::Vec3::ZERO; (w * h) as usize];
            for i in layers {
                for (p, v) in img.iter_mut().zip(out.film.aux_rgb(i)) {
                    *p += v;
                }
            }
            write_exr(&dir.join(format!("vertices{k}.exr")), w, h, &img).map_err(Error::runtime)?;
        }
    }
    if let Some(p) = &outputs.stats {
        let json = stats_json(a.integrator, &opts, &out);
        let text = serde_json::to_string_pretty(&json).unwrap();
        crate::io::output::write_bytes(p, text.as_bytes()).map_err(Error::runtime)?;
    }
    eprintln!(
        "{}: {} spp in {:.2} s ({:.3} M samples/s), {} NaN/Inf rejected",
        a.integrator.name(),
        out.film.spp,
        out.seconds,
        out.stats.paths as f64 / out.seconds.max(1e-9) / 1e6,
        out.stats.nan_inf_rejected
    );
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct DiffArgs {
    /// The first image (OpenEXR, linear sRGB).
    pub a: PathBuf,
    /// The second image, of the same size.
    pub b: PathBuf,
    /// The figure: a PNG (and an SVG beside it) with both images and Y(a) − Y(b).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The figure's title (default: the two file names).
    #[arg(long)]
    pub title: Option<String>,
}

/// `stokes diff`: the signed luminance difference of two EXRs as a figure (red/green diverging,
/// symmetric scale at the 99th percentile of |difference|; Mojzík 2018 Fig. 11d/f).
pub fn diff(a: &DiffArgs) -> Result<(), Error> {
    use crate::film::output::{has_extension, read_exr};
    if !has_extension(&a.output, "png") {
        return Err(Error::input(format!(
            "-o/--output '{}': the figure is a PNG, so its name must end in .png",
            show_path(&a.output)
        )));
    }
    let target = check_output(&a.output).map_err(|e| output_error("-o/--output", &a.output, e))?;
    let (wa, ha, ia) = read_exr(&a.a).map_err(Error::input)?;
    let (wb, hb, ib) = read_exr(&a.b).map_err(Error::input)?;
    if (wa, ha) != (wb, hb) {
        return Err(Error::input(format!(
            "'{}' is {wa}×{ha} and '{}' is {wb}×{hb}: a difference needs images of one size",
            show_path(&a.a),
            show_path(&a.b)
        )));
    }
    let name = |p: &Path| {
        p.file_stem()
            .map_or_else(|| show_path(p), |s| s.to_string_lossy().into_owned())
    };
    let (na, nb) = (name(&a.a), name(&a.b));
    let title = a.title.clone().unwrap_or_else(|| format!("{na} − {nb}"));
    let dir = target.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or(Path::new("."));
    let stem = target
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (_, m) = crate::experiment::figures::difference_of_images(
        (&na, &ia),
        (&nb, &ib),
        (wa, ha),
        &title,
        (dir, &stem),
    )?;
    use crate::experiment::figures::luminance;
    let y = |img: &[glam::Vec3]| {
        img.iter().map(|c| luminance(*c)).sum::<f64>() / img.len().max(1) as f64
    };
    println!(
        "mean Y: {na} {:.6}, {nb} {:.6}, difference {:+.6}; scale ±{m:.4} (99th percentile of |ΔY|)",
        y(&ia),
        y(&ib),
        y(&ia) - y(&ib)
    );
    // SNR of a against b as the experiments measure it, and of its luminance alone (spatial
    // noise without colour noise)
    let rgb = crate::experiment::metrics::compare(&ia, &ib, None).snr_db;
    let (sig, noise) = ia.iter().zip(&ib).fold((0.0, 0.0), |(s, n), (p, q)| {
        let (lp, lq) = (luminance(*p), luminance(*q));
        (s + lq * lq, n + (lp - lq).powi(2))
    });
    let y_snr = crate::experiment::metrics::snr_db(sig, noise);
    println!("SNR of {na} against {nb}: {rgb:.2} dB (linear sRGB), {y_snr:.2} dB (luminance Y)");
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct PngArgs {
    /// The image (OpenEXR, linear sRGB).
    pub input: PathBuf,
    /// The 8-bit sRGB PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Exposure in stops; without it the 99th percentile of the brightest channel maps to white.
    #[arg(long)]
    pub exposure: Option<f32>,
}

/// `stokes png`: an sRGB PNG of an EXR (for example a strategy image or `vertices<k>.exr`).
pub fn png(a: &PngArgs) -> Result<(), Error> {
    use crate::film::output::{has_extension, read_exr};
    if !has_extension(&a.output, "png") {
        return Err(Error::input(format!(
            "-o/--output '{}': the name of the PNG must end in .png",
            show_path(&a.output)
        )));
    }
    if let Some(e) = a.exposure
        && !(e.abs() <= MAX_EXPOSURE)
    {
        return Err(Error::input(format!(
            "--exposure must be a finite number of stops in [-{MAX_EXPOSURE}, {MAX_EXPOSURE}], got {e}"
        )));
    }
    let target = check_output(&a.output).map_err(|e| output_error("-o/--output", &a.output, e))?;
    let (w, h, img) = read_exr(&a.input).map_err(Error::input)?;
    // the figures' exposure: the 99th percentile of the brightest channel to white
    let exposure = a
        .exposure
        .unwrap_or_else(|| crate::experiment::figures::exposure(&img).log2());
    write_png(&target, w, h, &img, exposure).map_err(Error::runtime)?;
    println!("{}: exposure {exposure:+.2} stops", show_path(&target));
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Shard EXRs written by `stokes render --samples FROM..TO` (or by an experiment's jobs).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// The merged EXR: a shard of the union of the ranges.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write an sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
}

/// `stokes merge`: add the exact sums of shards of one render (same scene, seed, integrator,
/// options and size; ranges neither overlapping nor leaving gaps) into one EXR.
pub fn merge(a: &MergeArgs) -> Result<(), Error> {
    use crate::film::output::has_extension;
    if !has_extension(&a.output, "exr") {
        return Err(Error::input(format!(
            "-o/--output '{}': the merged image is written as OpenEXR, so its name must end in .exr",
            a.output.display()
        )));
    }
    if let Some(p) = &a.png
        && !has_extension(p, "png")
    {
        return Err(Error::input(format!(
            "--png '{}': the name of the PNG preview must end in .png",
            p.display()
        )));
    }
    let mut outs = vec![("-o/--output", check_output(&a.output), &a.output)];
    if let Some(p) = &a.png {
        outs.push(("--png", check_output(p), p));
    }
    let mut targets: Vec<PathBuf> = Vec::new();
    for (opt, checked, given) in outs {
        let t = checked.map_err(|e| output_error(opt, given, e))?;
        let c = canonical_output(&t);
        if a.shards.iter().any(|s| canonical_output(s) == c) {
            return Err(Error::input(format!(
                "{opt} '{}' is also an input shard: it would be replaced; give the merge its own path",
                show_path(given)
            )));
        }
        if targets.iter().any(|q| canonical_output(q) == c) {
            return Err(Error::input(format!(
                "{opt} '{}' is the same file as -o/--output: give each output its own path",
                show_path(given)
            )));
        }
        targets.push(t);
    }
    let shards = a
        .shards
        .iter()
        .map(|p| crate::film::shard::read_shard(p).map_err(Error::input))
        .collect::<Result<Vec<_>, _>>()?;
    let n = shards.len();
    let merged = crate::film::shard::merge(shards).map_err(Error::input)?;
    merged.write(&targets[0]).map_err(Error::runtime)?;
    if let Some(p) = targets.get(1) {
        let f = merged.film();
        write_png(p, f.width, f.height, &f.rgb(), 0.0).map_err(Error::runtime)?;
    }
    eprintln!(
        "merged {n} shards: samples {}..{} ({} spp) of {} with {}, seed {} -> {}",
        merged.info.from,
        merged.info.to,
        merged.info.to - merged.info.from,
        crate::io::text::escape_control(&merged.info.scene, false),
        crate::io::text::escape_control(&merged.info.integrator, false),
        merged.info.seed,
        show_path(&a.output)
    );
    Ok(())
}

/// The `--stats` JSON document.
pub fn stats_json(
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    out: &crate::integrator::RenderOutput,
) -> serde_json::Value {
    let s = &out.stats;
    serde_json::json!({
        "integrator": kind.name(),
        "options": opts,
        "spp": out.film.spp,
        "width": out.film.width,
        "height": out.film.height,
        "seconds": out.seconds,
        "samples_per_second": s.paths as f64 / out.seconds.max(1e-9),
        "rays": s.rays,
        "rays_per_second": s.rays as f64 / out.seconds.max(1e-9),
        "nan_inf_rejected": s.nan_inf_rejected,
        "dropped_strategy_pdfs": s.dropped_strategy_pdfs,
        "paths": s.paths,
        "contributing_paths": s.contributing_paths,
        "contributing_paths_by_segments": s.contributing_by_length,
    })
}

pub fn inspect(path: &Path) -> Result<(), Error> {
    let s = load_scene(path, false)?;
    // Names come from the scene file: their control bytes are escaped, never sent to the
    // terminal.
    let esc = |n: &str| crate::io::text::escape_control(n, false);
    println!("scene: {}", show_path(path));
    println!(
        "domain: [{}, {}] nm, camera range [{}, {}] nm",
        s.domain.min, s.domain.max, s.observer.range.min, s.observer.range.max
    );
    println!(
        "camera: {}×{}, sensor {}",
        s.camera.width,
        s.camera.height,
        sensor_label(&s)
    );
    println!(
        "primitives: {} triangles, {} spheres",
        s.triangles.len(),
        s.spheres.len()
    );
    let (nodes, packets, _, bytes) = s.accel.layout();
    let quality = match s.accel.quality() {
        Some((crate::geometry::BuildQuality::Auto, q)) => format!("auto → {}", q.name()),
        Some((q, _)) => q.name().to_string(),
        None => "custom".to_string(),
    };
    println!(
        "acceleration: BVH8 of quality {quality}, built in {:.3} s: {nodes} nodes, {packets} leaf \
         packets, {:.2} MB{}",
        s.accel.build_seconds(),
        bytes as f64 / 1e6,
        if s.accel.is_flat() {
            "; traced as one flat loop over the triangles"
        } else {
            ""
        }
    );
    for (n, m) in s.material_names.iter().zip(&s.materials) {
        use crate::material::Bbrrdf;
        let kind = match m {
            crate::material::Material::Lambert(_) => "lambert".to_string(),
            #[cfg(feature = "fluorescence")]
            crate::material::Material::Fluorescent(_) => "fluorescent-diffuse".to_string(),
            #[cfg(feature = "fluorescence")]
            crate::material::Material::Reradiation(r) => {
                let (o, i) = r.shape();
                format!(
                    "reradiation, {o}×{i} matrix, {} bytes to render",
                    r.render_bytes()
                )
            }
            #[cfg(feature = "fluorescence")]
            crate::material::Material::ReradiationGmm(g) => format!(
                "reradiation-gmm, {} Gaussians, model {} bytes, {} bytes to render",
                g.components(),
                g.model_bytes(),
                g.render_bytes()
            ),
        };
        println!(
            "material {}: {kind}, {}",
            esc(n),
            if m.is_fluorescent() {
                "fluorescent"
            } else {
                "non-fluorescent"
            }
        );
    }
    for (n, m) in s.medium_names.iter().zip(&s.media) {
        use crate::medium::Density;
        let density = match &m.density {
            Density::Homogeneous => "homogeneous".to_string(),
            Density::Grid(g) => format!(
                "grid {}×{}×{}, density scale {}, max density {}",
                g.grid.res[0],
                g.grid.res[1],
                g.grid.res[2],
                g.scale,
                g.grid.max_density() * g.scale
            ),
        };
        let fl = if m.coefficients.is_fluorescent() {
            "fluorescent"
        } else {
            "non-fluorescent"
        };
        println!("medium {}: {density}, {fl}, phase g = {}", esc(n), m.g);
    }
    if s.camera_medium != crate::scene::NONE {
        println!(
            "camera in medium {}",
            esc(&s.medium_names[s.camera_medium as usize])
        );
    }
    for l in &s.lights {
        println!(
            "light {}: area {:.4}, power {:.4}{}",
            esc(&l.name),
            l.area,
            l.power,
            if l.two_sided { ", two-sided" } else { "" }
        );
    }
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct ExperimentArgs {
    /// Experiment config JSON.
    #[arg(required_unless_present = "collect")]
    pub config: Option<PathBuf>,
    /// Results root (default `results`, `results/quick` with --quick); the run goes to
    /// `<out>/<name>/runs/<timestamp>/`. With --plan or --slurm: the run folder itself, new or
    /// empty (default: a new `<root>/<name>/runs/<timestamp>/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Small resolution, few spp, one repeat: a smoke test.
    #[arg(long)]
    pub quick: bool,
    /// Do not render: write the run folder and its job list (`jobs.jsonl`), one independent
    /// render per line, for `stokes job` (docs/cluster.md).
    #[arg(long, conflicts_with = "slurm")]
    pub plan: bool,
    /// With --plan or --slurm: split the rendered reference's samples into this many shard
    /// jobs (default 8).
    #[arg(long, value_name = "K")]
    pub reference_shards: Option<u32>,
    /// Finish a planned run whose jobs have all run: merge, metrics, figures.
    #[arg(long, value_name = "RUN_DIR", conflicts_with_all = ["config", "plan", "slurm", "quick", "out", "reference_shards", "partition", "time", "cpus_per_task", "dry_run"])]
    pub collect: Option<PathBuf>,
    /// Plan the run and submit it to Slurm: an array of its jobs, then a collect job that
    /// depends on the array (afterok).
    #[arg(long)]
    pub slurm: bool,
    /// Slurm partition (default: the cluster's default).
    #[arg(long)]
    pub partition: Option<String>,
    /// Slurm time limit per job, e.g. 30, 1:00:00 or 1-00:00:00.
    #[arg(long)]
    pub time: Option<String>,
    /// CPUs per job (its worker threads); default: the config's `threads`, else 1.
    #[arg(long)]
    pub cpus_per_task: Option<u32>,
    /// Write and print the Slurm scripts without submitting them.
    #[arg(long)]
    pub dry_run: bool,
}

pub fn experiment(a: &ExperimentArgs) -> Result<(), Error> {
    use crate::experiment::cluster;
    if let Some(dir) = &a.collect {
        cluster::collect(dir)?;
        return Ok(());
    }
    let config = a.config.as_deref().expect("clap requires CONFIG");
    check_cluster_options(a)?;
    if !(a.plan || a.slurm) {
        crate::experiment::run_experiment(config, a.out.as_deref(), a.quick)?;
        return Ok(());
    }
    let opts = crate::experiment::cluster::slurm::SlurmOptions {
        partition: a.partition.clone(),
        time: a.time.clone(),
        cpus_per_task: a.cpus_per_task,
        dry_run: a.dry_run,
    };
    if a.slurm {
        crate::experiment::cluster::slurm::validate(&opts)?;
    }
    let (run_dir, plan, jobs) = cluster::write_plan(
        config,
        a.out.as_deref(),
        a.quick,
        a.reference_shards.unwrap_or(8),
    )?;
    let shards = jobs
        .iter()
        .filter(|j| matches!(j.work, cluster::plan::Work::ReferenceShard { .. }))
        .count();
    eprintln!(
        "planned {} jobs into {}: {shards} reference shards of {} spp, {} renders",
        jobs.len(),
        run_dir.display(),
        plan.shard_spp,
        jobs.len() - shards
    );
    if !a.slurm {
        eprintln!(
            "run each job with `stokes job {d} INDEX` (INDEX 0–{}; `--all` runs them one after the other), then `stokes experiment --collect {d}`",
            jobs.len() - 1,
            d = run_dir.display()
        );
        println!("{}", run_dir.display());
        return Ok(());
    }
    slurm_submit(&run_dir, &plan, jobs.len(), opts)
}

/// The options of planned and Slurm runs are refused where they would be ignored.
fn check_cluster_options(a: &ExperimentArgs) -> Result<(), Error> {
    let slurm_only = [
        ("--partition", a.partition.is_some()),
        ("--time", a.time.is_some()),
        ("--cpus-per-task", a.cpus_per_task.is_some()),
        ("--dry-run", a.dry_run),
    ];
    if !a.slurm
        && let Some((opt, _)) = slurm_only.iter().find(|(_, given)| *given)
    {
        return Err(Error::input(format!(
            "{opt} is an option of --slurm submissions; it does nothing {}",
            if a.plan {
                "with --plan (edit the run's scripts, or use --slurm)"
            } else {
                "without --slurm"
            }
        )));
    }
    if a.reference_shards.is_some() && !(a.plan || a.slurm) {
        return Err(Error::input(
            "--reference-shards splits the reference of a planned run: use it with --plan or --slurm",
        ));
    }
    Ok(())
}

/// Write the Slurm scripts of a planned run and submit them (or print them with `--dry-run`).
fn slurm_submit(
    run_dir: &Path,
    plan: &crate::experiment::cluster::plan::Plan,
    jobs: usize,
    mut opts: crate::experiment::cluster::slurm::SlurmOptions,
) -> Result<(), Error> {
    use crate::experiment::cluster::slurm;
    if opts.cpus_per_task.is_none() {
        let cfg = crate::experiment::Config::load(&plan.config_file)?;
        opts.cpus_per_task = Some(cfg.threads.unwrap_or(1).min(1024) as u32);
    }
    let exe = std::env::current_exe()
        .map_err(|e| Error::runtime(format!("cannot find the stokes binary: {e}")))?;
    let scripts = slurm::write_scripts(run_dir, jobs, &plan.name, &exe, &opts)?;
    // After the scripts are written: an oversized run is then submitted in parts with them.
    let fits = slurm::check_array_size(jobs, slurm::max_array_size());
    if opts.dry_run {
        if let Err(e) = fits {
            eprintln!("warning: {}", e.message);
        }
        for p in [&scripts.array, &scripts.collect] {
            let text =
                crate::io::input::read_text(p, crate::io::input::RUN_RECORD).unwrap_or_default();
            println!("# {}\n{text}", p.display());
        }
        eprintln!(
            "dry run: nothing submitted; submit with `bash {}`",
            scripts.submit.display()
        );
        return Ok(());
    }
    fits?;
    let (array, collect) = slurm::submit(&scripts)?;
    eprintln!(
        "submitted array job {array} ({jobs} tasks) and collect job {collect} (afterok:{array}); results: {}",
        run_dir.display()
    );
    println!("{array} {collect}");
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct JobArgs {
    /// Run folder planned with `stokes experiment CONFIG --plan` (or `--slurm`).
    pub run_dir: PathBuf,
    /// Job index (line of jobs.jsonl, from 0); default: SLURM_ARRAY_TASK_ID.
    #[arg(conflicts_with = "all")]
    pub index: Option<usize>,
    /// Run every job that has not finished, one after the other.
    #[arg(long)]
    pub all: bool,
}

/// `stokes job`: run one job of a planned run (skipped when it already finished), or all.
pub fn job(a: &JobArgs) -> Result<(), Error> {
    use crate::experiment::cluster;
    if a.all {
        return cluster::run_all(&a.run_dir);
    }
    cluster::run_job(&a.run_dir, cluster::job_index(a.index)?)
}

/// `stokes figures`: regenerate the figures of a stored run (only the plots with `plots_only`).
pub fn figures(dir: &Path, plots_only: bool) -> Result<(), Error> {
    // An interrupted run has no run.json yet: look for its marker first.
    crate::experiment::record::check_complete(dir)?;
    let run = crate::experiment::figures::resolve_run_dir(dir)?;
    crate::experiment::record::check_complete(&run)?;
    crate::io::tree::check_run_folder(&run).map_err(Error::input)?;
    let files = crate::experiment::figures::make(&run, !plots_only)?;
    for f in files {
        println!("{}", f.display());
    }
    Ok(())
}

/// `stokes report`: write `report.html` into a stored run folder and print its path.
pub fn report(dir: &Path) -> Result<(), Error> {
    let w = crate::experiment::report::write(dir)?;
    eprintln!(
        "report: {} images, {} figures, {:.1} MB",
        w.images,
        w.figures,
        w.bytes as f64 / 1e6
    );
    println!("{}", w.file.display());
    Ok(())
}

#[derive(Args, Debug, Clone)]
pub struct GmmFitArgs {
    /// A BFC file, or a folder of them.
    pub input: PathBuf,
    /// Gaussians per mixture (at most 32; `bayes` may use fewer).
    #[arg(long, default_value_t = 8)]
    pub components: usize,
    /// Weighted EM, or weighted variational Bayesian inference (Hua §5.2).
    #[arg(long, value_enum, default_value = "em")]
    pub method: crate::material::mixture::FitMethod,
    /// Seed of the k-means++ initialisation; fits are deterministic for a seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Iteration limit of a fit.
    #[arg(long, default_value_t = 1000)]
    pub max_iterations: usize,
    /// Convergence: stop when the mean log-likelihood changes by less than this.
    #[arg(long, default_value_t = 1e-7)]
    pub tolerance: f64,
    /// Output model file (one input file) or folder (a folder of inputs: `<STEM>.json` each).
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Args, Debug, Clone)]
pub struct GmmDenseArgs {
    /// A fitted model file (`stokes gmm fit`).
    pub model: PathBuf,
    /// Cell size of the matrix in nm; must divide the measured support (1, 2, 5, 10 for RIT).
    #[arg(long, default_value_t = 1.0)]
    pub step: f32,
    /// Output BFC file, for the `reradiation` material.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// An output file of a `gmm` command, checked before any work as `render` checks its own: the
/// name ends in `.ext` (`why` says why), it is a regular file or new, with a legal name in a
/// folder that takes a new file, and it is not the input file. Returns the path to write.
fn check_output_file(
    opt: &str,
    p: &Path,
    ext: &str,
    why: &str,
    input: &Path,
) -> Result<PathBuf, Error> {
    if !crate::film::output::has_extension(p, ext) {
        return Err(Error::input(format!("{opt} '{}': {why}", show_path(p))));
    }
    let target = check_output(p).map_err(|e| output_error(opt, p, e))?;
    let input = std::fs::canonicalize(input).unwrap_or_else(|_| canonical_output(input));
    if canonical_output(&target) == input {
        return Err(Error::input(format!(
            "{opt} '{}' is the input file '{}': give the output its own path",
            show_path(p),
            show_path(&input)
        )));
    }
    Ok(target)
}

/// Write the dense matrix a model evaluates to, as a BFC file.
pub fn gmm_dense(a: &GmmDenseArgs) -> Result<(), Error> {
    use crate::material::mixture::GmmFile;
    let out = check_output_file(
        "-o/--output",
        &a.output,
        "bfc",
        "the matrix is written as a BFC file, so its name must end in .bfc (or .BFC)",
        &a.model,
    )?;
    let text =
        crate::io::input::read_text(&a.model, crate::io::input::GMM_MODEL).map_err(Error::input)?;
    let f = GmmFile::parse(&text)
        .map_err(|m| Error::input(format!("malformed GMM file '{}': {m}", a.model.display())))?;
    let m = f.to_matrix_at(a.step).map_err(|m| {
        Error::input(format!(
            "--{m}, on the measured support of the model '{}'",
            a.model.display()
        ))
    })?;
    let title = format!(
        "dense {} nm matrix of the GMM fit of {}",
        a.step, f.source.file
    );
    crate::io::output::write_bytes(&out, m.to_bfc(&title).as_bytes()).map_err(Error::runtime)?;
    println!(
        "{}: {}×{} cells of {} nm",
        a.output.display(),
        m.n_em,
        m.n_ex,
        a.step
    );
    Ok(())
}

pub fn gmm_fit(a: &GmmFitArgs) -> Result<(), Error> {
    use crate::material::mixture::FitOptions;
    let mut opt = FitOptions::new(a.components, a.method, a.seed);
    opt.max_iterations = a.max_iterations;
    opt.tolerance = a.tolerance;
    if !a.input.exists() {
        return Err(Error::input(format!(
            "'{}' does not exist (give a BFC file or a folder of them)",
            a.input.display()
        )));
    }
    let jobs = crate::gmm::fit::targets(&a.input, &a.output)?;
    let jobs = check_fit_outputs(a, jobs)?;
    let t = std::time::Instant::now();
    let fitted = crate::gmm::fit::fit(&jobs, &opt)?;
    let secs = t.elapsed().as_secs_f64();
    for f in &fitted {
        let m = &f.model;
        println!(
            "{}: {} components, {} iterations{}, scale {:.4} nm -> {}",
            f.input.display(),
            m.components.len(),
            m.fit.iterations,
            if m.fit.converged {
                ""
            } else {
                " (not converged)"
            },
            m.scale,
            f.output.display()
        );
    }
    let unconverged = fitted.iter().filter(|f| !f.model.fit.converged).count();
    println!(
        "fitted {} matrices ({} components, {:?}, seed {}) in {secs:.2} s; {unconverged} did not converge",
        fitted.len(),
        a.components,
        a.method,
        a.seed
    );
    Ok(())
}

/// The outputs of `gmm fit`, checked before anything is fitted: a folder of inputs is fitted
/// into the folder `-o` (created if missing, like `render --strategy-images`), which must take
/// new files; one input into a `.json` file in an existing folder (or into an existing folder).
/// Every model file is a regular file or new ([`crate::io::output::check_output`]). Returns the
/// jobs with the paths to write.
fn check_fit_outputs(
    a: &GmmFitArgs,
    jobs: Vec<(PathBuf, PathBuf)>,
) -> Result<Vec<(PathBuf, PathBuf)>, Error> {
    let opt = "-o/--output";
    if a.input.is_dir() || a.output.is_dir() {
        if a.output.exists() && !a.output.is_dir() {
            return Err(Error::input(format!(
                "{opt} '{}': a folder of BFC files is fitted into a folder, but this is a file",
                show_path(&a.output)
            )));
        }
        std::fs::create_dir_all(&a.output)
            .map_err(|e| format!("cannot create the folder: {e}"))
            .and_then(|()| crate::io::output::check_folder(&a.output))
            .map_err(|e| Error::input(format!("{opt} '{}': {e}", show_path(&a.output))))?;
        return jobs
            .into_iter()
            .map(|(input, out)| {
                let target = crate::io::output::refuse_non_regular(&out)
                    .map(|()| out.clone())
                    .map_err(|e| {
                        Error::input(format!(
                            "{opt}: the model of '{}' cannot be written: {e}",
                            show_path(&input)
                        ))
                    })?;
                Ok((input, target))
            })
            .collect();
    }
    jobs.into_iter()
        .map(|(input, out)| {
            let target = check_output_file(
                opt,
                &out,
                "json",
                "the model is written as JSON, so its name must end in .json (or give a folder)",
                &input,
            )?;
            Ok((input, target))
        })
        .collect()
}

#[derive(Args, Debug, Clone)]
pub struct GmmEvalArgs {
    /// A folder of BFC files (e.g. data/bispectral/rit).
    pub dir: PathBuf,
    /// Numbers of Gaussians to fit, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
    pub components: Vec<usize>,
    #[arg(long, value_enum, default_value = "em")]
    pub method: crate::material::mixture::FitMethod,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A folder of illuminant tables ("λ, value" CSV files) to use instead of the 59 CIE
    /// illuminants built into stokes.
    #[arg(long)]
    pub illuminants: Option<PathBuf>,
    /// Output folder: delta-e00.csv, summary.json, box plots.
    #[arg(short, long, default_value = crate::gmm::evaluate::DEFAULT_OUT)]
    pub output: PathBuf,
}

/// ΔE00 of fitted against measured matrices under CIE illuminants and monochromatic light.
pub fn gmm_eval(a: &GmmEvalArgs) -> Result<(), Error> {
    let s = crate::gmm::evaluate::evaluate(
        &a.dir,
        &a.components,
        a.method,
        a.seed,
        &a.output,
        a.illuminants.as_deref(),
    )?;
    println!(
        "{} matrices, {} illuminants, {} monochromatic lines, {:?} fits, {:.1} s",
        s.materials.len(),
        s.illuminants.len(),
        s.mono_wavelengths.len(),
        s.method,
        s.seconds
    );
    println!(
        "  K | ΔE00 CIE mean  median     p95     max | mono mean  median     p95     max | worst under CIE"
    );
    for c in &s.per_components {
        println!(
            "{:>3} | {:>13.3} {:>7.3} {:>7.3} {:>7.3} | {:>9.3} {:>7.3} {:>7.3} {:>7.3} | {}",
            c.components,
            c.cie.mean,
            c.cie.median,
            c.cie.p95,
            c.cie.max,
            c.mono.mean,
            c.mono.median,
            c.mono.p95,
            c.mono.max,
            c.worst_cie
                .iter()
                .take(3)
                .map(|m| format!("{} {:.2}", m.material, m.mean))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for f in &s.outputs {
        println!("{}", f.display());
    }
    Ok(())
}

/// What the camera of `scene` integrates, for the spectral EXR's `stokes.sensor` attribute.
fn sensor_label(scene: &Scene) -> String {
    let r = scene.observer.range;
    match scene.observer.sensor_response() {
        None => format!("cie-1931 over [{}, {}] nm", r.min, r.max),
        Some(crate::spectrum::Spectrum::Box { .. }) => format!("band [{}, {}] nm", r.min, r.max),
        Some(_) => format!("response curve over [{}, {}] nm", r.min, r.max),
    }
}
