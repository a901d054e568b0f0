//! Participating media (Mojzík 2018 §5–7): homogeneous and grid media whose collisions may shift
//! wavelengths, their coefficients (Table 1) and the distance-tracking schemes.
//!
//! - [`coefficients`]: σa, σs and the fluorophore; σ̂t, σ̂s and the in-shift draw.
//! - [`tracking`]: exponential, max hot-fix and fluorescence-aware free flights (eq. 6).
//! - [`grid`]: density grids read from Mitsuba `.vol` files, the majorant grid and its DDA.

pub mod coefficients;
pub mod grid;
pub mod tracking;

pub use coefficients::{Coefficients, CollisionCoefficients, Fluorophore, InShift};
pub use tracking::{Flight, FreeFlight, MixtureFlight, Tracking};

/// A medium: its coefficients per unit density, its phase function and its density.
#[derive(Clone, Debug)]
pub struct Medium {
    pub coefficients: Coefficients,
    /// Henyey–Greenstein asymmetry (0: isotropic).
    pub g: f32,
    pub density: Density,
}

/// Where the medium's density comes from.
#[derive(Clone, Debug)]
pub enum Density {
    /// Density 1 everywhere inside the medium's boundary.
    Homogeneous,
    /// A density grid, its majorant grid and a scale (Mitsuba's `gridvolume` times `scale`).
    Grid(Box<GridDensity>),
}

/// A heterogeneous density: `scale` × the trilinear grid, 0 outside its bounding box.
#[derive(Clone, Debug)]
pub struct GridDensity {
    pub grid: grid::DensityGrid,
    pub majorant: grid::MajorantGrid,
    pub scale: f32,
}

impl GridDensity {
    pub fn new(grid: grid::DensityGrid, scale: f32) -> Self {
        let majorant = grid::MajorantGrid::new(&grid, grid::MAJORANT_RES);
        GridDensity {
            grid,
            majorant,
            scale,
        }
    }
}
