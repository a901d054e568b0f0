//! Experiment runs from Python: run a config (a file or a dict) as `stokes experiment` does,
//! and read a stored run folder back, checked as the CLI checks it before trusting it.

use crate::errors::{from_error, input_error};
use crate::json;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use stokes::experiment::record::{Row, check_complete, read_metrics};

/// _run_experiment(config, quick=False, out=None, base_dir=None) -> str
///
/// Run an experiment config and return its run folder.
#[pyfunction]
#[pyo3(signature = (config, quick=false, out=None, base_dir=None))]
pub fn run_experiment(
    py: Python<'_>,
    config: &Bound<'_, PyAny>,
    quick: bool,
    out: Option<PathBuf>,
    base_dir: Option<PathBuf>,
) -> PyResult<PathBuf> {
    let (path, text) = if config.is_instance_of::<PyDict>() {
        let text = json::dumps(config).map_err(|e| {
            let m = format!("the config dict is not JSON: {e}");
            input_error(&m, None, None, &m)
        })?;
        let name = config
            .get_item("name")
            .ok()
            .and_then(|n| n.extract::<String>().ok())
            .filter(|n| !n.is_empty() && !n.contains(['/', '\\']))
            .unwrap_or_else(|| "config".into());
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        (base.join(format!("<{name}>.json")), Some(text))
    } else {
        if base_dir.is_some() {
            let m =
                "base_dir is for configs given as a dict; a file's paths resolve from its folder";
            return Err(input_error(m, None, Some("base_dir"), m));
        }
        (config.extract::<PathBuf>()?, None)
    };
    let run = crate::wait::run(
        py,
        move |cancel, _tx: std::sync::mpsc::Sender<()>| {
            let src = stokes::experiment::Source {
                path: &path,
                text: text.as_deref(),
                cancel: Some(cancel),
            };
            stokes::experiment::run_experiment_from(&src, out.as_deref(), quick)
        },
        |_, ()| Ok(()),
    )?;
    run.map_err(|e| {
        if e.message.ends_with(stokes::integrator::CANCELLED) {
            pyo3::exceptions::PyKeyboardInterrupt::new_err(
                "the experiment was interrupted; its run folder keeps the marker of an incomplete run",
            )
        } else {
            from_error(&e)
        }
    })
}

/// _load_run(path) -> dict
///
/// Read a stored run folder (or an experiment folder, through its `latest`): the record
/// (`run.json`), the metrics rows, the summary and the paths of its images and figures.
#[pyfunction]
pub fn load_run<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let err = |e: stokes::Error| from_error(&e);
    check_complete(&path).map_err(err)?;
    let run = stokes::experiment::figures::resolve_run_dir(&path).map_err(err)?;
    check_complete(&run).map_err(err)?;
    stokes::io::tree::check_run_folder(&run).map_err(|m| input_error(&m, None, None, &m))?;
    let d = PyDict::new(py);
    d.set_item("path", &run)?;
    d.set_item("info", read_record(py, &run.join("run.json"))?)?;
    if run.join("sweep.json").is_file() {
        // a sweep: one run folder per value, under sweep/<index>/
        d.set_item("sweep", read_record(py, &run.join("sweep.json"))?)?;
        d.set_item("points", files(&run.join("sweep"), |p| p.is_dir())?)?;
        d.set_item("metrics", PyList::empty(py))?;
        d.set_item("summary", PyList::empty(py))?;
    } else {
        stokes::experiment::RunInfo::read(&run).map_err(err)?;
        let rows = read_metrics(&run.join("metrics.csv")).map_err(err)?;
        let list = PyList::empty(py);
        for r in &rows {
            list.append(row_dict(py, r)?)?;
        }
        d.set_item("metrics", list)?;
        // every complete run writes it: a missing one is a broken folder, as for the report
        d.set_item("summary", read_record(py, &run.join("summary.json"))?)?;
        d.set_item("points", PyList::empty(py))?;
    }
    let is_image = |p: &Path| stokes::io::output::has_extension(p, "exr");
    d.set_item("images", files(&run.join("images"), is_image)?)?;
    let reference = run.join("reference.exr");
    d.set_item("reference", reference.is_file().then_some(reference))?;
    d.set_item("figures", files(&run.join("figures"), |p| p.is_file())?)?;
    let report = run.join("report.html");
    d.set_item("report", report.is_file().then_some(report))?;
    Ok(d)
}

/// A JSON record of a run folder (`run.json`, `summary.json`, `sweep.json`), read as the CLI
/// reads it (a regular file within the record size cap) and parsed; errors name the file.
fn read_record<'py>(py: Python<'py>, path: &Path) -> PyResult<Bound<'py, PyAny>> {
    let file = path.display().to_string();
    let text = stokes::io::input::read_text(path, stokes::io::input::RUN_RECORD)
        .map_err(|m| input_error(&m, Some(&file), None, &m))?;
    json::loads(py, &text).map_err(|e| {
        let m = format!("not JSON: {e}");
        input_error(&format!("{file}: {m}"), Some(&file), None, &m)
    })
}

/// The entries of `dir` that pass `keep`, sorted by name (none when `dir` is missing).
fn files(dir: &Path, keep: impl Fn(&Path) -> bool) -> PyResult<Vec<PathBuf>> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Ok(Vec::new());
    };
    let mut v: Vec<PathBuf> = rd.flatten().map(|e| e.path()).filter(|p| keep(p)).collect();
    v.sort();
    Ok(v)
}

/// One row of metrics.csv as a dict, its columns in the file's order.
fn row_dict<'py>(py: Python<'py>, r: &Row) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("variant", &r.variant)?;
    d.set_item("integrator", &r.integrator)?;
    d.set_item("mode", &r.mode)?;
    d.set_item("budget", r.budget)?;
    d.set_item("repeat", r.repeat)?;
    d.set_item("seed", r.seed)?;
    d.set_item("spp", r.spp)?;
    d.set_item("seconds", r.seconds)?;
    d.set_item("samples_per_second", r.samples_per_second)?;
    d.set_item("region", &r.region)?;
    d.set_item("pixels", r.pixels)?;
    d.set_item("mse", r.mse)?;
    d.set_item("rel_mse", r.rel_mse)?;
    d.set_item("snr_db", r.snr_db)?;
    d.set_item("efficiency", r.efficiency)?;
    Ok(d)
}
