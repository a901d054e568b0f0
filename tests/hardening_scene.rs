//! Scene input that used to crash, hang, render garbage or be silently misread: huge but finite
//! numbers, names defined twice, byte-order marks, one-point spectra, empty lights, more than
//! 65,535 shapes, misleading messages and named spectra that refer forward. Each case must give
//! an input error naming the file and the field (exit code 2), or render a finite image.

mod common;

use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::Command;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::io::InputError;
use stokes::scene::Scene;

/// A valid small scene that the cases below break in one place: a floor, a ball and a light.
fn good() -> Value {
    json!({
        "camera": { "origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8 },
        "materials": { "white": { "type": "lambert", "reflectance": 0.5 } },
        "shapes": [
            { "type": "quad", "name": "floor", "material": "white",
              "corners": [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]] },
            { "type": "sphere", "name": "ball", "material": "white", "center": [0, 0, 0], "radius": 0.5 },
            { "type": "quad", "name": "light", "material": "white",
              "corners": [[-0.2, 1, -0.2], [0.2, 1, -0.2], [0.2, 1, 0.2], [-0.2, 1, 0.2]],
              "emission": { "spectrum": 5 } }
        ]
    })
}

/// Write `text` as `scene.json` in a new folder with `files`; returns the scene's path.
fn write(tag: &str, text: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let d = common::temp_dir(&format!("hardening-scene-{tag}"));
    for (name, bytes) in files {
        std::fs::write(d.join(name), bytes).unwrap();
    }
    let p = d.join("scene.json");
    std::fs::write(&p, text).unwrap();
    p
}

fn load_text(tag: &str, text: &str, files: &[(&str, &[u8])]) -> Result<Scene, InputError> {
    Scene::load(&write(tag, text, files))
}

fn load(tag: &str, v: &Value, files: &[(&str, &[u8])]) -> Result<Scene, InputError> {
    load_text(tag, &v.to_string(), files)
}

/// The input error of loading `v`, checked to name the scene file and the JSON path `field`
/// and to contain `words`.
fn expect_error_in(
    tag: &str,
    text: &str,
    files: &[(&str, &[u8])],
    field: &str,
    words: &str,
) -> InputError {
    let e = match load_text(tag, text, files) {
        Ok(_) => panic!("{tag}: loaded, but should fail at `{field}`"),
        Err(e) => e,
    };
    let shown = e.to_string();
    assert_eq!(e.path, field, "{tag}: {shown}");
    assert!(shown.contains("scene.json"), "{tag}: {shown}");
    assert!(
        shown.contains(words),
        "{tag}: expected '{words}' in: {shown}"
    );
    e
}

fn expect_error(tag: &str, v: &Value, field: &str, words: &str) -> InputError {
    expect_error_in(tag, &v.to_string(), &[], field, words)
}

/// `good()` changed by `f`.
fn with(f: impl FnOnce(&mut Value)) -> Value {
    let mut v = good();
    f(&mut v);
    v
}

/// Run `stokes render` on scene text `text`: (exit code, stderr).
fn cli(tag: &str, text: &str, files: &[(&str, &[u8])]) -> (i32, String) {
    let scene = write(tag, text, files);
    let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "--spp",
            "1",
            "--threads",
            "1",
            "-o",
        ])
        .arg(scene.with_file_name("out.exr"))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The mean luminance of a small render of `scene`, checked to be finite with nothing rejected.
fn mean_y(scene: &Scene, kind: IntegratorKind, spp: u32) -> f64 {
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 1,
        threads: Some(1),
        ..Default::default()
    };
    let out = render(scene, kind, &IntegratorOptions::default(), &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0, "{kind:?}");
    let xyz = out.film.xyz();
    assert!(xyz.iter().all(|p| p.is_finite()), "{kind:?}");
    xyz.iter().map(|p| p.y as f64).sum::<f64>() / xyz.len() as f64
}

const ALL: [IntegratorKind; 6] = [
    IntegratorKind::PtMono,
    IntegratorKind::PtHero,
    IntegratorKind::BdptForward,
    IntegratorKind::BdptBackward,
    IntegratorKind::BdptCombined,
    IntegratorKind::BdptAllbins,
];

// ---------------------------------------------------------------- huge but finite numbers

#[test]
fn a_huge_domain_is_an_input_error_not_an_allocation() {
    for (tag, hi) in [("1e30", 1e30), ("1e9", 1e9), ("1e5", 1e5)] {
        let v = with(|v| v["domain"] = json!([280.0, hi]));
        expect_error(tag, &v, "domain", "must lie within [0, 10000] nm");
    }
    // Through the binary: exit 2, not a "capacity overflow" panic.
    let v = with(|v| v["domain"] = json!([280.0, 1e30]));
    let (code, err) = cli("domain-cli", &v.to_string(), &[]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("scene.json") && err.contains("`domain`"),
        "{err}"
    );
    // The widest domain allowed loads, and renders.
    let v = with(|v| v["domain"] = json!([0.0, 10000.0]));
    let scene = load("domain-max", &v, &[]).unwrap();
    assert!(mean_y(&scene, IntegratorKind::PtMono, 2) > 0.0);
}

