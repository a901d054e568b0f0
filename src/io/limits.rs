//! Render limits: the largest image, sample count, time budget and thread count a scene, an
//! experiment config or a command line may ask for, checked before anything is allocated.

/// Largest image side and pixel count (the film holds at least 48 bytes per pixel).
pub const MAX_SIDE: u32 = 16_384;
pub const MAX_PIXELS: u64 = 1 << 26;

/// Most worker threads (`threads`, and `--threads` of `stokes render`).
pub const MAX_THREADS: usize = 1024;
/// Most samples per pixel of a budget or a reference.
pub const MAX_SPP: u32 = 1 << 24;
/// Longest time budget, seconds.
pub const MAX_SECONDS: f64 = 1e7;
