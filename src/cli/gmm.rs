//! `stokes gmm fit`, `dense`, `eval` and `figures`: Gaussian-mixture reradiation models and their
//! checks.

use super::{choice, output_error};
use crate::Error;
pub use crate::gmm::options::{Components, parse_components, parse_restarts};
use crate::io::output::{canonical_output, check_output};
use crate::io::text::show_path;
use crate::material::mixture::fit::ScaleMethod;
use crate::material::mixture::{FitMethod, FitOptions};
use clap::Args;
use std::path::{Path, PathBuf};

/// The defaults of `gmm fit`: 8 Gaussians, the default method, seed 0, and the core's iteration
/// limit and tolerance.
fn fit_defaults() -> FitOptions {
    FitOptions::new(8, FitMethod::default(), 0)
}

#[derive(Args, Debug, Clone)]
pub struct GmmFitArgs {
    /// A BFC file, or a folder of them.
    pub input: PathBuf,
    /// Gaussians per mixture (at most 32; `bayes` may use fewer), or `auto` / `auto:MAX` to
    /// choose up to MAX (default 8): by BIC for `em`, by the fit's own pruning for `bayes`.
    #[arg(long, value_parser = parse_components, default_value = "8")]
    pub components: Components,
    /// Weighted EM, or weighted variational Bayesian inference (Hua §5.2).
    #[arg(long, value_parser = choice::<FitMethod>(), default_value = fit_defaults().method.name())]
    pub method: FitMethod,
    /// Seed of the k-means++ initialisation; fits are deterministic for a seed.
    #[arg(long, default_value_t = fit_defaults().seed)]
    pub seed: u64,
    /// Iteration limit of a fit.
    #[arg(long, default_value_t = fit_defaults().max_iterations)]
    pub max_iterations: usize,
    /// Convergence: stop when the mean log-likelihood changes by less than this.
    #[arg(long, default_value_t = fit_defaults().tolerance)]
    pub tolerance: f64,
    /// Output model file (one input file) or folder (a folder of inputs: `<STEM>.json` each).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Seeded k-means++ starts per fit; the best final log-likelihood is kept (start 0 uses
    /// `--seed` itself, so 1 is a single start from it).
    #[arg(long, value_parser = parse_restarts, default_value_t = fit_defaults().restarts)]
    pub restarts: usize,
    /// The scale S of ρ = S·p: the integral ratio (Hua eq. 5) or least squares over the matrix
    /// cells (eq. 4).
    #[arg(long, value_parser = choice::<ScaleMethod>(), default_value = fit_defaults().scale_method.name())]
    pub scale: ScaleMethod,
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
    if !crate::io::output::has_extension(p, ext) {
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
    let mut opt = FitOptions::new(a.components.count, a.method, a.seed);
    opt.max_iterations = a.max_iterations;
    opt.tolerance = a.tolerance;
    opt.restarts = a.restarts;
    opt.scale_method = a.scale;
    opt.auto_components = a.components.auto;
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
        if !m.fit.bic.is_empty() {
            let b: Vec<String> = m.fit.bic.iter().map(|b| format!("{b:.1}")).collect();
            println!("  BIC for K = 1..={}: {}", m.fit.bic.len(), b.join(" "));
        }
    }
    let unconverged = fitted.iter().filter(|f| !f.model.fit.converged).count();
    println!(
        "fitted {} matrices ({} components, {:?}, seed {}) in {secs:.2} s; {unconverged} did not converge",
        fitted.len(),
        a.components,
        a.method,
        a.seed
    );
    println!(
        "  best of {} starts each, scale by {}",
        a.restarts,
        a.scale.name()
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
    #[arg(long, value_parser = choice::<FitMethod>(), default_value = FitMethod::default().name())]
    pub method: FitMethod,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A folder of illuminant tables ("λ, value" CSV files) to use instead of the 59 CIE
    /// illuminants built into stokes.
    #[arg(long)]
    pub illuminants: Option<PathBuf>,
    /// Output folder: delta-e00.csv, summary.json, box plots.
    #[arg(short, long, default_value = crate::gmm::evaluate::DEFAULT_OUT)]
    pub output: PathBuf,
    /// Seeded k-means++ starts per fit (as `gmm fit --restarts`).
    #[arg(long, value_parser = parse_restarts, default_value_t = fit_defaults().restarts)]
    pub restarts: usize,
}

/// ΔE00 of fitted against measured matrices under CIE illuminants and monochromatic light.
pub fn gmm_eval(a: &GmmEvalArgs) -> Result<(), Error> {
    let s = crate::gmm::evaluate::evaluate_restarts(
        &a.dir,
        &a.components,
        a.method,
        a.seed,
        &a.output,
        a.illuminants.as_deref(),
        a.restarts,
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
        "ΔE00 of each fit against the measured matrix as cleaned by Hua §5.1 (the reference):"
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
    print_raw_reference(&s);
    for f in &s.outputs {
        println!("{}", f.display());
    }
    Ok(())
}

/// The same fits against the uncleaned measurement, and the cleaning alone.
fn print_raw_reference(s: &crate::gmm::summary::Summary) {
    println!(
        "against the uncleaned measurement (fit vs raw), and the cleaning alone (cleaned vs raw):"
    );
    println!("  K | ΔE00 CIE mean  median     max | mono mean  median     max");
    let row = |k: &str, c: &crate::gmm::summary::KindStats| {
        println!(
            "{k:>3} | {:>13.3} {:>7.3} {:>7.3} | {:>9.3} {:>7.3} {:>7.3}",
            c.cie.mean, c.cie.median, c.cie.max, c.mono.mean, c.mono.median, c.mono.max
        )
    };
    for c in &s.per_components {
        row(&c.components.to_string(), &c.vs_raw);
    }
    row("cln", &s.cleaning);
    if let Some(c) = s.per_components.iter().find(|c| c.components == 4) {
        let worst: Vec<String> = c
            .worst_illuminants
            .iter()
            .map(|w| format!("{} {:.2}", w.light, w.mean))
            .collect();
        println!("worst illuminants at K = 4: {}", worst.join(", "));
    }
}

#[derive(Args, Debug, Clone)]
pub struct GmmFigsArgs {
    /// A folder of BFC files (e.g. data/bispectral/rit).
    pub dir: PathBuf,
    /// Numbers of Gaussians to fit, comma-separated (Figs. 5 and 8a use 4 when listed).
    #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
    pub components: Vec<usize>,
    #[arg(long, value_parser = choice::<FitMethod>(), default_value = FitMethod::default().name())]
    pub method: FitMethod,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A folder of illuminant tables instead of the 59 CIE illuminants built into stokes.
    #[arg(long)]
    pub illuminants: Option<PathBuf>,
    /// Fig. 4's material: a BFC file's stem (any case) or the start of exactly one.
    #[arg(long, default_value = crate::gmm::figures::FIG4_MATERIAL)]
    pub material: String,
    /// Fig. 4's excitation wavelength λi, nm.
    #[arg(long, default_value_t = crate::gmm::figures::FIG4_EXCITATION)]
    pub excitation: f32,
    /// How many of the worst materials Figs. 5 and 6 show (and worst illuminants Fig. 5).
    #[arg(long, default_value_t = 5)]
    pub worst: usize,
    /// Seeded k-means++ starts per fit (as `gmm fit --restarts`).
    #[arg(long, value_parser = parse_restarts, default_value_t = fit_defaults().restarts)]
    pub restarts: usize,
    /// Output folder [default: results/gmm-eval/<method>/figures].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

/// Hua's Figs. 4, 5, 6, 7a and 8a.
pub fn gmm_figures(a: &GmmFigsArgs) -> Result<(), Error> {
    let out = a.output.clone().unwrap_or_else(|| {
        Path::new(crate::gmm::evaluate::DEFAULT_OUT)
            .join(a.method.name())
            .join("figures")
    });
    let opt = crate::gmm::figures::Options {
        run: crate::gmm::evaluate::Run {
            dir: &a.dir,
            components: &a.components,
            method: a.method,
            seed: a.seed,
            out: &out,
            illuminants_dir: a.illuminants.as_deref(),
            restarts: a.restarts,
        },
        material: &a.material,
        excitation: a.excitation,
        worst: a.worst,
    };
    let d = crate::gmm::figures::figures(&opt)?;
    let list = |v: &[(String, f64)]| {
        v.iter()
            .map(|(n, m)| format!("{n} {m:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!(
        "figures of {} fits ({:?}) in {:.1} s; ΔE00 against the cleaned matrices (Hua §5.1)",
        a.dir.display(),
        a.method,
        d.seconds
    );
    println!("Fig. 4: {} at {} nm", d.material, a.excitation);
    println!(
        "Figs. 5, 6: worst under monochromatic light at K = {}: {}",
        d.components,
        list(&d.worst_materials)
    );
    println!(
        "Fig. 8a: worst CIE illuminants at K = {}: {}",
        d.components,
        list(&d.worst_illuminants)
    );
    for f in &d.outputs {
        println!("{}", f.display());
    }
    Ok(())
}
