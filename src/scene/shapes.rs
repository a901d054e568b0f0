//! The primitives of the scene as its shapes are added: materials, unique names, degenerate
//! triangles, and the area light of a shape that emits.

use super::checks::shape_err;
use super::format::{EmissionDesc, ShapeDesc};
use super::lights::{AreaLight, LightShape};
use super::limits::{MAX_PRIMITIVES, MAX_RADIANCE, MIN_AREA};
use super::media;
use super::shape_geometry::geometry;
use super::spectra::SpectrumContext;
use super::{NONE, PrimInfo, ShapeInfo};
use crate::geometry::{Sphere, Triangle};
use crate::io::InputError;
use crate::spectrum::Spectrum;
use std::collections::HashMap;
use std::path::Path;

/// The primitives of the scene as its shapes are added, in order.
#[derive(Default)]
pub(super) struct Builder {
    pub(super) triangles: Vec<Triangle>,
    pub(super) tri_info: Vec<PrimInfo>,
    pub(super) spheres: Vec<Sphere>,
    pub(super) sphere_flip: Vec<bool>,
    pub(super) sphere_info: Vec<PrimInfo>,
    pub(super) shapes: Vec<ShapeInfo>,
    pub(super) lights: Vec<AreaLight>,
    /// The shape of each light.
    pub(super) light_shapes: Vec<u32>,
    /// The shape each name (given or default) belongs to.
    names: HashMap<String, usize>,
}

impl Builder {
    /// Add shape number `si`, `s`, with its light if it emits.
    pub(super) fn add_shape(
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
