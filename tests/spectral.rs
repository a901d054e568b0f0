//! Spectral images (`--spectral`) and band sensors (`camera.sensor`) against the closed form of
//! the fluorescent furnace (scenes/furnace-fluorescent.json): L = 1/0.9 in 300–400 nm, 5.2 in
//! 500–550 nm and 2 elsewhere (derived in the scene's comment and in tests/furnaces.rs). The
//! spectral EXR is read back with the exr crate and, where a Python environment with
//! colour-science is at hand (scripts/colour-setup.sh), with colour-science's reader of the
//! Fichet 2021 layout.

mod common;

use common::{bin, expect_input_error, repo, run_limited, s, temp_dir};
use std::path::Path;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

/// The closed-form radiance of the fluorescent furnace at λ (nm).
fn furnace_l(l: f64) -> f64 {
    if (300.0..400.0).contains(&l) {
        1.0 / 0.9
    } else if (500.0..550.0).contains(&l) {
        5.2
    } else {
        2.0
    }
}

/// The fluorescent furnace with `edit` applied to its JSON, `size`×`size` pixels.
fn furnace(size: u32, edit: impl FnOnce(&mut serde_json::Value)) -> Scene {
    let path = repo().join("scenes/furnace-fluorescent.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    v["camera"]["width"] = size.into();
    v["camera"]["height"] = size.into();
    edit(&mut v);
    Scene::from_str(&path, &v.to_string()).unwrap()
}

/// Depth 64 with roulette for the path tracers; 16 segments for BDPT (no roulette: every
/// segment multiplies the throughput by at most 0.5, so truncation leaves < 0.5^15 ≈ 3e-5 of L,
/// far below the tests' noise, and 64 would cost 16× the connections).
fn opts(kind: IntegratorKind) -> IntegratorOptions {
    let pt = matches!(kind, IntegratorKind::PtMono | IntegratorKind::PtHero);
    IntegratorOptions {
        max_depth: if pt { 64 } else { 16 },
        rr_depth: Some(6),
        ..Default::default()
    }
}

/// Mean and standard error of the mean of `values` (one per pixel).
fn mean_se(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let v: Vec<f64> = values.collect();
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

const SPECTRAL: [IntegratorKind; 5] = [
    IntegratorKind::PtMono,
    IntegratorKind::PtHero,
    IntegratorKind::BdptForward,
    IntegratorKind::BdptBackward,
    IntegratorKind::BdptCombined,
];

/// Every bin of the spectral image (10 nm bins over the camera's 360–780 nm, aligned with the
/// furnace's box edges) has the closed-form mean, for each integrator that makes one.
#[test]
fn spectral_image_of_the_fluorescent_furnace_is_the_closed_form() {
    let scene = furnace(16, |_| {});
    assert_eq!(
        (scene.observer.range.min, scene.observer.range.max),
        (360.0, 780.0)
    );
    for kind in SPECTRAL {
        let spp = match kind {
            IntegratorKind::PtMono => 2048,
            IntegratorKind::PtHero => 512,
            _ => 256,
        };
        let settings = RenderSettings {
            spp,
            seed: 3,
            spectral: Some(42),
            ..Default::default()
        };
        let out = render(&scene, kind, &opts(kind), &settings, None).unwrap();
        let sf = out.film.spectral.as_ref().expect("a spectral film");
        let values = sf.values(out.film.spp);
        let n = sf.bins.n;
        let px = values.len() / n;
        let mut worst: f64 = 0.0;
        for b in 0..n {
            let want = furnace_l(sf.bins.centre(b));
            let (m, se) = mean_se((0..px).map(|p| values[p * n + b] as f64));
            let z = (m - want).abs() / (se + 1e-9);
            worst = worst.max(z);
            // within 5 standard errors, and the test has the power to see a 20 % error
            assert!(
                z < 5.0 && se < 0.04 * want,
                "{}: bin {b} ({} nm): mean {m} ± {se}, closed form {want}",
                kind.name(),
                sf.bins.centre(b)
            );
        }
        eprintln!("{}: worst bin {worst:.2} standard errors", kind.name());
    }
}

/// A band sensor's image is grey and equals the band's mean closed-form radiance, for every
/// integrator, in bands inside the UV (outside the CIE observer), on the emission and across it.
#[test]
fn band_sensor_of_the_fluorescent_furnace_is_the_closed_form() {
    for (band, want) in [
        ([300.0, 380.0], 1.0 / 0.9),
        ([500.0, 550.0], 5.2),
        (
            [450.0, 600.0],
            (50.0 * 2.0 + 50.0 * 5.2 + 50.0 * 2.0) / 150.0,
        ),
    ] {
        let scene = furnace(8, |v| {
            v["camera"]["sensor"] = serde_json::json!({ "band": band })
        });
        assert_eq!(
            (scene.observer.range.min, scene.observer.range.max),
            (band[0] as f32, band[1] as f32)
        );
        for kind in IntegratorKind::all() {
            let spp = match kind {
                IntegratorKind::PtMono => 1024,
                IntegratorKind::PtHero => 256,
                _ => 64,
            };
            let settings = RenderSettings {
                spp,
                seed: 5,
                ..Default::default()
            };
            let out = render(&scene, kind, &opts(kind), &settings, None).unwrap();
            let rgb = out.film.rgb();
            for c in 0..3 {
                let (m, se) = mean_se(rgb.iter().map(|p| p[c] as f64));
                assert!(
                    (m - want).abs() < 5.0 * se + 2e-3 * want,
                    "{} band {band:?} channel {c}: {m} ± {se}, closed form {want}",
                    kind.name()
                );
            }
            // grey: the three channels of every pixel agree
            for p in &rgb {
                assert!(
                    (p.x - p.y).abs() <= 1e-4 * p.y.abs().max(1.0)
                        && (p.z - p.y).abs() <= 1e-4 * p.y.abs().max(1.0),
                    "{} band {band:?}: pixel {p} is not grey",
                    kind.name()
                );
            }
        }
    }
}

/// Named channels or attributes.
type Named<T> = Vec<(String, T)>;

/// The channels of a spectral EXR (exr crate): (name, values) sorted by name, and the text
/// attributes.
fn read_channels(path: &Path) -> (Named<Vec<f32>>, Named<String>) {
    use exr::prelude::*;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap();
    let layer = img.layer_data;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v = match &c.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => panic!("channel {} is not f32: {other:?}", c.name),
            };
            (c.name.to_string(), v)
        })
        .collect();
    let attrs = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    (channels, attrs)
}

