//! Building a runtime [`Scene`] from the format types of `format.rs`, validating as it goes:
//! domain and camera checks, spectra and materials, shapes (triangles, spheres, OBJ files) and
//! their lights, the light selection distribution, and the acceleration structure.

use super::error::from_tagged_value;
use super::format::{
    self, CameraDesc, EmissionDesc, FovAxis, MaterialDesc, ShapeDesc, ShapeGeometry,
};
use super::gmm;
use super::lights::{AreaLight, LightSet, LightShape};
use super::limits::{
    MAX_COORD, MAX_LIGHT_CELLS, MAX_PIXELS, MAX_PRIMITIVES, MAX_RADIANCE, MAX_REFLECTANCE,
    MAX_SIDE, MAX_WAVELENGTH, MIN_AREA, MIN_FOV, MIN_RADIUS,
};
use super::media;
use super::spectra::SpectrumContext;
use super::{InputError, NONE, PrimInfo, Scene, ShapeInfo};
use crate::geometry::{Accel, Camera, Sphere, Triangle};
use crate::material::{Bbrrdf, FluorescentDiffuse, Lambert, Material, Reradiation};
use crate::spectrum::cie::Sensor;
use crate::spectrum::{DEFAULT_DOMAIN, Domain, Observer, Spectrum};
use glam::Vec3;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// Parse and validate the scene `text` of file `path` (which names the file in errors and
/// resolves relative paths).
pub fn scene(path: &Path, text: &str) -> Result<Scene, InputError> {
    let (f, shape_descs) = format::read(path, text)?;
    let mut warnings = Vec::new();
    let domain = domain(path, f.domain)?;
    let camera = camera(path, &f.camera)?;

    // Spectra and materials.
    let mut ctx = SpectrumContext {
        file: path,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        named: BTreeMap::new(),
        domain,
    };
    ctx.add_named(&f.spectra)?;
    let sensor = sensor(&ctx, f.camera.sensor.as_ref())?;
    let observer = Observer::with_sensor(domain, &sensor).map_err(|m| {
        let field = if sensor == Sensor::Cie1931 {
            "domain"
        } else {
            "camera.sensor"
        };
        at(path, field, m)
    })?;
    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    for (name, v) in &f.materials {
        let base = format!("materials.{name}");
        let desc: MaterialDesc = from_tagged_value(path, &base, "type", v)?;
        materials.push(material(&ctx, &base, desc, &mut warnings)?);
        material_names.push(name.clone());
    }

    let (media, medium_names) = media::media(&ctx, &f.media, &mut warnings)?;
    let camera_medium = media::medium_id(&ctx, &medium_names, &f.camera.medium, "camera.medium")?;

    // Shapes and lights.
    check_light_count(path, &shape_descs, domain)?;
    let mut b = Builder::default();
    for (si, s) in shape_descs.iter().enumerate() {
        let interface = media::interface(&ctx, &medium_names, s, &format!("shapes[{si}]"))?;
        b.add_shape(&ctx, &material_names, si, s, interface)?;
    }
    if b.lights.is_empty() {
        return Err(at(
            path,
            "shapes",
            "the scene has no light: give at least one shape an `emission`".into(),
        ));
    }
    if b.lights.iter().all(|l| l.power <= 0.0) {
        return Err(at(
            path,
            "shapes",
            "every light emits zero power over the wavelength domain".into(),
        ));
    }
    let mut prims = b.tri_info;
    prims.extend(b.sphere_info);
    let accel = Accel::build_quality(&b.triangles, &b.spheres, f.accel.quality);
    let triangle_normals = b
        .triangles
        .iter()
        .map(|t| t.normal_raw().normalize())
        .collect();
    let has_fluorescence = materials.iter().any(|m| m.is_fluorescent());
    let light_shapes = b.light_shapes;
    let mut scene = Scene {
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
        media,
        medium_names,
        camera_medium,
        has_media: false,
        light_media: Vec::new(),
        warnings,
    };
    scene.has_media =
        scene.camera_medium != NONE || scene.shapes.iter().any(|s| s.interface.is_some());
    if scene.has_media {
        media::check_nesting(&scene)?;
        scene.light_media = media::light_media(&scene, &light_shapes);
    }
    let unused = media::check_usage(&scene)?;
    media::check_optical_depth(&scene)?;
    scene.warnings.extend(unused);
    Ok(scene)
}

