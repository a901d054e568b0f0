//! The JSON scene format: the serde types a scene file is read into, and nothing else
//! (`build.rs` validates them and builds the runtime [`Scene`](super::Scene)).
//!
//! Shapes are read in two steps so that every error keeps its full JSON path: the top level is
//! parsed with each shape left as a JSON value, then the shape's `type` chooses the struct its
//! fields must fit. A serde internally tagged enum would report errors inside a shape at the
//! shape (`shapes[1]`, not `shapes[1].radius`), and `deny_unknown_fields` does not work with
//! `#[serde(flatten)]`; so `shape_kinds!` writes the fields common to every shape into one
//! struct per kind, and serde rejects misplaced fields and enforces the required ones.

use crate::io::InputError;
use crate::io::json::{from_json_str, from_json_value, reject_duplicate_keys};
use serde::Deserialize;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// The top level of a scene file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Free text; ignored.
    #[serde(default)]
    #[allow(dead_code)]
    pub comment: Option<Value>,
    #[serde(default)]
    pub domain: Option<[f32; 2]>,
    pub camera: CameraDesc,
    /// Named spectra (see `spectra.rs`).
    #[serde(default)]
    pub spectra: BTreeMap<String, Value>,
    /// Named materials, each a [`MaterialDesc`] (read by the builder, after the spectra).
    #[serde(default)]
    pub materials: BTreeMap<String, Value>,
    /// Named media, each a [`MediumDesc`] (read by the builder, after the spectra).
    #[serde(default)]
    pub media: BTreeMap<String, Value>,
    /// Each a [`ShapeDesc`]; [`read`] reads them.
    pub shapes: Vec<Value>,
    /// The acceleration structure's settings.
    #[serde(default)]
    pub accel: AccelDesc,
}

/// `"accel": {"quality": "auto" | "medium" | "high"}` (docs/scene-format.md).
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct AccelDesc {
    #[serde(default)]
    pub quality: crate::geometry::BuildQuality,
}

/// Read the scene file `file` with text `text`: its top level, then every shape. A leading
/// UTF-8 byte-order mark is skipped; a key defined twice in an object is an error.
pub fn read(file: &Path, text: &str) -> Result<(SceneFile, Vec<ShapeDesc>), InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    reject_duplicate_keys(file, text)?;
    let f: SceneFile = from_json_str(file, text)?;
    let shapes = f
        .shapes
        .iter()
        .enumerate()
        .map(|(i, v)| ShapeDesc::from_value(file, &format!("shapes[{i}]"), v))
        .collect::<Result<_, _>>()?;
    Ok((f, shapes))
}

/// A pinhole camera.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub origin: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Full field of view in degrees.
    pub fov: f32,
    #[serde(default)]
    pub fov_axis: FovAxis,
    pub width: u32,
    pub height: u32,
    /// The medium the camera sits in (none: vacuum).
    #[serde(default)]
    pub medium: Option<String>,
    /// What the camera integrates: `"cie-1931"` (the default), `{"band": [lo, hi]}` or
    /// `{"response": SPECTRUM}`; read by `build.rs`.
    #[serde(default)]
    pub sensor: Option<serde_json::Value>,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// The image axis along which the camera's `fov` is measured.
#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
pub enum FovAxis {
    #[default]
    X,
    Y,
}

/// A material, by its `type`; spectra are left as JSON values for `spectra.rs`.
#[derive(Deserialize)]
// Written `{"type": "<kind>", …}`, read with `from_tagged_value` (field paths kept).
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum MaterialDesc {
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
    /// A measured bispectral matrix (BFC file).
    Reradiation {
        file: String,
        /// A [`ShiftSamplingDesc`], read by the builder (so that errors inside keep their path).
        #[serde(default)]
        sampling: Option<Value>,
    },
    /// A Gaussian-mixture reradiation model (Hua 2022): a fitted model `file`, or a `bfc`
    /// matrix fitted at load time (cached).
    ReradiationGmm {
        #[serde(default)]
        file: Option<String>,
        #[serde(default)]
        bfc: Option<String>,
        #[serde(default)]
        components: Option<usize>,
        #[serde(default)]
        method: Option<crate::material::mixture::FitMethod>,
        #[serde(default)]
        seed: Option<u64>,
        #[serde(default)]
        restarts: Option<usize>,
    },
}