#[test]
fn coordinates_beyond_f32_ray_tracing_are_input_errors() {
    let cases: Vec<(&str, Value, &str)> = vec![
        (
            "center",
            with(|v| v["shapes"][1]["center"] = json!([0, 1e12, 0])),
            "shapes[1].center",
        ),
        (
            "corner",
            with(|v| v["shapes"][0]["corners"][2] = json!([1e20, -1, 1])),
            "shapes[0].corners[2]",
        ),
        (
            "box",
            with(|v| {
                v["shapes"][1] = json!({"type": "box", "material": "white",
                                        "min": [0, 0, 0], "max": [1, 1, 3e38]})
            }),
            "shapes[1].max",
        ),
        (
            "vertex",
            with(|v| {
                v["shapes"][1] = json!({"type": "triangles", "material": "white",
                    "vertices": [[0, 0, 0], [1, 0, 0], [0, -1e10, 0]], "indices": [[0, 1, 2]]})
            }),
            "shapes[1].vertices[2]",
        ),
        (
            "origin",
            with(|v| v["camera"]["origin"] = json!([0, 0, 1e38])),
            "camera.origin",
        ),
        (
            "target",
            with(|v| v["camera"]["target"] = json!([-1e30, 0, 0])),
            "camera.target",
        ),
    ];
    for (tag, v, field) in cases {
        expect_error(tag, &v, field, "within ±1e9");
    }
    // The radius that used to panic in the BVH builder: exit 2 through the binary.
    let v = with(|v| v["shapes"][1]["radius"] = json!(1e19));
    expect_error("radius", &v, "shapes[1].radius", "must be in [1e-7, 1e9]");
    let (code, err) = cli("radius-cli", &v.to_string(), &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("shapes[1].radius"), "{err}");
    // Tiny spheres cannot be sampled in f32.
    let v = with(|v| v["shapes"][1]["radius"] = json!(1e-30));
    expect_error(
        "tiny-radius",
        &v,
        "shapes[1].radius",
        "must be in [1e-7, 1e9]",
    );
}

#[test]
fn large_legal_geometry_renders_a_finite_image() {
    // A closed furnace of radius 1e8 around the camera, and a 1e9 ground plane.
    let v = json!({
        "camera": { "origin": [0, 0, 0], "target": [0, 0, -1], "fov": 40, "width": 4, "height": 4 },
        "materials": { "grey": { "type": "lambert", "reflectance": 0.5 } },
        "shapes": [
            { "type": "sphere", "center": [0, 0, 0], "radius": 1e8, "flip_normals": true,
              "material": "grey", "emission": { "spectrum": 1 } },
            { "type": "quad", "material": "grey",
              "corners": [[-1e9, -1, -1e9], [-1e9, -1, 1e9], [1e9, -1, 1e9], [1e9, -1, -1e9]] }
        ]
    });
    let scene = load("large-legal", &v, &[]).unwrap();
    for kind in ALL {
        assert!(mean_y(&scene, kind, 2) > 0.0, "{kind:?}");
    }
}

#[test]
fn emission_that_overflows_f32_is_an_input_error() {
    // 1e20 × 1e20 used to render black with exit 0.
    let v = with(|v| v["shapes"][2]["emission"] = json!({"spectrum": 1e20, "scale": 1e20}));
    expect_error("scale", &v, "shapes[2].emission.scale", "exceeds 1e30");
    let (code, err) = cli("scale-cli", &v.to_string(), &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("shapes[2].emission.scale"), "{err}");
    let v = with(|v| {
        v["shapes"][2]["emission"] =
            json!({"spectrum": {"type": "gaussian", "center": 500, "fwhm": 50, "peak": 1e31}})
    });
    expect_error("peak", &v, "shapes[2].emission.spectrum", "exceeds 1e30");
    // A tabulated spectrum's own `scale` that overflows names that field.
    let v = with(|v| {
        v["materials"]["white"]["reflectance"] =
            json!({"type": "tabulated", "pairs": [[400, 1e30], [700, 1e30]], "scale": 1e30})
    });
    expect_error(
        "tab-scale",
        &v,
        "materials.white.reflectance.scale",
        "finite in f32",
    );
}

#[test]
fn the_brightest_allowed_emission_renders_and_scales_exactly() {
    // Radiance 1e30 renders a finite image in every integrator, 1e30 times that of radiance 1.
    let unit = load(
        "unit",
        &with(|v| v["shapes"][2]["emission"] = json!({"spectrum": 1})),
        &[],
    )
    .unwrap();
    let bright = with(|v| v["shapes"][2]["emission"] = json!({"spectrum": 1e15, "scale": 1e15}));
    let bright = load("bright", &bright, &[]).unwrap();
    for kind in ALL {
        let (a, b) = (mean_y(&unit, kind, 2), mean_y(&bright, kind, 2));
        assert!(a > 0.0, "{kind:?}");
        assert!((b / a / 1e30 - 1.0).abs() < 1e-3, "{kind:?}: {b} vs {a}");
    }
}