/// Each light tabulates its emission in 1-nm cells over the domain: check, before any is built,
/// that the lights × the domain's width stay within [`MAX_LIGHT_CELLS`].
fn check_light_count(path: &Path, shapes: &[ShapeDesc], domain: Domain) -> Result<(), InputError> {
    let per_light = domain.width().max(1.0) as f64;
    let max_lights = (MAX_LIGHT_CELLS / per_light) as usize;
    let emitting = shapes
        .iter()
        .enumerate()
        .filter(|(_, s)| s.emission.is_some());
    match emitting.clone().nth(max_lights) {
        None => Ok(()),
        Some((si, _)) => Err(at(
            path,
            &format!("shapes[{si}].emission"),
            format!(
                "too many lights for the domain: {} emitting shapes × a {} nm domain need more \
                 than {MAX_LIGHT_CELLS} 1-nm sampling cells (at most {max_lights} lights; merge \
                 emitters into one mesh or narrow the domain)",
                emitting.count(),
                domain.width()
            ),
        )),
    }
}

/// An error at JSON path `field` of `file`.
fn at(file: &Path, field: &str, message: String) -> InputError {
    InputError::new(file, field, message)
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// The point `a`, found at JSON path `path`, if its coordinates are finite and within
/// ±[`MAX_COORD`].
fn finite3(file: &Path, path: &str, a: [f32; 3]) -> Result<Vec3, InputError> {
    check_point(a)
        .map(|()| v3(a))
        .map_err(|m| InputError::new(file, path, m))
}

/// Why point `a` cannot be traced in f32, if it cannot.
fn check_point(a: [f32; 3]) -> Result<(), String> {
    if !a.iter().all(|x| x.is_finite()) {
        Err(format!("coordinates must be finite numbers, got {a:?}"))
    } else if !a.iter().all(|x| x.abs() <= MAX_COORD) {
        Err(format!(
            "coordinates must be within ±{MAX_COORD:e} (larger ones overflow f32 ray tracing), got {a:?}"
        ))
    } else {
        Ok(())
    }
}

/// The wavelength domain: the file's, checked, or the default.
fn domain(path: &Path, d: Option<[f32; 2]>) -> Result<Domain, InputError> {
    match d {
        None => Ok(DEFAULT_DOMAIN),
        Some([a, b]) => {
            if !(a.is_finite() && b.is_finite() && a >= 0.0 && a < b) {
                return Err(at(
                    path,
                    "domain",
                    format!("needs 0 ≤ min < max, got [{a}, {b}]"),
                ));
            }
            if b > MAX_WAVELENGTH {
                return Err(at(
                    path,
                    "domain",
                    format!(
                        "must lie within [0, {MAX_WAVELENGTH}] nm (spectra are tabulated in 1-nm \
                         cells over it), got [{a:?}, {b:?}]"
                    ),
                ));
            }
            Ok(Domain { min: a, max: b })
        }
    }
}

fn camera(path: &Path, c: &CameraDesc) -> Result<Camera, InputError> {
    let origin = finite3(path, "camera.origin", c.origin)?;
    let target = finite3(path, "camera.target", c.target)?;
    let up = finite3(path, "camera.up", c.up)?;
    let forward = (target - origin).normalize_or_zero();
    if forward == Vec3::ZERO {
        return Err(at(
            path,
            "camera.target",
            "must differ from camera.origin".into(),
        ));
    }
    if up.normalize_or_zero() == Vec3::ZERO {
        return Err(at(path, "camera.up", "must not be zero".into()));
    }
    if forward.cross(up.normalize()).length() < 1e-6 {
        return Err(at(
            path,
            "camera.up",
            "must not be parallel to the viewing direction".into(),
        ));
    }
    if !(c.fov >= MIN_FOV && c.fov < 180.0) {
        // Below MIN_FOV the film's area underflows in f32 and the camera's pdfs overflow.
        return Err(at(
            path,
            "camera.fov",
            format!("must be in [{MIN_FOV}, 180) degrees, got {}", c.fov),
        ));
    }
    for (v, field) in [(c.width, "camera.width"), (c.height, "camera.height")] {
        if !(1..=MAX_SIDE).contains(&v) {
            return Err(at(
                path,
                field,
                format!("must be 1–{MAX_SIDE} pixels, got {v}"),
            ));
        }
    }
    if c.width as u64 * c.height as u64 > MAX_PIXELS {
        return Err(at(
            path,
            "camera.height",
            format!(
                "{}×{} is more than {MAX_PIXELS} pixels (the film would not fit in memory)",
                c.width, c.height
            ),
        ));
    }
    Ok(Camera::look_at(
        origin,
        target,
        up,
        c.fov,
        c.fov_axis == FovAxis::X,
        c.width,
        c.height,
    ))
}

/// A passive surface reflects at most the light it receives: the reflectance of material
/// `base` may not exceed [`MAX_REFLECTANCE`] anywhere on the domain (beyond f32 rounding), or
/// path throughputs grow with every bounce until they overflow. The fluorescent material's
/// total albedo, r(1 − c·a) + c·a·Φ·∫e, is then at most 1 too, since a ≤ 1, ∫e = 1 and c, Φ ≤ 1.
fn check_reflectance(ctx: &SpectrumContext, base: &str, r: &Spectrum) -> Result<(), InputError> {
    let d = ctx.domain;
    let max = r.max_value(d);
    if max <= MAX_REFLECTANCE * (1.0 + 1e-6) {
        return Ok(());
    }
    let shown = if max < 1e6 {
        max.to_string()
    } else {
        format!("{max:e}")
    };
    // Where it is largest, to a quarter nm.
    let n = ((d.width() * 4.0) as usize).max(1);
    let at_max = (0..=n)
        .map(|i| d.min + d.width() * i as f32 / n as f32)
        .fold((d.min, f32::MIN), |best, l| {
            let v = r.eval(l);
            if v > best.1 { (l, v) } else { best }
        })
        .0;
    Err(at(
        ctx.file,
        &format!("{base}.reflectance"),
        format!(
            "is {shown} at {at_max} nm, above {MAX_REFLECTANCE}: a passive surface reflects at most \
             the light it receives"
        ),
    ))
}

/// The material `desc` found at JSON path `base`; warnings about it go to `warnings`.
fn material(
    ctx: &SpectrumContext,
    base: &str,
    desc: MaterialDesc,
    warnings: &mut Vec<String>,
) -> Result<Material, InputError> {
    let err = |p: &str, m: String| at(ctx.file, p, m);
    let domain = ctx.domain;
    if !cfg!(feature = "fluorescence") && !matches!(desc, MaterialDesc::Lambert { .. }) {
        return Err(err(
            &format!("{base}.type"),
            "this build of stokes has no fluorescent materials (built without the \
             `fluorescence` cargo feature); rebuild with the default features"
                .into(),
        ));
    }
    Ok(match desc {
        MaterialDesc::Lambert { reflectance } => {
            let r = ctx.parse(&reflectance, &format!("{base}.reflectance"))?;
            check_reflectance(ctx, base, &r)?;
            Material::Lambert(Lambert { reflectance: r })
        }
        #[cfg(feature = "fluorescence")]
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
            check_reflectance(ctx, base, &r)?;
            let (m, w) = FluorescentDiffuse::new(r, a, e, quantum_yield, concentration, domain)
                .map_err(|(f, m)| err(&format!("{base}.{f}"), m))?;
            warnings.extend(w.into_iter().map(|w| format!("{base}: {w}")));
            Material::Fluorescent(m)
        }
        #[cfg(feature = "fluorescence")]
        MaterialDesc::Reradiation { file } => {
            let full = ctx.dir.join(&file);
            let text = crate::io::input::read_text(&full, crate::io::input::BFC)
                .map_err(|e| err(&format!("{base}.file"), e))?;
            let m = Reradiation::parse_bfc(&text, domain).map_err(|m| {
                err(
                    &format!("{base}.file"),
                    format!("malformed BFC file '{}': {m}", full.display()),
                )
            })?;
            Material::Reradiation(m)
        }
        #[cfg(feature = "fluorescence")]
        MaterialDesc::ReradiationGmm {
            file,
            bfc,
            components,
            method,
            seed,
        } => {
            let src = gmm::GmmSource {
                file,
                bfc,
                components,
                method,
                seed,
            };
            let f = gmm::load(ctx.file, &ctx.dir, base, src, warnings)?;
            Material::ReradiationGmm(crate::material::ReradiationGmm::new(&f, domain))
        }
        #[cfg(not(feature = "fluorescence"))]
        _ => unreachable!("refused above"),
    })
}