/// How a `reradiation` material draws the new wavelength of a shift.
#[derive(Deserialize)]
// Written `{"type": "<kind>", …}`, read with `from_tagged_value` (field paths kept).
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum ShiftSamplingDesc {
    /// The matrix's own tabulated CDFs (the default).
    Matrix {},
    /// A fitted Gaussian mixture (Hua 2022) used for sampling only, the matrix still evaluated:
    /// a fitted model `file`, or the material's own matrix fitted at load (cached) with
    /// `components`, `method`, `seed` and `restarts`; `defensive` is the tables' share α of the
    /// draws.
    Mixture {
        #[serde(default)]
        file: Option<String>,
        #[serde(default)]
        components: Option<usize>,
        #[serde(default)]
        method: Option<crate::material::mixture::FitMethod>,
        #[serde(default)]
        seed: Option<u64>,
        #[serde(default)]
        restarts: Option<usize>,
        #[serde(default)]
        defensive: Option<f32>,
    },
}

/// A participating medium, by its `type`; spectra, the phase function and the fluorophore are
/// left as JSON values (serde loses the JSON path of errors inside an internally tagged enum).
#[derive(Deserialize)]
// Written `{"type": "<kind>", …}`, read with `from_tagged_value` (field paths kept).
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum MediumDesc {
    Homogeneous {
        sigma_a: Value,
        sigma_s: Value,
        /// A [`PhaseDesc`], read by the builder (so that errors inside keep their path).
        #[serde(default)]
        phase: Option<Value>,
        /// A [`FluorescenceDesc`], read by the builder.
        #[serde(default)]
        fluorescence: Option<Value>,
    },
    /// A density grid (Mitsuba `.vol` file, relative to the scene's folder) scaling the
    /// coefficients.
    Grid {
        file: String,
        #[serde(default = "one")]
        density_scale: f32,
        sigma_a: Value,
        sigma_s: Value,
        /// A [`PhaseDesc`], read by the builder (so that errors inside keep their path).
        #[serde(default)]
        phase: Option<Value>,
        /// A [`FluorescenceDesc`], read by the builder.
        #[serde(default)]
        fluorescence: Option<Value>,
    },
}

/// The phase function of a medium.
#[derive(Deserialize)]
// Written `{"type": "<kind>", …}`, read with `from_tagged_value` (field paths kept).
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum PhaseDesc {
    Isotropic {},
    HenyeyGreenstein { g: f32 },
}

/// The fluorophore of a medium: absorption a(λ) at a concentration (extinction per scene
/// unit at the peak of a), emission e(λ) and quantum yield Φ.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluorescenceDesc {
    pub absorption: Value,
    pub concentration: f32,
    pub emission: Value,
    pub quantum_yield: f32,
}

/// The emission of a shape that is a light.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    pub spectrum: Value,
    #[serde(default = "one")]
    pub scale: f32,
    #[serde(default)]
    pub two_sided: bool,
}

fn one() -> f32 {
    1.0
}

/// A shape: the fields every kind of shape has, and the geometry its `type` selects.
pub struct ShapeDesc {
    pub name: Option<String>,
    pub material: Option<String>,
    /// The media inside and outside the shape (its normal points outside).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    pub emission: Option<EmissionDesc>,
    pub flip_normals: bool,
    pub geometry: ShapeGeometry,
}

/// Only the `type` of a shape: the rest is read once the kind is known.
#[derive(Deserialize)]
#[serde(expecting = "a shape object")]
struct ShapeTag {
    #[serde(rename = "type")]
    kind: ShapeKind,
}

