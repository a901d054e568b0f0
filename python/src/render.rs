//! `Scene` and `Render`: a scene loaded from a file or a dict, rendered by any integrator into
//! NumPy arrays, saved as the command line's EXR.

use crate::errors::{from_input, from_render, input_error, option_error};
use crate::json;
use numpy::{PyArray1, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use stokes::film::Film;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderOutput, RenderSettings};
use stokes::io::limits::{MAX_SECONDS, MAX_SPP, MAX_THREADS};

/// A scene ready to render: parsed, checked and with its BVH built.
#[pyclass(module = "stokes", frozen)]
pub struct Scene {
    inner: Arc<stokes::scene::Scene>,
    /// The file (or the name given to a dict): errors name it, relative paths resolve from it.
    path: PathBuf,
    /// The JSON text that was parsed (its hash goes into saved EXRs, as the CLI's).
    text: String,
}

/// Parse `text` as the scene file `path`, without the GIL (the BVH build runs in parallel).
fn parse(py: Python<'_>, path: &Path, text: String) -> PyResult<Scene> {
    let scene = py
        .detach(|| stokes::scene::Scene::from_str(path, &text))
        .map_err(|e| from_input(&e))?;
    Ok(Scene {
        inner: Arc::new(scene),
        path: path.to_path_buf(),
        text,
    })
}

/// load_scene(path) -> Scene
///
/// Load a scene file (JSON, docs/scene-format.md). Raises InputError naming the file and the
/// field when the scene is malformed.
#[pyfunction]
pub fn load_scene(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
    let text = stokes::io::input::read_text(&path, stokes::io::input::SCENE).map_err(|e| {
        let file = path.display().to_string();
        input_error(
            &format!("{file}: cannot read the scene: {e}"),
            Some(&file),
            None,
            &format!("cannot read the scene: {e}"),
        )
    })?;
    parse(py, &path, text)
}

#[pymethods]
impl Scene {
    /// Scene.from_dict(d, base_dir=None, name=None) -> Scene
    ///
    /// A scene from its JSON as a Python dict, e.g. a loaded file with one parameter changed.
    /// Relative paths in it (meshes, spectra, matrices) resolve from ``base_dir`` (default: the
    /// current folder); ``name`` (default ``"<dict>.json"``) names it in errors.
    #[staticmethod]
    #[pyo3(signature = (d, base_dir=None, name=None))]
    fn from_dict(
        py: Python<'_>,
        d: &Bound<'_, PyAny>,
        base_dir: Option<PathBuf>,
        name: Option<String>,
    ) -> PyResult<Scene> {
        if !d.is_instance_of::<PyDict>() {
            return Err(input_error(
                "Scene.from_dict: the scene must be a dict (a JSON object)",
                None,
                None,
                "the scene must be a dict (a JSON object)",
            ));
        }
        let text = json::dumps(d).map_err(|e| {
            let m = format!("the dict is not JSON: {e}");
            input_error(&format!("Scene.from_dict: {m}"), None, None, &m)
        })?;
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let path = base.join(name.unwrap_or_else(|| "<dict>.json".into()));
        parse(py, &path, text)
    }

