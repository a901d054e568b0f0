//! `stokes render`: its arguments, the checks of its options and outputs, the render, its stats.

use super::{MAX_EXPOSURE, choice, output_error, parse_sets, print_warnings, sensor_label};
use crate::Error;
use crate::film::{write_exr, write_png};
use crate::integrator::{
    IntegratorKind, IntegratorOptions, LaneWeighting, LightWavelengths, MisHeuristic,
    RenderSettings, ResetChoice,
};
use crate::io::limits::{MAX_SECONDS, MAX_SPP, MAX_THREADS};
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
    #[arg(
        long,
        value_parser = choice::<IntegratorKind>(),
        default_value = IntegratorKind::PtMono.name()
    )]
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
    #[arg(long, default_value_t = IntegratorOptions::default().max_depth)]
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
    #[arg(
        long,
        value_parser = choice::<CameraWavelengths>(),
        default_value = IntegratorOptions::default().camera_wavelengths.name()
    )]
    pub camera_wavelengths: CameraWavelengths,
    /// New-wavelength sampling at fluorescent vertices (Jung 7.1.2).
    #[arg(
        long,
        value_parser = choice::<WavelengthSampling>(),
        default_value = IntegratorOptions::default().wavelength_sampling.name()
    )]
    pub wavelength_sampling: WavelengthSampling,
    /// Hero wavelength lanes (pt-hero).
    #[arg(long, default_value_t = IntegratorOptions::default().lanes)]
    pub lanes: u32,
    /// First wavelength of light sub-paths (BDPT).
    #[arg(
        long,
        value_parser = choice::<LightWavelengths>(),
        default_value = IntegratorOptions::default().light_wavelengths.name()
    )]
    pub light_wavelengths: LightWavelengths,
    /// MIS heuristic.
    #[arg(
        long,
        value_parser = choice::<MisHeuristic>(),
        default_value = IntegratorOptions::default().mis.name()
    )]
    pub mis: MisHeuristic,
    /// Bin width in nm (bdpt-allbins).
    #[arg(long, default_value_t = IntegratorOptions::default().bin_width)]
    pub bin_width: f32,
    /// Distance tracking in participating media (Mojzík §5): fluorescence-aware (eq. 6), the
    /// max(σ̂t, σ̂s) hot-fix, or classic exponential sampling by σ̂t.
    #[arg(
        long,
        value_parser = choice::<Tracking>(),
        default_value = IntegratorOptions::default().tracking.name()
    )]
    pub tracking: Tracking,
    /// pt-hero in media: weight the lanes by the balance heuristic over every lane's distance
    /// pdfs, or by the hero's distance decisions alone (Mojzík's HWSS, §6.2).
    #[arg(
        long,
        value_parser = choice::<LaneWeighting>(),
        default_value = IntegratorOptions::default().lane_weighting.name()
    )]
    pub lane_weighting: LaneWeighting,
    /// bdpt-combined: evaluate both wavelength resets at every connection, or one chosen at
    /// random with probability 1/2 (one-sample MIS; about one reset's cost), or one per pixel
    /// learned from the first 8 passes (adaptive).
    #[arg(
        long,
        value_parser = choice::<ResetChoice>(),
        default_value = IntegratorOptions::default().reset_choice.name()
    )]
    pub reset_choice: ResetChoice,
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
            reset_choice: self.reset_choice,
        }
    }
}

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
        .validate_for(a.integrator)
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
    if !crate::io::output::has_extension(&a.output, "exr") {
        return Err(Error::input(format!(
            "-o/--output '{}': the image is written as OpenEXR, so its name must end in .exr (use --png for a PNG preview)",
            a.output.display()
        )));
    }
    if let Some(p) = &a.png
        && !crate::io::output::has_extension(p, "png")
    {
        return Err(Error::input(format!(
            "--png '{}': the name of the PNG preview must end in .png",
            p.display()
        )));
    }
    if let Some(p) = &a.spectral_output
        && !crate::io::output::has_extension(p, "exr")
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
        cancel: None,
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
        let json = out.stats_json(a.integrator, &opts);
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