/// Declares the kinds of shape once: the `type` names ([`ShapeKind`]), the variants of
/// [`ShapeGeometry`], and for each kind a serde struct (in `fields`) of the fields common to
/// every shape followed by the kind's own, so that `deny_unknown_fields` knows every field the
/// kind allows. `Option` fields may be left out; all others are required.
macro_rules! shape_kinds {
    ($($(#[$doc:meta])* $kind:ident { $($field:ident: $ty:ty),* $(,)? })*) => {
        /// The `type` of a shape.
        #[derive(Deserialize, Clone, Copy, Debug)]
        #[serde(rename_all = "kebab-case")]
        enum ShapeKind {
            $($kind),*
        }

        /// The geometry of a shape, by its `type`.
        pub enum ShapeGeometry {
            $($(#[$doc])* $kind { $($field: $ty),* }),*
        }

        /// One struct per kind of shape, with all the fields it may have.
        mod fields {
            use super::EmissionDesc;
            use serde::Deserialize;
            use serde::de::IgnoredAny;

            $(
                #[derive(Deserialize)]
                #[serde(deny_unknown_fields)]
                pub struct $kind {
                    /// Already read as a [`super::ShapeTag`].
                    #[serde(rename = "type")]
                    _kind: IgnoredAny,
                    #[serde(default)]
                    pub name: Option<String>,
                    #[serde(default)]
                    pub material: Option<String>,
                    #[serde(default)]
                    pub interior: Option<String>,
                    #[serde(default)]
                    pub exterior: Option<String>,
                    #[serde(default)]
                    pub emission: Option<EmissionDesc>,
                    #[serde(default)]
                    pub flip_normals: bool,
                    $(pub $field: $ty),*
                }
            )*
        }

        /// Read shape `v` (at JSON path `base`) as a shape of kind `kind`.
        fn read_kind(
            kind: ShapeKind,
            file: &Path,
            base: &str,
            v: &Value,
        ) -> Result<ShapeDesc, InputError> {
            Ok(match kind {
                $(ShapeKind::$kind => {
                    let s: fields::$kind = from_json_value(file, base, v)?;
                    ShapeDesc {
                        name: s.name,
                        material: s.material,
                        interior: s.interior,
                        exterior: s.exterior,
                        emission: s.emission,
                        flip_normals: s.flip_normals,
                        geometry: ShapeGeometry::$kind { $($field: s.$field),* },
                    }
                })*
            })
        }
    };
}

shape_kinds! {
    /// Triangulated as (c0, c1, c2), (c0, c2, c3).
    Quad { corners: [[f32; 3]; 4] }
    /// Axis-aligned, faces pointing outwards.
    Box { min: [f32; 3], max: [f32; 3] }
    Sphere { center: [f32; 3], radius: f32 }
    /// Each index triple is a triangle of `vertices`.
    Triangles { vertices: Vec<[f32; 3]>, indices: Vec<[u32; 3]> }
    /// An OBJ file (relative to the scene's folder), scaled, then translated.
    Obj { file: String, scale: Option<f32>, translate: Option<[f32; 3]> }
}

impl ShapeDesc {
    /// Read the shape `v` found at JSON path `base` of `file`.
    pub fn from_value(file: &Path, base: &str, v: &Value) -> Result<ShapeDesc, InputError> {
        let kind = from_json_value::<ShapeTag>(file, base, v)?.kind;
        read_kind(kind, file, base, v).map_err(|mut e| {
            // serde reports a missing field at the object that lacks it: point at the field.
            if e.path == base
                && let Some(field) = e
                    .message
                    .strip_prefix("missing field `")
                    .and_then(|m| m.strip_suffix('`'))
            {
                e.path = format!("{base}.{field}");
                e.message = format!("required for a {kind:?} shape");
            }
            e
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape(json: &str) -> Result<ShapeDesc, InputError> {
        let v: Value = serde_json::from_str(json).unwrap();
        ShapeDesc::from_value(Path::new("s.json"), "shapes[3]", &v)
    }

    fn error(json: &str) -> (String, String) {
        let e = shape(json).err().expect("an error");
        (e.path, e.message)
    }

    #[test]
    fn reads_each_kind_with_common_fields() {
        let s =
            shape(r#"{"radius": 2, "name": "b", "center": [1, 2, 3], "type": "sphere"}"#).unwrap();
        assert_eq!(s.name.as_deref(), Some("b"));
        assert!(s.material.is_none() && s.emission.is_none() && !s.flip_normals);
        assert!(matches!(
            s.geometry,
            ShapeGeometry::Sphere {
                center: [1.0, 2.0, 3.0],
                radius: 2.0
            }
        ));
        let s = shape(r#"{"type": "obj", "file": "a.obj", "flip_normals": true}"#).unwrap();
        assert!(s.flip_normals);
        assert!(matches!(
            s.geometry,
            ShapeGeometry::Obj {
                scale: None,
                translate: None,
                ..
            }
        ));
    }

    #[test]
    fn errors_name_the_field() {
        let (p, m) = error(r#"{"type": "sphere", "center": [0, 0, 0]}"#);
        assert_eq!(
            (p.as_str(), m.as_str()),
            ("shapes[3].radius", "required for a Sphere shape")
        );
        let (p, m) = error(
            r#"{"type": "quad", "radius": 1, "corners": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]}"#,
        );
        assert_eq!(p, "shapes[3].radius");
        assert!(m.starts_with("unknown field `radius`"), "{m}");
        let (p, _) = error(r#"{"type": "box", "min": [0, 0, "x"], "max": [1, 1, 1]}"#);
        assert_eq!(p, "shapes[3].min[2]");
        let (p, m) = error(r#"{"type": "cone"}"#);
        assert_eq!(p, "shapes[3].type");
        assert!(m.starts_with("unknown variant `cone`"), "{m}");
        let (p, m) = error(r#"{"center": [0, 0, 0]}"#);
        assert_eq!(
            (p.as_str(), m.as_str()),
            ("shapes[3]", "missing field `type`")
        );
        // Not remapped: the missing field is within `emission`.
        let (p, m) =
            error(r#"{"type": "sphere", "center": [0, 0, 0], "radius": 1, "emission": {}}"#);
        assert_eq!(
            (p.as_str(), m.as_str()),
            ("shapes[3].emission", "missing field `spectrum`")
        );
    }
}