    /// The scene's JSON as a dict (edit it and pass it to ``Scene.from_dict``, with
    /// ``base_dir`` the folder of ``path``).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::loads(py, &self.text)
    }

    /// The scene file (or the name a dict scene was given).
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// Image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.inner.camera.width
    }

    /// Image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.inner.camera.height
    }

    /// What the scene loader warned about (the CLI prints these).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.inner.warnings.clone()
    }

    /// The wavelength range the camera integrates, (min, max) in nm.
    #[getter]
    fn wavelength_range(&self) -> (f32, f32) {
        let r = self.inner.observer.range;
        (r.min, r.max)
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene('{}', {}x{})",
            self.path.display(),
            self.inner.camera.width,
            self.inner.camera.height
        )
    }

    /// Render the scene; the same image as ``stokes render`` with the same arguments.
    ///
    /// Args:
    ///     integrator: one of ``stokes.integrators()``: pt-mono, pt-hero, bdpt-forward,
    ///         bdpt-backward, bdpt-combined, bdpt-allbins.
    ///     spp: samples per pixel (at most; see ``time_limit`` and ``progress``).
    ///     seed: the image is a function of (scene, integrator, options, seed, spp), whatever
    ///         the thread count.
    ///     threads: worker threads (default: every core).
    ///     max_depth: maximum number of path segments.
    ///     time_limit: stop after the pass during which this many seconds have passed.
    ///     spectral: also make a spectral image of this many bins over the camera's range
    ///         (``Render.spectral``; not with bdpt-allbins).
    ///     progress: a callable ``progress(done_spp, spp, seconds)`` called after every pass
    ///         (return False to stop early), or True for the CLI's progress bar on a terminal.
    ///     **options: integrator options by their config names, e.g. ``lanes=8``,
    ///         ``mis="power"``, ``camera_wavelengths="cmf"``, ``reset_choice="random"``
    ///         (``stokes.default_options()`` lists them with their defaults).
    ///
    /// The GIL is released while it renders, so other Python threads run (and render).
    /// Ctrl-C stops the render within one row of pixels and raises KeyboardInterrupt. Bad
    /// arguments raise InputError with ``field`` naming the argument or option.
    #[pyo3(signature = (integrator="pt-hero", spp=64, seed=0, threads=None, max_depth=8,
                        time_limit=None, spectral=None, progress=None, **options))]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &self,
        py: Python<'_>,
        integrator: &str,
        spp: i64,
        seed: i128,
        threads: Option<i64>,
        max_depth: i64,
        time_limit: Option<f64>,
        spectral: Option<i64>,
        progress: Option<Bound<'_, PyAny>>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Render> {
        let kind = parse_integrator(integrator)?;
        let spp = in_range("spp", spp, 1, MAX_SPP as i64)? as u32;
        let seed = u64::try_from(seed)
            .map_err(|_| option_error("seed", format!("must be 0–{}, got {seed}", u64::MAX)))?;
        let threads = threads
            .map(|t| in_range("threads", t, 1, MAX_THREADS as i64))
            .transpose()?
            .map(|t| t as usize);
        let max_depth = in_range("max_depth", max_depth, 1, u32::MAX as i64)? as u32;
        if let Some(t) = time_limit
            && !(t > 0.0 && t <= MAX_SECONDS)
        {
            return Err(option_error(
                "time_limit",
                format!(
                    "must be a positive, finite number of seconds (at most {MAX_SECONDS:e}), got {t}"
                ),
            ));
        }
        let spectral = spectral
            .map(|n| in_range("spectral", n, 1, stokes::film::spectral::MAX_BINS as i64))
            .transpose()?
            .map(|n| n as usize);
        if spectral.is_some() {
            kind.spectral_support()
                .map_err(|m| option_error("spectral", m))?;
        }
        let opts = integrator_options(max_depth, options)?;
        opts.validate_for(kind).map_err(|m| {
            // the message starts with the option's name
            let name = m.split_whitespace().next().unwrap_or("");
            let known = serde_json::to_value(&opts)
                .ok()
                .is_some_and(|v| v.get(name).is_some() || name == "reset_choice");
            if known {
                input_error(&format!("option {m}"), None, Some(name), &m)
            } else {
                input_error(&format!("option {m}"), None, None, &m)
            }
        })?;
        let (callback, bar) = match &progress {
            None => (None, false),
            Some(p) if p.is_callable() => (Some(p.clone().unbind()), false),
            Some(p) => (None, p.is_truthy()?),
        };
        let keep_going = Arc::new(AtomicBool::new(true));
        let scene = self.inner.clone();
        let kg = keep_going.clone();
        let want_passes = callback.is_some();
        let render_opts = opts.clone();
        let out = crate::wait::run(
            py,
            move |cancel, tx| {
                let settings = RenderSettings {
                    first_sample: 0,
                    spp,
                    seed,
                    threads,
                    time_limit,
                    progress: bar,
                    spectral,
                    cancel: Some(cancel),
                };
                // a pass callback only when Python asked for progress: without one the render
                // loop is the CLI's exactly
                let mut on_pass = move |film: &Film, _: &stokes::integrator::Stats, secs: f64| {
                    let _ = tx.send((film.spp, secs));
                    kg.load(Ordering::Relaxed)
                };
                let cb: Option<&mut stokes::integrator::render::PassCallback> = if want_passes {
                    Some(&mut on_pass)
                } else {
                    None
                };
                stokes::integrator::render(&scene, kind, &render_opts, &settings, cb)
            },
            |py, (done, secs): (u32, f64)| {
                if let Some(cb) = &callback {
                    let r = cb.bind(py).call1((done, spp, secs))?;
                    // returning False stops the render after this pass, as a time limit does
                    if !r.is_none() && !r.is_truthy()? {
                        keep_going.store(false, Ordering::Relaxed);
                    }
                }
                Ok(())
            },
        )?
        .map_err(from_render)?;
        Ok(Render::new(self, kind, opts, seed, out))
    }
}