#[test]
fn camera_and_mesh_sizes_are_bounded_before_allocating() {
    let v = with(|v| {
        v["camera"]["width"] = json!(16384);
        v["camera"]["height"] = json!(16384)
    });
    expect_error("pixels", &v, "camera.height", "more than 67108864 pixels");
    // An OBJ is counted before its triangles are built; a scene's lights × domain cells too.
    let many = (0..70_000)
        .map(|i| {
            let x = i as f32 * 1e-3;
            json!({"type": "quad", "material": "white", "emission": {"spectrum": 1},
                   "corners": [[x, 5, 0], [x + 5e-4, 5, 0], [x + 5e-4, 5, 1e-3], [x, 5, 1e-3]]})
        })
        .collect::<Vec<_>>();
    let v = with(|v| {
        v["domain"] = json!([0, 10000]);
        v["shapes"] = json!(many)
    });
    expect_error(
        "light-cells",
        &v,
        "shapes[3355].emission",
        "too many lights",
    );
}

// ---------------------------------------------------------------- silent acceptance

#[test]
fn names_defined_twice_are_input_errors() {
    let base = good().to_string();
    let insert = |after: &str, extra: &str| {
        let i = base.find(after).unwrap() + after.len();
        format!("{}{extra}{}", &base[..i], &base[i..])
    };
    // A material, a named spectrum, a medium, and a key inside a shape and inside a material.
    let text = insert(
        r#""materials":{"#,
        r#""white":{"type":"lambert","reflectance":0.9},"#,
    );
    expect_error_in("material", &text, &[], "materials.white", "defined twice");
    let (code, err) = cli("material-cli", &text, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("materials.white"), "{err}");
    let text = insert(r#"{"#, r#""spectra":{"a":0.5,"a":0.7},"#);
    expect_error_in("spectrum", &text, &[], "spectra.a", "defined twice");
    let text = insert(
        r#"{"#,
        r#""media":{"fog":{"type":"homogeneous","sigma_a":0,"sigma_s":1},"fog":{"type":"homogeneous","sigma_a":1,"sigma_s":1}},"#,
    );
    expect_error_in("medium", &text, &[], "media.fog", "defined twice");
    let text = base.replace(r#""radius":0.5"#, r#""radius":0.5,"radius":0.7"#);
    expect_error_in("key", &text, &[], "shapes[1].radius", "defined twice");
    let text = base.replace(
        r#""reflectance":0.5"#,
        r#""reflectance":0.5,"reflectance":2"#,
    );
    expect_error_in(
        "in-material",
        &text,
        &[],
        "materials.white.reflectance",
        "defined twice",
    );
    // Shapes, and so lights and regions, are named too.
    let v = with(|v| v["shapes"][2]["name"] = json!("ball"));
    expect_error(
        "shape",
        &v,
        "shapes[2].name",
        "already the name of shapes[1]",
    );
    let v = with(|v| {
        v["shapes"][0]["name"] = json!("shape1");
        v["shapes"][1].as_object_mut().unwrap().remove("name");
    });
    expect_error("default-name", &v, "shapes[1]", "default name 'shape1'");
}

#[test]
fn a_byte_order_mark_is_skipped() {
    use stokes::scene::spectra::parse_csv;
    let (xs, ys) = parse_csv("\u{feff}400, 0.25\n700, 0.75\n").unwrap();
    assert_eq!((xs, ys), (vec![400.0, 700.0], vec![0.25, 0.75]));
    let (xs, _) = parse_csv("\u{feff}wavelength,value\n400,1\n500,1\n700,1\n").unwrap();
    assert_eq!(xs, vec![400.0, 500.0, 700.0]);
    // The same scene with and without the mark in its CSV and in itself renders the same.
    let v = with(|v| {
        v["materials"]["white"]["reflectance"] = json!({"type": "tabulated", "file": "r.csv"})
    });
    let plain = load("plain", &v, &[("r.csv", b"400,0.2\n550,0.9\n700,0.4\n")]).unwrap();
    let bom = load_text(
        "bom",
        &format!("\u{feff}{v}"),
        &[("r.csv", b"\xef\xbb\xbf400,0.2\n550,0.9\n700,0.4\n")],
    )
    .unwrap();
    assert_eq!(plain.materials.len(), bom.materials.len());
    let (a, b) = (
        mean_y(&plain, IntegratorKind::PtMono, 2),
        mean_y(&bom, IntegratorKind::PtMono, 2),
    );
    assert_eq!(a, b);
}

#[test]
fn a_single_point_spectrum_is_an_input_error() {
    let v = with(|v| {
        v["materials"]["white"]["reflectance"] = json!({"type": "tabulated", "pairs": [[500, 0.5]]})
    });
    expect_error("pairs", &v, "materials.white.reflectance", "at least two");
    let v = with(|v| {
        v["shapes"][2]["emission"]["spectrum"] = json!({"type": "tabulated", "file": "e.csv"})
    });
    expect_error_in(
        "csv",
        &v.to_string(),
        &[("e.csv", b"wavelength,value\n550,1\n")],
        "shapes[2].emission.spectrum",
        "at least two",
    );
}

#[test]
fn an_emitting_shape_without_triangles_is_an_input_error() {
    let v = with(|v| {
        v["shapes"][2] = json!({"type": "triangles", "material": "white",
            "vertices": [], "indices": [], "emission": {"spectrum": 1}});
        v["shapes"][1]["emission"] = json!({"spectrum": 1})
    });
    expect_error("empty", &v, "shapes[2].indices", "at least one triangle");
    let (code, err) = cli("empty-cli", &v.to_string(), &[]);
    assert_eq!(code, 2, "{err}");
    let v = with(|v| {
        v["shapes"][2] = json!({"type": "obj", "file": "empty.obj", "emission": {"spectrum": 1}})
    });
    expect_error_in(
        "empty-obj",
        &v.to_string(),
        &[("empty.obj", b"v 0 0 0\nv 1 0 0\n")],
        "shapes[2].file",
        "no triangles",
    );
}

/// 70,000 shapes: the camera sees shape 69,999 (and the floor, shape 0); a u16 region id would
/// wrap it to 4,463 and label its pixels with that shape's name.
#[test]
fn seventy_thousand_shapes_keep_their_region_ids() {
    let mut shapes = vec![json!({"type": "quad", "name": "floor", "material": "white",
        "corners": [[-10, -1, -10], [-10, -1, 10], [10, -1, 10], [10, -1, -10]]})];
    for i in 1..69_999 {
        // Tiny, behind the camera.
        let x = (i % 300) as f32 * 0.01;
        let y = (i / 300) as f32 * 0.01;
        shapes.push(json!({"type": "quad", "material": "white",
            "corners": [[x, y, 5], [x + 0.005, y, 5], [x + 0.005, y + 0.005, 5], [x, y + 0.005, 5]]}));
    }
    shapes.push(
        json!({"type": "quad", "name": "target", "material": "white",
        "emission": {"spectrum": 1, "two_sided": true},
        "corners": [[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]]}),
    );
    let v = with(|v| {
        v["camera"]["origin"] = json!([0, 0, 3]);
        v["shapes"] = json!(shapes)
    });
    let scene = write("70k", &v.to_string(), &[]);
    let dir = scene.parent().unwrap();
    let config = json!({
        "name": "regions70k", "scene": "scene.json",
        "reference": {"integrator": "pt-mono", "spp": 1},
        "variants": [{"name": "mono", "integrator": "pt-mono"}],
        "budget": {"spp": [1]}, "threads": 1,
        "regions": {"by": "shape"}
    });
    let cfg = dir.join("config.json");
    std::fs::write(&cfg, config.to_string()).unwrap();
    let out = common::quick_experiment(&cfg, &dir.join("out"));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let run = latest_run(&dir.join("out/regions70k"));
    let regions: Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("regions.json")).unwrap()).unwrap();
    let ids: Vec<i64> = regions["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i.as_i64().unwrap())
        .collect();
    assert!(ids.contains(&69_999), "the target's id");
    assert!(
        ids.iter().all(|&i| i == -1 || i == 0 || i == 69_999),
        "{ids:?}"
    );
    assert_eq!(regions["names"][69_999], "target");
    let metrics = std::fs::read_to_string(run.join("metrics.csv")).unwrap();
    assert!(metrics.contains(",target,"), "{metrics}");
    assert!(!metrics.contains("shape4463"), "{metrics}");
}

/// The run folder `results/<name>/latest` names.
fn latest_run(results: &Path) -> PathBuf {
    let latest = std::fs::read_to_string(results.join("latest")).unwrap_or_default();
    let name = latest.trim();
    if !name.is_empty() && results.join("runs").join(name).is_dir() {
        return results.join("runs").join(name);
    }
    let runs = std::fs::read_dir(results.join("runs")).unwrap();
    runs.map(|e| e.unwrap().path()).max().unwrap()
}

// ---------------------------------------------------------------- misleading messages

#[test]
fn messages_name_the_field_that_is_wrong() {
    let v = with(|v| v["camera"]["height"] = json!(0));
    expect_error("height", &v, "camera.height", "got 0");
    let v = with(|v| v["camera"]["width"] = json!(20000));
    expect_error("width", &v, "camera.width", "got 20000");
    // A huge origin is the origin's fault, not the up vector's.
    let v = with(|v| v["camera"]["origin"] = json!([0, 0, 1e38]));
    expect_error("origin", &v, "camera.origin", "within ±1e9");
    let v = with(|v| v["camera"]["up"] = json!([0, 0, 0]));
    expect_error("up-zero", &v, "camera.up", "must not be zero");
    let v = with(|v| v["camera"]["up"] = json!([0, 0, 5]));
    expect_error("up-parallel", &v, "camera.up", "parallel");
    // Non-finite geometry is called non-finite, not "zero area".
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n";
    let v = with(|v| v["shapes"][1] = json!({"type": "obj", "file": "m.obj", "material": "white"}));
    let e = expect_error_in(
        "nan-obj",
        &v.to_string(),
        &[("m.obj", obj)],
        "shapes[1].file",
        "finite",
    );
    assert!(!e.message.contains("zero area"), "{e}");
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let v = with(|v| {
        v["shapes"][1] = json!({"type": "obj", "file": "m.obj", "material": "white", "scale": 1e8,
                   "translate": [0, 0, 0]})
    });
    expect_error_in(
        "big-obj",
        &v.to_string(),
        &[("m.obj", b"v 0 0 0\nv 100 0 0\nv 0 1 0\nf 1 2 3\n")],
        "shapes[1].file",
        "within ±1e9",
    );
    let v = with(|v| {
        v["shapes"][1] = json!({"type": "obj", "file": "m.obj", "material": "white",
                                "translate": [0, 1e30, 0]})
    });
    expect_error_in(
        "translate",
        &v.to_string(),
        &[("m.obj", obj)],
        "shapes[1].translate",
        "within ±1e9",
    );
    // A really degenerate triangle is still "zero area".
    let v = with(|v| {
        v["shapes"][1] = json!({"type": "triangles", "material": "white",
            "vertices": [[0, 0, 0], [1e-9, 0, 0], [0, 1e-9, 0]], "indices": [[0, 1, 2]]})
    });
    expect_error("tiny", &v, "shapes[1]", "zero area");
}

/// `accel.quality` chooses the BVH build; a wrong value or an unknown key there is an input
/// error naming the field, and without the key the default (`auto`) is used.
#[test]
fn the_accel_quality_is_read_and_checked() {
    use stokes::geometry::BuildQuality;
    let q = |tag: &str, v: &Value| load(tag, v, &[]).unwrap().accel.quality();
    let auto = Some((BuildQuality::Auto, BuildQuality::High));
    assert_eq!(q("accel-none", &good()), auto);
    for (name, want) in [
        ("auto", auto),
        ("medium", Some((BuildQuality::Medium, BuildQuality::Medium))),
        ("high", Some((BuildQuality::High, BuildQuality::High))),
    ] {
        let v = with(|v| v["accel"] = json!({ "quality": name }));
        assert_eq!(q(&format!("accel-{name}"), &v), want, "{name}");
    }
    let v = with(|v| v["accel"] = json!({ "quality": "best" }));
    expect_error("accel-bad", &v, "accel.quality", "unknown variant `best`");
    let v = with(|v| v["accel"] = json!({ "qualty": "high" }));
    expect_error("accel-key", &v, "accel.qualty", "unknown field `qualty`");
}

// ---------------------------------------------------------------- named spectra

#[test]
fn named_spectra_resolve_in_dependency_order() {
    // `a` names `b`, which names `c`, defined after both: fine in any order.
    let v = with(|v| {
        v["spectra"] = json!({"a": "b", "b": "zz", "zz": {"type": "constant", "value": 0.25}});
        v["materials"]["white"]["reflectance"] = json!("a")
    });
    let scene = load("forward", &v, &[]).unwrap();
    let direct = load(
        "direct",
        &with(|v| v["materials"]["white"]["reflectance"] = json!(0.25)),
        &[],
    )
    .unwrap();
    assert_eq!(
        mean_y(&scene, IntegratorKind::PtMono, 2),
        mean_y(&direct, IntegratorKind::PtMono, 2)
    );
    // A real cycle is reported as a cycle, naming its members.
    let v = with(|v| v["spectra"] = json!({"a": "b", "b": "c", "c": "a", "d": 0.5}));
    let e = expect_error("cycle", &v, "spectra.a", "cycle");
    assert!(e.message.contains("a → b → c → a"), "{e}");
    let v = with(|v| v["spectra"] = json!({"x": "y", "y": "y"}));
    let e = expect_error("self", &v, "spectra.y", "cycle");
    assert!(e.message.contains("y → y"), "{e}");
    let v = with(|v| v["spectra"] = json!({"a": "b", "b": "nope"}));
    let e = expect_error("unknown", &v, "spectra.b", "unknown spectrum name 'nope'");
    assert!(e.message.contains("a, b"), "lists every name: {e}");
}

// ---------------------------------------------------------------- tried as a new user would

/// A malformed scene: its tag, how it breaks `good()`, and the field its error must name.
type Case = (&'static str, Box<dyn Fn(&mut Value)>, &'static str);

/// Malformed scenes, one field each: NaN (by overflow), ±inf (1e39), 1e38, negative and zero
/// values in every class of numeric field. Each gives exit 2 naming the file and the field.
#[test]
fn malformed_numbers_in_every_field_class_exit_2_naming_the_field() {
    let fluor = json!({"type": "fluorescent-diffuse", "reflectance": 0.2,
        "absorption": {"type": "box", "lo": 300, "hi": 400, "value": 1},
        "emission": {"type": "box", "lo": 500, "hi": 550, "value": 0.02},
        "quantum_yield": 0.9, "concentration": 0.5});
    let medium = json!({"type": "homogeneous", "sigma_a": 0.1, "sigma_s": 0.5});
    let cases: Vec<Case> = vec![
        (
            "fov0",
            Box::new(|v| v["camera"]["fov"] = json!(0)),
            "camera.fov",
        ),
        (
            "fov-inf",
            Box::new(|v| v["camera"]["fov"] = json!(1e39)),
            "camera.fov",
        ),
        (
            "fov180",
            Box::new(|v| v["camera"]["fov"] = json!(180)),
            "camera.fov",
        ),
        (
            "width-neg",
            Box::new(|v| v["camera"]["width"] = json!(-8)),
            "camera.width",
        ),
        (
            "target=origin",
            Box::new(|v| v["camera"]["target"] = json!([0, 0, 3])),
            "camera.target",
        ),
        (
            "up-inf",
            Box::new(|v| v["camera"]["up"] = json!([0, 1e39, 0])),
            "camera.up[1]",
        ),
        (
            "radius0",
            Box::new(|v| v["shapes"][1]["radius"] = json!(0)),
            "shapes[1].radius",
        ),
        (
            "radius-neg",
            Box::new(|v| v["shapes"][1]["radius"] = json!(-1)),
            "shapes[1].radius",
        ),
        (
            "radius-inf",
            Box::new(|v| v["shapes"][1]["radius"] = json!(1e39)),
            "shapes[1].radius",
        ),
        (
            "corner-inf",
            Box::new(|v| v["shapes"][0]["corners"][0][1] = json!(-1e39)),
            "shapes[0].corners[0]",
        ),
        (
            "quad-zero",
            Box::new(|v| {
                v["shapes"][0]["corners"] = json!([[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]])
            }),
            "shapes[0]",
        ),
        (
            "refl-neg",
            Box::new(|v| v["materials"]["white"]["reflectance"] = json!(-0.5)),
            "materials.white.reflectance",
        ),
        (
            "refl-inf",
            Box::new(|v| v["materials"]["white"]["reflectance"] = json!(1e39)),
            "materials.white.reflectance",
        ),
        (
            "scale-neg",
            Box::new(|v| v["shapes"][2]["emission"]["scale"] = json!(-1)),
            "shapes[2].emission.scale",
        ),
        (
            "emission-1e38",
            Box::new(|v| v["shapes"][2]["emission"]["spectrum"] = json!(1e38)),
            "shapes[2].emission.spectrum",
        ),
        (
            "emission-zero",
            Box::new(|v| v["shapes"][2]["emission"]["spectrum"] = json!(0)),
            "shapes",
        ),
        (
            "box-lo>hi",
            Box::new(|v| {
                v["shapes"][2]["emission"]["spectrum"] =
                    json!({"type": "box", "lo": 600, "hi": 500, "value": 1})
            }),
            "shapes[2].emission.spectrum",
        ),
        (
            "fwhm0",
            Box::new(|v| {
                v["shapes"][2]["emission"]["spectrum"] =
                    json!({"type": "gaussian", "center": 500, "fwhm": 0, "peak": 1})
            }),
            "shapes[2].emission.spectrum",
        ),
        (
            "binned-width0",
            Box::new(|v| {
                v["materials"]["white"]["reflectance"] =
                    json!({"type": "binned", "lo": 400, "width": 0, "values": [0.5]})
            }),
            "materials.white.reflectance",
        ),
        (
            "tab-decreasing",
            Box::new(|v| {
                v["materials"]["white"]["reflectance"] =
                    json!({"type": "tabulated", "pairs": [[500, 0.5], [400, 0.5]]})
            }),
            "materials.white.reflectance",
        ),
        (
            "tab-scale-neg",
            Box::new(|v| {
                v["materials"]["white"]["reflectance"] =
                    json!({"type": "tabulated", "pairs": [[400, 0.5], [700, 0.5]], "scale": -2})
            }),
            "materials.white.reflectance.scale",
        ),
        (
            "domain-neg",
            Box::new(|v| v["domain"] = json!([-10, 700])),
            "domain",
        ),
        (
            "domain-empty",
            Box::new(|v| v["domain"] = json!([500, 500])),
            "domain",
        ),
        (
            "domain-uv",
            Box::new(|v| v["domain"] = json!([100, 300])),
            "domain",
        ),
        (
            "qy",
            Box::new(move |v| {
                v["materials"]["dye"] = fluor.clone();
                v["materials"]["dye"]["quantum_yield"] = json!(1e39)
            }),
            "materials.dye.quantum_yield",
        ),
        (
            "sigma-neg",
            Box::new({
                let m = medium.clone();
                move |v| {
                    v["media"] = json!({"fog": m.clone()});
                    v["media"]["fog"]["sigma_s"] = json!(-1)
                }
            }),
            "media.fog.sigma_s",
        ),
        (
            "sigma-inf",
            Box::new({
                let m = medium.clone();
                move |v| {
                    v["media"] = json!({"fog": m.clone()});
                    v["media"]["fog"]["sigma_a"] = json!(1e39)
                }
            }),
            "media.fog.sigma_a",
        ),
        (
            "g1",
            Box::new(move |v| {
                v["media"] = json!({"fog": medium.clone()});
                v["media"]["fog"]["phase"] = json!({"type": "henyey-greenstein", "g": 1})
            }),
            "media.fog.phase.g",
        ),
        (
            "obj-scale0",
            Box::new(|v| {
                v["shapes"][1] =
                    json!({"type": "obj", "file": "m.obj", "material": "white", "scale": 0})
            }),
            "shapes[1].scale",
        ),
    ];
    let obj: &[(&str, &[u8])] = &[("m.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")];
    for (tag, f, field) in cases {
        let v = with(|v| f(v));
        let (code, err) = cli(tag, &v.to_string(), obj);
        assert_eq!(code, 2, "{tag}: {err}");
        assert!(err.contains("scene.json"), "{tag}: {err}");
        assert!(
            err.contains(&format!("field `{field}`")),
            "{tag}: wanted `{field}` in {err}"
        );
    }
}

/// A grey room with a box of medium `medium` (its `interior`), lit from above.
fn with_medium(medium: Value) -> Value {
    with(|v| {
        v["media"] = json!({ "fog": medium });
        v["shapes"][1] = json!({"type": "box", "name": "tank", "min": [-0.5, -1, -0.5],
                                "max": [0.5, 0, 0.5], "interior": "fog"});
    })
}

#[test]
fn media_too_dense_to_track_are_input_errors() {
    // σ = 1e30 used to hang (grid: null collisions) or drop every BDPT strategy.
    let v = with_medium(json!({"type": "homogeneous", "sigma_a": 0, "sigma_s": 1e30}));
    expect_error("homogeneous", &v, "media.fog", "optical depth");
    let dir = common::temp_dir("hardening-scene-vol");
    let grid = stokes::medium::grid::DensityGrid::from_fn(
        [4, 4, 4],
        glam::Vec3::new(-0.5, -1.0, -0.5),
        glam::Vec3::new(0.5, 0.0, 0.5),
        |_| 1.0,
    );
    grid.write_vol(&dir.join("g.vol")).unwrap();
    let vol = std::fs::read(dir.join("g.vol")).unwrap();
    let grid_medium = |scale: f64| {
        with_medium(
            json!({"type": "grid", "file": "g.vol", "density_scale": scale,
                           "sigma_a": 0.1, "sigma_s": 1}),
        )
    };
    let (code, err) = cli(
        "grid-dense",
        &grid_medium(1e30).to_string(),
        &[("g.vol", &vol)],
    );
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("field `media.fog`") && err.contains("optical depth"),
        "{err}"
    );
    // Dense but trackable: renders a finite image.
    let scene = load("grid-ok", &grid_medium(100.0), &[("g.vol", &vol)]).unwrap();
    for kind in [IntegratorKind::PtMono, IntegratorKind::BdptForward] {
        assert!(mean_y(&scene, kind, 2).is_finite(), "{kind:?}");
    }
    // A grid whose bounding box is beyond f32 ray tracing.
    let far = stokes::medium::grid::DensityGrid::from_fn(
        [2, 2, 2],
        glam::Vec3::splat(-1e20),
        glam::Vec3::splat(1e20),
        |_| 1.0,
    );
    far.write_vol(&dir.join("far.vol")).unwrap();
    let vol = std::fs::read(dir.join("far.vol")).unwrap();
    let v = with_medium(json!({"type": "grid", "file": "far.vol", "sigma_a": 0, "sigma_s": 0}));
    expect_error_in(
        "grid-far",
        &v.to_string(),
        &[("far.vol", &vol)],
        "media.fog.file",
        "beyond ±1e9",
    );
}

