//! Input errors that name the file, the JSON path of the field and what is wrong.

use std::fmt;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone)]
pub struct InputError {
    pub file: PathBuf,
    /// JSON path of the offending field (e.g. `materials.wall.concentration`), empty for the file.
    pub path: String,
    pub message: String,
}

impl InputError {
    pub fn new(file: &Path, path: impl Into<String>, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            path: path.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "{}: {}", self.file.display(), self.message)
        } else {
            write!(
                f,
                "{}: field `{}`: {}",
                self.file.display(),
                self.path,
                self.message
            )
        }
    }
}

impl std::error::Error for InputError {}

/// Deserialize `T` from JSON text with the JSON path of any error.
pub fn from_json_str<T: serde::de::DeserializeOwned>(
    file: &Path,
    text: &str,
) -> Result<T, InputError> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let path = if path == "." { String::new() } else { path };
        InputError::new(file, path, format!("{inner}"))
    })
}

/// Deserialize `T` from a JSON value found at `base` within `file`.
pub fn from_json_value<T: serde::de::DeserializeOwned>(
    file: &Path,
    base: &str,
    v: &serde_json::Value,
) -> Result<T, InputError> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let p = e.path().to_string();
        let inner = e.into_inner();
        let path = if p == "." {
            base.to_string()
        } else {
            format!("{base}.{p}")
        };
        InputError::new(file, path, format!("{inner}"))
    })
}
