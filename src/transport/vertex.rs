//! The path vertex shared by the bidirectional integrators: a camera, light or surface
//! interaction with the area-measure pdfs of being generated in both directions (pbrt-v4
//! `pdfFwd` / `pdfRev`) and a payload `P` that the integrator owns (wavelengths, a scalar
//! throughput). [`Vertex::pdf`] evaluates the area pdf of any vertex sampling any other through
//! the vertex's [`Scattering`] lobe or its light's emission.

use super::scattering::Scattering;
use super::visibility::Endpoint;
use crate::geometry::Ray;
use crate::scene::lights::LightOrigin;
use crate::scene::{Interaction, NONE, Scene};
use glam::Vec3;

/// What generated a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VertexKind {
    // In this order, the sets the hot paths test (Camera | Medium: no normal; Medium | Surface:
    // scatters) are ranges of the discriminant.
    /// The pinhole x0; `n` is the viewing direction.
    Camera,
    /// A collision in a medium; `material` holds the medium's id and `n` is zero.
    Medium,
    /// A surface hit (it may also be an emitter: `light != NONE`).
    #[default]
    Surface,
    /// A point sampled on an emitter (first light sub-path vertex or NEE sample).
    Light,
}

/// A path vertex with the integrator's payload `data`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Vertex<P> {
    pub p: Vec3,
    /// Geometric normal (camera: forward axis; light: oriented emitting normal).
    pub n: Vec3,
    pub kind: VertexKind,
    /// bdpt-forward/backward: the vertex changed the wavelength (λ_in ≠ λ_out sampled, a
    /// fluorescent interaction); false in bdpt-allbins. Wavelength bookkeeping, but kept here
    /// rather than in the payload because it fits in the padding after `kind`: as a payload
    /// field it grows the bdpt vertex from 52 to 56 bytes, which cost 3.5 % more instructions
    /// per bdpt-forward sample (the connections copy vertices into `FullPath`).
    pub shift: bool,
    /// bdpt-forward/backward: the vertex's spectral part can shift wavelengths (a fluorescent
    /// material or medium), set by the sub-path walk, so that the resets and the MIS pdfs of
    /// every connection skip the material lookup at the others; false in bdpt-allbins. In the
    /// padding after `shift`, like it.
    pub fluorescent: bool,
    pub material: u32,
    pub light: u32,
    /// Area pdf of this vertex given its predecessor on its own sub-path.
    pub pdf_fwd: f32,
    /// Area pdf of this vertex sampled from its successor on its own sub-path (the reverse
    /// direction); set when the successor's direction is sampled, 0 until then.
    pub pdf_rev: f32,
    /// Integrator-specific payload (wavelengths, scalar throughput).
    pub data: P,
}

impl<P: Copy + Default> Vertex<P> {
    /// The pinhole x0 and the primary ray through film position (x, y) with its solid-angle pdf.
    #[inline]
    pub fn camera(scene: &Scene, x: f32, y: f32) -> (Self, Ray, f32) {
        let cam = &scene.camera;
        let ray = cam.generate_ray(x, y);
        let v = Vertex {
            p: cam.origin,
            n: cam.forward,
            kind: VertexKind::Camera,
            material: NONE,
            light: NONE,
            pdf_fwd: 1.0,
            ..Default::default()
        };
        (v, ray, cam.pdf_dir(ray.d.dot(cam.forward)))
    }

    /// A light vertex at a sampled light-path origin (`pdf_fwd` is its area pdf).
    #[inline]
    pub fn light(o: &LightOrigin) -> Self {
        Vertex {
            p: o.p,
            n: o.n,
            kind: VertexKind::Light,
            material: NONE,
            light: o.light as u32,
            pdf_fwd: o.pdf_pos,
            ..Default::default()
        }
    }

    /// A surface vertex at a ray hit, with its forward area pdf.
    #[inline]
    pub fn surface(it: &Interaction, pdf_fwd: f32) -> Self {
        Vertex {
            p: it.p,
            n: it.n,
            kind: VertexKind::Surface,
            material: it.material,
            light: it.light,
            pdf_fwd,
            ..Default::default()
        }
    }
}

impl<P> Vertex<P> {
    #[inline]
    pub fn is_emitter(&self) -> bool {
        self.light != NONE
    }

    /// A collision in medium `medium` at `p`, with its forward area pdf.
    #[inline]
    pub fn medium(p: Vec3, medium: u32, pdf_fwd: f32) -> Self
    where
        P: Default,
    {
        Vertex {
            p,
            n: Vec3::ZERO,
            kind: VertexKind::Medium,
            shift: false,
            fluorescent: false,
            material: medium,
            light: NONE,
            pdf_fwd,
            pdf_rev: 0.0,
            data: P::default(),
        }
    }

