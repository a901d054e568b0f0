//! Bad media input gets a clear error: exit code 2 and a message naming the file and the field.

use std::path::PathBuf;
use std::process::Command;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stokes-media-errors-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A valid scene with a medium; each case replaces one marked piece of it.
const GOOD: &str = r#"{
  "camera": { "origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8 CAMERA },
  "materials": { "white": { "type": "lambert", "reflectance": 0.5 } },
  "media": {
    "fog": { "type": "homogeneous", "sigma_a": SIGMA_A, "sigma_s": 0.5, "phase": PHASE,
             "fluorescence": { "absorption": { "type": "gaussian", "center": 400, "fwhm": 40, "peak": 1 },
                               "concentration": 1, "emission": { "type": "gaussian", "center": 550, "fwhm": 40, "peak": 0.0235 },
                               "quantum_yield": YIELD } }
  },
  "shapes": [
    { "type": "quad", "name": "floor", "material": "white",
      "corners": [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]] },
    { "type": "box", "name": "tank", "min": [-0.8, -0.9, -0.8], "max": [0.8, 0.5, 0.8] TANK },
    { "type": "quad", "name": "light", "material": "white",
      "corners": [[-0.2, 1, -0.2], [0.2, 1, -0.2], [0.2, 1, 0.2], [-0.2, 1, 0.2]],
      "emission": { "spectrum": 5 } } EXTRA
  ]
}"#;

