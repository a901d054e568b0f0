//! From a cleaned BFC matrix to a fitted, scaled model (Hua §5).

use super::conditional::MAX_COMPONENTS;
use super::file::{FORMAT, FitInfo, Grid, Source};
use super::{ConditionalMixture, FitReport, GmmFile, WeightedPoints, bayes, em, select};
use crate::material::bfc::BfcMatrix;
use rayon::prelude::*;

named_enum! {
    /// The fitting algorithm.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
    pub enum FitMethod {
        /// Weighted expectation–maximisation.
        #[default]
        Em = "em",
        /// Weighted variational Bayesian inference (may use fewer components than asked).
        Bayes = "bayes",
    }
}

named_enum! {
    /// How the scale S of ρ = S·p is set (Hua §5.3).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
    pub enum ScaleMethod {
        /// Integral ratio (eq. 5): the model keeps the matrix's energy.
        #[default]
        Integral = "integral",
        /// Error minimisation (eq. 4, L2): least squares over the matrix cells.
        Error = "error",
    }
}

/// k-means++ starts of a fit unless told otherwise, by measurement (`examples/gmm_restarts.rs`,
/// results/README.md "Robust fits"): GOLFYE at K = 2 lands within 0.1 ΔE00 of its best seed for
/// every seed 0–9 from 5 starts on, and for every seed 0–199 from 8 (5: 197 of 200); 8 starts
/// at K = 8 take 0.35 s per RIT matrix on one thread.
pub const DEFAULT_RESTARTS: usize = 8;

/// Largest number of starts of one fit.
pub const MAX_RESTARTS: usize = 1000;

/// Settings of one fit. Fields added after the first model files are omitted from a file when
/// they hold the value those files were fitted with, and read as that value when missing.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitOptions {
    /// Gaussians per mixture; the maximum when `auto_components` is set.
    pub components: usize,
    pub method: FitMethod,
    pub seed: u64,
    pub max_iterations: usize,
    /// Convergence: stop when the mean log-likelihood changes by less than this.
    pub tolerance: f64,
    /// Seeded k-means++ starts; the fit with the best final log-likelihood (EM) or lower bound
    /// (Bayes) is kept. Start 0 uses `seed` itself.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub restarts: usize,
    /// How S is set.
    #[serde(default, skip_serializing_if = "is_integral")]
    pub scale_method: ScaleMethod,
    /// Choose the number of Gaussians up to `components`: by BIC for EM ([`select`]), by the
    /// variational fit's own pruning for Bayes (a fit with `components`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub auto_components: bool,
}

