//! Gaussian-mixture reradiation models (Hua 2022) from Python: fit a measured BFC matrix as
//! `stokes gmm fit` does, evaluate and sample the mixture, save and load model files.

use crate::errors::{input_error, option_error};
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use rand::{Rng, SeedableRng};
use std::path::PathBuf;
use stokes::material::mixture::conditional::ConditionalMixture;
use stokes::material::mixture::{FitMethod, FitOptions, GmmFile, ScaleMethod, mixture_density};
use stokes::spectrum::Domain;

/// A fitted reradiation model: ρ(λi → λo) = S·p(λi, λo) with p a mixture of 2-D Gaussians
/// over (excitation λi, emission λo), restricted to λo > λi inside the measured support.
#[pyclass(module = "stokes.gmm", frozen)]
pub struct Mixture {
    file: GmmFile,
    conditional: ConditionalMixture,
}

impl Mixture {
    fn new(file: GmmFile) -> Mixture {
        // the whole measured support: no scene's wavelength range clips it
        let all = Domain {
            min: 0.0,
            max: f32::MAX,
        };
        let conditional = file.conditional(all);
        Mixture { file, conditional }
    }

    /// `n` draws of the unknown wavelength on `axis` given `known`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        known: f64,
        axis: usize,
        n: usize,
        seed: u64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (name, other) = if axis == 0 {
            ("lambda_in", "emission")
        } else {
            ("lambda_out", "excitation")
        };
        if !known.is_finite() || self.conditional.total(known, axis) <= 0.0 {
            return Err(option_error(
                name,
                format!(
                    "{known} nm has no {other} wavelength to shift to: the model's reradiation \
                     from it is zero (outside the measured support, or past its last cell)"
                ),
            ));
        }
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let u = [rng.random::<f64>(), rng.random::<f64>()];
            match self.conditional.sample(known, axis, u) {
                Some(d) => out.push(d.lambda),
                None => out.push(f64::NAN),
            }
        }
        Ok(PyArray1::from_vec(py, out))
    }
}

/// Evaluate `f` at each pair of two equally long 1-D arrays.
fn pairwise<'py>(
    py: Python<'py>,
    a: PyReadonlyArray1<'py, f64>,
    b: PyReadonlyArray1<'py, f64>,
    f: impl Fn(f64, f64) -> f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (a, b) = (a.as_array(), b.as_array());
    if a.len() != b.len() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "the two wavelength arrays differ in length ({} and {})",
            a.len(),
            b.len()
        )));
    }
    let v: Vec<f64> = a.iter().zip(b.iter()).map(|(&x, &y)| f(x, y)).collect();
    Ok(PyArray1::from_vec(py, v))
}

