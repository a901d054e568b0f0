//! What every bidirectional integrator does when it joins a camera prefix to a light suffix,
//! written once for `bdpt-forward`, `bdpt-backward` (both evaluations) and `bdpt-allbins`: the
//! connecting segment with its cosines and geometry factor, the camera's end of a path (the
//! pinhole importance), the shadow ray, where light tracing splats, and how a contribution
//! reaches the film and its strategy image.

use super::strategy_layer;
use crate::integrator::{SampleSink, Stats};
use crate::scene::Scene;
use crate::transport::{Scattering, Transmittance, Vertex, VertexKind, transmittance};
use glam::Vec3;

/// A segment x_a → x_b in path order (camera towards light).
#[derive(Clone, Copy, Debug, Default)]
pub struct Seg {
    /// Unit direction from x_a to x_b.
    pub w: Vec3,
    /// Squared distance.
    pub d2: f32,
    /// The geometry factor |cos θ_a| |cos θ_b| / d² (eq. 6.2), without visibility.
    pub g: f64,
}

impl Seg {
    /// The segment from `a` to `b` (|cos| is 1 at the pinhole and in a medium, `Vertex::abs_cos`).
    #[inline]
    pub fn new<P, Q>(a: &Vertex<P>, b: &Vertex<Q>) -> Seg {
        let (w, d2) = a.towards(b);
        Seg::with_cosines(w, d2, a.abs_cos(w), b.abs_cos(w))
    }

    /// The segment of unit direction `w`, squared length `d2` and |cos θ| `abs_a`, `abs_b` at
    /// its ends.
    #[inline(always)]
    fn with_cosines(w: Vec3, d2: f32, abs_a: f32, abs_b: f32) -> Seg {
        // G(a ↔ b) without visibility (eq. 6.2)
        let g = abs_a as f64 * abs_b as f64 / d2 as f64;
        Seg { w, d2, g }
    }
}

/// The connection x(s−1) → x_s of a strategy: its segment, the signed cosines n·w of its
/// direction at both ends (at the pinhole n is the camera's axis, in a medium n is 0), which
/// the lobes at the two ends reuse, and the |cos θ| of the measure conversions (1 at the pinhole
/// and in a medium). Its transmittance is [`Connection::shadow`] (or the media walk of
/// `super::media`), traced last by the callers so that the arithmetic of the weight overlaps
/// the ray.
#[derive(Clone, Copy, Debug)]
pub struct Connection {
    pub seg: Seg,
    pub cos_a: f32,
    pub cos_b: f32,
    pub abs_a: f32,
    pub abs_b: f32,
}

impl Connection {
    #[inline]
    pub fn new<P, Q>(a: &Vertex<P>, b: &Vertex<Q>) -> Self {
        let (w, d2) = a.towards(b);
        let (abs_a, abs_b) = (a.abs_cos(w), b.abs_cos(w));
        Connection {
            seg: Seg::with_cosines(w, d2, abs_a, abs_b),
            cos_a: a.n.dot(w),
            cos_b: b.n.dot(w),
            abs_a,
            abs_b,
        }
    }

    /// The geometry factor in single precision, for `bdpt-allbins`' f32 spectra.
    #[inline]
    pub fn g32(&self) -> f32 {
        self.abs_a * self.abs_b / self.seg.d2
    }

    /// The transmittance of x(s−1) → x_s in a scene without media: shadow rays start on the
    /// surface side, so light tracing's (`camera_end`: `a` is the pinhole) starts at `b`.
    ///
    /// Out of line: one copy of the inlined shadow ray instead of one in every connection of
    /// bdpt-forward and bdpt-backward, whose registers are already short (bdpt-forward on
    /// cornell-box 1.04× faster); bdpt-allbins' connections, which keep their spectra in
    /// buffers, call `transport::transmittance` inline.
    #[inline(never)]
    pub fn shadow<P, Q>(
        scene: &Scene,
        a: &Vertex<P>,
        b: &Vertex<Q>,
        camera_end: bool,
        rays: &mut u64,
    ) -> Transmittance {
        let (a, b) = (a.endpoint(), b.endpoint());
        if camera_end {
            transmittance(scene, b, a, rays)
        } else {
            transmittance(scene, a, b, rays)
        }
    }
}

