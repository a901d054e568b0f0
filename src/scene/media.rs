//! Media in a scene: building the named media of the file, the medium interfaces of shapes
//! (`interior`/`exterior`) and the camera's medium, and checking that they nest consistently.
//!
//! The conventions are pbrt-v4's and Mitsuba's: a shape's normal points to its exterior; a shape
//! with an interface changes the medium a ray is in when the ray crosses it, one without leaves
//! it unchanged; a shape with no material and no emission is an index-matched boundary:
//! invisible, and not a bounce.

use super::format::{FluorescenceDesc, MediumDesc, PhaseDesc, ShapeDesc};
use super::limits::{MAX_COORD, MAX_OPTICAL_DEPTH};
use super::spectra::SpectrumContext;
use super::{NONE, Scene};
use crate::geometry::ray::cross_boundary_ray;
use crate::io::InputError;
use crate::io::json::{from_json_value, from_tagged_value};
use crate::medium::grid::DensityGrid;
use crate::medium::{Coefficients, Density, Fluorophore, GridDensity, Medium};
use crate::spectrum::{Spectrum, normalisable};
use serde_json::Value;
use std::collections::BTreeMap;

/// The media on the two sides of a shape (ids into `Scene::media`, [`NONE`] for vacuum).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MediumInterface {
    pub interior: u32,
    pub exterior: u32,
}

impl MediumInterface {
    /// The medium on the side of a surface with normal `n` that direction `d` leaves towards.
    #[inline]
    pub fn towards(&self, n: glam::Vec3, d: glam::Vec3) -> u32 {
        if n.dot(d) > 0.0 {
            self.exterior
        } else {
            self.interior
        }
    }
}

/// Build the media of the file: (media, names).
pub fn media(
    ctx: &SpectrumContext,
    descs: &BTreeMap<String, Value>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Medium>, Vec<String>), InputError> {
    let mut media = Vec::new();
    let mut names = Vec::new();
    for (name, v) in descs {
        let base = format!("media.{name}");
        let desc: MediumDesc = from_tagged_value(ctx.file, &base, "type", v)?;
        media.push(medium(ctx, &base, desc, warnings)?);
        names.push(name.clone());
    }
    Ok((media, names))
}

/// A spectrum that must be finite and non-negative over the domain.
fn coefficient(ctx: &SpectrumContext, v: &Value, path: &str) -> Result<Spectrum, InputError> {
    let s = ctx.parse(v, path)?;
    let lo = s.min_value(ctx.domain);
    if !(lo >= 0.0) || !s.max_value(ctx.domain).is_finite() {
        return Err(InputError::new(
            ctx.file,
            path,
            format!("a coefficient must be finite and non-negative, its minimum is {lo}"),
        ));
    }
    Ok(s)
}

fn medium(
    ctx: &SpectrumContext,
    base: &str,
    desc: MediumDesc,
    warnings: &mut Vec<String>,
) -> Result<Medium, InputError> {
    if !cfg!(feature = "media") {
        return Err(InputError::new(
            ctx.file,
            base,
            "this build of stokes has no participating media (built without the `media` cargo \
             feature); rebuild with the default features",
        ));
    }
    let (sigma_a, sigma_s, phase, fluorescence, density) = match desc {
        MediumDesc::Homogeneous {
            sigma_a,
            sigma_s,
            phase,
            fluorescence,
        } => (sigma_a, sigma_s, phase, fluorescence, Density::Homogeneous),
        MediumDesc::Grid {
            file,
            density_scale,
            sigma_a,
            sigma_s,
            phase,
            fluorescence,
        } => {
            let d = grid_density(ctx, base, &file, density_scale)?;
            (sigma_a, sigma_s, phase, fluorescence, d)
        }
    };
    let phase: PhaseDesc = match phase {
        None => PhaseDesc::Isotropic {},
        Some(v) => from_tagged_value(ctx.file, &format!("{base}.phase"), "type", &v)?,
    };
    let fluorescence: Option<FluorescenceDesc> = match fluorescence {
        None => None,
        Some(_) if !cfg!(feature = "fluorescence") => {
            return Err(InputError::new(
                ctx.file,
                format!("{base}.fluorescence"),
                "this build of stokes has no fluorescence (built without the `fluorescence` \
                 cargo feature); rebuild with the default features",
            ));
        }
        Some(v) => Some(from_json_value(
            ctx.file,
            &format!("{base}.fluorescence"),
            &v,
        )?),
    };
    let g = match phase {
        PhaseDesc::Isotropic {} => 0.0,
        PhaseDesc::HenyeyGreenstein { g } => {
            if !(g > -1.0 && g < 1.0) {
                return Err(InputError::new(
                    ctx.file,
                    format!("{base}.phase.g"),
                    format!("must be in (−1, 1), got {g}"),
                ));
            }
            g
        }
    };
    let fluorophore = match fluorescence {
        None => None,
        Some(f) => Some(fluorophore(
            ctx,
            &format!("{base}.fluorescence"),
            f,
            warnings,
        )?),
    };
    let coefficients = Coefficients::new(
        coefficient(ctx, &sigma_a, &format!("{base}.sigma_a"))?,
        coefficient(ctx, &sigma_s, &format!("{base}.sigma_s"))?,
        fluorophore,
    );
    Ok(Medium {
        coefficients,
        g,
        density,
    })
}

