//! Files, the lowest layer: every file stokes reads is opened through [`input`] (a regular file
//! within a size cap, never a FIFO, device or folder), every file it writes goes through
//! [`output`] (checked before any work, written to a temporary file and renamed, never over
//! anything but a regular file), run folders and results roots are checked by [`tree`] before
//! anything is written into them (no links, no special files), and [`text`] makes untrusted
//! strings safe for a terminal and for EXR text attributes (docs/hardening.md). JSON inputs are
//! read by [`json`] into types, with errors ([`InputError`]) naming the file and the JSON path
//! of the field; [`limits`] bounds what a render may ask for (image size, samples, time,
//! threads), and [`hash`] gives content hashes that are stable across builds.

pub mod error;
pub mod hash;
pub mod input;
pub mod json;
pub mod limits;
pub mod output;
pub mod text;
pub mod tree;

pub use error::InputError;