/// The primitives of the scene as its shapes are added, in order.
#[derive(Default)]
struct Builder {
    triangles: Vec<Triangle>,
    tri_info: Vec<PrimInfo>,
    spheres: Vec<Sphere>,
    sphere_flip: Vec<bool>,
    sphere_info: Vec<PrimInfo>,
    shapes: Vec<ShapeInfo>,
    lights: Vec<AreaLight>,
    /// The shape of each light.
    light_shapes: Vec<u32>,
    /// The shape each name (given or default) belongs to.
    names: HashMap<String, usize>,
}

/// An error at field `field` of the shape at JSON path `base` (the shape itself if empty).
fn shape_err(file: &Path, base: &str, field: &str, m: String) -> InputError {
    if field.is_empty() {
        InputError::new(file, base, m)
    } else {
        InputError::new(file, format!("{base}.{field}"), m)
    }
}

impl Builder {
    /// Add shape number `si`, `s`, with its light if it emits.
    fn add_shape(
        &mut self,
        ctx: &SpectrumContext,
        material_names: &[String],
        si: usize,
        s: &ShapeDesc,
        interface: Option<media::MediumInterface>,
    ) -> Result<(), InputError> {
        let base = format!("shapes[{si}]");
        let err = |p: &str, m: String| shape_err(ctx.file, &base, p, m);
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
        let shape_id = self.shapes.len() as u32;
        let name = self.unique_name(ctx.file, &base, si, s)?;
        self.shapes.push(ShapeInfo {
            name: name.clone(),
            material,
            interface,
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

        let budget = MAX_PRIMITIVES - self.triangles.len() - self.spheres.len();
        let (mut tris, sphere) = geometry(ctx.file, &ctx.dir, &base, &s.geometry, budget)?;
        check_areas(&tris).map_err(|m| err("", m))?;
        if s.flip_normals {
            tris.iter_mut().for_each(|t| t.v.swap(1, 2));
        }
        let area: f32 = if let Some(sp) = sphere {
            sp.area()
        } else {
            tris.iter().map(|t| t.area()).sum()
        };

        if let Some(e) = &s.emission {
            let shape = if let Some(sp) = sphere {
                LightShape::Sphere {
                    sphere: sp,
                    flip: s.flip_normals,
                }
            } else {
                triangles_light_shape(&tris, area)
            };
            let light = area_light(ctx, &base, name, e, shape, area)?;
            self.lights.push(light);
            self.light_shapes.push(shape_id);
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

    /// The name of shape `s` (number `si`, at JSON path `base`): its `name`, or `shape<si>`;
    /// names identify regions and lights, so a name used twice is an error.
    fn unique_name(
        &mut self,
        file: &Path,
        base: &str,
        si: usize,
        s: &ShapeDesc,
    ) -> Result<String, InputError> {
        let name = s.name.clone().unwrap_or_else(|| format!("shape{si}"));
        if let Some(&other) = self.names.get(&name) {
            let (field, what) = if s.name.is_some() {
                ("name", format!("'{name}'"))
            } else {
                (
                    "",
                    format!("the default name '{name}' of this unnamed shape"),
                )
            };
            return Err(shape_err(
                file,
                base,
                field,
                format!(
                    "{what} is already the name of shapes[{other}] (shape names identify \
                     regions and lights, and must be unique)"
                ),
            ));
        }
        self.names.insert(name.clone(), si);
        Ok(name)
    }
}

/// Why triangles `tris` cannot be rendered, if one is degenerate.
fn check_areas(tris: &[Triangle]) -> Result<(), String> {
    for (k, t) in tris.iter().enumerate() {
        let a = t.area();
        if !a.is_finite() {
            return Err(format!(
                "triangle {k} has a non-finite area ({a}): its coordinates are not finite or too large"
            ));
        }
        if a < MIN_AREA {
            return Err(format!(
                "degenerate geometry: triangle {k} has zero area ({a}, below {MIN_AREA:e})"
            ));
        }
    }
    Ok(())
}

/// The light of shape `name` at JSON path `base`, emitting `e` from `shape` of area `area`.
fn area_light(
    ctx: &SpectrumContext,
    base: &str,
    name: String,
    e: &EmissionDesc,
    shape: LightShape,
    area: f32,
) -> Result<AreaLight, InputError> {
    if !(e.scale.is_finite() && e.scale >= 0.0) {
        return Err(shape_err(
            ctx.file,
            base,
            "emission.scale",
            format!("must be a finite non-negative number, got {}", e.scale),
        ));
    }
    let spec = ctx.parse(&e.spectrum, &format!("{base}.emission.spectrum"))?;
    let peak = largest_value(&spec) as f64;
    if peak * e.scale as f64 > MAX_RADIANCE {
        let field = if peak > MAX_RADIANCE || e.scale == 1.0 {
            "emission.spectrum"
        } else {
            "emission.scale"
        };
        return Err(shape_err(
            ctx.file,
            base,
            field,
            format!(
                "emitted radiance spectrum × scale = {:?} × {:?} = {:.3e} exceeds \
                 {MAX_RADIANCE:e} (f32 radiance arithmetic would overflow)",
                peak as f32,
                e.scale,
                peak * e.scale as f64
            ),
        ));
    }
    let spec = spec.scaled(e.scale);
    Ok(AreaLight::new(
        name,
        shape,
        spec,
        e.two_sided,
        area,
        ctx.domain,
    ))
}

/// The largest value spectrum `s` takes anywhere.
fn largest_value(s: &Spectrum) -> f32 {
    match s {
        Spectrum::Constant(v) => *v,
        Spectrum::Box { value, .. } => *value,
        Spectrum::Gaussian { peak, .. } => *peak,
        Spectrum::Tabulated { ys: v, .. } | Spectrum::Binned { values: v, .. } => {
            v.iter().copied().fold(0.0, f32::max)
        }
    }
}

/// A light made of (a copy of) triangles `tris` of total area `area`.
fn triangles_light_shape(tris: &[Triangle], area: f32) -> LightShape {
    let mut acc = 0.0;
    let cdf = tris
        .iter()
        .map(|t| {
            acc += t.area() / area;
            acc
        })
        .collect();
    LightShape::triangles(tris.to_vec(), cdf)
}

/// The triangles, or the sphere, of the shape at JSON path `base` (relative files are in `dir`),
/// at most `budget` of them (the primitives the scene may still add).
fn geometry(
    file: &Path,
    dir: &Path,
    base: &str,
    g: &ShapeGeometry,
    budget: usize,
) -> Result<(Vec<Triangle>, Option<Sphere>), InputError> {
    let too_many = |n: usize| {
        format!(
            "{n} triangles would take the scene past its limit of {MAX_PRIMITIVES} primitives \
             ({budget} left)"
        )
    };
    let err = |p: &str, m: String| shape_err(file, base, p, m);
    let mut tris: Vec<Triangle> = Vec::new();
    match g {
        ShapeGeometry::Quad { corners } => {
            let p: Vec<Vec3> = corners
                .iter()
                .enumerate()
                .map(|(i, x)| finite3(file, &format!("{base}.corners[{i}]"), *x))
                .collect::<Result<_, _>>()?;
            tris.push(Triangle::new(p[0], p[1], p[2]));
            tris.push(Triangle::new(p[0], p[2], p[3]));
        }
        ShapeGeometry::Box { min, max } => {
            let lo = finite3(file, &format!("{base}.min"), *min)?;
            let hi = finite3(file, &format!("{base}.max"), *max)?;
            if !(lo.cmplt(hi).all()) {
                return Err(err(
                    "max",
                    format!("box needs min < max on every axis, got {lo} and {hi}"),
                ));
            }
            tris.extend(box_triangles(lo, hi));
        }
        ShapeGeometry::Sphere { center, radius } => {
            let c = finite3(file, &format!("{base}.center"), *center)?;
            let r = *radius;
            if !(r > 0.0 && r.is_finite()) {
                return Err(err("radius", format!("must be a positive number, got {r}")));
            }
            if !(MIN_RADIUS..=MAX_COORD).contains(&r) {
                return Err(err(
                    "radius",
                    format!(
                        "must be in [{MIN_RADIUS:e}, {MAX_COORD:e}] (f32 ray tracing), got {r:e}"
                    ),
                ));
            }
            if budget == 0 {
                return Err(err("", too_many(1).replace("1 triangles", "a sphere")));
            }
            let sphere = Sphere {
                center: c,
                radius: r,
            };
            return Ok((tris, Some(sphere)));
        }
        ShapeGeometry::Triangles { vertices, indices } => {
            for (i, x) in vertices.iter().enumerate() {
                finite3(file, &format!("{base}.vertices[{i}]"), *x)?;
            }
            if indices.is_empty() {
                return Err(err(
                    "indices",
                    "needs at least one triangle, got none".into(),
                ));
            }
            if indices.len() > budget {
                return Err(err("indices", too_many(indices.len())));
            }
            tris.reserve(indices.len());
            for (k, idx) in indices.iter().enumerate() {
                if let Some(bad) = idx.iter().find(|&&i| i as usize >= vertices.len()) {
                    return Err(err(
                        &format!("indices[{k}]"),
                        format!("index {bad} out of range ({} vertices)", vertices.len()),
                    ));
                }
                tris.push(Triangle::new(
                    v3(vertices[idx[0] as usize]),
                    v3(vertices[idx[1] as usize]),
                    v3(vertices[idx[2] as usize]),
                ));
            }
        }
        ShapeGeometry::Obj {
            file: obj,
            scale,
            translate,
        } => {
            let scale = scale.unwrap_or(1.0);
            let tr = finite3(
                file,
                &format!("{base}.translate"),
                translate.unwrap_or([0.0; 3]),
            )?;
            if !(scale.is_finite() && scale != 0.0 && scale.abs() <= MAX_COORD) {
                return Err(err(
                    "scale",
                    format!("must be a non-zero finite number within ±{MAX_COORD:e}, got {scale}"),
                ));
            }
            tris = obj_triangles(&dir.join(obj), scale, tr, budget).map_err(|m| err("file", m))?;
        }
    }
    Ok((tris, None))
}

/// The triangles of OBJ file `full`, scaled by `scale`, then translated by `tr`; at most
/// `budget` of them.
fn obj_triangles(
    full: &Path,
    scale: f32,
    tr: Vec3,
    budget: usize,
) -> Result<Vec<Triangle>, String> {
    use crate::io::input::{LineCapped, MAX_LINE_BYTES, MTL, OBJ, reader};
    let (r, _) = reader(full, OBJ)?;
    let mut r = LineCapped::new(r, MAX_LINE_BYTES);
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    // Material libraries are read as the OBJ is (a regular file, capped); their materials are
    // not used, so one that cannot be read is no error.
    let dir = full.parent().unwrap_or(Path::new("."));
    let mtl = |p: &Path| match reader(&dir.join(p), MTL) {
        Ok((m, _)) => tobj::load_mtl_buf(&mut LineCapped::new(m, MAX_LINE_BYTES)),
        Err(_) => Err(tobj::LoadError::OpenFileFailed),
    };
    let (models, _) = tobj::load_obj_buf(&mut r, &options, mtl).map_err(|e| {
        if r.overlong() {
            format!(
                "cannot load OBJ '{}': a line longer than {MAX_LINE_BYTES} bytes",
                full.display()
            )
        } else {
            format!("cannot load OBJ '{}': {e}", full.display())
        }
    })?;
    let n: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    if n > budget {
        return Err(format!(
            "OBJ '{}' has {n} triangles: more than the {budget} the scene may still add (at most \
             {MAX_PRIMITIVES} primitives)",
            full.display()
        ));
    }
    let mut tris = Vec::with_capacity(n);
    for m in models {
        // Every vertex, transformed and checked (the indices are checked by tobj).
        let pos: Vec<Vec3> = m
            .mesh
            .positions
            .chunks_exact(3)
            .enumerate()
            .map(|(k, p)| {
                let q = Vec3::new(p[0], p[1], p[2]) * scale + tr;
                check_point(q.to_array()).map(|()| q).map_err(|e| {
                    format!(
                        "OBJ '{}', object '{}', vertex {k} after scale and translate: {e}",
                        full.display(),
                        m.name
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        for t in m.mesh.indices.chunks_exact(3) {
            let p = |i: u32| pos.get(i as usize).copied().unwrap_or(Vec3::NAN);
            tris.push(Triangle::new(p(t[0]), p(t[1]), p(t[2])));
        }
    }
    if tris.is_empty() {
        return Err(format!("OBJ '{}' has no triangles", full.display()));
    }
    Ok(tris)
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

/// The camera's `sensor`: absent or `"cie-1931"`, `{"band": [lo, hi]}` (nm, lo < hi) or
/// `{"response": SPECTRUM}` (any spectrum the scene format takes).
fn sensor(ctx: &SpectrumContext, v: Option<&serde_json::Value>) -> Result<Sensor, InputError> {
    use serde_json::Value;
    const FIELD: &str = "camera.sensor";
    let err = |field: &str, m: &str| Err(InputError::new(ctx.file, field, m.to_string()));
    let Some(v) = v else {
        return Ok(Sensor::Cie1931);
    };
    match v {
        Value::String(s) if s == "cie-1931" => Ok(Sensor::Cie1931),
        Value::Object(o) if o.len() == 1 && o.contains_key("band") => {
            let band = &o["band"];
            let pair = band.as_array().and_then(|a| {
                let lo = a.first()?.as_f64()?;
                let hi = a.get(1)?.as_f64()?;
                (a.len() == 2).then_some((lo as f32, hi as f32))
            });
            match pair {
                Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo < hi => {
                    Ok(Sensor::Response(Spectrum::Box { lo, hi, value: 1.0 }))
                }
                Some((lo, hi)) => err(
                    "camera.sensor.band",
                    &format!("needs finite wavelengths lo < hi in nm, got [{lo}, {hi}]"),
                ),
                None => err(
                    "camera.sensor.band",
                    "must be two wavelengths in nm, [lo, hi]",
                ),
            }
        }
        Value::Object(o) if o.len() == 1 && o.contains_key("response") => Ok(Sensor::Response(
            ctx.parse(&o["response"], "camera.sensor.response")?,
        )),
        _ => err(
            FIELD,
            "must be \"cie-1931\", {\"band\": [lo, hi]} or {\"response\": SPECTRUM}",
        ),
    }
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
