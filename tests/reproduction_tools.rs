//! The tools of the papers' reproduction (results/REPRODUCTION.md): `render --set`, `stokes diff`,
//! `stokes png`, the images of one path length (`vertices<k>.exr`) and a parameter grid's
//! `grid.csv`, each against a value known without them.

mod common;

use common::{bin, expect_input_error, repo, run_limited, s, temp_dir};
use std::path::Path;
use std::process::Command;

/// Run `stokes` with `args` in `dir`; stdout on success, a panic with stderr otherwise.
fn stokes_ok(dir: &Path, args: &[&str]) -> String {
    let o = Command::new(bin())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "stokes {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Mean of every channel of every pixel of an EXR.
fn mean(p: &Path) -> f64 {
    let (_, _, px) = stokes::film::output::read_exr(p).unwrap();
    px.iter().map(|c| (c.x + c.y + c.z) as f64).sum::<f64>() / (3 * px.len()) as f64
}

/// `--set` changes the scene that renders: in the Lambert furnace every camera sample sees
/// Σ_{k<8} ρ^k Le (8 segments), so with the same seed (the same wavelengths) the image with
/// reflectance ρ is (1 − ρ⁸) / (1 − ρ) times the image with ρ = 0, whatever the file says (0.5).
/// Bad arguments name `--set`, a bad value the field.
#[test]
fn set_changes_the_scene_and_bad_sets_are_named() {
    let d = temp_dir("set");
    let scene = repo().join("scenes/furnace-lambert.json");
    let sc = s(&scene);
    let render = |rho: &str| {
        let set = format!("materials.grey.reflectance={rho}");
        stokes_ok(
            &d,
            &[
                "render", sc, "--spp", "4", "--set", &set, "-o", "f.exr", "--quiet",
            ],
        );
        mean(&d.join("f.exr"))
    };
    let m0 = render("0");
    for rho in [0.5f64, 0.75] {
        let want = (1.0 - rho.powi(8)) / (1.0 - rho);
        let got = render(&rho.to_string()) / m0;
        assert!(
            (got - want).abs() < 1e-5 * want,
            "reflectance {rho}: {got} times the emitter alone, closed form {want}"
        );
    }
    for (arg, names) in [
        ("materials.grey.reflectance", vec!["--set", "PATH=JSON"]),
        ("materials.grey.reflectance=nope", vec!["--set", "not JSON"]),
        ("materials..reflectance=1", vec!["--set", "dot path"]),
        ("materials.nothing.reflectance=1", vec!["--set", "nothing"]),
        (
            "materials.grey.reflectance=-1",
            vec!["materials.grey.reflectance"],
        ),
    ] {
        let r = run_limited(
            &d,
            &["render", sc, "--spp", "1", "--set", arg, "-o", "x.exr"],
        );
        expect_input_error(arg, r, &names);
    }
    assert!(!d.join("x.exr").exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `stokes diff` of an image with itself is zero everywhere (SNR ∞) and of two renders states
/// their mean luminances; `stokes png` writes a PNG of the EXR's size; both refuse bad names and
/// images of different sizes.
#[test]
fn diff_and_png_write_figures_and_check_their_inputs() {
    let d = temp_dir("diff");
    let scene = repo().join("scenes/cornell-box.json");
    let sc = s(&scene);
    for (seed, out) in [("1", "a.exr"), ("2", "b.exr")] {
        stokes_ok(
            &d,
            &[
                "render",
                sc,
                "--spp",
                "2",
                "--seed",
                seed,
                "--quiet",
                "--set",
                "camera.width=32",
                "--set",
                "camera.height=24",
                "-o",
                out,
            ],
        );
    }
    let same = stokes_ok(&d, &["diff", "a.exr", "a.exr", "-o", "same.png"]);
    assert!(same.contains("difference +0.000000"), "{same}");
    assert!(same.contains("inf dB (linear sRGB)"), "{same}");
    let ab = stokes_ok(&d, &["diff", "a.exr", "b.exr", "-o", "ab.png"]);
    assert!(ab.contains("SNR of a against b:"), "{ab}");
    for f in ["same.png", "same.svg", "ab.png", "ab.svg"] {
        assert!(d.join(f).is_file(), "{f}");
    }
    stokes_ok(&d, &["png", "a.exr", "-o", "a.png"]);
    let img = image::open(d.join("a.png")).unwrap();
    assert_eq!((img.width(), img.height()), (32, 24));
    // errors: a name that is not .png, images of two sizes, a missing input
    stokes_ok(
        &d,
        &[
            "render",
            sc,
            "--spp",
            "1",
            "--quiet",
            "--set",
            "camera.width=16",
            "-o",
            "c.exr",
        ],
    );
    for (args, names) in [
        (
            vec!["diff", "a.exr", "b.exr", "-o", "x.jpg"],
            vec!["-o/--output", ".png"],
        ),
        (
            vec!["diff", "a.exr", "c.exr", "-o", "x.png"],
            vec!["a.exr", "c.exr", "one size"],
        ),
        (
            vec!["diff", "a.exr", "none.exr", "-o", "x.png"],
            vec!["none.exr"],
        ),
        (
            vec!["png", "a.exr", "-o", "x.exr"],
            vec!["-o/--output", ".png"],
        ),
        (
            vec!["png", "a.exr", "--exposure", "inf", "-o", "x.png"],
            vec!["--exposure"],
        ),
    ] {
        let r = run_limited(&d, &args);
        expect_input_error(&format!("{args:?}"), r, &names);
    }
    assert!(!d.join("x.png").exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `--strategy-images` also writes the images of one path length: `vertices<k>.exr` is the sum
/// of the strategy images `s<i>_t<j>.exr` with i + j = k, and the lengths sum to the image.
#[test]
fn images_of_one_path_length_sum_the_strategies() {
    let d = temp_dir("lengths");
    let scene = repo().join("scenes/fluorescent-walls.json");
    stokes_ok(
        &d,
        &[
            "render",
            s(&scene),
            "--integrator",
            "bdpt-forward",
            "--spp",
            "2",
            "--max-depth",
            "4",
            "--quiet",
            "--set",
            "camera.width=24",
            "--set",
            "camera.height=24",
            "--strategy-images",
            "st",
            "-o",
            "walls.exr",
        ],
    );
    let read = |n: &str| {
        stokes::film::output::read_exr(&d.join("st").join(n))
            .unwrap()
            .2
    };
    let mut total = vec![glam::Vec3::ZERO; 24 * 24];
    for k in 2..=5 {
        let mut sum = vec![glam::Vec3::ZERO; 24 * 24];
        for i in 1..=k {
            for (p, v) in sum.iter_mut().zip(read(&format!("s{i}_t{}.exr", k - i))) {
                *p += v;
            }
        }
        let got = read(&format!("vertices{k}.exr"));
        for (a, b) in got.iter().zip(&sum) {
            assert!((*a - *b).abs().max_element() <= 1e-5 * b.abs().max_element().max(1e-3));
        }
        for (t, v) in total.iter_mut().zip(got) {
            *t += v;
        }
    }
    assert!(
        !d.join("st/vertices6.exr").exists(),
        "max depth 4: 5 vertices at most"
    );
    let image = stokes::film::output::read_exr(&d.join("walls.exr"))
        .unwrap()
        .2;
    let (a, b): (f64, f64) = total.iter().zip(&image).fold((0.0, 0.0), |(a, b), (t, i)| {
        (a + t.y as f64, b + i.y as f64)
    });
    assert!((a - b).abs() <= 1e-4 * b, "lengths {a} vs image {b}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// A parameter grid writes `grid.csv` with each cell's mean luminance over the grid's material:
/// with the concentration at 0 the quantum yield changes nothing (Jung Fig. 7.13's first check),
/// and the quantum yield at 0 with the concentration at 1 absorbs without re-emitting, so the
/// sphere is darker than at c = 0 (its second).
#[test]
fn parameter_grid_writes_the_cells_means() {
    let d = temp_dir("grid-csv");
    let cfg = repo().join("experiments/fluorescence-parameters.json");
    let o = common::quick_experiment(&cfg, &d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let exp = d.join("fluorescence-parameters");
    let latest = std::fs::read_to_string(exp.join("latest")).unwrap();
    let csv = std::fs::read_to_string(exp.join(latest.trim()).join("grid.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("row,column,concentration,quantum_yield,material_mean_y")
    );
    let cells: Vec<(f64, f64, f64)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
                f[4].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(cells.len(), 36);
    let at = |c: f64, q: f64| cells.iter().find(|x| x.0 == c && x.1 == q).unwrap().2;
    for q in [0.2, 0.4, 0.6, 0.8, 1.0] {
        assert_eq!(at(0.0, q), at(0.0, 0.0), "c = 0 row, Φ = {q}");
    }
    assert!(
        at(1.0, 0.0) < at(0.0, 0.0),
        "c = 1, Φ = 0 is darker than c = 0"
    );
    assert!(
        at(1.0, 1.0) > at(0.0, 0.0),
        "c = Φ = 1 is brighter than c = 0"
    );
    std::fs::remove_dir_all(&d).unwrap();
}
