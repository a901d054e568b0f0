//! The JSON scene format: the serde types a scene file is read into, and nothing else
//! (`build.rs` validates them and builds the runtime [`Scene`](super::Scene)).

use serde::Deserialize;
use serde_json::Value;
use std::collections::BTreeMap;

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
    pub shapes: Vec<ShapeDesc>,
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
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
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
    },
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

/// The `type` of a shape.
#[derive(Deserialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "kebab-case")]
pub enum ShapeKind {
    Quad,
    Box,
    Sphere,
    Triangles,
    Obj,
}

/// A shape; which fields it may and must have depends on its `type` (checked by the builder).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeDesc {
    #[serde(rename = "type")]
    pub kind: ShapeKind,
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub material: Option<String>,
    #[serde(default)]
    pub emission: Option<EmissionDesc>,
    #[serde(default)]
    pub flip_normals: bool,
    #[serde(default)]
    pub corners: Option<[[f32; 3]; 4]>,
    #[serde(default)]
    pub min: Option<[f32; 3]>,
    #[serde(default)]
    pub max: Option<[f32; 3]>,
    #[serde(default)]
    pub center: Option<[f32; 3]>,
    #[serde(default)]
    pub radius: Option<f32>,
    #[serde(default)]
    pub vertices: Option<Vec<[f32; 3]>>,
    #[serde(default)]
    pub indices: Option<Vec<[u32; 3]>>,
    #[serde(default)]
    pub file: Option<String>,
    #[serde(default)]
    pub scale: Option<f32>,
    #[serde(default)]
    pub translate: Option<[f32; 3]>,
}
