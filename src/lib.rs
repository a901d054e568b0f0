//! stokes: a research testbed for fluorescence in spectral light transport.
pub mod geometry;
pub mod spectrum;
pub mod material;
pub mod scene;
pub mod film;
