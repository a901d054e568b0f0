//! Path segments through participating media for the bidirectional integrators.
//!
//! A segment joins two consecutive vertices of a path. Through media it is a list of
//! [`Stretch`]es (one per medium it crosses; vacuum is not stored), so that its distance pdfs can
//! be evaluated again in either direction and at any wavelength after a wavelength reset:
//!
//! - [`distance_pdf`]: the free-flight pdf of the segment as the camera or the light would sample
//!   it (pass probabilities of the stretches before the end, then the collision density at a
//!   medium vertex or the pass probability in front of a surface). Homogeneous media give the exact
//!   pdf of the tracking mode; the aware density needs the distance past the end vertex to the
//!   next surface ([`Segment::far_end`], [`Segment::far_start`]). Delta tracking in grids has no
//!   closed-form pdf: there the MIS weights use its local collision rate and a pass probability
//!   of 1, which keeps them a partition of unity (docs/design.md §4).
//! - [`retarget`]: the factor T(λ_new)/T(λ_old) of a segment tracked at λ_old whose wavelength a
//!   reset changed, analytic in homogeneous media and a signed ratio-tracking estimate in grids.

pub use super::media::Stretch;
use super::media::signed_ratio_tracking;
use crate::medium::{Density, FreeFlight, GridDensity, Medium, MixtureFlight, Tracking};
use crate::scene::{NONE, Scene};
use glam::Vec3;

/// What a sub-path or a connection knows about one segment, in media scenes.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    /// Its stretches `first..last` in the owner's stretch buffer, from its start.
    pub first: u32,
    pub last: u32,
    /// The free-flight weight of the sampled segment at `lambda`: T·ρ/p at a collision, T/P
    /// before a surface (1 for a connection, whose transmittance is evaluated separately).
    pub w: f32,
    /// The wavelength the segment was tracked at.
    pub lambda: f32,
    /// Distance from the end vertex onwards, along the segment, to the next surface (∞: none).
    pub far_end: f32,
    /// Distance from the start vertex backwards, against the segment, to the next surface.
    pub far_start: f32,
    /// The media on the front (normal) and back side of the end vertex (both the same in a
    /// medium, or on a surface without an interface).
    pub end_media: [u32; 2],
}

impl Default for Segment {
    fn default() -> Self {
        Segment {
            first: 0,
            last: 0,
            w: 1.0,
            lambda: 0.0,
            far_end: f32::INFINITY,
            far_start: f32::INFINITY,
            end_media: [NONE; 2],
        }
    }
}

impl Segment {
    #[inline]
    pub fn stretches<'a>(&self, buf: &'a [Stretch]) -> &'a [Stretch] {
        &buf[self.first as usize..self.last as usize]
    }
}

/// The media on both sides of a surface point with normal `n` (front = side of `n`), given the
/// medium `arrival` the path was in and the shape's interface.
#[inline]
pub fn surface_media(iface: Option<crate::scene::MediumInterface>, arrival: u32) -> [u32; 2] {
    match iface {
        Some(i) => [i.exterior, i.interior],
        None => [arrival, arrival],
    }
}

/// The medium on the side of `n` that direction `d` leaves into.
#[inline]
pub fn towards(media: [u32; 2], n: Vec3, d: Vec3) -> u32 {
    if n.dot(d) > 0.0 { media[0] } else { media[1] }
}

/// Distance from `p` along `d` to the next surface of any kind (∞ if none); a ray is counted.
#[inline]
pub fn distance_to_surface(scene: &Scene, p: Vec3, d: Vec3, rays: &mut u64) -> f32 {
    *rays += 1;
    let ray = crate::geometry::Ray::new(p, d);
    scene
        .intersect(&ray, f32::INFINITY)
        .map_or(f32::INFINITY, |h| h.t)
}

