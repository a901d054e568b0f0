//! JSON values between Rust and Python, through Python's own `json` module: what a dict holds
//! reaches the library exactly as the same JSON file would.

use pyo3::prelude::*;

/// A Python object (dict, list, number, …) as JSON text.
pub fn dumps(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    let json = obj.py().import("json")?;
    let kwargs = pyo3::types::PyDict::new(obj.py());
    // NaN and infinities are not JSON: refused, as in a file
    kwargs.set_item("allow_nan", false)?;
    json.call_method("dumps", (obj,), Some(&kwargs))?.extract()
}

/// JSON text as a Python object.
pub fn loads<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// A JSON value as a Python object.
pub fn to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    loads(py, &v.to_string())
}