#[test]
fn a_vanishing_field_of_view_is_an_input_error() {
    let v = with(|v| v["camera"]["fov"] = json!(1e-30));
    expect_error("fov", &v, "camera.fov", "must be in [0.001, 180)");
    let scene = load("fov-min", &with(|v| v["camera"]["fov"] = json!(1e-3)), &[]).unwrap();
    for kind in [IntegratorKind::PtMono, IntegratorKind::BdptForward] {
        assert!(mean_y(&scene, kind, 2).is_finite(), "{kind:?}");
    }
}

/// A reflectance above 1 creates energy: every bounce multiplies the path throughput until it
/// overflows, so it is an input error naming the field, the value and the wavelength where it
/// is largest; exactly 1 is fine.
#[test]
fn a_reflectance_above_one_is_an_input_error() {
    let v = with(|v| v["materials"]["white"]["reflectance"] = json!(5e19));
    expect_error("refl-huge", &v, "materials.white.reflectance", "above 1");
    let v = with(|v| {
        v["materials"]["white"]["reflectance"] =
            json!({"type": "tabulated", "pairs": [[400, 0.5], [600, 1.5], [700, 0.5]]})
    });
    let e = expect_error(
        "refl-tab",
        &v,
        "materials.white.reflectance",
        "1.5 at 600 nm",
    );
    assert!(e.to_string().contains("passive surface"), "{e}");
    let fluor = json!({"type": "fluorescent-diffuse", "reflectance": 1e9,
        "absorption": {"type": "box", "lo": 300, "hi": 400, "value": 1},
        "emission": {"type": "box", "lo": 500, "hi": 550, "value": 0.02},
        "quantum_yield": 1, "concentration": 1});
    let v = with(|v| v["materials"]["white"] = fluor);
    expect_error("refl-fluor", &v, "materials.white.reflectance", "above 1");
    let scene = load(
        "refl-one",
        &with(|v| v["materials"]["white"]["reflectance"] = json!(1)),
        &[],
    )
    .unwrap();
    assert!(scene.warnings.iter().all(|w| !w.contains("reflectance")));
    assert!(mean_y(&scene, IntegratorKind::PtMono, 2).is_finite());
}

