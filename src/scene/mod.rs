//! The runtime scene: its primitives, materials and lights, and the ray and light queries the
//! integrators make. The JSON format is in `format.rs`, building and validating a scene from it
//! in `build.rs`; [`Scene::load`] and [`Scene::from_str`] are the entry points.

mod build;
mod camera;
mod checks;
mod format;
mod gmm;
pub mod lights;
pub mod limits;
mod materials;
pub mod media;
mod shape_geometry;
mod shapes;
pub mod spectra;

pub use lights::{AreaLight, LightPoint, LightSet, LightShape, LightWavelengths};
pub use media::MediumInterface;

use crate::geometry::{Accel, Camera, Ray, Sphere, Triangle};
use crate::io::InputError;
use crate::material::Material;
use crate::medium::Medium;
use crate::spectrum::{Domain, Observer};
use glam::Vec3;
use std::path::{Path, PathBuf};

pub const NONE: u32 = u32::MAX;

/// Per-primitive data: material, light and the shape it belongs to.
#[derive(Clone, Copy, Debug)]
pub struct PrimInfo {
    pub material: u32,
    pub light: u32,
    pub shape: u32,
}

/// A named shape of the scene (for region masks and statistics).
#[derive(Clone, Debug)]
pub struct ShapeInfo {
    pub name: String,
    pub material: u32,
    /// The media on its two sides, if it names any.
    pub interface: Option<MediumInterface>,
}

/// A surface point found by a ray.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    pub p: Vec3,
    /// Geometric normal, oriented as the shape's normal (not flipped towards the ray).
    pub n: Vec3,
    pub t: f32,
    pub prim: u32,
    pub material: u32,
    pub light: u32,
}

pub struct Scene {
    pub file: PathBuf,
    pub domain: Domain,
    pub observer: Observer,
    pub camera: Camera,
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    pub triangles: Vec<Triangle>,
    pub spheres: Vec<Sphere>,
    pub sphere_flip: Vec<bool>,
    /// Unit geometric normals of the triangles (precomputed: one per hit otherwise).
    pub triangle_normals: Vec<Vec3>,
    /// Indexed by primitive id (triangles first, then spheres).
    pub prims: Vec<PrimInfo>,
    pub shapes: Vec<ShapeInfo>,
    /// The lights, chosen ∝ power, and their sampling operations.
    pub lights: LightSet,
    pub accel: Accel,
    pub has_fluorescence: bool,
    /// The participating media and their names (ids index both).
    pub media: Vec<Medium>,
    pub medium_names: Vec<String>,
    /// The medium the camera sits in ([`NONE`]: vacuum).
    pub camera_medium: u32,
    /// True when a shape or the camera is in a medium.
    pub has_media: bool,
    /// Per light, the media on the front (normal) and back side of its surface (filled when the
    /// scene has media; light paths start in them).
    pub light_media: Vec<[u32; 2]>,
    pub warnings: Vec<String>,
}

impl Scene {
    /// Load and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene, InputError> {
        let text = crate::io::input::read_text(path, crate::io::input::SCENE)
            .map_err(|e| InputError::new(path, "", format!("cannot read the scene: {e}")))?;
        Self::from_str(path, &text)
    }

    /// Parse a scene from JSON text; `path` names the file in errors and resolves relative paths.
    pub fn from_str(path: &Path, text: &str) -> Result<Scene, InputError> {
        build::scene(path, text)
    }

    /// Closest surface hit.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Interaction> {
        let h = self.accel.intersect(ray, t_max)?;
        let p = ray.at(h.t);
        let info = self.prims[h.prim as usize];
        let n = self.normal(h.prim, p);
        Some(Interaction {
            p,
            n,
            t: h.t,
            prim: h.prim,
            material: info.material,
            light: info.light,
        })
    }

    /// The first surface along `ray` that is not an index-matched boundary (those are invisible).
    pub fn first_visible(&self, ray: &Ray) -> Option<Interaction> {
        let mut ray = *ray;
        for _ in 0..256 {
            let it = self.intersect(&ray, f32::INFINITY)?;
            if it.material != NONE || it.light != NONE {
                return Some(it);
            }
            ray = crate::geometry::ray::cross_boundary_ray(it.p, it.n, ray.d);
        }
        None
    }

    /// Whether anything blocks the segment of length `t_max`.
    #[inline(always)]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.accel.occluded(ray, t_max)
    }

    /// Oriented geometric normal of primitive `prim` at `p`.
    #[inline]
    pub fn normal(&self, prim: u32, p: Vec3) -> Vec3 {
        let nt = self.triangles.len();
        if (prim as usize) < nt {
            self.triangle_normals[prim as usize]
        } else {
            let k = prim as usize - nt;
            let s = &self.spheres[k];
            let n = (p - s.center) / s.radius;
            if self.sphere_flip[k] { -n } else { n }
        }
    }

    /// The medium interface of the surface `it`, if its shape has one.
    #[inline]
    pub fn interface(&self, it: &Interaction) -> Option<MediumInterface> {
        self.shapes[self.prims[it.prim as usize].shape as usize].interface
    }

    /// The medium a ray in medium `current` is in after leaving surface `it` in direction `d`.
    #[inline]
    pub fn medium_after(&self, it: &Interaction, d: Vec3, current: u32) -> u32 {
        match self.interface(it) {
            Some(i) => i.towards(it.n, d),
            None => current,
        }
    }

    /// The media on the front and back side of light `li` (vacuum when unknown).
    #[inline]
    pub fn light_media(&self, li: usize) -> [u32; 2] {
        self.light_media.get(li).copied().unwrap_or([NONE; 2])
    }

    /// The medium `id` ([`NONE`]: vacuum).
    #[inline]
    pub fn medium(&self, id: u32) -> Option<&Medium> {
        self.media.get(id as usize)
    }

    pub fn material(&self, id: u32) -> Option<&Material> {
        self.materials.get(id as usize)
    }

    /// True if any material can shift wavelengths.
    pub fn is_fluorescent(&self) -> bool {
        self.has_fluorescence
    }

    /// Name of the first feature that makes directional sampling depend on wavelength, if any
    /// (the reset algorithms and the all-bins evaluator refuse such scenes).
    pub fn wavelength_dependent_feature(&self) -> Option<String> {
        // Media qualify: phase functions do not depend on wavelength, and the free flights, which
        // do, are re-weighted when a reset changes a segment's wavelength (bdpt/media.rs).
        self.materials
            .iter()
            .zip(&self.material_names)
            .find(|(m, _)| m.wavelength_dependent_directions())
            .map(|(_, n)| format!("material '{n}' with wavelength-dependent directional sampling"))
    }
}