/// The free-flight pdf of a segment with stretches `st` (stored from its start) sampled from its
/// start (`reverse` false) or from its end (`reverse` true) at wavelength `lambda` by a camera
/// (`light` false) or light path: the product of the pass probabilities of the stretches before
/// the far vertex, then the collision density at it if it is a medium vertex (`far` is the
/// distance past it to the next surface) or the pass probability of the last stretch.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn distance_pdf(
    scene: &Scene,
    st: &[Stretch],
    reverse: bool,
    at_medium_vertex: bool,
    far: f32,
    lambda: f32,
    light: bool,
    mode: Tracking,
) -> f32 {
    over_stretches(scene, st, reverse, at_medium_vertex, |m, s, collide| {
        let c = m.coefficients.at_side(1, lambda, light);
        let flight = FreeFlight::new(mode, c.hat_t, c.hat_s);
        match &m.density {
            Density::Homogeneous if collide => flight.pdf_collision(s.len, s.len + far),
            Density::Homogeneous => flight.pdf_pass(s.len),
            // Delta tracking: the local collision rate; pass probabilities taken as 1.
            Density::Grid(g) if collide => {
                let rate = match mode {
                    Tracking::Exponential => c.hat_t,
                    Tracking::Max | Tracking::Aware => c.hat_t.max(c.hat_s),
                };
                rate * end_density(g, s)
            }
            Density::Grid(_) => 1.0,
        }
    })
}

/// The product over the stretches of `st` of `factor(medium, stretch, collide)`, walked from
/// the segment's start (or from its end if `reverse`, each stretch turned around); `collide` is
/// set for the last stretch when the far vertex is a medium vertex. Vacuum gives 1.
#[inline(always)]
fn over_stretches(
    scene: &Scene,
    st: &[Stretch],
    reverse: bool,
    at_medium_vertex: bool,
    mut factor: impl FnMut(&Medium, &Stretch, bool) -> f32,
) -> f32 {
    let n = st.len();
    let mut p = 1.0f32;
    for k in 0..n {
        let s = if reverse {
            st[n - 1 - k].reversed()
        } else {
            st[k]
        };
        if let Some(m) = scene.medium(s.medium) {
            p *= factor(m, &s, at_medium_vertex && k + 1 == n);
        }
    }
    p
}

/// The density at the end of a stretch in a grid medium.
#[inline]
fn end_density(g: &GridDensity, s: &Stretch) -> f32 {
    g.scale * g.grid.density(s.o + s.d * s.len)
}

/// T(λ_to) / T(λ_from) along the stretches `st`: exact in homogeneous media, a signed ratio-
/// tracking estimate in grids (unbiased for either sign of σ̂t(λ_to) − σ̂t(λ_from)).
#[inline]
pub fn retarget(
    scene: &Scene,
    st: &[Stretch],
    from: f32,
    to: f32,
    u: &mut impl FnMut() -> f32,
) -> f32 {
    if from == to {
        return 1.0;
    }
    let mut f = 1.0f32;
    for s in st {
        let Some(m) = scene.medium(s.medium) else {
            continue;
        };
        let delta = m.coefficients.at(1, to).hat_t - m.coefficients.at(1, from).hat_t;
        if delta == 0.0 {
            continue;
        }
        match &m.density {
            Density::Homogeneous => f *= (-delta * s.len).exp(),
            Density::Grid(g) => {
                let ray = crate::geometry::Ray::new(s.o, s.d);
                f *= signed_ratio_tracking(g, &ray, s.len, delta, u);
            }
        }
    }
    f
}

/// [`distance_pdf`] for the all-bins evaluator's wavelength-independent tracking: the mixture
/// density `flight(id)` in homogeneous media; in grids, delta tracking at the rate `rate(id)`,
/// for which the MIS weights use the local collision rate and pass probabilities of 1, as in
/// [`distance_pdf`].
#[inline]
pub fn grey_distance_pdf(
    scene: &Scene,
    st: &[Stretch],
    reverse: bool,
    at_medium_vertex: bool,
    flight: impl Fn(u32) -> (MixtureFlight, f32),
) -> f32 {
    over_stretches(scene, st, reverse, at_medium_vertex, |m, s, collide| {
        let (f, c) = flight(s.medium);
        match &m.density {
            Density::Homogeneous if collide => f.pdf_collision(s.len),
            Density::Homogeneous => f.pdf_pass(s.len),
            Density::Grid(g) if collide => c * end_density(g, s),
            Density::Grid(_) => 1.0,
        }
    })
}