#[pymethods]
impl Mixture {
    /// One of the model's functions at pairs of wavelengths (two 1-D float64 arrays of one
    /// length; `stokes.gmm` broadcasts and reshapes): ``"pdf"`` the mixture density p(λi, λo)
    /// per nm² (Hua eq. 1); ``"kernel"`` ρ(λi → λo) = S·p on λo > λi inside the measured
    /// support, per nm; ``"pdf_out"`` the density of ``sample_out`` (λo given λi, the arrays
    /// λi, λo) and ``"pdf_in"`` that of ``sample_in`` (λi given λo, the arrays λo, λi), per nm.
    fn _evaluate<'py>(
        &self,
        py: Python<'py>,
        which: &str,
        a: PyReadonlyArray1<'py, f64>,
        b: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (c, m) = (&self.file.components, &self.conditional);
        match which {
            "pdf" => pairwise(py, a, b, |i, o| mixture_density(c, [i, o])),
            "kernel" => pairwise(py, a, b, |i, o| m.kernel(i, o)),
            "pdf_out" => pairwise(py, a, b, |i, o| m.density(i, o, 0)),
            "pdf_in" => pairwise(py, a, b, |o, i| m.density(o, i, 1)),
            _ => Err(pyo3::exceptions::PyValueError::new_err(format!(
                "unknown function {which:?}: pdf, kernel, pdf_out or pdf_in"
            ))),
        }
    }

    /// ∫ρ(λi → λo) dλo: the fraction of light at λi that is reradiated (1-D arrays).
    fn _total_out<'py>(
        &self,
        py: Python<'py>,
        lambda_in: PyReadonlyArray1<'py, f64>,
    ) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = lambda_in
            .as_array()
            .iter()
            .map(|&l| self.conditional.total(l, 0))
            .collect();
        PyArray1::from_vec(py, v)
    }

    /// sample_out(lambda_in, n, seed=0) -> numpy.ndarray
    ///
    /// ``n`` emission wavelengths drawn from the conditional mixture λo | λi (Hua §6, truncated
    /// to λo > λi and the measured support), as the renderer draws them; float64, nm.
    #[pyo3(signature = (lambda_in, n, seed=0))]
    fn sample_out<'py>(
        &self,
        py: Python<'py>,
        lambda_in: f64,
        n: usize,
        seed: u64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.sample(py, lambda_in, 0, n, seed)
    }

    /// sample_in(lambda_out, n, seed=0) -> numpy.ndarray
    ///
    /// ``n`` excitation wavelengths drawn from λi | λo (camera paths); float64, nm.
    #[pyo3(signature = (lambda_out, n, seed=0))]
    fn sample_in<'py>(
        &self,
        py: Python<'py>,
        lambda_out: f64,
        n: usize,
        seed: u64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.sample(py, lambda_out, 1, n, seed)
    }

    /// save(path)
    ///
    /// Write the model file, byte for byte what ``stokes gmm fit`` writes.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let file = path.display().to_string();
        if !stokes::io::output::has_extension(&path, "json") {
            let m = "the model is written as JSON, so its name must end in .json";
            return Err(input_error(&format!("'{file}': {m}"), Some(&file), None, m));
        }
        let p = stokes::io::output::check_output(&path)
            .map_err(|m| input_error(&format!("'{file}': {m}"), Some(&file), None, &m))?;
        stokes::io::output::write_bytes(&p, self.file.to_json().as_bytes())
            .map_err(pyo3::exceptions::PyOSError::new_err)
    }

    /// The model file's text (pretty JSON).
    fn to_json(&self) -> String {
        self.file.to_json()
    }

    /// Number of Gaussians K.
    #[getter]
    fn n_components(&self) -> usize {
        self.file.components.len()
    }

    /// Mixing weights π_k, shape (K,).
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.file.components.iter().map(|c| c.weight).collect())
    }

    /// Means (λi, λo) in nm, shape (K, 2).
    #[getter]
    fn means<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let a = PyArray2::<f64>::zeros(py, [self.file.components.len(), 2], false);
        // SAFETY: the array was just created here and is not shared yet
        let s = unsafe { a.as_slice_mut() }.expect("a new array is contiguous");
        for (d, c) in s.chunks_mut(2).zip(&self.file.components) {
            d.copy_from_slice(&c.mean);
        }
        a
    }

    /// Covariances in nm², shape (K, 2, 2).
    #[getter]
    fn covariances<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let k = self.file.components.len();
        let a = PyArray3::<f64>::zeros(py, [k, 2, 2], false);
        // SAFETY: the array was just created here and is not shared yet
        let s = unsafe { a.as_slice_mut() }.expect("a new array is contiguous");
        for (d, c) in s.chunks_mut(4).zip(&self.file.components) {
            d.copy_from_slice(&[c.cov[0][0], c.cov[0][1], c.cov[1][0], c.cov[1][1]]);
        }
        a
    }

    /// S of Hua eq. 3, nm: ρ = S·p.
    #[getter]
    fn scale(&self) -> f64 {
        self.file.scale
    }

    /// The measured support: ((λi min, λi max), (λo min, λo max)) in nm.
    #[getter]
    fn support(&self) -> ((f64, f64), (f64, f64)) {
        (self.file.grid.ex_support(), self.file.grid.em_support())
    }

    /// The fitted BFC file's name.
    #[getter]
    fn source(&self) -> String {
        self.file.source.file.clone()
    }

    /// How it was fitted: options, iterations, log-likelihood, convergence (a dict).
    #[getter]
    fn fit<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = serde_json::to_value(&self.file.fit).expect("fit info serialises");
        crate::json::to_py(py, &v)
    }

    fn __repr__(&self) -> String {
        format!(
            "Mixture('{}', {} components, scale {:.4} nm)",
            self.file.source.file,
            self.file.components.len(),
            self.file.scale
        )
    }
}

