//! Building a runtime [`Scene`] from the format types of `format.rs`, validating as it goes:
//! the domain, camera and sensor (`camera.rs`), spectra and materials (`materials.rs`), shapes
//! and their lights (`shapes.rs`, their triangles and spheres in `shape_geometry.rs`), the light
//! selection distribution, and the acceleration structure.

use super::camera::{camera, domain, sensor};
use super::checks::at;
use super::format::{self, MaterialDesc, ShapeDesc};
use super::lights::LightSet;
use super::limits::MAX_LIGHT_CELLS;
use super::materials::material;
use super::media;
use super::shapes::Builder;
use super::spectra::SpectrumContext;
use super::{NONE, Scene};
use crate::geometry::Accel;
use crate::io::InputError;
use crate::io::json::from_tagged_value;
use crate::material::Bbrrdf;
use crate::spectrum::cie::Sensor;
use crate::spectrum::{Domain, Observer};
use std::collections::BTreeMap;
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
