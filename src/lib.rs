//! stokes: a research testbed for fluorescence in spectral light transport.
#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` deliberately rejects NaN too.
pub mod cli;
pub mod error;
pub mod experiment;
pub mod film;
pub mod geometry;
pub mod gmm;
pub mod integrator;
pub mod material;
pub mod medium;
pub mod scene;
pub mod spectrum;
pub mod transport;

pub use error::{Error, ErrorKind};
