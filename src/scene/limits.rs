//! The limits a scene must keep, checked before anything is allocated or computed from the
//! numbers: sizes that drive an allocation, and magnitudes that single-precision ray tracing
//! and radiance arithmetic cannot carry. docs/scene-format.md lists them; the image's size is
//! bounded by the render limits of [`crate::io::limits`].

/// Largest wavelength of the domain, nm. Spectra are tabulated in 1-nm cells over the domain
/// (light and fluorescence sampling tables), so the domain's width sizes allocations.
pub const MAX_WAVELENGTH: f32 = 10_000.0;

/// Largest absolute coordinate of any point, and largest sphere radius, in scene units. Ray
/// tracing works in f32: bounding-box areas, cross products and triple products of coordinate
/// differences must stay finite (f32 overflows at 3.4e38).
pub const MAX_COORD: f32 = 1e9;

/// Smallest triangle area: below it the geometric normal underflows in f32 and 1/area (the
/// light's area pdf) loses precision or overflows.
pub const MIN_AREA: f32 = 1e-15;

/// Smallest sphere radius (its area stays above [`MIN_AREA`]).
pub const MIN_RADIUS: f32 = 1e-7;

/// Largest emitted spectral radiance (spectrum × scale): leaves headroom of about 1e8 for the
/// throughputs and inverse pdfs it is multiplied by in f32.
pub const MAX_RADIANCE: f64 = 1e30;

/// Largest reflectance of the analytic materials (`lambert`, `fluorescent-diffuse`): a passive
/// surface reflects at most the light it receives, and above 1 the path throughputs grow with
/// every bounce until they overflow f32.
pub const MAX_REFLECTANCE: f32 = 1.0;

/// Most primitives (triangles and spheres) in a scene: ids are u32, and each costs about
/// 150 bytes with its acceleration structure.
pub const MAX_PRIMITIVES: usize = 1 << 25;

/// Most 1-nm sampling-table cells over all lights (each light tabulates its emission over the
/// domain): lights × domain width.
pub const MAX_LIGHT_CELLS: f64 = (1u64 << 25) as f64;

/// Smallest field of view, degrees: below it the film's area at unit distance underflows in f32
/// and the camera's directional pdf overflows.
pub const MIN_FOV: f32 = 1e-3;

/// Largest optical depth of a medium across its extent (the bounding box of the shapes it
/// fills, and of its grid): distance tracking takes about that many steps per ray through it,
/// and e^-1e5 is opaque anyway.
pub const MAX_OPTICAL_DEPTH: f64 = 1e5;