/// The density of a grid medium: the `.vol` file `file` scaled by `scale`.
fn grid_density(
    ctx: &SpectrumContext,
    base: &str,
    file: &str,
    scale: f32,
) -> Result<Density, InputError> {
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(InputError::new(
            ctx.file,
            format!("{base}.density_scale"),
            format!("must be a finite non-negative number, got {scale}"),
        ));
    }
    let full = ctx.dir.join(file);
    let grid = DensityGrid::read_vol(&full).map_err(|m| {
        InputError::new(
            ctx.file,
            format!("{base}.file"),
            format!("grid volume '{}': {m}", full.display()),
        )
    })?;
    if grid.min.abs().max(grid.max.abs()).max_element() > MAX_COORD {
        return Err(InputError::new(
            ctx.file,
            format!("{base}.file"),
            format!(
                "grid volume '{}': its bounding box {} – {} reaches beyond ±{MAX_COORD:e}",
                full.display(),
                grid.min,
                grid.max
            ),
        ));
    }
    Ok(Density::Grid(Box::new(GridDensity::new(grid, scale))))
}

fn fluorophore(
    ctx: &SpectrumContext,
    base: &str,
    f: FluorescenceDesc,
    warnings: &mut Vec<String>,
) -> Result<Fluorophore, InputError> {
    let err = |field: &str, m: String| InputError::new(ctx.file, format!("{base}.{field}"), m);
    if !(0.0..=1.0).contains(&f.quantum_yield) {
        return Err(err(
            "quantum_yield",
            format!("must be in [0, 1], got {}", f.quantum_yield),
        ));
    }
    if !(f.concentration.is_finite() && f.concentration >= 0.0) {
        return Err(err(
            "concentration",
            format!(
                "must be a finite non-negative extinction per scene unit, got {}",
                f.concentration
            ),
        ));
    }
    let domain = ctx.domain;
    let a = coefficient(ctx, &f.absorption, &format!("{base}.absorption"))?;
    let e = coefficient(ctx, &f.emission, &format!("{base}.emission"))?;
    let a_max = a.max_value(domain);
    if !(a_max > 0.0) {
        return Err(err(
            "absorption",
            "is zero on the whole wavelength domain".into(),
        ));
    }
    let e_area = e.integral(domain.min, domain.max);
    if !(e_area > 0.0) {
        return Err(err(
            "emission",
            "is zero on the whole wavelength domain".into(),
        ));
    }
    normalisable("its peak", a_max as f64).map_err(|m| err("absorption", m))?;
    normalisable("its area (nm)", e_area).map_err(|m| err("emission", m))?;
    if (a_max - 1.0).abs() > 1e-3 {
        warnings.push(format!(
            "{base}.absorption: max is {a_max}, not 1: normalised (the concentration is the peak extinction)"
        ));
    }
    if (e_area - 1.0).abs() > 1e-3 {
        warnings.push(format!(
            "{base}.emission: area {e_area} nm on the domain, not 1: normalised"
        ));
    }
    Ok(Fluorophore::new(
        a.divided(a_max as f64),
        f.concentration,
        e.divided(e_area),
        f.quantum_yield,
        domain,
    ))
}