/// _fit(bfc_path, components, seed, method, restarts, max_iterations, tolerance, scale)
///
/// Fit a BFC matrix as ``stokes gmm fit`` does.
#[pyfunction]
#[pyo3(name = "gmm_fit", signature = (bfc_path, components, seed, method, restarts,
                                     max_iterations, tolerance, scale))]
#[allow(clippy::too_many_arguments)]
pub fn gmm_fit(
    py: Python<'_>,
    bfc_path: PathBuf,
    components: &Bound<'_, PyAny>,
    seed: u64,
    method: &str,
    restarts: usize,
    max_iterations: usize,
    tolerance: f64,
    scale: &str,
) -> PyResult<Mixture> {
    use stokes::gmm::options::{parse_components, parse_restarts};
    let comp_text = match components.extract::<i64>() {
        Ok(n) => n.to_string(),
        Err(_) => components.extract::<String>().map_err(|_| {
            option_error(
                "components",
                "expected a number of Gaussians, 'auto' or 'auto:MAX'",
            )
        })?,
    };
    let c = parse_components(&comp_text).map_err(|m| option_error("components", m))?;
    let method = FitMethod::ALL
        .into_iter()
        .find(|m| m.name() == method)
        .ok_or_else(|| option_error("method", format!("{method:?}: one of em, bayes")))?;
    let scale = ScaleMethod::ALL
        .into_iter()
        .find(|m| m.name() == scale)
        .ok_or_else(|| option_error("scale", format!("{scale:?}: one of integral, error")))?;
    let restarts =
        parse_restarts(&restarts.to_string()).map_err(|m| option_error("restarts", m))?;
    let mut opt = FitOptions::new(c.count, method, seed);
    opt.max_iterations = max_iterations;
    opt.tolerance = tolerance;
    opt.restarts = restarts;
    opt.scale_method = scale;
    opt.auto_components = c.auto;
    if !bfc_path.is_file() {
        let file = bfc_path.display().to_string();
        let m = "no such BFC file";
        return Err(input_error(&format!("'{file}': {m}"), Some(&file), None, m));
    }
    let f = crate::wait::run(
        py,
        move |_, _tx: std::sync::mpsc::Sender<()>| stokes::gmm::fit::fit_file(&bfc_path, &opt),
        |_, ()| Ok(()),
    )?
    .map_err(|e| crate::errors::from_error(&e))?;
    Ok(Mixture::new(f))
}

/// _load(path) -> Mixture
///
/// Read a model file written by ``stokes gmm fit`` or ``Mixture.save``.
#[pyfunction]
#[pyo3(name = "gmm_load")]
pub fn gmm_load(path: PathBuf) -> PyResult<Mixture> {
    let file = path.display().to_string();
    let text = stokes::io::input::read_text(&path, stokes::io::input::GMM_MODEL)
        .map_err(|m| input_error(&m, Some(&file), None, &m))?;
    let f = GmmFile::parse(&text).map_err(|m| {
        input_error(
            &format!("malformed GMM file '{file}': {m}"),
            Some(&file),
            None,
            &m,
        )
    })?;
    Ok(Mixture::new(f))
}
