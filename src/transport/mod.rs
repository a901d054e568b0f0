//! The transport layer every integrator stands on: what happens at and between path vertices,
//! written once.
//!
//! - [`scattering`]: the directional lobe of a vertex ([`Scattering`]: `eval`, `sample`, `pdf`
//!   in both directions), diffuse on surfaces, Henyey–Greenstein in media.
//! - [`vertex`]: the bidirectional path vertex with its area pdfs ([`Vertex`]).
//! - [`visibility`]: [`transmittance`] between two vertices.
//! - [`segment`]: segments of BDPT paths through media, their distance pdfs in both directions
//!   and at any wavelength.
//! - [`spectral`]: a medium collision as a BBRRDF, so that surface and medium vertices share
//!   the wavelength sampling, P_c/P_l and bin operators (`with_spectrum!` picks the one of a
//!   vertex).
//! - [`media`]: free flights through participating media and spectral transmittance through
//!   index-matched boundaries ([`travel`], [`transmittance_lanes`]).
//! - Light sampling (pbrt-v4's four operations) is [`crate::scene::LightSet`], owned by the
//!   scene; spectral scattering (the new wavelength at a vertex) is [`crate::material::Material`].
//!
//! Layering: `spectrum`, `geometry` < `material` < `scene` < `transport` < `integrator` <
//! `experiment` < `cli`; no module imports from one above it.

pub mod media;
pub mod scattering;
pub mod segment;
pub mod spectral;
pub mod vertex;
pub mod visibility;

pub use media::{Travel, transmittance_lanes, travel};
pub use scattering::{DirectionSample, Scattering};
pub use segment::{Segment, Stretch};
pub use vertex::{Vertex, VertexKind};
pub use visibility::{Endpoint, Transmittance, transmittance};