/// One end of a connection as its lobe and pdfs see it.
#[derive(Clone, Copy, Debug)]
pub enum End {
    /// The pinhole x0 (light tracing).
    Camera,
    /// A point on emitter `light` with normal `n`: a light sub-path's origin or a fresh light
    /// point of next-event estimation.
    Emitter { light: u32, n: Vec3 },
    /// A scattering vertex: its lobe, the unit direction `wo` to its other neighbour on its own
    /// sub-path and the cosine n·wo. Lobes that depend only on the cosines (the diffuse lobe,
    /// `Scattering::eval_pdf_with_cosines`) reuse the connection's; others take the directions.
    Scatter {
        lobe: Scattering,
        wo: Vec3,
        cos_o: f32,
    },
    /// A scattering vertex without another neighbour: it samples nothing.
    Alone,
}

impl End {
    /// The scattering vertex `x` whose other neighbour lies in the unit direction `wo`.
    #[inline(always)]
    pub fn scatter<P>(scene: &Scene, x: &Vertex<P>, wo: Vec3) -> Self {
        End::Scatter {
            lobe: x.scattering(scene),
            wo,
            cos_o: x.n.dot(wo),
        }
    }

    /// Vertex `x` of a connection whose other neighbour on its own sub-path is `other`.
    #[inline]
    pub fn of<P, Q>(scene: &Scene, x: &Vertex<P>, other: Option<&Vertex<Q>>) -> Self {
        match (x.kind, other) {
            (VertexKind::Camera, _) => End::Camera,
            (VertexKind::Light, _) => End::Emitter {
                light: x.light,
                n: x.n,
            },
            (_, Some(o)) => End::scatter(scene, x, x.towards(o).0),
            (_, None) => End::Alone,
        }
    }

    /// The solid-angle pdf that the pinhole or the emitter samples the unit direction `wi`
    /// (pbrt `Vertex::Pdf`); a lobe's comes with its value in [`End::towards`].
    #[inline(always)]
    fn pdf(&self, scene: &Scene, wi: Vec3) -> f32 {
        match self {
            End::Camera => {
                let pdf = scene.camera.pdf_dir_towards(scene.camera.forward, wi);
                pdf.unwrap_or(0.0)
            }
            End::Emitter { light, n } => scene.lights.pdf_le_direction(*light as usize, *n, wi),
            End::Scatter { .. } | End::Alone => 0.0,
        }
    }
}

/// What one end of a connection gives the other: f_dir towards it (1 at the pinhole and at an
/// emitter, whose factors are W_e and L_e) and the solid-angle pdf of sampling that direction.
#[derive(Clone, Copy, Debug)]
pub struct Towards {
    pub f: f32,
    pub pdf: f32,
}

impl End {
    /// f_dir and the solid-angle pdf towards the unit direction `wi` (cosine `cos_i`), in one
    /// look at the end and its lobe.
    #[inline(always)]
    pub fn towards(&self, scene: &Scene, wi: Vec3, cos_i: f32) -> Towards {
        let (f, pdf) = match self {
            End::Scatter { lobe, wo, cos_o } => {
                lobe.eval_pdf_with_cosines((*wo, *cos_o), (wi, cos_i))
            }
            End::Alone => (0.0, 0.0),
            _ => (1.0, self.pdf(scene, wi)),
        };
        Towards { f, pdf }
    }
}

impl Connection {
    /// The ends' values towards each other: `a`'s (x(s−1)) along w, `b`'s (x_s) along −w, whose
    /// cosine is −(n·w) exactly.
    #[inline(always)]
    pub fn ends(&self, scene: &Scene, a: &End, b: &End) -> (Towards, Towards) {
        let w = self.seg.w;
        let ta = a.towards(scene, w, self.cos_a);
        let tb = b.towards(scene, -w, -self.cos_b);
        (ta, tb)
    }