    /// True for a vertex that scatters: a surface with a material, or a medium collision.
    #[inline]
    pub fn scatters(&self) -> bool {
        self.material != NONE && matches!(self.kind, VertexKind::Surface | VertexKind::Medium)
    }

    /// The directional lobe of a scattering vertex: diffuse on surfaces (every material is),
    /// the medium's Henyey–Greenstein phase function in a medium.
    #[inline]
    pub fn scattering(&self, scene: &Scene) -> Scattering {
        match self.kind {
            VertexKind::Medium => Scattering::HenyeyGreenstein {
                g: scene.medium(self.material).map_or(0.0, |m| m.g),
            },
            _ => Scattering::Diffuse { n: self.n },
        }
    }

    /// The end of a shadow segment at this vertex: surfaces are offset along their normal, the
    /// pinhole and medium collisions are not (their `n` is not a surface normal).
    #[inline]
    pub fn endpoint(&self) -> Endpoint {
        match self.kind {
            VertexKind::Camera | VertexKind::Medium => Endpoint {
                p: self.p,
                n: Vec3::ZERO,
            },
            _ => Endpoint {
                p: self.p,
                n: self.n,
            },
        }
    }

    /// |cos θ| of direction `w` at this vertex for measure conversions (1 at the pinhole and in
    /// a medium, where the area measure is the volume measure).
    #[inline]
    pub fn abs_cos(&self, w: Vec3) -> f32 {
        match self.kind {
            VertexKind::Camera | VertexKind::Medium => 1.0,
            _ => self.n.dot(w).abs(),
        }
    }

    /// Unit direction to `next` and the squared distance.
    #[inline]
    pub fn towards<Q>(&self, next: &Vertex<Q>) -> (Vec3, f32) {
        let d = next.p - self.p;
        let d2 = d.length_squared();
        (d / d2.sqrt(), d2)
    }

    /// Solid-angle → area conversion (pbrt `ConvertDensity`): p_A = p_ω · |cos θ_next| / d² for
    /// the unit direction `w` from this vertex to `next` at squared distance `d2`.
    #[inline]
    pub fn area_pdf<Q>(pdf_dir: f32, w: Vec3, d2: f32, next: &Vertex<Q>) -> f32 {
        pdf_dir * next.abs_cos(w) / d2
    }

    /// Area pdf that a scattering vertex, reached from `prev`, samples `next` (the direction
    /// only: free-flight pdfs through media are kept per segment, `super::segment`).
    #[inline]
    pub fn pdf_scatter<Q, R>(&self, scene: &Scene, prev: &Vertex<Q>, next: &Vertex<R>) -> f32 {
        let (wi, d2) = self.towards(next);
        let (wo, _) = self.towards(prev);
        Self::area_pdf(self.scattering(scene).pdf(wo, wi), wi, d2, next)
    }

    /// Area pdf that the light sub-path's emission sampling leaves this emitter point towards
    /// `next` (pbrt `PdfLight`).
    #[inline]
    pub fn pdf_emit<Q>(&self, scene: &Scene, next: &Vertex<Q>) -> f32 {
        let (w, d2) = self.towards(next);
        let pdf_dir = scene
            .lights
            .pdf_le_direction(self.light as usize, self.n, w);
        Self::area_pdf(pdf_dir, w, d2, next)
    }

    /// Area pdf of choosing this emitter point as a light origin (pbrt `PdfLightOrigin`).
    #[inline]
    pub fn pdf_light_origin(&self, scene: &Scene) -> f32 {
        scene.lights.pdf_le_origin(self.light as usize)
    }

    /// Area pdf of `next` given this vertex (pbrt `Vertex::Pdf`), for any vertex kind; a
    /// scattering vertex needs its other neighbour `prev`.
    #[inline]
    pub fn pdf<Q, R>(&self, scene: &Scene, prev: Option<&Vertex<Q>>, next: &Vertex<R>) -> f32 {
        match self.kind {
            VertexKind::Camera => {
                let (w, d2) = self.towards(next);
                match scene.camera.pdf_dir_towards(self.n, w) {
                    Some(p) => Self::area_pdf(p, w, d2, next),
                    None => 0.0,
                }
            }
            VertexKind::Light => self.pdf_emit(scene, next),
            VertexKind::Surface | VertexKind::Medium => match prev {
                Some(prev) => self.pdf_scatter(scene, prev, next),
                None => 0.0,
            },
        }
    }
}
