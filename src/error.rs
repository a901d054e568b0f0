//! The library's error type: a message and whether it came from bad input or from a failure
//! while running. The command line maps the kind to the exit code (2 and 1).

use std::fmt;

/// Whether the user can fix the error by changing the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// Bad input: a config, scene, option or file the user gave (exit code 2).
    Input,
    /// A failure while running, e.g. a file that cannot be written (exit code 1).
    Runtime,
}

#[derive(Clone, Debug)]
pub struct Error {
    pub kind: ErrorKind,
    pub message: String,
}

impl Error {
    pub fn input(m: impl Into<String>) -> Self {
        Error {
            kind: ErrorKind::Input,
            message: m.into(),
        }
    }

    pub fn runtime(m: impl Into<String>) -> Self {
        Error {
            kind: ErrorKind::Runtime,
            message: m.into(),
        }
    }

    /// Process exit code: 2 for bad input, 1 for failures while running.
    pub fn exit_code(&self) -> u8 {
        match self.kind {
            ErrorKind::Input => 2,
            ErrorKind::Runtime => 1,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl From<crate::io::InputError> for Error {
    fn from(e: crate::io::InputError) -> Self {
        Error::input(e.to_string())
    }
}