    /// The area pdfs of x_s sampled from x(s−1) and of x(s−1) sampled from x_s, from the two
    /// ends' solid-angle pdfs towards each other (`Vertex::area_pdf`).
    #[inline(always)]
    pub fn area_pdfs(&self, pdf_a: f32, pdf_b: f32) -> (f32, f32) {
        let d2 = self.seg.d2;
        (pdf_a * self.abs_b / d2, pdf_b * self.abs_a / d2)
    }

    /// The two area pdfs this connection changes (eq. 6.3, pbrt `Vertex::Pdf`): of x_s sampled
    /// from x(s−1) (`a`, towards the camera) and of x(s−1) sampled from x_s (`b`), each the
    /// end's solid-angle pdf turned into an area pdf at the other end.
    #[inline(always)]
    pub fn pdfs(&self, scene: &Scene, a: &End, b: &End) -> (f32, f32) {
        let (ta, tb) = self.ends(scene, a, b);
        self.area_pdfs(ta.pdf, tb.pdf)
    }
}

/// The camera's end of the measurement (eq. 6.2): the pinhole importance W_e(x0 → x1) =
/// 1 / (A cos⁴θ) (`Camera::importance`) times the geometry factor of x0 → x1 without a cosine
/// at the pinhole, for the unit direction `w` from x0 to x1 at squared distance `d2`; 0 behind
/// the camera.
#[inline]
pub fn camera_term<P>(scene: &Scene, w: Vec3, d2: f32, x1: &Vertex<P>) -> f64 {
    let c0 = w.dot(scene.camera.forward) as f64;
    if c0 <= 0.0 {
        return 0.0;
    }
    c0 * x1.abs_cos(w) as f64 / d2 as f64 * scene.camera.importance(c0)
}

/// Where light tracing (s = 1) splats: the film position at which the pinhole `x0` sees `x1`;
/// `None` off the film.
#[inline(always)]
pub fn splat_position<P, Q>(scene: &Scene, x0: &Vertex<P>, x1: &Vertex<Q>) -> Option<(f32, f32)> {
    let (px, py, _) = scene.camera.project((x1.p - x0.p).normalize())?;
    Some((px, py))
}

/// A connection's contribution: XYZ, the film position for light tracing, and (λ0, w · f / p),
/// the spectral radiance sample behind the XYZ value (for spectral images).
pub type Contribution = (Vec3, Option<(f32, f32)>, (f32, f32));

/// The CIE weight at λ0, kept in `last` with the bits of its wavelength for the next
/// connection (most connections of a sample share λ0).
#[inline]
pub fn xyz_weight(scene: &Scene, lambda0: f32, last: &mut Option<(u32, Vec3)>) -> Vec3 {
    let bits = lambda0.to_bits();
    match *last {
        Some((b, xyz)) if b == bits => xyz,
        _ => {
            let xyz = scene.observer.xyz_weight(lambda0);
            *last = Some((bits, xyz));
            xyz
        }
    }
}

/// The contribution w · f / p (eqs. 6.18/6.19, computed in f64) in XYZ with the CIE weight at
/// λ0; a zero, negative or NaN value adds nothing, and a NaN or infinite one is counted.
#[inline(always)]
pub fn weighted(
    xyz_w: Vec3,
    lambda0: f32,
    wfp: f64,
    splat: Option<(f32, f32)>,
    stats: &mut Stats,
) -> Option<Contribution> {
    let c = wfp as f32;
    if c.is_nan() || c <= 0.0 || !c.is_finite() {
        stats.nan_inf_rejected += !c.is_finite() as u64;
        return None;
    }
    Some((xyz_w * c, splat, (lambda0, c)))
}

/// Splat `xyz` of strategy (s, t) at film position (x, y) (light tracing), and into its
/// strategy image when `images`; false when it did not reach the film.
#[inline(always)]
pub fn splat(
    sink: &mut SampleSink,
    (s, t): (usize, usize),
    (x, y): (f32, f32),
    xyz: Vec3,
    images: bool,
) -> bool {
    let ok = sink.splat(x, y, xyz);
    if ok && images {
        let pix = (y as u32).min(sink.height - 1) * sink.width + (x as u32).min(sink.width - 1);
        sink.aux(strategy_layer(s, t), pix, xyz);
    }
    ok
}