/// An integrator's name, or `InputError` listing the names.
fn parse_integrator(name: &str) -> PyResult<IntegratorKind> {
    IntegratorKind::ALL
        .into_iter()
        .find(|k| k.name() == name)
        .ok_or_else(|| {
            let names: Vec<&str> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
            option_error(
                "integrator",
                format!("unknown integrator {name:?}; one of {}", names.join(", ")),
            )
        })
}

fn in_range(option: &str, v: i64, lo: i64, hi: i64) -> PyResult<i64> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(option_error(option, format!("must be {lo}–{hi}, got {v}")))
    }
}

/// The integrator options: the defaults, `max_depth`, then the keyword options by their JSON
/// names (`lanes=8`, `mis="power"`, …), checked as a config's `options` are.
fn integrator_options(
    max_depth: u32,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<IntegratorOptions> {
    let mut v = serde_json::to_value(IntegratorOptions {
        max_depth,
        ..Default::default()
    })
    .expect("options serialise");
    if let Some(d) = options {
        for (k, val) in d.iter() {
            let key: String = k.extract()?;
            let text = json::dumps(&val)
                .map_err(|e| option_error(&key, format!("the value is not JSON: {e}")))?;
            let j: serde_json::Value = serde_json::from_str(&text)
                .map_err(|e| option_error(&key, format!("the value is not JSON: {e}")))?;
            v[key.as_str()] = j;
        }
    }
    let mut track = serde_path_to_error::Track::new();
    let de = serde_path_to_error::Deserializer::new(&v, &mut track);
    <IntegratorOptions as serde::Deserialize>::deserialize(de).map_err(|e| {
        let field = track.path().to_string();
        let msg = e.to_string();
        if field.is_empty() || field == "." {
            input_error(&format!("options: {msg}"), None, None, &msg)
        } else {
            option_error(&field, msg)
        }
    })
}

/// default_options() -> dict
///
/// The integrator options and their defaults, as ``Scene.render`` takes them by keyword.
#[pyfunction]
pub fn default_options<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
    let v = serde_json::to_value(IntegratorOptions::default()).expect("options serialise");
    json::to_py(py, &v)
}

/// integrators() -> list[str]
///
/// The names of the integrators.
#[pyfunction]
pub fn integrators() -> Vec<&'static str> {
    IntegratorKind::ALL.iter().map(|k| k.name()).collect()
}

/// The result of ``Scene.render``.
#[pyclass(module = "stokes", frozen)]
pub struct Render {
    film: Film,
    stats: serde_json::Value,
    seconds: f64,
    kind: IntegratorKind,
    opts: IntegratorOptions,
    seed: u64,
    scene_path: PathBuf,
    scene_text: String,
    sensor: String,
}

impl Render {
    fn new(
        scene: &Scene,
        kind: IntegratorKind,
        opts: IntegratorOptions,
        seed: u64,
        out: RenderOutput,
    ) -> Render {
        let stats = out.stats_json(kind, &opts);
        Render {
            stats,
            seconds: out.seconds,
            film: out.film,
            kind,
            opts,
            seed,
            scene_path: scene.path.clone(),
            scene_text: scene.text.clone(),
            sensor: sensor_label(&scene.inner),
        }
    }

