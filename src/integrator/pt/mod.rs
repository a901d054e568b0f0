//! Uni-directional path tracers (Mojzík §6): one random walk, [`walk::Walk`], generic over the
//! number of wavelengths a path carries. `pt-mono` is the walk with one lane, `pt-hero` the same
//! walk with N hero-rotated lanes.

pub mod hero;
pub mod mono;
pub mod walk;

pub use hero::PtHero;
pub use mono::PtMono;