/// `stokes render --spectral` writes the Fichet 2021 layout beside the RGB EXR: one `S0.<λ>nm`
/// channel per bin with the bin's closed-form radiance (a constant spectrum reads back as that
/// constant), the RGB preview, and `spectralLayoutVersion`.
#[test]
fn render_writes_a_fichet_2021_spectral_exr() {
    let dir = temp_dir("spectral-exr");
    let out = dir.join("lambert.exr");
    let st = std::process::Command::new(bin())
        .args([
            "render",
            s(&repo().join("scenes/furnace-lambert.json")),
            "--integrator",
            "pt-hero",
            "--spp",
            "64",
            "--spectral",
            "6",
            "--quiet",
            "-o",
            s(&out),
        ])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let spectral = dir.join("lambert.spectral.exr");
    let (channels, attrs) = read_channels(&spectral);
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    // 6 bins of 70 nm over 360–780 nm, named by their centres
    assert_eq!(
        names,
        [
            "B",
            "G",
            "R",
            "S0.395,000000nm",
            "S0.465,000000nm",
            "S0.535,000000nm",
            "S0.605,000000nm",
            "S0.675,000000nm",
            "S0.745,000000nm"
        ]
    );
    assert!(
        attrs
            .iter()
            .any(|(k, v)| k == "spectralLayoutVersion" && v == "1.0")
    );
    assert!(attrs.iter().any(|(k, _)| k == "stokes.film"));
    // the Lambert furnace: L = 2 at every wavelength (the RGB preview is of an equal-energy
    // white, not grey)
    for (name, v) in channels.iter().filter(|(n, _)| n.starts_with("S0.")) {
        let (m, se) = mean_se(v.iter().map(|x| *x as f64));
        assert!(
            (m - 2.0).abs() < 5.0 * se + 1e-3,
            "{name}: mean {m} ± {se}, closed form 2"
        );
    }
    colour_science_reads(&spectral, &channels);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// colour-science's `read_spectral_image_Fichet2021` reads the same wavelengths and values
/// (exactly: both are the file's f32). Skipped with a message without a Python that has
/// colour-science and OpenImageIO (scripts/colour-setup.sh makes one in target/colour-venv),
/// unless STOKES_REQUIRE_COLOUR=1 (CI sets it).
fn colour_science_reads(path: &Path, channels: &[(String, Vec<f32>)]) {
    let python = std::env::var("STOKES_COLOUR_PYTHON")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| repo().join("target/colour-venv/bin/python"));
    let required = std::env::var("STOKES_REQUIRE_COLOUR").is_ok_and(|v| v == "1");
    if !python.exists() {
        assert!(
            !required,
            "STOKES_REQUIRE_COLOUR=1 but {} does not exist (run scripts/colour-setup.sh)",
            python.display()
        );
        eprintln!(
            "skipped: colour-science's reader ({} does not exist; run scripts/colour-setup.sh)",
            python.display()
        );
        return;
    }
    let script = r#"
import json, sys, warnings
warnings.simplefilter("ignore")
import colour
c = colour.read_spectral_image_Fichet2021(sys.argv[1])
w, v = c["S0"]
print(json.dumps({"wavelengths": [float(x) for x in w],
                  "shape": list(v.shape),
                  "values": [[float(x) for x in v[..., i].ravel()] for i in range(v.shape[-1])]}))
"#;
    let out = std::process::Command::new(&python)
        .args(["-c", script, s(path)])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "colour-science failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let spectral: Vec<&(String, Vec<f32>)> = channels
        .iter()
        .filter(|(n, _)| n.starts_with("S0."))
        .collect();
    let wavelengths = v["wavelengths"].as_array().unwrap();
    assert_eq!(wavelengths.len(), spectral.len());
    for (i, (name, ours)) in spectral.iter().enumerate() {
        let want: f64 = name[3..name.len() - 2].replace(',', ".").parse().unwrap();
        assert_eq!(wavelengths[i].as_f64().unwrap(), want, "{name}");
        let theirs: Vec<f32> = v["values"][i]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        // colour-science returns rows top to bottom, as the EXR stores them
        assert_eq!(&theirs, ours, "{name}: colour-science reads other values");
    }
    eprintln!(
        "colour-science read {} channels of {:?}",
        spectral.len(),
        v["shape"]
    );
}