fn one() -> usize {
    1
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

fn is_integral(s: &ScaleMethod) -> bool {
    *s == ScaleMethod::Integral
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl FitOptions {
    pub fn new(components: usize, method: FitMethod, seed: u64) -> Self {
        FitOptions {
            components,
            method,
            seed,
            max_iterations: 1000,
            tolerance: 1e-7,
            restarts: DEFAULT_RESTARTS,
            scale_method: ScaleMethod::default(),
            auto_components: false,
        }
    }
}

/// The seed of start `r` of a fit with `seed`: `seed` itself for start 0 (so one start is the
/// fit of that seed), a SplitMix64 hash of (seed, r) for the others.
pub fn restart_seed(seed: u64, r: usize) -> u64 {
    if r == 0 {
        return seed;
    }
    let mut z = seed.wrapping_add((r as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The off-diagonal cells with a positive value as weighted observations at their centres.
pub fn points(m: &BfcMatrix) -> WeightedPoints {
    let mut data = WeightedPoints {
        cell: m.step as f64,
        ..Default::default()
    };
    for o in 0..m.n_em {
        for i in 0..m.n_ex {
            let v = m.off(o, i);
            if v > 0.0 {
                data.x.push([m.ex(i) as f64, m.em(o) as f64]);
                data.w.push(v as f64);
            }
        }
    }
    data
}

impl FitOptions {
    /// The settings are in range; an error names the field.
    pub fn check(&self) -> Result<(), String> {
        if self.components == 0 || self.components > MAX_COMPONENTS {
            return Err(format!(
                "components: {} is not in 1..={MAX_COMPONENTS}",
                self.components
            ));
        }
        if self.max_iterations == 0 || self.max_iterations > 1_000_000 {
            return Err(format!(
                "max_iterations: {} is not in 1..=1000000",
                self.max_iterations
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(format!(
                "tolerance: {} is not a positive number",
                self.tolerance
            ));
        }
        if self.restarts == 0 || self.restarts > MAX_RESTARTS {
            return Err(format!(
                "restarts: {} is not in 1..={MAX_RESTARTS}",
                self.restarts
            ));
        }
        Ok(())
    }
}

/// The best of the seeded starts of a fit with `k` components: its report and which start it
/// was.
#[derive(Clone, Debug)]
pub struct BestStart {
    pub report: FitReport,
    pub restart: usize,
}

/// One start of `opt.method` with `k` components from `seed`; a fit with an invalid component
/// is an error ("singular fit").
fn one_start(
    data: &WeightedPoints,
    k: usize,
    seed: u64,
    opt: &FitOptions,
) -> Result<FitReport, String> {
    let (it, tol) = (opt.max_iterations, opt.tolerance);
    let report = match opt.method {
        FitMethod::Em => em::fit_em(data, k, seed, it, tol),
        FitMethod::Bayes => bayes::fit_bayes(data, k, seed, it, tol),
    }?;
    if let Some(c) = report.components.iter().position(|c| !c.is_valid()) {
        return Err(format!(
            "singular fit: component {c} came out as {:?}",
            report.components[c]
        ));
    }
    Ok(report)
}

/// `opt.restarts` starts with `k` components (seeds [`restart_seed`]), run in parallel; the one
/// with the largest final log-likelihood (or bound) is kept, the earliest on a tie, so the
/// result depends on neither the thread count nor the order the starts finish in. Starts that
/// fail are skipped; if all fail, the first start's error is returned.
pub fn best_start(data: &WeightedPoints, k: usize, opt: &FitOptions) -> Result<BestStart, String> {
    let runs: Vec<Result<FitReport, String>> = (0..opt.restarts.max(1))
        .into_par_iter()
        .map(|r| one_start(data, k, restart_seed(opt.seed, r), opt))
        .collect();
    let mut best: Option<BestStart> = None;
    let mut first_error = None;
    for (restart, run) in runs.into_iter().enumerate() {
        match run {
            Ok(report) if report.log_likelihood.is_finite() || report.components.is_empty() => {
                let better = best
                    .as_ref()
                    .is_none_or(|b| report.log_likelihood > b.report.log_likelihood);
                if better {
                    best = Some(BestStart { report, restart });
                }
            }
            Ok(report) => {
                first_error.get_or_insert(format!(
                    "singular fit: the log-likelihood came out as {}",
                    report.log_likelihood
                ));
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    best.ok_or_else(|| first_error.unwrap_or_default())
}

/// Fit a cleaned matrix (its off-diagonal part, Hua §5.2) with the best of `opt.restarts`
/// starts, choosing the number of components when asked, and scale the mixture by the integral
/// ratio (eq. 5), so that the model keeps the matrix's energy, or by least squares (eq. 4). The
/// result's `source` is left empty for the caller to fill.
pub fn fit_matrix(m: &BfcMatrix, opt: &FitOptions) -> Result<GmmFile, String> {
    opt.check()?;
    let data = points(m);
    let (best, bic) = if opt.auto_components && opt.method == FitMethod::Em && !data.x.is_empty() {
        select::by_bic(
            &data,
            opt.components,
            |k| best_start(&data, k, opt),
            |b| &b.report,
        )?
    } else {
        (best_start(&data, opt.components, opt)?, Vec::new())
    };
    let report = best.report;
    let grid = Grid::of(m);
    let scale = if report.components.is_empty() {
        0.0
    } else {
        let p = ConditionalMixture::new(
            &report.components,
            1.0,
            grid.ex_support(),
            grid.em_support(),
        );
        match opt.scale_method {
            ScaleMethod::Integral => integral_scale(&data, m.step as f64, &p)?,
            ScaleMethod::Error => error_scale(m, &p)?,
        }
    };
    Ok(GmmFile {
        format: FORMAT.to_string(),
        source: Source::default(),
        fit: FitInfo {
            options: *opt,
            iterations: report.iterations,
            log_likelihood: report.log_likelihood,
            converged: report.converged,
            restart: best.restart,
            bic,
        },
        grid,
        reflectance: (0..m.n_em).map(|o| m.reflectance(o)).collect(),
        scale,
        components: report.components,
    })
}

/// S of the integral ratio: the matrix's energy over the mixture's mass (`p`, scale 1) on the
/// measured support above the diagonal.
fn integral_scale(data: &WeightedPoints, step: f64, p: &ConditionalMixture) -> Result<f64, String> {
    // ∬ρ = Σ D/Δλ · Δλ · Δλ over the off-diagonal cells, nm.
    let energy: f64 = data.w.iter().sum::<f64>() * step;
    let mass = p.mass();
    if mass > 0.0 && (energy / mass).is_finite() {
        Ok(energy / mass) // Hua eq. 5
    } else {
        Err(format!(
            "singular fit: the mixture has mass {mass} above the diagonal of the measured support"
        ))
    }
}

/// S minimising Σ (D/Δλ − S·p)² over the off-diagonal cells, with p the mixture (`p`, scale 1)
/// at the cell centres where the model is evaluated (zero below the diagonal, like the cleaned
/// matrix): the kernel per nm against the model's, so the matrix the model evaluates to,
/// Δλ·S·p, is the least-squares one.
fn error_scale(m: &BfcMatrix, p: &ConditionalMixture) -> Result<f64, String> {
    let (mut dp, mut pp) = (0.0, 0.0);
    for o in 0..m.n_em {
        for i in 0..m.n_ex {
            if m.is_diagonal(o, i) {
                continue;
            }
            let q = p.kernel(m.ex(i) as f64, m.em(o) as f64);
            dp += m.off(o, i) as f64 / m.step as f64 * q;
            pp += q * q;
        }
    }
    let s = dp / pp; // Hua eq. 4, L2: S = Σ D·p / Σ p²
    if pp > 0.0 && s.is_finite() {
        Ok(s)
    } else {
        Err(format!(
            "singular fit: the mixture is {pp} (sum of squares) on the matrix cells above the \
             diagonal"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::mixture::{Component, mixture_density};

    /// A 10 nm matrix whose cells hold Δλ·S·p of a known mixture, with p a density per nm²:
    /// the kernel per nm is D/Δλ = S·p (docs/design.md §2).
    fn synthetic(truth: &[Component], s: f64) -> BfcMatrix {
        let (n_em, n_ex) = (41, 49);
        let mut m = BfcMatrix {
            em_lo: 380.0,
            ex_lo: 300.0,
            step: 10.0,
            n_em,
            n_ex,
            d: vec![0.0; n_em * n_ex],
        };
        for o in 0..n_em {
            for i in 0..n_ex {
                let (lo, li) = (m.em(o) as f64, m.ex(i) as f64);
                m.d[o * n_ex + i] = if m.is_diagonal(o, i) {
                    0.2
                } else if lo > li {
                    (10.0 * s * mixture_density(truth, [li, lo])) as f32
                } else {
                    0.0
                };
            }
        }
        m
    }

    /// The fit of a matrix drawn from a known two-component mixture recovers its weights,
    /// means, covariances and scale S, so the kernel comes out per nm: a per-bin reading
    /// would be ten times too large, a missing Δλ ten times too small.
    #[test]
    fn recovers_a_known_mixture_and_its_scale_per_nm() {
        let truth = [
            Component {
                weight: 0.4,
                mean: [360.0, 460.0],
                cov: [[500.0, 150.0], [150.0, 700.0]],
            },
            Component {
                weight: 0.6,
                mean: [470.0, 580.0],
                cov: [[800.0, -200.0], [-200.0, 600.0]],
            },
        ];
        let s0 = 55.0;
        let m = synthetic(&truth, s0);
        let f = fit_matrix(&m, &FitOptions::new(2, FitMethod::Em, 1)).unwrap();
        assert!(f.fit.converged);
        let mut c = f.components.clone();
        c.sort_by(|a, b| a.mean[0].total_cmp(&b.mean[0]));
        for (c, t) in c.iter().zip(&truth) {
            assert!((c.weight - t.weight).abs() < 0.01, "{c:?} vs {t:?}");
            for a in 0..2 {
                assert!((c.mean[a] - t.mean[a]).abs() < 1.0, "{c:?} vs {t:?}");
                for b in 0..2 {
                    let want = t.cov[a][b] + if a == b { 100.0 / 12.0 } else { 0.0 };
                    assert!((c.cov[a][b] - want).abs() < 0.05 * t.cov[a][a], "{c:?}");
                }
            }
        }
        assert!((f.scale / s0 - 1.0).abs() < 0.01, "S = {} vs {s0}", f.scale);
        // The kernel per nm at the first component's mean, and the matrix it evaluates to.
        let cond = f.conditional(crate::spectrum::DEFAULT_DOMAIN);
        let want = s0 * mixture_density(&truth, [360.0, 460.0]);
        let got = cond.kernel(360.0, 460.0);
        assert!((got / want - 1.0).abs() < 0.02, "ρ = {got} vs {want}");
        let back = f.to_matrix();
        let (o, i) = (8, 6); // λo = 460, λi = 360
        assert!((back.d[o * 49 + i] / m.d[o * 49 + i] - 1.0).abs() < 0.02);
        assert_eq!(back.reflectance(20), 0.2);
    }

    /// The integral ratio keeps the measured energy: Σ over columns of ∫ρ dλo times the column
    /// width equals Σ D·Δλ; and each column's ∫ρ dλo is close to the measured column sum Σ_o D.
    #[test]
    fn integral_ratio_keeps_the_energy_of_a_measured_matrix() {
        let m = BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap();
        let f = fit_matrix(&m, &FitOptions::new(8, FitMethod::Em, 0)).unwrap();
        let g = f.grid;
        let cond = ConditionalMixture::new(&f.components, f.scale, g.ex_support(), g.em_support());
        let energy: f64 = points(&m).w.iter().sum::<f64>() * 10.0;
        let (a, b) = g.ex_support();
        let n = 4900;
        let h = (b - a) / n as f64;
        let total: f64 = (0..n)
            .map(|j| cond.total(a + (j as f64 + 0.5) * h, 0) * h)
            .sum();
        assert!((total / energy - 1.0).abs() < 1e-4, "{total} vs {energy}");
        // Per column (the bright ones), the fit's ∫ρ dλo against the measured Σ_o D[o][i]: the
        // fit error scatters them by about ±10 %, but their median is 1 (a unit slip would put
        // it at 10 or 0.1).
        let col = |i: usize| (0..m.n_em).map(|o| m.off(o, i) as f64).sum::<f64>();
        let mut r: Vec<f64> = (0..m.n_ex)
            .filter(|&i| col(i) > 0.05)
            .map(|i| cond.total(m.ex(i) as f64, 0) / col(i))
            .collect();
        r.sort_by(f64::total_cmp);
        let median = r[r.len() / 2];
        assert!((median - 1.0).abs() < 0.05, "{r:?}");
    }

    fn golfye() -> BfcMatrix {
        BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap()
    }

    fn with_restarts(k: usize, seed: u64, restarts: usize) -> FitOptions {
        let mut o = FitOptions::new(k, FitMethod::Em, seed);
        o.restarts = restarts;
        o
    }

    /// One start is the fit of `seed` itself, bit for bit (EM and Bayes), and its file holds
    /// only the options that files had before restarts existed, so `--restarts 1` writes what
    /// a single-start fit always wrote.
    #[test]
    fn one_start_is_the_fit_of_the_seed() {
        let m = golfye();
        let data = points(&m);
        for (method, seed) in [(FitMethod::Em, 3), (FitMethod::Bayes, 0)] {
            let mut o = with_restarts(4, seed, 1);
            o.method = method;
            let f = fit_matrix(&m, &o).unwrap();
            let r = match method {
                FitMethod::Em => em::fit_em(&data, 4, seed, o.max_iterations, o.tolerance),
                FitMethod::Bayes => bayes::fit_bayes(&data, 4, seed, o.max_iterations, o.tolerance),
            }
            .unwrap();
            assert_eq!(format!("{:?}", f.components), format!("{:?}", r.components));
            assert_eq!(f.fit.log_likelihood.to_bits(), r.log_likelihood.to_bits());
            assert_eq!((f.fit.iterations, f.fit.restart), (r.iterations, 0));
            let v: serde_json::Value = serde_json::from_str(&f.to_json()).unwrap();
            let keys: Vec<&String> = v["fit"]["options"].as_object().unwrap().keys().collect();
            assert_eq!(
                keys,
                [
                    "components",
                    "max_iterations",
                    "method",
                    "seed",
                    "tolerance"
                ]
            );
            assert_eq!(v["fit"].as_object().unwrap().len(), 4, "{}", v["fit"]);
        }
        assert_eq!(restart_seed(12345, 0), 12345);
        assert_ne!(restart_seed(12345, 1), restart_seed(12345, 2));
        assert_ne!(restart_seed(12345, 1), restart_seed(12346, 1));
    }

    /// The best of N starts has the largest final log-likelihood of the N single starts from
    /// their seeds, is the same on one thread as on two, and on GOLFYE at K = 2 escapes the
    /// worse optimum that seed 0's single start lands in.
    #[test]
    fn restarts_keep_the_best_start_on_any_number_of_threads() {
        let m = golfye();
        let n = 6;
        let best = fit_matrix(&m, &with_restarts(2, 0, n)).unwrap();
        let singles: Vec<f64> = (0..n)
            .map(|r| {
                let o = with_restarts(2, restart_seed(0, r), 1);
                fit_matrix(&m, &o).unwrap().fit.log_likelihood
            })
            .collect();
        let top = singles.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(best.fit.log_likelihood, top, "{singles:?}");
        assert_eq!(singles[best.fit.restart], top);
        assert!(top > singles[0] + 1e-3, "{singles:?}");
        let pool = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        };
        let one = pool(1).install(|| fit_matrix(&m, &with_restarts(2, 0, n)).unwrap());
        let two = pool(2).install(|| fit_matrix(&m, &with_restarts(2, 0, n)).unwrap());
        assert_eq!(one.to_json(), best.to_json());
        assert_eq!(two.to_json(), best.to_json());
    }

    /// Σ over the off-diagonal cells of (model − measured)², the model being the matrix the
    /// fit evaluates to.
    fn squared_error(f: &GmmFile, m: &BfcMatrix) -> f64 {
        let back = f.to_matrix();
        let mut e = 0.0;
        for o in 0..m.n_em {
            for i in 0..m.n_ex {
                let d = back.off(o, i) as f64 - m.off(o, i) as f64;
                e += d * d;
            }
        }
        e
    }

    /// Hua eq. 4: when the matrix is exactly Δλ·S₀·p of a mixture, the error scale of that
    /// mixture is S₀ (to the matrix's single precision); on a real matrix it minimises the
    /// squared error, below the integral ratio's and below S·(1 ± 1 %).
    #[test]
    fn error_scale_recovers_an_exact_scale_and_minimises_the_squared_error() {
        let m = golfye();
        let f = fit_matrix(&m, &with_restarts(3, 0, 1)).unwrap();
        let g = f.grid;
        let p = ConditionalMixture::new(&f.components, 1.0, g.ex_support(), g.em_support());
        let s0 = 71.25;
        let mut exact = m.clone();
        for o in 0..m.n_em {
            for i in 0..m.n_ex {
                if !m.is_diagonal(o, i) {
                    let q = p.kernel(m.ex(i) as f64, m.em(o) as f64);
                    exact.d[o * m.n_ex + i] = (m.step as f64 * s0 * q) as f32;
                }
            }
        }
        let s = error_scale(&exact, &p).unwrap();
        assert!((s / s0 - 1.0).abs() < 1e-6, "S = {s} vs {s0}");

        let mut o = with_restarts(3, 0, 1);
        o.scale_method = ScaleMethod::Error;
        let e = fit_matrix(&m, &o).unwrap();
        assert_eq!(e.components, f.components);
        assert_ne!(e.scale, f.scale);
        let at = |s: f64| {
            let mut x = e.clone();
            x.scale = s;
            squared_error(&x, &m)
        };
        let best = at(e.scale);
        for s in [e.scale * 0.99, e.scale * 1.01, f.scale] {
            assert!(
                at(s) > best,
                "S = {s}: {} <= {best} at S = {}",
                at(s),
                e.scale
            );
        }
        // A matrix drawn from a known mixture: both scales find its S within 1 %.
        let truth = [Component {
            weight: 1.0,
            mean: [400.0, 520.0],
            cov: [[600.0, 100.0], [100.0, 500.0]],
        }];
        let syn = synthetic(&truth, 40.0);
        let mut o = FitOptions::new(1, FitMethod::Em, 0);
        o.scale_method = ScaleMethod::Error;
        let f = fit_matrix(&syn, &o).unwrap();
        assert!((f.scale / 40.0 - 1.0).abs() < 0.01, "S = {}", f.scale);
    }

    /// `auto_components`: EM chooses K by BIC among 1..=max and records every BIC; Bayes fits
    /// with the maximum and prunes, recording none.
    #[test]
    fn automatic_number_of_components() {
        let truth = [
            Component {
                weight: 0.4,
                mean: [360.0, 460.0],
                cov: [[500.0, 150.0], [150.0, 700.0]],
            },
            Component {
                weight: 0.6,
                mean: [470.0, 580.0],
                cov: [[800.0, -200.0], [-200.0, 600.0]],
            },
        ];
        let m = synthetic(&truth, 55.0);
        let mut o = FitOptions::new(5, FitMethod::Em, 0);
        o.auto_components = true;
        let f = fit_matrix(&m, &o).unwrap();
        assert_eq!(f.fit.bic.len(), 5);
        let k = f.components.len();
        let min = f.fit.bic.iter().cloned().fold(f64::INFINITY, f64::min);
        assert_eq!(f.fit.bic[k - 1], min, "{:?}", f.fit.bic);
        // The chosen fit is the fit with that many components.
        let fixed = fit_matrix(&m, &FitOptions::new(k, FitMethod::Em, 0)).unwrap();
        assert_eq!(f.components, fixed.components);
        o.method = FitMethod::Bayes;
        let b = fit_matrix(&m, &o).unwrap();
        assert!(b.fit.bic.is_empty() && b.components.len() <= 5);
    }

    #[test]
    fn bad_options_and_empty_matrices() {
        let mut m = BfcMatrix::parse(include_str!("../../../data/bispectral/GOLFYE.BFC")).unwrap();
        for k in [0, 33] {
            let e = fit_matrix(&m, &FitOptions::new(k, FitMethod::Em, 0)).unwrap_err();
            assert!(e.contains("components"), "{e}");
        }
        let mut o = FitOptions::new(2, FitMethod::Em, 0);
        o.tolerance = f64::NAN;
        assert!(fit_matrix(&m, &o).unwrap_err().contains("tolerance"));
        for r in [0, MAX_RESTARTS + 1] {
            let e = fit_matrix(&m, &with_restarts(2, 0, r)).unwrap_err();
            assert!(e.starts_with("restarts: "), "{e}");
        }
        // No fluorescence: an empty mixture, not an error.
        for o in 0..m.n_em {
            for i in 0..m.n_ex {
                if !m.is_diagonal(o, i) {
                    m.d[o * m.n_ex + i] = 0.0;
                }
            }
        }
        let f = fit_matrix(&m, &FitOptions::new(4, FitMethod::Em, 0)).unwrap();
        assert!(f.components.is_empty());
        assert_eq!(f.scale, 0.0);
        assert!(f.conditional(crate::spectrum::DEFAULT_DOMAIN).is_empty());
    }
}