/// Resolve a medium name at JSON path `path` (`None`: vacuum).
pub fn medium_id(
    ctx: &SpectrumContext,
    names: &[String],
    name: &Option<String>,
    path: &str,
) -> Result<u32, InputError> {
    let Some(name) = name else { return Ok(NONE) };
    names
        .iter()
        .position(|n| n == name)
        .map(|i| i as u32)
        .ok_or_else(|| {
            InputError::new(
                ctx.file,
                path,
                if names.is_empty() {
                    format!("unknown medium '{name}': the scene defines no `media`")
                } else {
                    format!("unknown medium '{name}' (defined: {})", names.join(", "))
                },
            )
        })
}

/// The interface of shape `s` at JSON path `base`, if it names a medium.
pub fn interface(
    ctx: &SpectrumContext,
    names: &[String],
    s: &ShapeDesc,
    base: &str,
) -> Result<Option<MediumInterface>, InputError> {
    if s.interior.is_none() && s.exterior.is_none() {
        if s.material.is_none() && s.emission.is_none() {
            return Err(InputError::new(
                ctx.file,
                format!("{base}.material"),
                "a shape needs a `material`, an `emission`, or both; without them it is an \
                 index-matched boundary and must name an `interior` or `exterior` medium"
                    .to_string(),
            ));
        }
        return Ok(None);
    }
    Ok(Some(MediumInterface {
        interior: medium_id(ctx, names, &s.interior, &format!("{base}.interior"))?,
        exterior: medium_id(ctx, names, &s.exterior, &format!("{base}.exterior"))?,
    }))
}

/// Check which media are used: an error for a medium that is only ever an `exterior` (it can
/// never be entered); returns a warning for each medium nobody names.
pub fn check_usage(scene: &Scene) -> Result<Vec<String>, InputError> {
    let n = scene.media.len();
    let mut interior = vec![false; n];
    let mut exterior_of: Vec<Option<usize>> = vec![None; n];
    for (si, s) in scene.shapes.iter().enumerate() {
        if let Some(i) = s.interface {
            if i.interior != NONE {
                interior[i.interior as usize] = true;
            }
            if i.exterior != NONE {
                exterior_of[i.exterior as usize].get_or_insert(si);
            }
        }
    }
    if scene.camera_medium != NONE {
        interior[scene.camera_medium as usize] = true;
    }
    let mut warnings = Vec::new();
    for (m, name) in scene.medium_names.iter().enumerate() {
        if !interior[m] && exterior_of[m].is_none() {
            warnings.push(format!(
                "media.{name} is never used: no shape has it as `interior` or `exterior`"
            ));
        }
        if let Some(si) = exterior_of[m].filter(|_| !interior[m]) {
            let shape = &scene.shapes[si].name;
            return Err(InputError::new(
                &scene.file,
                format!("shapes[{si}].exterior"),
                format!(
                    "medium '{name}' is the exterior of shape '{shape}' but no shape has it as \
                     `interior` and the camera is not in it: it can never be entered"
                ),
            ));
        }
    }
    Ok(warnings)
}

/// Check that no medium is so dense that tracking through it would not end: its largest
/// collision coefficient (σ̂t or σ̂s, times the grid's density) times its extent (the bounding
/// box of the shapes it fills, of its grid, or of the scene for the camera's medium) is at most
/// [`MAX_OPTICAL_DEPTH`].
pub fn check_optical_depth(scene: &Scene) -> Result<(), InputError> {
    use glam::Vec3;
    let n = scene.media.len();
    let nt = scene.triangles.len();
    let prim_bounds = |p: usize| -> (Vec3, Vec3) {
        if p < nt {
            let v = scene.triangles[p].v;
            (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]))
        } else {
            let s = &scene.spheres[p - nt];
            (s.center - s.radius, s.center + s.radius)
        }
    };
    // Per medium, then (last) for the whole scene: the bounding box.
    let mut lo = vec![Vec3::INFINITY; n + 1];
    let mut hi = vec![Vec3::NEG_INFINITY; n + 1];
    for (p, info) in scene.prims.iter().enumerate() {
        let (a, b) = prim_bounds(p);
        let interior = scene.shapes[info.shape as usize]
            .interface
            .map_or(NONE, |i| i.interior);
        for k in [n, interior as usize] {
            if k <= n {
                lo[k] = lo[k].min(a);
                hi[k] = hi[k].max(b);
            }
        }
    }
    let size = |k: usize| (hi[k] - lo[k]).max(Vec3::ZERO).length();
    for (m, medium) in scene.media.iter().enumerate() {
        let mut extent = if hi[m].x >= lo[m].x { size(m) } else { size(n) };
        let (density, with) = match &medium.density {
            crate::medium::Density::Homogeneous => (1.0, ""),
            crate::medium::Density::Grid(g) => {
                extent = extent.min((g.grid.max - g.grid.min).length());
                let d = g.scale as f64 * g.grid.max_density() as f64;
                (d, " (with the grid's largest density × density_scale)")
            }
        };
        let sigma = medium.coefficients.majorant_over(scene.domain) as f64 * density;
        let depth = sigma * extent as f64;
        if !(depth <= MAX_OPTICAL_DEPTH) {
            return Err(InputError::new(
                &scene.file,
                format!("media.{}", scene.medium_names[m]),
                format!(
                    "too dense: its largest collision coefficient {sigma:.3e} per unit{with} \
                     across its extent of {extent:.3e} \
                     units is an optical depth of {depth:.3e}, more than {MAX_OPTICAL_DEPTH:e} \
                     (tracking would take about that many steps per ray)"
                ),
            ));
        }
    }
    Ok(())
}

