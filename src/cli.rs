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

pub fn render_cmd_validate(a: &RenderArgs) -> Result<(), Error> {
    if a.spp == 0 {
        return Err(Error::input("--spp must be at least 1"));
    }
    if let Some(t) = a.time_limit
        && !(t > 0.0 && t.is_finite())
    {
        return Err(Error::input(format!(
            "--time-limit must be a positive number of seconds, got {t}"
        )));
    }
    if a.threads == Some(0) {
        return Err(Error::input("--threads must be at least 1"));
    }
    a.options()
        .validate()
        .map_err(|m| Error::input(format!("option {m}")))
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
    let run = crate::experiment::figures::resolve_run_dir(dir).map_err(Error::input)?;
    let files = crate::experiment::figures::make_all(&run).map_err(Error::runtime)?;
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

/// Write the dense matrix a model evaluates to, as a BFC file.
pub fn gmm_dense(a: &GmmDenseArgs) -> Result<(), Error> {
    use crate::material::mixture::GmmFile;
    let text = std::fs::read_to_string(&a.model)
        .map_err(|e| Error::input(format!("cannot read '{}': {e}", a.model.display())))?;
    let f = GmmFile::parse(&text)
        .map_err(|m| Error::input(format!("malformed GMM file '{}': {m}", a.model.display())))?;
    let m = f
        .to_matrix_at(a.step)
        .map_err(|m| Error::input(format!("--{m}")))?;
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
    let t = std::time::Instant::now();
    let fitted = crate::gmm::fit::fit(&a.input, &opt, &a.output)?;
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
