//! Errors as Python sees them: bad input is `stokes.InputError` (a `ValueError`) with the file
//! and the field path the command line prints; failures while running are `RuntimeError`; a
//! cancelled render is `KeyboardInterrupt`.

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    stokes,
    InputError,
    PyValueError,
    "Bad input: a scene, config, option or data file that cannot be used.\n\n\
     Attributes: ``file`` (the file, or None), ``field`` (the JSON path or option name of the \
     offending field, or None) and ``message`` (what is wrong). ``str(e)`` is the command \
     line's message."
);

/// An `InputError` with its attributes set.
pub fn input_error(text: &str, file: Option<&str>, field: Option<&str>, message: &str) -> PyErr {
    Python::attach(|py| {
        let e = InputError::new_err(text.to_string());
        let v = e.value(py);
        let set = |k: &str, x: Option<&str>| v.setattr(k, x.map(str::to_string));
        if let Err(err) = set("file", file)
            .and_then(|()| set("field", field))
            .and_then(|()| v.setattr("message", message.to_string()))
        {
            return err;
        }
        e
    })
}

/// From the library's structured input error.
pub fn from_input(e: &stokes::io::InputError) -> PyErr {
    let file = e.file.display().to_string();
    let field = (!e.path.is_empty()).then_some(e.path.as_str());
    input_error(&e.to_string(), Some(&file), field, &e.message)
}

/// From the library's error: bad input becomes `InputError`, with the file and field read back
/// from the message when it has the form `FILE: field `PATH`: MESSAGE`; the rest `RuntimeError`.
pub fn from_error(e: &stokes::Error) -> PyErr {
    match e.kind {
        stokes::ErrorKind::Input => {
            let m = &e.message;
            match m.split_once(": field `").and_then(|(file, rest)| {
                let (field, msg) = rest.split_once("`: ")?;
                Some((file, field, msg))
            }) {
                Some((file, field, msg)) => input_error(m, Some(file), Some(field), msg),
                None => input_error(m, None, None, m),
            }
        }
        stokes::ErrorKind::Runtime => PyRuntimeError::new_err(e.message.clone()),
    }
}

/// An option given to a function: `InputError` naming the option.
pub fn option_error(option: &str, message: impl std::fmt::Display) -> PyErr {
    let message = message.to_string();
    input_error(
        &format!("option `{option}`: {message}"),
        None,
        Some(option),
        &message,
    )
}

/// The error of a render's library call: a cancelled render is `KeyboardInterrupt`.
pub fn from_render(e: String) -> PyErr {
    if e == stokes::integrator::CANCELLED {
        PyKeyboardInterrupt::new_err("the render was interrupted")
    } else {
        input_error(&e, None, None, &e)
    }
}