/// Follow probe rays from the camera through every surface and check that each interface a ray
/// crosses has, on the side the ray comes from, the medium the ray is in. Errors name both
/// shapes involved.
pub fn check_nesting(scene: &Scene) -> Result<(), InputError> {
    const PROBES: u32 = 24;
    let (w, h) = (scene.camera.width as f32, scene.camera.height as f32);
    let medium_name = |m: u32| {
        if m == NONE {
            "vacuum".to_string()
        } else {
            format!("'{}'", scene.medium_names[m as usize])
        }
    };
    for py in 0..PROBES {
        for px in 0..PROBES {
            let x = (px as f32 + 0.5) / PROBES as f32 * w;
            let y = (py as f32 + 0.5) / PROBES as f32 * h;
            let mut ray = scene.camera.generate_ray(x, y);
            let mut current = scene.camera_medium;
            let mut from = "the camera (`camera.medium`)".to_string();
            for _ in 0..256 {
                let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
                    break;
                };
                let si = scene.prims[it.prim as usize].shape as usize;
                if let Some(i) = scene.shapes[si].interface {
                    let (near, far) = if it.n.dot(ray.d) < 0.0 {
                        (i.exterior, i.interior)
                    } else {
                        (i.interior, i.exterior)
                    };
                    let side = if near == i.exterior {
                        "exterior"
                    } else {
                        "interior"
                    };
                    let shape = &scene.shapes[si].name;
                    if near != current {
                        return Err(InputError::new(
                            &scene.file,
                            format!("shapes[{si}].{side}"),
                            format!(
                                "inconsistent media: shape '{shape}' has {} as its {side}, but a \
                                 ray from the camera reaches that side through {} (entered at {from})",
                                medium_name(near),
                                medium_name(current)
                            ),
                        ));
                    }
                    current = far;
                    from = format!("shape '{shape}'");
                }
                ray = cross_boundary_ray(it.p, it.n, ray.d);
            }
        }
    }
    Ok(())
}

/// The media on the front and back side of each light: its shape's interface, or, for a shape
/// without one, the medium around a point of the light, found by walking a ray from the camera
/// to it through the interfaces on the way.
pub fn light_media(scene: &Scene, light_shapes: &[u32]) -> Vec<[u32; 2]> {
    light_shapes
        .iter()
        .enumerate()
        .map(|(li, &si)| {
            if let Some(i) = scene.shapes[si as usize].interface {
                return [i.exterior, i.interior];
            }
            let p = scene.lights[li].sample_point(0.5, [0.5, 0.5]).p;
            let m = medium_at(scene, p);
            [m, m]
        })
        .collect()
}

/// The medium at point `p`, by following the interfaces a ray from the camera crosses on its
/// way to `p`.
pub fn medium_at(scene: &Scene, p: glam::Vec3) -> u32 {
    let o = scene.camera.origin;
    let mut current = scene.camera_medium;
    let to = p - o;
    let dist = to.length();
    if !(dist > 0.0) {
        return current;
    }
    let mut ray = crate::geometry::Ray::new(o, to / dist);
    let mut travelled = 0.0f32;
    for _ in 0..256 {
        let Some(it) = scene.intersect(&ray, dist - travelled - 1e-4 * dist) else {
            break;
        };
        if let Some(i) = scene.interface(&it) {
            current = i.towards(it.n, ray.d);
        }
        ray = cross_boundary_ray(it.p, it.n, ray.d);
        travelled = (ray.o - o).length();
        if travelled >= dist {
            break;
        }
    }
    current
}
