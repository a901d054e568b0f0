//! Scenes: the JSON format (serde), validation, OBJ loading, lights, and ray queries.

pub mod error;
pub mod lights;
pub mod spectra;

pub use error::InputError;
pub use lights::{AreaLight, LightPoint, LightSet, LightShape, LightWavelengths};

use crate::geometry::{Accel, Camera, Ray, Sphere, Triangle};
use crate::material::{Bbrrdf, FluorescentDiffuse, Lambert, Material, Reradiation};
use crate::spectrum::{DEFAULT_DOMAIN, Domain, Observer};
use error::{from_json_str, from_json_value};
use glam::Vec3;
use serde::Deserialize;
use serde_json::Value;
use spectra::SpectrumContext;
use std::collections::BTreeMap;
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
    pub has_media: bool,
    pub warnings: Vec<String>,
}

// ---------------------------------------------------------------- JSON format

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    #[allow(dead_code)]
    comment: Option<Value>,
    #[serde(default)]
    domain: Option<[f32; 2]>,
    camera: CameraDesc,
    #[serde(default)]
    spectra: BTreeMap<String, Value>,
    #[serde(default)]
    materials: BTreeMap<String, Value>,
    shapes: Vec<ShapeDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    origin: [f32; 3],
    target: [f32; 3],
    #[serde(default = "default_up")]
    up: [f32; 3],
    /// Full field of view in degrees.
    fov: f32,
    #[serde(default)]
    fov_axis: FovAxis,
    width: u32,
    height: u32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum FovAxis {
    #[default]
    X,
    Y,
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
enum MaterialDesc {
    Lambert {
        reflectance: Value,
    },
    FluorescentDiffuse {
        reflectance: Value,
        absorption: Value,
        emission: Value,
        quantum_yield: f32,
        concentration: f32,
    },
    Reradiation {
        file: String,
    },
}

#[derive(Deserialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "kebab-case")]
enum ShapeKind {
    Quad,
    Box,
    Sphere,
    Triangles,
    Obj,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeDesc {
    #[serde(rename = "type")]
    kind: ShapeKind,
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    emission: Option<EmissionDesc>,
    #[serde(default)]
    flip_normals: bool,
    #[serde(default)]
    corners: Option<[[f32; 3]; 4]>,
    #[serde(default)]
    min: Option<[f32; 3]>,
    #[serde(default)]
    max: Option<[f32; 3]>,
    #[serde(default)]
    center: Option<[f32; 3]>,
    #[serde(default)]
    radius: Option<f32>,
    #[serde(default)]
    vertices: Option<Vec<[f32; 3]>>,
    #[serde(default)]
    indices: Option<Vec<[u32; 3]>>,
    #[serde(default)]
    file: Option<String>,
    #[serde(default)]
    scale: Option<f32>,
    #[serde(default)]
    translate: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EmissionDesc {
    spectrum: Value,
    #[serde(default = "one")]
    scale: f32,
    #[serde(default)]
    two_sided: bool,
}

fn one() -> f32 {
    1.0
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

fn finite3(file: &Path, path: &str, a: [f32; 3]) -> Result<Vec3, InputError> {
    if a.iter().all(|x| x.is_finite()) {
        Ok(v3(a))
    } else {
        Err(InputError::new(
            file,
            path,
            format!("coordinates must be finite numbers, got {a:?}"),
        ))
    }
}

impl Scene {
    /// Load and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene, InputError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InputError::new(path, "", format!("cannot read the scene file: {e}")))?;
        Self::from_str(path, &text)
    }

    /// Parse a scene from JSON text; `path` names the file in errors and resolves relative paths.
    pub fn from_str(path: &Path, text: &str) -> Result<Scene, InputError> {
        let f: SceneFile = from_json_str(path, text)?;
        let err = |p: &str, m: String| InputError::new(path, p, m);
        let mut warnings = Vec::new();

        let domain = match f.domain {
            None => DEFAULT_DOMAIN,
            Some([a, b]) => {
                if !(a.is_finite() && b.is_finite() && a >= 0.0 && a < b) {
                    return Err(err(
                        "domain",
                        format!("needs 0 ≤ min < max, got [{a}, {b}]"),
                    ));
                }
                Domain { min: a, max: b }
            }
        };
        let observer = Observer::new(domain);
        if observer.range.width() <= 0.0 {
            return Err(err(
                "domain",
                "does not overlap the observer's 360–830 nm".into(),
            ));
        }

        // Camera.
        let c = &f.camera;
        let origin = finite3(path, "camera.origin", c.origin)?;
        let target = finite3(path, "camera.target", c.target)?;
        let up = finite3(path, "camera.up", c.up)?;
        if (target - origin).length() <= 0.0 {
            return Err(err(
                "camera.target",
                "must differ from camera.origin".into(),
            ));
        }
        if (target - origin).normalize().cross(up).length() < 1e-6 {
            return Err(err(
                "camera.up",
                "must not be parallel to the viewing direction".into(),
            ));
        }
        if !(c.fov > 0.0 && c.fov < 180.0) {
            return Err(err(
                "camera.fov",
                format!("must be in (0, 180) degrees, got {}", c.fov),
            ));
        }
        if c.width == 0 || c.height == 0 || c.width > 16384 || c.height > 16384 {
            return Err(err(
                "camera.width",
                format!("resolution must be 1–16384, got {}×{}", c.width, c.height),
            ));
        }
        let camera = Camera::look_at(
            origin,
            target,
            up,
            c.fov,
            c.fov_axis == FovAxis::X,
            c.width,
            c.height,
        );

        // Spectra and materials.
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut ctx = SpectrumContext {
            file: path,
            dir: dir.clone(),
            named: BTreeMap::new(),
            domain,
        };
        for (name, v) in &f.spectra {
            let s = ctx.parse(v, &format!("spectra.{name}"))?;
            ctx.named.insert(name.clone(), s);
        }
        let mut materials = Vec::new();
        let mut material_names = Vec::new();
        for (name, v) in &f.materials {
            let base = format!("materials.{name}");
            let desc: MaterialDesc = from_json_value(path, &base, v)?;
            let m = match desc {
                MaterialDesc::Lambert { reflectance } => {
                    let r = ctx.parse(&reflectance, &format!("{base}.reflectance"))?;
                    if r.max_value(domain) > 1.0 {
                        warnings.push(format!(
                            "{base}.reflectance exceeds 1: the surface creates energy"
                        ));
                    }
                    Material::Lambert(Lambert { reflectance: r })
                }
                MaterialDesc::FluorescentDiffuse {
                    reflectance,
                    absorption,
                    emission,
                    quantum_yield,
                    concentration,
                } => {
                    for (v, n) in [
                        (quantum_yield, "quantum_yield"),
                        (concentration, "concentration"),
                    ] {
                        if !(0.0..=1.0).contains(&v) {
                            return Err(err(
                                &format!("{base}.{n}"),
                                format!("must be in [0, 1], got {v}"),
                            ));
                        }
                    }
                    let r = ctx.parse(&reflectance, &format!("{base}.reflectance"))?;
                    let a = ctx.parse(&absorption, &format!("{base}.absorption"))?;
                    let e = ctx.parse(&emission, &format!("{base}.emission"))?;
                    if r.max_value(domain) > 1.0 {
                        warnings.push(format!(
                            "{base}.reflectance exceeds 1: the surface creates energy"
                        ));
                    }
                    let (m, w) =
                        FluorescentDiffuse::new(r, a, e, quantum_yield, concentration, domain)
                            .map_err(|m| err(&base, m))?;
                    warnings.extend(w.into_iter().map(|w| format!("{base}: {w}")));
                    Material::Fluorescent(m)
                }
                MaterialDesc::Reradiation { file } => {
                    let full = dir.join(&file);
                    let text = std::fs::read_to_string(&full).map_err(|e| {
                        err(
                            &format!("{base}.file"),
                            format!("cannot read '{}': {e}", full.display()),
                        )
                    })?;
                    let m = Reradiation::parse_bfc(&text, domain).map_err(|m| {
                        err(
                            &format!("{base}.file"),
                            format!("malformed BFC file '{}': {m}", full.display()),
                        )
                    })?;
                    Material::Reradiation(m)
                }
            };
            materials.push(m);
            material_names.push(name.clone());
        }

        // Shapes.
        let mut b = Builder::default();
        for (si, s) in f.shapes.iter().enumerate() {
            b.add_shape(path, &dir, si, s, &ctx, &material_names, domain)?;
        }
        if b.lights.is_empty() {
            return Err(err(
                "shapes",
                "the scene has no light: give at least one shape an `emission`".into(),
            ));
        }
        if b.lights.iter().all(|l| l.power <= 0.0) {
            return Err(err(
                "shapes",
                "every light emits zero power over the wavelength domain".into(),
            ));
        }
        let mut prims = b.tri_info;
        prims.extend(b.sphere_info);
        let accel = Accel::build(&b.triangles, &b.spheres);
        let triangle_normals = b
            .triangles
            .iter()
            .map(|t| t.normal_raw().normalize())
            .collect();
        let has_fluorescence = materials.iter().any(|m| m.is_fluorescent());
        Ok(Scene {
            file: path.to_path_buf(),
            domain,
            observer,
            camera,
            materials,
            material_names,
            triangles: b.triangles,
            spheres: b.spheres,
            sphere_flip: b.sphere_flip,
            triangle_normals,
            prims,
            shapes: b.shapes,
            lights: LightSet::new(b.lights),
            accel,
            has_fluorescence,
            has_media: false,
            warnings,
        })
    }

    /// Closest surface hit.
    #[inline]
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

    /// Whether anything blocks the segment of length `t_max`.
    #[inline]
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
        if self.has_media {
            return Some("participating media".into());
        }
        self.materials
            .iter()
            .zip(&self.material_names)
            .find(|(m, _)| m.wavelength_dependent_directions())
            .map(|(_, n)| format!("material '{n}' with wavelength-dependent directional sampling"))
    }
}

#[derive(Default)]
struct Builder {
    triangles: Vec<Triangle>,
    tri_info: Vec<PrimInfo>,
    spheres: Vec<Sphere>,
    sphere_flip: Vec<bool>,
    sphere_info: Vec<PrimInfo>,
    shapes: Vec<ShapeInfo>,
    lights: Vec<AreaLight>,
}

impl Builder {
    #[allow(clippy::too_many_arguments)]
    fn add_shape(
        &mut self,
        file: &Path,
        dir: &Path,
        si: usize,
        s: &ShapeDesc,
        ctx: &SpectrumContext,
        material_names: &[String],
        domain: Domain,
    ) -> Result<(), InputError> {
        let base = format!("shapes[{si}]");
        let err = |p: &str, m: String| {
            InputError::new(
                file,
                if p.is_empty() {
                    base.clone()
                } else {
                    format!("{base}.{p}")
                },
                m,
            )
        };
        let material = match &s.material {
            None => NONE,
            Some(name) => material_names
                .iter()
                .position(|n| n == name)
                .map(|i| i as u32)
                .ok_or_else(|| {
                    err(
                        "material",
                        format!(
                            "unknown material '{name}' (defined: {})",
                            material_names.join(", ")
                        ),
                    )
                })?,
        };
        if material == NONE && s.emission.is_none() {
            return Err(err(
                "material",
                "a shape needs a `material`, an `emission`, or both".into(),
            ));
        }
        let shape_id = self.shapes.len() as u32;
        let name = s.name.clone().unwrap_or_else(|| format!("shape{si}"));
        self.shapes.push(ShapeInfo {
            name: name.clone(),
            material,
        });
        let light_id = if s.emission.is_some() {
            self.lights.len() as u32
        } else {
            NONE
        };
        let info = PrimInfo {
            material,
            light: light_id,
            shape: shape_id,
        };

        // Fields not used by this kind are errors, so typos do not pass silently.
        let used: &[&str] = match s.kind {
            ShapeKind::Quad => &["corners"],
            ShapeKind::Box => &["min", "max"],
            ShapeKind::Sphere => &["center", "radius"],
            ShapeKind::Triangles => &["vertices", "indices"],
            ShapeKind::Obj => &["file", "scale", "translate"],
        };
        let present = [
            ("corners", s.corners.is_some()),
            ("min", s.min.is_some()),
            ("max", s.max.is_some()),
            ("center", s.center.is_some()),
            ("radius", s.radius.is_some()),
            ("vertices", s.vertices.is_some()),
            ("indices", s.indices.is_some()),
            ("file", s.file.is_some()),
            ("scale", s.scale.is_some()),
            ("translate", s.translate.is_some()),
        ];
        for (f, p) in present {
            if p && !used.contains(&f) {
                return Err(err(
                    f,
                    format!(
                        "not a field of a {:?} shape (fields: {})",
                        s.kind,
                        used.join(", ")
                    ),
                ));
            }
        }
        let need = |o: bool, f: &str| {
            if o {
                Ok(())
            } else {
                Err(err(f, format!("required for a {:?} shape", s.kind)))
            }
        };

        let mut tris: Vec<Triangle> = Vec::new();
        let mut sphere: Option<Sphere> = None;
        match s.kind {
            ShapeKind::Quad => {
                need(s.corners.is_some(), "corners")?;
                let c = s.corners.unwrap();
                let p: Vec<Vec3> = c
                    .iter()
                    .enumerate()
                    .map(|(i, x)| finite3(file, &format!("{base}.corners[{i}]"), *x))
                    .collect::<Result<_, _>>()?;
                tris.push(Triangle::new(p[0], p[1], p[2]));
                tris.push(Triangle::new(p[0], p[2], p[3]));
            }
            ShapeKind::Box => {
                need(s.min.is_some(), "min")?;
                need(s.max.is_some(), "max")?;
                let lo = finite3(file, &format!("{base}.min"), s.min.unwrap())?;
                let hi = finite3(file, &format!("{base}.max"), s.max.unwrap())?;
                if !(lo.cmplt(hi).all()) {
                    return Err(err(
                        "max",
                        format!("box needs min < max on every axis, got {lo} and {hi}"),
                    ));
                }
                tris.extend(box_triangles(lo, hi));
            }
            ShapeKind::Sphere => {
                need(s.center.is_some(), "center")?;
                need(s.radius.is_some(), "radius")?;
                let c = finite3(file, &format!("{base}.center"), s.center.unwrap())?;
                let r = s.radius.unwrap();
                if !(r > 0.0 && r.is_finite()) {
                    return Err(err("radius", format!("must be a positive number, got {r}")));
                }
                sphere = Some(Sphere {
                    center: c,
                    radius: r,
                });
            }
            ShapeKind::Triangles => {
                need(s.vertices.is_some(), "vertices")?;
                need(s.indices.is_some(), "indices")?;
                let v = s.vertices.as_ref().unwrap();
                for (i, x) in v.iter().enumerate() {
                    finite3(file, &format!("{base}.vertices[{i}]"), *x)?;
                }
                for (k, idx) in s.indices.as_ref().unwrap().iter().enumerate() {
                    if let Some(bad) = idx.iter().find(|&&i| i as usize >= v.len()) {
                        return Err(err(
                            &format!("indices[{k}]"),
                            format!("index {bad} out of range ({} vertices)", v.len()),
                        ));
                    }
                    tris.push(Triangle::new(
                        v3(v[idx[0] as usize]),
                        v3(v[idx[1] as usize]),
                        v3(v[idx[2] as usize]),
                    ));
                }
            }
            ShapeKind::Obj => {
                need(s.file.is_some(), "file")?;
                let full = dir.join(s.file.as_ref().unwrap());
                let scale = s.scale.unwrap_or(1.0);
                let tr = v3(s.translate.unwrap_or([0.0; 3]));
                if !(scale.is_finite() && scale != 0.0) {
                    return Err(err(
                        "scale",
                        format!("must be a non-zero finite number, got {scale}"),
                    ));
                }
                let (models, _) = tobj::load_obj(
                    &full,
                    &tobj::LoadOptions {
                        triangulate: true,
                        single_index: false,
                        ..Default::default()
                    },
                )
                .map_err(|e| err("file", format!("cannot load OBJ '{}': {e}", full.display())))?;
                for m in models {
                    let pos = &m.mesh.positions;
                    let idx = &m.mesh.indices;
                    tris.reserve(idx.len() / 3);
                    for t in idx.chunks_exact(3) {
                        let p = |i: u32| {
                            Vec3::new(
                                pos[3 * i as usize],
                                pos[3 * i as usize + 1],
                                pos[3 * i as usize + 2],
                            ) * scale
                                + tr
                        };
                        tris.push(Triangle::new(p(t[0]), p(t[1]), p(t[2])));
                    }
                }
                if tris.is_empty() {
                    return Err(err(
                        "file",
                        format!("OBJ '{}' has no triangles", full.display()),
                    ));
                }
            }
        }
        // Degenerate triangles.
        for (k, t) in tris.iter_mut().enumerate() {
            if !(t.area() > 0.0) || !t.area().is_finite() {
                return Err(err(
                    "",
                    format!("degenerate geometry: triangle {k} has zero area"),
                ));
            }
            if s.flip_normals {
                t.v.swap(1, 2);
            }
        }
        let area: f32 = if let Some(sp) = sphere {
            sp.area()
        } else {
            tris.iter().map(|t| t.area()).sum()
        };

        // Light.
        if let Some(e) = &s.emission {
            if !(e.scale.is_finite() && e.scale >= 0.0) {
                return Err(err(
                    "emission.scale",
                    format!("must be a finite non-negative number, got {}", e.scale),
                ));
            }
            let spec = ctx
                .parse(&e.spectrum, &format!("{base}.emission.spectrum"))?
                .scaled(e.scale);
            let shape = if let Some(sp) = sphere {
                LightShape::Sphere {
                    sphere: sp,
                    flip: s.flip_normals,
                }
            } else {
                let mut acc = 0.0;
                let cdf = tris
                    .iter()
                    .map(|t| {
                        acc += t.area() / area;
                        acc
                    })
                    .collect();
                LightShape::Triangles {
                    tris: tris.clone(),
                    cdf,
                }
            };
            self.lights
                .push(AreaLight::new(name, shape, spec, e.two_sided, area, domain));
        }
        if let Some(sp) = sphere {
            self.spheres.push(sp);
            self.sphere_flip.push(s.flip_normals);
            self.sphere_info.push(info);
        } else {
            self.tri_info.extend(std::iter::repeat_n(info, tris.len()));
            self.triangles.extend(tris);
        }
        Ok(())
    }
}

/// Twelve outward-facing triangles of an axis-aligned box.
fn box_triangles(lo: Vec3, hi: Vec3) -> Vec<Triangle> {
    let c = |x: bool, y: bool, z: bool| {
        Vec3::new(
            if x { hi.x } else { lo.x },
            if y { hi.y } else { lo.y },
            if z { hi.z } else { lo.z },
        )
    };
    // Each face as four corners counter-clockwise seen from outside.
    let faces = [
        [
            c(true, false, false),
            c(true, true, false),
            c(true, true, true),
            c(true, false, true),
        ], // +x
        [
            c(false, false, false),
            c(false, false, true),
            c(false, true, true),
            c(false, true, false),
        ], // -x
        [
            c(false, true, false),
            c(false, true, true),
            c(true, true, true),
            c(true, true, false),
        ], // +y
        [
            c(false, false, false),
            c(true, false, false),
            c(true, false, true),
            c(false, false, true),
        ], // -y
        [
            c(false, false, true),
            c(true, false, true),
            c(true, true, true),
            c(false, true, true),
        ], // +z
        [
            c(false, false, false),
            c(false, true, false),
            c(true, true, false),
            c(true, false, false),
        ], // -z
    ];
    faces
        .iter()
        .flat_map(|q| {
            [
                Triangle::new(q[0], q[1], q[2]),
                Triangle::new(q[0], q[2], q[3]),
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_point_outwards() {
        let lo = Vec3::splat(-1.0);
        let hi = Vec3::splat(1.0);
        for t in box_triangles(lo, hi) {
            let centroid = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
            assert!(t.normal_raw().dot(centroid) > 0.0);
        }
    }
}
