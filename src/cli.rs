//! Command implementations behind `main.rs`, kept in the library so tests can call them. Errors
//! are the library's [`Error`]; `main.rs` turns its kind into the exit code.

use crate::Error;
use crate::film::{write_exr, write_png};
use crate::integrator::{
    IntegratorKind, IntegratorOptions, LightWavelengths, MisHeuristic, RenderSettings,
};
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
    /// Russian roulette from this many segments on (uni-directional tracers); off by default.
    #[arg(long)]
    pub rr_depth: Option<u32>,
    /// Write each BDPT strategy's weighted contribution as its own EXR into this folder.
    #[arg(long)]
    pub strategy_images: Option<PathBuf>,
    /// Do not print scene warnings.
    #[arg(long)]
    pub quiet: bool,
}

impl RenderArgs {
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
            strategy_images: self.strategy_images.is_some(),
        }
    }
}

/// Load a scene and print its warnings.
pub fn load_scene(path: &Path, quiet: bool) -> Result<Scene, Error> {
    let scene = Scene::load(path)?;
    if !quiet {
        for w in &scene.warnings {
            eprintln!("warning: {}: {w}", path.display());
        }
    }
    Ok(scene)
}

use crate::experiment::config::{MAX_SECONDS, MAX_SPP, MAX_THREADS};
/// Largest `--exposure` magnitude, stops.
pub const MAX_EXPOSURE: f32 = 64.0;