    fn info(&self) -> stokes::film::shard::ShardInfo {
        stokes::integrator::shard_info(
            &self.scene_path,
            &self.scene_text,
            self.kind,
            &self.opts,
            self.seed,
            (0, self.film.spp),
        )
    }
}

/// What the camera integrates, for a spectral EXR's `stokes.sensor` (as the CLI writes it).
fn sensor_label(scene: &stokes::scene::Scene) -> String {
    let r = scene.observer.range;
    match scene.observer.sensor_response() {
        None => format!("cie-1931 over [{}, {}] nm", r.min, r.max),
        Some(stokes::spectrum::Spectrum::Box { .. }) => format!("band [{}, {}] nm", r.min, r.max),
        Some(_) => format!("response curve over [{}, {}] nm", r.min, r.max),
    }
}

/// A new H×W×C float32 array (C-contiguous, owning its memory) filled from `values`.
pub fn image<'py>(
    py: Python<'py>,
    (h, w, c): (usize, usize, usize),
    values: impl Iterator<Item = f32>,
) -> Bound<'py, PyArray3<f32>> {
    let a = PyArray3::<f32>::zeros(py, [h, w, c], false);
    // SAFETY: the array was just created here and is not shared yet
    let s = unsafe { a.as_slice_mut() }.expect("a new array is contiguous");
    for (d, v) in s.iter_mut().zip(values) {
        *d = v;
    }
    a
}

fn vec3s(v: &[glam::Vec3]) -> impl Iterator<Item = f32> + '_ {
    v.iter().flat_map(|p| [p.x, p.y, p.z])
}

/// Check an output path as the CLI checks its own: the extension and a writable regular file.
fn output_path(p: &Path, ext: &str, what: &str) -> PyResult<PathBuf> {
    let file = p.display().to_string();
    if !stokes::io::output::has_extension(p, ext) {
        let m = format!("{what} is written as {ext}, so its name must end in .{ext}");
        return Err(input_error(
            &format!("'{file}': {m}"),
            Some(&file),
            None,
            &m,
        ));
    }
    stokes::io::output::check_output(p)
        .map_err(|m| input_error(&format!("'{file}': {m}"), Some(&file), None, &m))
}

