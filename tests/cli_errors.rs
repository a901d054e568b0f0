//! Bad input gets a clear error: exit code 2 and a message naming the file and the field.

use std::path::{Path, PathBuf};
use std::process::Command;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stokes-cli-errors-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A valid minimal scene, as JSON text, that the cases below break in one place.
const GOOD: &str = r#"{
  "camera": { "origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8 },
  "materials": {
    "white": { "type": "lambert", "reflectance": 0.5 },
    "dye": { "type": "fluorescent-diffuse", "reflectance": 0.2,
             "absorption": { "type": "box", "lo": 300, "hi": 400, "value": 1 },
             "emission": { "type": "box", "lo": 500, "hi": 550, "value": 0.02 },
             "quantum_yield": 0.9, "concentration": 0.5 }
  },
  "shapes": [
    { "type": "quad", "name": "floor", "material": "white",
      "corners": [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]] },
    { "type": "sphere", "name": "ball", "material": "dye", "center": [0, 0, 0], "radius": 0.5 },
    { "type": "quad", "name": "light", "material": "white",
      "corners": [[-0.2, 1, -0.2], [0.2, 1, -0.2], [0.2, 1, 0.2], [-0.2, 1, 0.2]],
      "emission": { "spectrum": 5 } }
  ]
}"#;

fn run_scene(name: &str, text: &str, extra_files: &[(&str, &str)]) -> (i32, String) {
    let d = tmpdir(name);
    for (f, content) in extra_files {
        std::fs::write(d.join(f), content).unwrap();
    }
    let scene = d.join("scene.json");
    std::fs::write(&scene, text).unwrap();
    run(&[
        scene.to_str().unwrap(),
        "--spp",
        "1",
        "-o",
        d.join("out.exr").to_str().unwrap(),
    ])
}

fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
        .arg("render")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

fn expect_error(name: &str, text: &str, extra: &[(&str, &str)], field: &str) -> String {
    let (code, err) = run_scene(name, text, extra);
    assert_eq!(code, 2, "{name}: exit code {code}, stderr: {err}");
    assert!(
        err.contains("scene.json"),
        "{name}: message does not name the file: {err}"
    );
    assert!(
        err.contains(field),
        "{name}: message does not name `{field}`: {err}"
    );
    assert!(!err.contains("panicked"), "{name}: panic: {err}");
    err
}

