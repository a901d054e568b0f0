//! The compiled half of the Python package `stokes` (`stokes._stokes`): scenes and renders,
//! experiment runs, Gaussian-mixture fits and the CIE observer, over the same library the
//! command line uses. The pure-Python half (`python/stokes/`) re-exports these names, shapes
//! arrays and carries the docstrings users read first.

mod errors;
mod experiment;
mod gmm;
mod json;
mod render;
mod spectrum;
mod wait;

use pyo3::prelude::*;

/// The command line's allocator, so that renders from Python allocate as the CLI's do.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[pymodule]
fn _stokes(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("InputError", py.get_type::<errors::InputError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<render::Scene>()?;
    m.add_class::<render::Render>()?;
    m.add_function(wrap_pyfunction!(render::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(render::read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(render::integrators, m)?)?;
    m.add_function(wrap_pyfunction!(render::default_options, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::run_experiment, m)?)?;
    m.add_function(wrap_pyfunction!(experiment::load_run, m)?)?;
    m.add_class::<gmm::Mixture>()?;
    m.add_function(wrap_pyfunction!(gmm::gmm_fit, m)?)?;
    m.add_function(wrap_pyfunction!(gmm::gmm_load, m)?)?;
    m.add_function(wrap_pyfunction!(spectrum::cie_xyz, m)?)?;
    m.add_function(wrap_pyfunction!(spectrum::xyz_to_srgb_matrix, m)?)?;
    Ok(())
}