/// Bad sensors and spectral options are input errors that name the field or option.
#[test]
fn bad_sensors_and_spectral_options_are_named() {
    let dir = temp_dir("spectral-errors");
    let base: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(repo().join("scenes/furnace-lambert.json")).unwrap(),
    )
    .unwrap();
    let cases: [(serde_json::Value, &[&str]); 6] = [
        (
            serde_json::json!({ "band": [400] }),
            &["camera.sensor.band", "two wavelengths"],
        ),
        (
            serde_json::json!({ "band": [500, 400] }),
            &["camera.sensor.band", "lo < hi"],
        ),
        (
            serde_json::json!({ "band": [100, 200] }),
            &["camera.sensor", "zero over the scene's domain"],
        ),
        (serde_json::json!("cie1931"), &["camera.sensor", "cie-1931"]),
        (
            serde_json::json!({ "response": "nope" }),
            &["camera.sensor.response", "nope"],
        ),
        (
            serde_json::json!({ "band": [400, 500], "x": 1 }),
            &["camera.sensor"],
        ),
    ];
    for (i, (sensor, names)) in cases.iter().enumerate() {
        let mut v = base.clone();
        v["camera"]["sensor"] = sensor.clone();
        let scene = dir.join(format!("s{i}.json"));
        std::fs::write(&scene, v.to_string()).unwrap();
        let mut want = names.to_vec();
        want.push(s(&scene));
        let r = run_limited(&dir, &["render", s(&scene), "--spp", "1", "-o", "x.exr"]);
        expect_input_error(&format!("sensor {sensor}"), r, &want);
    }
    let scene = repo().join("scenes/furnace-lambert.json");
    let sc = s(&scene);
    for (args, names) in [
        (vec!["--spectral", "0"], vec!["--spectral", "1–1024"]),
        (vec!["--spectral", "5000"], vec!["--spectral", "1–1024"]),
        (
            vec!["--spectral", "8", "--integrator", "bdpt-allbins"],
            vec!["--spectral", "bdpt-allbins"],
        ),
        (
            vec!["--spectral", "8", "--samples", "0..4"],
            vec!["--spectral", "--samples"],
        ),
        (
            vec!["--spectral", "8", "--spectral-output", "x.png"],
            vec!["--spectral-output", ".exr"],
        ),
        (
            vec!["--spectral", "8", "--spectral-output", "x.exr"],
            vec!["--spectral-output", "same file"],
        ),
    ] {
        let mut a = vec!["render", sc, "--spp", "1", "-o", "x.exr"];
        a.extend(args.iter().copied());
        let r = run_limited(&dir, &a);
        expect_input_error(&format!("{args:?}"), r, &names);
    }
    assert!(!dir.join("x.exr").exists(), "an error left an image behind");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An experiment config's `spectral` writes each variant's final image of repeat 0 as a spectral
