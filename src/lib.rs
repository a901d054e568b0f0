//! stokes: a research testbed for fluorescence in spectral light transport.
pub mod cli;
pub mod experiment;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod material;
pub mod scene;
pub mod spectrum;