#[pymethods]
impl Render {
    /// The image in linear sRGB (D65): an H×W×3 float32 array, a new copy on each access.
    #[getter]
    fn rgb<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        image(py, (h, w, 3), vec3s(&self.film.rgb()))
    }

    /// The image in CIE XYZ: an H×W×3 float32 array, a new copy on each access.
    #[getter]
    fn xyz<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        image(py, (h, w, 3), vec3s(&self.film.xyz()))
    }

    /// The spectral image asked for with ``render(spectral=N)``: an H×W×N float32 array of each
    /// bin's mean spectral radiance; None without one.
    #[getter]
    fn spectral<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f32>>> {
        let sf = self.film.spectral.as_ref()?;
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        let v = sf.values(self.film.spp);
        Some(image(py, (h, w, sf.bins.n), v.into_iter()))
    }

    /// The centres of the spectral image's bins in nm (float64, length N); None without one.
    #[getter]
    fn wavelengths<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        let sf = self.film.spectral.as_ref()?;
        let c: Vec<f64> = (0..sf.bins.n).map(|b| sf.bins.centre(b)).collect();
        Some(PyArray1::from_vec(py, c))
    }

    /// The bins' edges in nm (float64, length N + 1); None without a spectral image.
    #[getter]
    fn wavelength_edges<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        let b = self.film.spectral.as_ref()?.bins;
        let step = (b.max as f64 - b.min as f64) / b.n as f64;
        let e: Vec<f64> = (0..=b.n).map(|i| b.min as f64 + step * i as f64).collect();
        Some(PyArray1::from_vec(py, e))
    }

    /// The render's statistics (the CLI's ``--stats`` JSON): integrator, options, spp,
    /// seconds, samples and rays per second, rejected NaN/Inf samples, contributing paths.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_py(py, &self.stats)
    }

    /// With ``strategy_images=True`` (the BDPT integrators): each strategy's weighted
    /// contribution as a dict ``{"s<i>_t<j>": (H, W, 3) float32 linear sRGB}`` (the CLI's
    /// ``--strategy-images``; they sum to ``rgb``); an empty dict otherwise.
    #[getter]
    fn strategy_images<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        for (i, name) in self.film.aux_names.iter().enumerate() {
            d.set_item(name, image(py, (h, w, 3), vec3s(&self.film.aux_rgb(i))))?;
        }
        Ok(d)
    }

    /// Samples per pixel rendered (fewer than asked for when a time limit or the progress
    /// callback stopped the render).
    #[getter]
    fn spp(&self) -> u32 {
        self.film.spp
    }

    /// Wall-clock seconds of rendering (scene loading excluded).
    #[getter]
    fn seconds(&self) -> f64 {
        self.seconds
    }

    /// The integrator's name.
    #[getter]
    fn integrator(&self) -> &'static str {
        self.kind.name()
    }

    /// The integrator options the render used (all of them, defaults included).
    #[getter]
    fn options<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = serde_json::to_value(&self.opts).expect("options serialise");
        json::to_py(py, &v)
    }

    /// The seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// save_exr(path)
    ///
    /// Write the image as the CLI's ``render -o`` does: linear sRGB, float32, with the scene's
    /// hash, the integrator, its options, the seed and the sample range as attributes.
    fn save_exr(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let p = output_path(&path, "exr", "the image")?;
        let info = self.info();
        py.detach(|| stokes::film::shard::write_film(&p, &self.film, &info, false))
            .map_err(pyo3::exceptions::PyOSError::new_err)
    }

    /// save_spectral_exr(path)
    ///
    /// Write the spectral image as the CLI's ``--spectral`` does (channels ``S0.<λ>nm``, the
    /// layout of Fichet et al. 2021). Raises ValueError when the render made none.
    fn save_spectral_exr(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let Some(sf) = &self.film.spectral else {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "this render has no spectral image: render with spectral=N",
            ));
        };
        let p = output_path(&path, "exr", "the spectral image")?;
        let mut extra = stokes::film::shard::attributes(&self.info());
        extra.push(("stokes.sensor".to_string(), self.sensor.clone()));
        let (w, h) = (self.film.width, self.film.height);
        let rgb = self.film.rgb();
        py.detach(|| {
            let values = sf.values(self.film.spp);
            stokes::film::spectral::write_spectral_exr(&p, (w, h), &sf.bins, &values, &rgb, &extra)
        })
        .map_err(pyo3::exceptions::PyOSError::new_err)
    }

    /// save_png(path, exposure=0.0)
    ///
    /// Write an sRGB PNG preview, as the CLI's ``--png`` (``exposure`` in stops).
    #[pyo3(signature = (path, exposure=0.0))]
    fn save_png(&self, path: PathBuf, exposure: f32) -> PyResult<()> {
        let p = output_path(&path, "png", "the preview")?;
        stokes::film::write_png(
            &p,
            self.film.width,
            self.film.height,
            &self.film.rgb(),
            exposure,
        )
        .map_err(pyo3::exceptions::PyOSError::new_err)
    }

    fn __repr__(&self) -> String {
        format!(
            "Render({}, {}x{}, {} spp, {:.3} s)",
            self.kind.name(),
            self.film.width,
            self.film.height,
            self.film.spp,
            self.seconds
        )
    }
}

/// read_exr(path) -> numpy.ndarray
///
/// Read an RGB OpenEXR (e.g. one the CLI wrote) as an H×W×3 float32 array.
#[pyfunction]
pub fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let (w, h, px) = py
        .detach(|| stokes::film::output::read_exr(&path))
        .map_err(|m| {
            let file = path.display().to_string();
            input_error(&m, Some(&file), None, &m)
        })?;
    Ok(image(py, (h as usize, w as usize, 3), vec3s(&px)))
}
