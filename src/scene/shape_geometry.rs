//! The triangles, or the sphere, of one shape: quads, boxes, spheres, triangle lists and OBJ
//! files, each point checked and at most as many primitives as the scene may still add.

use super::checks::{check_point, finite3, shape_err, v3};
use super::format::ShapeGeometry;
use super::limits::{MAX_COORD, MAX_PRIMITIVES, MIN_RADIUS};
use crate::geometry::{Sphere, Triangle};
use crate::io::InputError;
use glam::Vec3;
use std::path::Path;

/// The triangles, or the sphere, of the shape at JSON path `base` (relative files are in `dir`),
/// at most `budget` of them (the primitives the scene may still add).
pub(super) fn geometry(
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