/// A measured matrix with an absurd entry, or a column that returns far more light than it
/// receives, is refused naming the file, its line, row and column.
#[test]
fn a_bfc_matrix_with_a_huge_entry_is_an_input_error() {
    let golfye = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/bispectral/GOLFYE.BFC"),
    )
    .unwrap();
    let row = golfye.lines().find(|l| l.starts_with("750\t")).unwrap();
    let mut cells: Vec<&str> = row.split('\t').collect();
    cells[1 + 34] = "3.4e38"; // excitation 640 nm
    let bad = golfye.replacen(row, &cells.join("\t"), 1);
    let v = with(|v| v["materials"]["white"] = json!({"type": "reradiation", "file": "bad.BFC"}));
    let e = expect_error_in(
        "bfc-huge",
        &v.to_string(),
        &[("bad.BFC", bad.as_bytes())],
        "materials.white.file",
        "row 750 nm (emission), column 640 nm (excitation)",
    );
    assert!(
        e.to_string().contains("bad.BFC") && e.to_string().contains("line "),
        "{e}"
    );
    // Every entry of a column below the bound, but together 20 × 9 = 180 > 100.
    let mut text = golfye.clone();
    for l in golfye.lines().filter(|l| {
        l.split('\t')
            .next()
            .and_then(|w| w.parse::<f32>().ok())
            .is_some_and(|w| (400.0..=590.0).contains(&w))
    }) {
        let mut c: Vec<String> = l.split('\t').map(str::to_string).collect();
        c[1 + 10] = "9".into(); // excitation 400 nm
        text = text.replacen(l, &c.join("\t"), 1);
    }
    expect_error_in(
        "bfc-column",
        &v.to_string(),
        &[("bad.BFC", text.as_bytes())],
        "materials.white.file",
        "column 400 nm (excitation)",
    );
}