fn scene(edits: &[(&str, &str)]) -> String {
    let mut s = GOOD.to_string();
    for (k, v) in edits {
        s = s.replace(k, v);
    }
    for (k, v) in [
        ("SIGMA_A", "0.1"),
        ("PHASE", r#"{ "type": "henyey-greenstein", "g": 0.3 }"#),
        ("YIELD", "0.9"),
        ("CAMERA", ""),
        ("TANK", r#", "interior": "fog""#),
        ("EXTRA", ""),
    ] {
        s = s.replace(k, v);
    }
    s
}

fn run(name: &str, text: &str, integrator: &str) -> (i32, String) {
    let d = tmpdir(name);
    let path = d.join("scene.json");
    std::fs::write(&path, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
        .args([
            "render",
            path.to_str().unwrap(),
            "--spp",
            "1",
            "--integrator",
            integrator,
        ])
        .args(["-o", d.join("out.exr").to_str().unwrap()])
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

fn expect_error(name: &str, edits: &[(&str, &str)], field: &str, words: &str) {
    let (code, err) = run(name, &scene(edits), "pt-hero");
    assert_eq!(code, 2, "{name}: exit code {code}, stderr: {err}");
    assert!(err.contains("scene.json"), "{name}: no file named: {err}");
    assert!(
        err.contains(field),
        "{name}: does not name `{field}`: {err}"
    );
    assert!(err.contains(words), "{name}: does not say `{words}`: {err}");
    assert!(!err.contains("panicked"), "{name}: panic: {err}");
}

#[test]
fn good_media_scene_renders() {
    for integrator in ["pt-mono", "pt-hero"] {
        let (code, err) = run("good", &scene(&[]), integrator);
        assert_eq!(code, 0, "{integrator}: {err}");
    }
}

#[test]
fn bad_coefficients() {
    expect_error(
        "neg",
        &[("SIGMA_A", "-0.1")],
        "media.fog.sigma_a",
        "negative",
    );
    expect_error("nan", &[("SIGMA_A", r#""nan""#)], "media.fog.sigma_a", "");
    let g = r#"{ "type": "henyey-greenstein", "g": 1.5 }"#;
    expect_error("g", &[("PHASE", g)], "media.fog.phase.g", "(−1, 1)");
    expect_error(
        "phase",
        &[("PHASE", r#"{ "type": "rayleigh" }"#)],
        "media.fog.phase",
        "",
    );
    let qy = "media.fog.fluorescence.quantum_yield";
    expect_error("yield", &[("YIELD", "1.5")], qy, "[0, 1]");
}

#[test]
fn unknown_and_unused_media() {
    let tank = r#", "interior": "smoke""#;
    expect_error(
        "unknown",
        &[("TANK", tank)],
        "shapes[1].interior",
        "unknown medium 'smoke'",
    );
    let cam = r#", "medium": "smoke""#;
    expect_error(
        "camera",
        &[("CAMERA", cam)],
        "camera.medium",
        "unknown medium 'smoke'",
    );
    // Seen from the camera, an exterior that is not the camera's medium.
    let tank = r#", "exterior": "fog""#;
    expect_error(
        "exterior",
        &[("TANK", tank)],
        "shapes[1].exterior",
        "inconsistent",
    );
    // Out of the camera's sight, a medium that is only ever an exterior: never entered.
    let extra = r#", { "type": "sphere", "name": "hidden", "center": [0, 0, 8], "radius": 0.2,
                      "exterior": "fog" }"#;
    let text = scene(&[("EXTRA", extra), ("TANK", "")]).replace(
        r#""name": "tank","#,
        r#""name": "tank", "material": "white","#,
    );
    let (code, err) = run("exterior-only", &text, "pt-mono");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("shapes[3].exterior") && err.contains("never be entered"),
        "{err}"
    );
    // A boundary with no medium on either side.
    expect_error(
        "boundary",
        &[("TANK", "")],
        "shapes[1].material",
        "index-matched boundary",
    );
}

#[test]
fn inconsistent_nesting_names_both_shapes() {
    // A ball inside the tank claims a different medium outside it.
    let extra = r#", { "type": "sphere", "name": "ball", "center": [0, -0.3, 0], "radius": 0.3,
                      "interior": "fog", "exterior": "fog2" }"#;
    let text = scene(&[("EXTRA", extra)]).replace(
        r#""media": {"#,
        r#""media": { "fog2": { "type": "homogeneous", "sigma_a": 0.1, "sigma_s": 0.1 },"#,
    );
    let (code, err) = run("nesting", &text, "pt-mono");
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("shapes[3].exterior"), "{err}");
    assert!(err.contains("'ball'") && err.contains("'tank'"), "{err}");
    assert!(err.contains("inconsistent media"), "{err}");
    // The camera inside the tank without saying so.
    let text = scene(&[]).replace(r#""origin": [0, 0, 3]"#, r#""origin": [0, 0, 0.5]"#);
    let (code, err) = run("camera-inside", &text, "pt-mono");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("camera.medium") && err.contains("'tank'"),
        "{err}"
    );
}

/// The bidirectional integrators render a scene with media from the command line and write the
/// image (they refused media before they supported them).
#[test]
fn bidirectional_integrators_render_media() {
    for integrator in ["bdpt-forward", "bdpt-backward", "bdpt-allbins"] {
        let name = format!("bdpt-{integrator}");
        let (code, err) = run(&name, &scene(&[]), integrator);
        assert_eq!(code, 0, "{integrator}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            tmpdir(&name).join("out.exr").exists(),
            "{integrator}: no image"
        );
    }
}

#[test]
fn bad_grid_files_name_the_field() {
    let grid = |file: &str| {
        scene(&[]).replace(
            r#""fog": { "type": "homogeneous","#,
            &format!(r#""fog": {{ "type": "grid", "file": "{file}","#),
        )
    };
    let d = tmpdir("grids");
    // A 2×2×2 grid: header, then 8 floats.
    let mut good = b"VOL\x03".to_vec();
    for v in [1i32, 2, 2, 2, 1] {
        good.extend(v.to_le_bytes());
    }
    for v in [-0.5f32, -0.5, -0.5, 0.5, 0.5, 0.5] {
        good.extend(v.to_le_bytes());
    }
    for _ in 0..8 {
        good.extend(0.5f32.to_le_bytes());
    }
    std::fs::write(d.join("good.vol"), &good).unwrap();
    std::fs::write(d.join("short.vol"), &good[..good.len() - 6]).unwrap();
    let mut big = good.clone();
    big[8..12].copy_from_slice(&3i32.to_le_bytes());
    std::fs::write(d.join("size.vol"), &big).unwrap();
    let mut neg = good.clone();
    let last = neg.len() - 4;
    neg[last..].copy_from_slice(&(-1.0f32).to_le_bytes());
    std::fs::write(d.join("neg.vol"), &neg).unwrap();
    let run_in = |file: &str| {
        let path = d.join("scene.json");
        std::fs::write(&path, grid(file)).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
            .args(["render", path.to_str().unwrap(), "--spp", "1"])
            .args(["-o", d.join("out.exr").to_str().unwrap()])
            .output()
            .unwrap();
        (
            out.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let (code, err) = run_in("good.vol");
    assert_eq!(code, 0, "{err}");
    for (file, words) in [
        ("missing.vol", "missing.vol"),
        ("short.vol", "truncated"),
        ("size.vol", "3×2×2"),
        ("neg.vol", "density -1"),
    ] {
        let (code, err) = run_in(file);
        assert_eq!(code, 2, "{file}: {err}");
        assert!(
            err.contains("media.fog.file") && err.contains(words),
            "{file}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}