#[test]
fn good_scene_renders() {
    let (code, err) = run_scene("good", GOOD, &[]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn unknown_keys() {
    expect_error(
        "unknown-top",
        &GOOD.replacen("\"camera\"", "\"lights\": 1, \"camera\"", 1),
        &[],
        "lights",
    );
    expect_error(
        "unknown-camera",
        &GOOD.replacen("\"fov\": 40", "\"fov\": 40, \"aperture\": 2", 1),
        &[],
        "camera",
    );
    expect_error(
        "unknown-material",
        &GOOD.replacen(
            "\"reflectance\": 0.5",
            "\"reflectance\": 0.5, \"gloss\": 1",
            1,
        ),
        &[],
        "materials.white",
    );
    expect_error(
        "shape-field-of-other-kind",
        &GOOD.replacen(
            "\"radius\": 0.5",
            "\"radius\": 0.5, \"corners\": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]]",
            1,
        ),
        &[],
        "shapes[1].corners",
    );
}

#[test]
fn missing_fields() {
    expect_error(
        "missing-camera",
        &GOOD.replacen("\"camera\"", "\"camera_\"", 1),
        &[],
        "camera",
    );
    expect_error(
        "missing-radius",
        &GOOD.replacen(", \"radius\": 0.5", "", 1),
        &[],
        "shapes[1].radius",
    );
    expect_error(
        "missing-qy",
        &GOOD.replacen("\"quantum_yield\": 0.9, ", "", 1),
        &[],
        "quantum_yield",
    );
}

/// Each shape `type` has its own fields: serde enforces the required ones and rejects the others.
#[test]
fn shape_fields_by_type() {
    const SPHERE: &str = r#""type": "sphere", "name": "ball", "material": "dye", "center": [0, 0, 0], "radius": 0.5"#;
    assert!(GOOD.contains(SPHERE));
    // `type` need not come first.
    let err = expect_error(
        "sphere-without-radius",
        &GOOD.replacen(
            SPHERE,
            r#""name": "ball", "material": "dye", "center": [0, 0, 0], "type": "sphere""#,
            1,
        ),
        &[],
        "shapes[1].radius",
    );
    assert!(err.contains("Sphere"), "{err}");
    let err = expect_error(
        "quad-with-radius",
        &GOOD.replacen(
            "\"name\": \"floor\",",
            "\"name\": \"floor\", \"radius\": 1,",
            1,
        ),
        &[],
        "shapes[0].radius",
    );
    assert!(err.contains("unknown field `radius`"), "{err}");
    let err = expect_error(
        "unknown-shape-type",
        &GOOD.replacen("\"type\": \"sphere\"", "\"type\": \"cone\"", 1),
        &[],
        "shapes[1].type",
    );
    assert!(err.contains("cone"), "{err}");
    for (name, min, max) in [
        ("box-min-equals-max", "[0, 0, 0]", "[1, 0, 1]"),
        ("box-min-above-max", "[0, 0, 0]", "[-1, -1, -1]"),
    ] {
        let b = format!(r#""type": "box", "material": "dye", "min": {min}, "max": {max}"#);
        let err = expect_error(name, &GOOD.replacen(SPHERE, &b, 1), &[], "shapes[1].max");
        assert!(err.contains("min < max"), "{err}");
    }
}

#[test]
fn missing_files() {
    let (code, err) = run(&["/nonexistent/scene.json", "-o", "/tmp/x.exr"]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent/scene.json"), "{err}");
    let t = GOOD.replacen(
        "\"reflectance\": 0.5",
        "\"reflectance\": { \"type\": \"tabulated\", \"file\": \"nope.csv\" }",
        1,
    );
    expect_error("missing-csv", &t, &[], "materials.white.reflectance.file");
    let t = GOOD.replacen(
        "\"type\": \"lambert\", \"reflectance\": 0.5",
        "\"type\": \"reradiation\", \"file\": \"nope.BFC\"",
        1,
    );
    expect_error("missing-bfc", &t, &[], "materials.white.file");
    let t = GOOD.replacen("\"type\": \"sphere\", \"name\": \"ball\", \"material\": \"dye\", \"center\": [0, 0, 0], \"radius\": 0.5", "\"type\": \"obj\", \"material\": \"dye\", \"file\": \"nope.obj\"", 1);
    expect_error("missing-obj", &t, &[], "shapes[1].file");
}

#[test]
fn nan_and_negative_values() {
    expect_error(
        "nan",
        &GOOD.replacen("\"radius\": 0.5", "\"radius\": NaN", 1),
        &[],
        "shapes[1].radius",
    );
    expect_error(
        "negative-radius",
        &GOOD.replacen("\"radius\": 0.5", "\"radius\": -0.5", 1),
        &[],
        "shapes[1].radius",
    );
    expect_error(
        "negative-reflectance",
        &GOOD.replacen("\"reflectance\": 0.5", "\"reflectance\": -0.5", 1),
        &[],
        "materials.white.reflectance",
    );
    expect_error(
        "negative-emission-scale",
        &GOOD.replacen("\"spectrum\": 5", "\"spectrum\": 5, \"scale\": -1", 1),
        &[],
        "shapes[2].emission.scale",
    );
    expect_error(
        "huge-number",
        &GOOD.replacen("\"radius\": 0.5", "\"radius\": 1e999", 1),
        &[],
        "shapes[1].radius",
    );
}

#[test]
fn fluorescence_parameters_out_of_range() {
    expect_error(
        "c>1",
        &GOOD.replacen("\"concentration\": 0.5", "\"concentration\": 1.5", 1),
        &[],
        "materials.dye.concentration",
    );
    expect_error(
        "phi<0",
        &GOOD.replacen("\"quantum_yield\": 0.9", "\"quantum_yield\": -0.1", 1),
        &[],
        "materials.dye.quantum_yield",
    );
}

#[test]
fn degenerate_geometry() {
    expect_error(
        "zero-area-quad",
        &GOOD.replacen(
            "[[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]]",
            "[[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]",
            1,
        ),
        &[],
        "shapes[0]",
    );
    expect_error(
        "zero-radius",
        &GOOD.replacen("\"radius\": 0.5", "\"radius\": 0", 1),
        &[],
        "shapes[1].radius",
    );
    expect_error(
        "camera-target",
        &GOOD.replacen("\"target\": [0, 0, 0]", "\"target\": [0, 0, 3]", 1),
        &[],
        "camera.target",
    );
}

#[test]
fn scene_without_lights() {
    expect_error(
        "no-lights",
        &GOOD.replacen(",\n      \"emission\": { \"spectrum\": 5 }", "", 1),
        &[],
        "no light",
    );
}

#[test]
fn malformed_data_files() {
    let t = GOOD.replacen(
        "\"reflectance\": 0.5",
        "\"reflectance\": { \"type\": \"tabulated\", \"file\": \"bad.csv\" }",
        1,
    );
    expect_error(
        "bad-csv",
        &t,
        &[("bad.csv", "wavelength,value\n400,0.5\n500,abc\n")],
        "bad.csv",
    );
    let t2 = GOOD.replacen(
        "\"type\": \"lambert\", \"reflectance\": 0.5",
        "\"type\": \"reradiation\", \"file\": \"bad.BFC\"",
        1,
    );
    expect_error(
        "bad-bfc",
        &t2,
        &[("bad.BFC", "VEC_01\n380 780 10 49 300 10\nr:c: 300 310\n")],
        "bad.BFC",
    );
    let (code, err) = run_scene("bad-json", "{ \"camera\": ", &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("scene.json"), "{err}");
}

#[test]
fn bad_command_line_values() {
    let d = tmpdir("cli");
    let scene = d.join("scene.json");
    std::fs::write(&scene, GOOD).unwrap();
    let s = scene.to_str().unwrap();
    let o = d.join("o.exr");
    let o = o.to_str().unwrap();
    assert_eq!(run(&[s, "--spp", "0", "-o", o]).0, 2);
    assert_eq!(run(&[s, "--max-depth", "0", "-o", o]).0, 2);
    assert_eq!(run(&[s, "--time-limit", "-1", "-o", o]).0, 2);
    assert_eq!(run(&[s, "--integrator", "nope", "-o", o]).0, 2);
    assert_eq!(run(&[s, "--reset-choice", "nope", "-o", o]).0, 2);
    // a reset choice is bdpt-combined's: elsewhere it is an error, not ignored
    let (code, err) = run(&[
        s,
        "--integrator",
        "bdpt-forward",
        "--reset-choice",
        "random",
        "-o",
        o,
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("reset_choice") && err.contains("bdpt-combined"),
        "{err}"
    );
}

#[test]
fn earlier_output_survives_a_failed_run() {
    let d = tmpdir("atomic");
    let scene = d.join("scene.json");
    std::fs::write(&scene, GOOD).unwrap();
    let out = d.join("keep.exr");
    let (code, err) = run(&[
        scene.to_str().unwrap(),
        "--spp",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let before = std::fs::read(&out).unwrap();
    std::fs::write(&scene, "{ broken").unwrap();
    assert_eq!(
        run(&[scene.to_str().unwrap(), "-o", out.to_str().unwrap()]).0,
        2
    );
    assert_eq!(std::fs::read(&out).unwrap(), before);
    assert!(Path::new(&out).exists());
}

/// `STOKES_ISA` forces an instruction set the CPU has; a value that is no instruction set, or
/// one the CPU lacks, is refused before any work with a message naming the variable, and
/// `stokes inspect` says which one is in use.
#[test]
fn forced_instruction_sets() {
    use stokes::geometry::Isa;
    let d = tmpdir("isa");
    let scene = d.join("scene.json");
    std::fs::write(&scene, GOOD).unwrap();
    let s = scene.to_str().unwrap();
    let stokes = |isa: &str, args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
            .env("STOKES_ISA", isa)
            .args(args)
            .output()
            .unwrap();
        (
            out.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&out.stdout).to_string(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let o = d.join("o.exr");
    let (code, _, err) = stokes(
        "sse9",
        &["render", s, "--spp", "1", "-o", o.to_str().unwrap()],
    );
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("STOKES_ISA=sse9") && err.contains("avx2"),
        "{err}"
    );
    assert!(!o.exists() && !err.contains("panicked"), "{err}");
    for isa in Isa::ALL {
        let (code, out, err) = stokes(isa.name(), &["inspect", s]);
        if isa.supported() {
            assert_eq!(code, 0, "{err}");
            let line = format!("instruction set: {isa}, forced by STOKES_ISA");
            assert!(out.contains(&line), "{out}");
        } else {
            assert_eq!(code, 2, "{err}");
            assert!(err.contains("does not support"), "{err}");
        }
    }
    let (code, out, _) = stokes("", &["inspect", s]);
    assert_eq!(code, 0);
    assert!(
        out.contains(&format!("instruction set: {} (", Isa::best())),
        "{out}"
    );
}