// ---------------------------------------------------------------- normalising tiny spectra

/// `good()` with the ball made of a fluorescent material whose absorption and emission are
/// boxes of values `a` (300–400 nm) and `e` (500–`e_hi` nm).
fn dye(a: f64, e: f64, e_hi: f64) -> Value {
    with(|v| {
        v["materials"]["dye"] = json!({
            "type": "fluorescent-diffuse", "reflectance": 0.5,
            "absorption": { "type": "box", "lo": 300, "hi": 400, "value": a },
            "emission": { "type": "box", "lo": 500, "hi": e_hi, "value": e },
            "quantum_yield": 0.9, "concentration": 0.8 });
        v["shapes"][1]["material"] = json!("dye");
    })
}

/// The fluorescent material normalises its absorption to peak 1 and its emission to unit area.
/// A peak or area that is not a normal f32 (a subnormal such as 1e-45) used to be divided by
/// in f32, which overflowed to infinity: exit 0 with hundreds of NaN/Inf samples rejected. It is
/// now an input error naming the spectrum; a tiny normal peak (1e-30) and an emission whose
/// area overflows f32 (3e38 over 50 nm) normalise in f64 to the same material as unit spectra.
#[test]
fn spectra_too_small_to_normalise_are_input_errors() {
    for (tag, v, field, words) in [
        (
            "a-1e-45",
            dye(1e-45, 0.02, 550.0),
            "absorption",
            "peak 1e-45 is too small",
        ),
        (
            "a-1e-40",
            dye(1e-40, 0.02, 550.0),
            "absorption",
            "peak 1e-40 is too small",
        ),
        (
            "e-1e-45",
            dye(1.0, 1e-45, 550.0),
            "emission",
            "is too small to normalise",
        ),
        // Normal values, but an area of 1e-36 × 0.001 nm = 1e-39.
        (
            "e-narrow",
            dye(1.0, 1e-36, 500.001),
            "emission",
            "is too small to normalise",
        ),
    ] {
        expect_error(tag, &v, &format!("materials.dye.{field}"), words);
        let (code, err) = cli(tag, &v.to_string(), &[]);
        assert_eq!(code, 2, "{tag}: {err}");
    }
    let unit = load("dye-unit", &dye(1.0, 0.02, 550.0), &[]).unwrap();
    for (tag, a, e) in [("a-tiny", 1e-30, 0.02), ("e-huge", 1.0, 3e38)] {
        let s = load(tag, &dye(a, e, 550.0), &[]).unwrap();
        let i = s.material_names.iter().position(|n| n == "dye").unwrap();
        let stokes::material::Material::Fluorescent(m) = &s.materials[i] else {
            panic!("{tag}: not fluorescent")
        };
        let d = s.domain;
        assert_eq!(m.a.max_value(d), 1.0, "{tag}");
        assert!((m.e.integral(d.min, d.max) - 1.0).abs() < 1e-6, "{tag}");
        for kind in ALL {
            let (y, y_unit) = (mean_y(&s, kind, 4), mean_y(&unit, kind, 4));
            assert!(
                y > 0.0 && (y - y_unit).abs() <= 1e-5 * y_unit,
                "{tag} {kind:?}: {y} vs {y_unit}"
            );
        }
    }
}

/// The medium fluorophore normalises its absorption peak and emission area like the surface
/// material: too small to normalise is an input error naming the field, not an infinite
/// collision coefficient blamed on the density.
#[test]
fn medium_fluorophore_spectra_too_small_to_normalise_are_input_errors() {
    let base: Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenes/furnace-medium.json"
        ))
        .unwrap(),
    )
    .unwrap();
    for (tag, field, words) in [
        ("medium-a-1e-45", "absorption", "peak 1e-45 is too small"),
        ("medium-e-1e-45", "emission", "is too small to normalise"),
    ] {
        let mut v = base.clone();
        let f = &mut v["media"]["fluid"]["fluorescence"];
        if field == "absorption" {
            f["absorption"]["value"] = serde_json::json!(1e-45);
        } else {
            f["emission"] =
                serde_json::json!({"type": "box", "lo": 500, "hi": 600, "value": 1e-45});
        }
        expect_error(tag, &v, &format!("media.fluid.fluorescence.{field}"), words);
    }
}