/// EXR beside its RGB one, with the closed form of the Lambert furnace in every bin; a
/// bdpt-allbins variant or a bin count out of range is an input error naming `spectral`.
#[test]
fn experiment_spectral_option_writes_the_variants_spectral_images() {
    let dir = temp_dir("spectral-config");
    let scene = repo().join("scenes/furnace-lambert.json");
    let config = |spectral: serde_json::Value, second: &str| {
        serde_json::json!({
            "name": "sp",
            "scene": scene,
            "reference": { "integrator": "pt-hero", "spp": 16, "seed": 9 },
            "variants": [
                { "name": "mono", "integrator": "pt-mono" },
                { "name": "second", "integrator": second }
            ],
            "budget": { "spp": [4, 16] },
            "repeats": 2,
            "threads": 1,
            "spectral": spectral
        })
    };
    let cfg = dir.join("sp.json");
    std::fs::write(&cfg, config(6.into(), "bdpt-forward").to_string()).unwrap();
    let out = dir.join("results");
    let st = std::process::Command::new(bin())
        .args(["experiment", s(&cfg), "--out", s(&out)])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let latest = std::fs::read_to_string(out.join("sp/latest")).unwrap();
    let images = out.join("sp").join(latest.trim()).join("images");
    let mut spectral: Vec<String> = std::fs::read_dir(&images)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".spectral.exr"))
        .collect();
    spectral.sort();
    assert_eq!(
        spectral,
        [
            "mono__spp1__r0.spectral.exr",
            "second__spp1__r0.spectral.exr"
        ]
    );
    for f in &spectral {
        let (channels, _) = read_channels(&images.join(f));
        let bins: Vec<_> = channels
            .iter()
            .filter(|(n, _)| n.starts_with("S0."))
            .collect();
        assert_eq!(bins.len(), 6, "{f}");
        for (name, v) in bins {
            let (m, se) = mean_se(v.iter().map(|x| *x as f64));
            assert!((m - 2.0).abs() < 5.0 * se + 1e-3, "{f} {name}: {m} ± {se}");
        }
    }
    for (spectral, second, names) in [
        (serde_json::json!(0), "pt-hero", vec!["spectral", "1–1024"]),
        (
            serde_json::json!(8),
            "bdpt-allbins",
            vec!["spectral", "bdpt-allbins", "second"],
        ),
    ] {
        std::fs::write(&cfg, config(spectral, second).to_string()).unwrap();
        let r = run_limited(&dir, &["experiment", s(&cfg), "--out", "bad"]);
        expect_input_error(second, r, &names);
        assert!(!dir.join("bad").exists(), "{second}: nothing is written");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `stokes inspect` names the sensor and the camera's range.
#[test]
fn inspect_names_the_sensor() {
    let dir = temp_dir("spectral-inspect");
    let mut v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(repo().join("scenes/furnace-lambert.json")).unwrap(),
    )
    .unwrap();
    for (sensor, want) in [
        (
            serde_json::json!({ "band": [300, 380] }),
            "sensor band [300, 380] nm",
        ),
        (
            serde_json::json!({ "response": { "type": "gaussian", "center": 550, "fwhm": 20, "peak": 1 } }),
            "sensor response curve over [280, 780] nm",
        ),
        (
            serde_json::json!("cie-1931"),
            "sensor cie-1931 over [360, 780] nm",
        ),
    ] {
        v["camera"]["sensor"] = sensor;
        let scene = dir.join("s.json");
        std::fs::write(&scene, v.to_string()).unwrap();
        let out = std::process::Command::new(bin())
            .args(["inspect", s(&scene)])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && text.contains(want),
            "{want}: {text}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
