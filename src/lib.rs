//! stokes: a research testbed for fluorescence in spectral light transport.
// `!(x > 0.0)` deliberately rejects NaN too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// A build without fluorescence or media exists only to measure what they cost
// (docs/performance.md); what it leaves unused is not worth a warning.
#![cfg_attr(
    not(all(feature = "fluorescence", feature = "media")),
    allow(unused, clippy::ptr_arg)
)]
pub mod cli;
pub mod error;
pub mod experiment;
pub mod film;
pub mod geometry;
pub mod gmm;
pub mod integrator;
pub mod io;
pub mod material;
pub mod medium;
pub mod scene;
pub mod spectrum;
pub mod transport;

pub use error::{Error, ErrorKind};