pub fn render_cmd_validate(a: &RenderArgs) -> Result<(), Error> {
    if a.spp == 0 || a.spp > MAX_SPP {
        return Err(Error::input(format!(
            "--spp must be 1–{MAX_SPP}, got {}",
            a.spp
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
    if !(a.exposure.abs() <= MAX_EXPOSURE) {
        return Err(Error::input(format!(
            "--exposure must be a finite number of stops in [-{MAX_EXPOSURE}, {MAX_EXPOSURE}], got {}",
            a.exposure
        )));
    }
    a.options()
        .validate()
        .map_err(|m| Error::input(format!("option {m}")))?;
    check_outputs(a)
}

/// The outputs of `render`, checked before the scene is loaded: `-o` ends in `.exr` and
/// `--png` in `.png` (the format follows the option, so the name must say it), no two outputs
/// are the same file (after resolving `.`, `..` and links of their folders), and each one's
/// folder exists and takes a new file. `--strategy-images` is a folder, created if missing.
fn check_outputs(a: &RenderArgs) -> Result<(), Error> {
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
    let mut outs: Vec<(&str, &Path)> = vec![("-o/--output", &a.output)];
    outs.extend(a.png.as_deref().map(|p| ("--png", p)));
    outs.extend(a.stats.as_deref().map(|p| ("--stats", p)));
    let mut seen: Vec<(&str, PathBuf)> = Vec::new();
    for (opt, p) in outs {
        crate::film::output::probe_writable(p)
            .map_err(|e| Error::input(format!("{opt} '{}': {e}", p.display())))?;
        let c = canonical_output(p);
        if let Some((other, _)) = seen.iter().find(|(_, q)| *q == c) {
            return Err(Error::input(format!(
                "{opt} '{}' is the same file as {other}: give each output its own path",
                p.display()
            )));
        }
        seen.push((opt, c));
    }
    if let Some(dir) = &a.strategy_images {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create the folder: {e}"))
            .and_then(|()| crate::film::output::probe_writable(&dir.join("probe.exr")))
            .map_err(|e| Error::input(format!("--strategy-images '{}': {e}", dir.display())))?;
        let d = canonical_output(&dir.join("x"));
        if let Some((opt, _)) = seen
            .iter()
            .find(|(_, q)| q.parent() == d.parent() && is_strategy_name(q))
        {
            return Err(Error::input(format!(
                "--strategy-images '{}': {opt} has the name of a strategy image (s<i>_t<j>.exr) in this folder and would be replaced",
                dir.display()
            )));
        }
    }
    Ok(())
}

/// Whether `p`'s file name is that of a strategy image, `s<i>_t<j>.exr`.
fn is_strategy_name(p: &Path) -> bool {
    let Some(n) = p.file_name().and_then(|n| n.to_str()) else {
        return false;
    };
    let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    n.strip_suffix(".exr")
        .and_then(|n| n.strip_prefix('s'))
        .and_then(|n| n.split_once("_t"))
        .is_some_and(|(a, b)| digits(a) && digits(b))
}

/// An output path with its (existing) folder made canonical, so `./P` and `P` compare equal.
fn canonical_output(p: &Path) -> PathBuf {
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    match p.file_name() {
        Some(n) => dir.join(n),
        None => dir,
    }
}

pub fn render(a: &RenderArgs) -> Result<(), Error> {
    render_cmd_validate(a)?;
    let scene = load_scene(&a.scene, a.quiet)?;
    let settings = RenderSettings {
        spp: a.spp,
        seed: a.seed,
        threads: a.threads,
        time_limit: a.time_limit,
        progress: true,
    };
    let opts = a.options();
    let out = crate::integrator::render(&scene, a.integrator, &opts, &settings, None)
        .map_err(Error::input)?;
    let (w, h) = (out.film.width, out.film.height);
    let rgb = out.film.rgb();
    write_exr(&a.output, w, h, &rgb).map_err(Error::runtime)?;
    if let Some(p) = &a.png {
        write_png(p, w, h, &rgb, a.exposure).map_err(Error::runtime)?;
    }
    if let Some(dir) = &a.strategy_images {
        for (i, name) in out.film.aux_names.iter().enumerate() {
            write_exr(&dir.join(format!("{name}.exr")), w, h, &out.film.aux_rgb(i))
                .map_err(Error::runtime)?;
        }
    }
    if let Some(p) = &a.stats {
        let json = stats_json(a.integrator, &opts, &out);
        crate::film::output::write_atomic(p, |tmp| {
            std::fs::write(tmp, serde_json::to_string_pretty(&json).unwrap())
                .map_err(|e| format!("cannot write stats '{}': {e}", p.display()))
        })
        .map_err(Error::runtime)?;
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
    println!("scene: {}", path.display());
    println!(
        "domain: [{}, {}] nm, camera range [{}, {}] nm",
        s.domain.min, s.domain.max, s.observer.range.min, s.observer.range.max
    );
    println!("camera: {}×{}", s.camera.width, s.camera.height);
    println!(
        "primitives: {} triangles, {} spheres",
        s.triangles.len(),
        s.spheres.len()
    );
    for (n, m) in s.material_names.iter().zip(&s.materials) {
        use crate::material::Bbrrdf;
        let kind = match m {
            crate::material::Material::Lambert(_) => "lambert".to_string(),
            crate::material::Material::Fluorescent(_) => "fluorescent-diffuse".to_string(),
            crate::material::Material::Reradiation(r) => {
                let (o, i) = r.shape();
                format!(
                    "reradiation, {o}×{i} matrix, {} bytes to render",
                    r.render_bytes()
                )
            }
            crate::material::Material::ReradiationGmm(g) => format!(
                "reradiation-gmm, {} Gaussians, model {} bytes, {} bytes to render",
                g.components(),
                g.model_bytes(),
                g.render_bytes()
            ),
        };
        println!(
            "material {n}: {kind}, {}",
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
        println!("medium {n}: {density}, {fl}, phase g = {}", m.g);
    }
    if s.camera_medium != crate::scene::NONE {
        println!(
            "camera in medium {}",
            s.medium_names[s.camera_medium as usize]
        );
    }
    for l in &s.lights {
        println!(
            "light {}: area {:.4}, power {:.4}{}",
            l.name,
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
    pub config: PathBuf,
    /// Results root (default `results`, `results/quick` with --quick); the run goes to `<out>/<name>/runs/<timestamp>/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Small resolution, few spp, one repeat: a smoke test.
    #[arg(long)]
    pub quick: bool,
}

pub fn experiment(a: &ExperimentArgs) -> Result<(), Error> {
    crate::experiment::run_experiment(&a.config, a.out.as_deref(), a.quick)?;
    Ok(())
}

pub fn figures(dir: &Path) -> Result<(), Error> {
    // An interrupted run has no run.json yet: look for its marker first.
    crate::experiment::record::check_complete(dir)?;
    let run = crate::experiment::figures::resolve_run_dir(dir)?;
    crate::experiment::record::check_complete(&run)?;
    let files = crate::experiment::figures::make_all(&run)?;
    for f in files {
        println!("{}", f.display());
    }
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
/// name ends in `.ext` (`why` says why), the folder exists and takes a new file, and it is not
/// the input file. Returns its canonical path.
fn check_output_file(
    opt: &str,
    p: &Path,
    ext: &str,
    why: &str,
    input: &Path,
) -> Result<PathBuf, Error> {
    if !crate::film::output::has_extension(p, ext) {
        return Err(Error::input(format!("{opt} '{}': {why}", p.display())));
    }
    crate::film::output::probe_writable(p)
        .map_err(|e| Error::input(format!("{opt} '{}': {e}", p.display())))?;
    let c = canonical_output(p);
    if c == canonical_output(input) {
        return Err(Error::input(format!(
            "{opt} '{}' is the input file '{}': give the output its own path",
            p.display(),
            input.display()
        )));
    }
    Ok(c)
}

/// Write the dense matrix a model evaluates to, as a BFC file.
pub fn gmm_dense(a: &GmmDenseArgs) -> Result<(), Error> {
    use crate::material::mixture::GmmFile;
    check_output_file(
        "-o/--output",
        &a.output,
        "bfc",
        "the matrix is written as a BFC file, so its name must end in .bfc (or .BFC)",
        &a.model,
    )?;
    let text = std::fs::read_to_string(&a.model)
        .map_err(|e| Error::input(format!("cannot read '{}': {e}", a.model.display())))?;
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
    crate::film::output::write_atomic(&a.output, |tmp| {
        std::fs::write(tmp, m.to_bfc(&title)).map_err(|e| e.to_string())
    })
    .map_err(|e| Error::runtime(format!("cannot write '{}': {e}", a.output.display())))?;
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
    check_fit_outputs(a, &jobs)?;
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
fn check_fit_outputs(a: &GmmFitArgs, jobs: &[(PathBuf, PathBuf)]) -> Result<(), Error> {
    let opt = "-o/--output";
    if a.input.is_dir() || a.output.is_dir() {
        if a.output.exists() && !a.output.is_dir() {
            return Err(Error::input(format!(
                "{opt} '{}': a folder of BFC files is fitted into a folder, but this is a file",
                a.output.display()
            )));
        }
        std::fs::create_dir_all(&a.output)
            .map_err(|e| format!("cannot create the folder: {e}"))
            .and_then(|()| crate::film::output::probe_writable(&a.output.join("probe.json")))
            .map_err(|e| Error::input(format!("{opt} '{}': {e}", a.output.display())))?;
        for (input, out) in jobs {
            if out.is_dir() {
                return Err(Error::input(format!(
                    "{opt} '{}': the model of '{}' would replace a folder",
                    out.display(),
                    input.display()
                )));
            }
        }
        return Ok(());
    }
    for (input, out) in jobs {
        check_output_file(
            opt,
            out,
            "json",
            "the model is written as JSON, so its name must end in .json (or give a folder)",
            input,
        )?;
    }
    Ok(())
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
    /// Folder of illuminant tables ("λ, value" CSV files).
    #[arg(long, default_value = crate::gmm::evaluate::DEFAULT_ILLUMINANTS)]
    pub illuminants: PathBuf,
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
        &a.illuminants,
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
