//! The command line, the experiment runner and `stokes figures` treat every option, config and
//! file they read back (run.json, metrics.csv, sweep.json, EXRs, references) as untrusted input:
//! exit code 2 and a message naming the file or option and the field, never a panic; outputs are
//! checked before rendering, never collide, are byte-identical between identical runs, and an
//! interrupted run leaves no temporary file and marks its run folder incomplete.

mod common;

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{bin, expect_input_error, repo, s};

/// A small valid scene of `size`×`size` pixels.
fn scene(dir: &Path, size: u32) -> PathBuf {
    let text = format!(
        r#"{{
  "camera": {{ "origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": {size}, "height": {size} }},
  "materials": {{ "white": {{ "type": "lambert", "reflectance": 0.5 }} }},
  "shapes": [
    {{ "type": "quad", "name": "floor", "material": "white",
      "corners": [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]] }},
    {{ "type": "sphere", "name": "ball", "material": "white", "center": [0, 0, 0], "radius": 0.5 }},
    {{ "type": "quad", "name": "light", "material": "white",
      "corners": [[-0.2, 1, -0.2], [0.2, 1, -0.2], [0.2, 1, 0.2], [-0.2, 1, 0.2]],
      "emission": {{ "spectrum": 5 }} }}
  ]
}}"#
    );
    let p = dir.join(format!("scene{size}.json"));
    std::fs::write(&p, text).unwrap();
    p
}

fn run(args: &[&str]) -> (i32, String) {
    let out: Output = Command::new(bin()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

/// `stokes render <scene> --spp 1 -o <dir>/out.exr` plus `extra`.
fn render(dir: &Path, extra: &[&str]) -> (i32, String) {
    let sc = scene(dir, 8);
    let out = dir.join("out.exr");
    let mut args = vec!["render", s(&sc), "--spp", "1", "-o", s(&out)];
    args.extend_from_slice(extra);
    run(&args)
}

#[test]
fn numeric_options_are_bounded() {
    let d = common::temp_dir("hard-numbers");
    for (extra, name) in [
        (&["--threads", "100000000"][..], "--threads"),
        (&["--threads", "0"], "--threads"),
        (&["--spp", "4000000000"], "--spp"),
        (&["--time-limit", "inf"], "--time-limit"),
        (&["--time-limit", "nan"], "--time-limit"),
        (&["--time-limit", "1e300"], "--time-limit"),
        (&["--exposure", "nan"], "--exposure"),
        (&["--exposure", "inf"], "--exposure"),
        (&["--exposure", "1000"], "--exposure"),
        (&["--lanes", "100000"], "lanes"),
        (&["--max-depth", "4000000000"], "max_depth"),
        (&["--bin-width", "nan"], "bin_width"),
        (&["--bin-width", "0.0001"], "bin_width"),
    ] {
        expect_input_error(&format!("{extra:?}"), render(&d, extra), &[name]);
    }
    // The ends of the ranges are accepted.
    assert_eq!(render(&d, &["--threads", "1", "--exposure=-64"]).0, 0);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn output_names_must_match_their_format_and_not_collide() {
    let d = common::temp_dir("hard-outputs");
    let sc = scene(&d, 8);
    let p = |n: &str| d.join(n).to_string_lossy().to_string();
    let (png, exr, json) = (p("x.png"), p("x.exr"), p("s.json"));
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["-o".into(), png.clone()], "-o/--output"),
        (
            vec!["-o".into(), exr.clone(), "--png".into(), p("y.exr")],
            "--png",
        ),
        // The same file twice, also spelled differently.
        (
            vec![
                "-o".into(),
                exr.clone(),
                "--stats".into(),
                format!("{}/./x.exr", s(&d)),
            ],
            "--stats",
        ),
        (
            vec![
                "-o".into(),
                exr.clone(),
                "--png".into(),
                png.clone(),
                "--stats".into(),
                format!(
                    "{}/../{}/x.png",
                    s(&d),
                    d.file_name().unwrap().to_str().unwrap()
                ),
            ],
            "--stats",
        ),
    ];
    for (extra, name) in cases {
        let mut args = vec![
            "render".to_string(),
            s(&sc).into(),
            "--spp".into(),
            "1".into(),
        ];
        args.extend(extra.iter().cloned());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        expect_input_error(&format!("{extra:?}"), run(&args), &[name]);
    }
    assert!(!d.join("x.exr").exists() && !d.join("x.png").exists());
    // Distinct outputs with the right extensions are written in their formats.
    let (code, err) = run(&[
        "render",
        s(&sc),
        "--spp",
        "1",
        "-o",
        &exr,
        "--png",
        &png,
        "--stats",
        &json,
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        &std::fs::read(&exr).unwrap()[..4],
        &[0x76, 0x2f, 0x31, 0x01]
    );
    assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn unwritable_outputs_are_found_before_rendering() {
    let d = common::temp_dir("hard-unwritable");
    let sc = scene(&d, 8);
    // A scene that would take minutes: the error must come at once.
    let slow = ["--spp", "16000000"];
    let t = std::time::Instant::now();
    for (opt, path) in [
        ("-o", d.join("no-such-folder/out.exr")),
        ("-o", d.join("scene8.json/out.exr")),
        ("--png", d.join("no-such-folder/out.png")),
        ("--stats", d.join("no-such-folder/s.json")),
    ] {
        let ok = d.join("ok.exr");
        let mut args = vec!["render", s(&sc), "-o", s(&ok)];
        args.extend_from_slice(&slow);
        if opt == "-o" {
            args[3] = s(&path);
        } else {
            args.extend_from_slice(&[opt, s(&path)]);
        }
        expect_input_error(opt, run(&args), &[opt, "does not exist"]);
        assert!(!path.parent().unwrap().is_dir() || path.parent().unwrap() == d);
    }
    // A folder given as the output file.
    std::fs::create_dir_all(d.join("dir.exr")).unwrap();
    let dir_out = d.join("dir.exr");
    let mut args = vec!["render", s(&sc), "-o", s(&dir_out)];
    args.extend_from_slice(&slow);
    expect_input_error("-o folder", run(&args), &["-o", "is a folder"]);
    assert!(t.elapsed().as_secs() < 10, "{:?}", t.elapsed());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn exr_output_is_byte_identical_between_identical_runs() {
    let d = common::temp_dir("hard-exr-bytes");
    let sc = scene(&d, 256);
    let mut files = Vec::new();
    for i in 0..2 {
        let out = d.join(format!("out{i}.exr"));
        let (code, err) = run(&[
            "render",
            s(&sc),
            "--spp",
            "1",
            "--threads",
            "2",
            "-o",
            s(&out),
        ]);
        assert_eq!(code, 0, "{err}");
        files.push(std::fs::read(&out).unwrap());
    }
    assert!(files[0].len() > 20_000, "{} bytes", files[0].len());
    assert!(files[0] == files[1], "the two EXRs differ");
    // The library writer too, for an image of many tiles written in parallel.
    let img: Vec<Vec3> = (0..512 * 512)
        .map(|i| Vec3::new((i % 7) as f32, (i % 13) as f32 * 0.1, (i % 101) as f32))
        .collect();
    let mut bytes = Vec::new();
    for i in 0..3 {
        let p = d.join(format!("lib{i}.exr"));
        stokes::film::output::write_exr(&p, 512, 512, &img).unwrap();
        bytes.push(std::fs::read(&p).unwrap());
    }
    assert!(
        bytes[0] == bytes[1] && bytes[1] == bytes[2],
        "EXR bytes vary"
    );
    let _ = std::fs::remove_dir_all(&d);
}

fn walls() -> String {
    repo()
        .join("scenes/fluorescent-walls.json")
        .to_string_lossy()
        .replace('\\', "/")
}

/// [`config`] with a reference of 1,000,000 spp, which takes minutes: a test that ends in
/// seconds shows that nothing was rendered (or that a signal arrived mid-render).
fn slow_config(extra: &str) -> String {
    config(extra).replace(r#""spp": 16"#, r#""spp": 1000000"#)
}

fn config(extra: &str) -> String {
    format!(
        r#"{{ "name": "t", "scene": "{}",
            "reference": {{ "integrator": "pt-mono", "spp": 16 }},
            "variants": [ {{ "name": "a", "integrator": "pt-mono" }} ],
            "budget": {{ "spp": [1, 2] }} {extra} }}"#,
        walls()
    )
}

/// Run `stokes experiment` on `json` (with `--quick` when `quick`); (exit code, stderr, folder).
fn experiment(tag: &str, json: &str, quick: bool) -> (i32, String, PathBuf) {
    let d = common::temp_dir(tag);
    let cfg = d.join("config.json");
    std::fs::write(&cfg, json).unwrap();
    let mut c = Command::new(bin());
    c.args(["experiment", s(&cfg), "--out", s(&d.join("results"))]);
    if quick {
        c.arg("--quick");
    }
    let out = c.output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).to_string(),
        d,
    )
}

#[test]
fn config_numbers_are_bounded_and_crop_does_not_overflow() {
    for (tag, extra, field) in [
        (
            "crop-overflow",
            r#", "crop": {"x": 4294967290, "y": 0, "w": 10, "h": 10}"#,
            "crop",
        ),
        (
            "crop-outside",
            r#", "crop": {"x": 4294967000, "y": 0, "w": 10, "h": 10}"#,
            "crop",
        ),
        ("threads", r#", "threads": 100000000"#, "threads"),
        (
            "seed-overflow",
            r#", "seed": 18446744073709551615, "repeats": 2"#,
            "seed",
        ),
        ("repeats", r#", "repeats": -1"#, "repeats"),
    ] {
        let (code, err, d) = experiment(tag, &config(extra), true);
        expect_input_error(tag, (code, err), &["config.json", field]);
        assert!(
            !d.join("results/t/runs").exists(),
            "{tag}: a run folder was made"
        );
        let _ = std::fs::remove_dir_all(&d);
    }
    for (tag, json, field) in [
        (
            "huge-spp",
            config("").replace("[1, 2]", "[1, 4000000000]"),
            "budget.spp",
        ),
        (
            "huge-seconds",
            config("").replace(r#""spp": [1, 2]"#, r#""seconds": [1e300]"#),
            "budget.seconds",
        ),
        (
            "huge-reference",
            config("").replace(r#""spp": 16"#, r#""spp": 4000000000"#),
            "reference.spp",
        ),
        (
            "negative-budget",
            config("").replace("[1, 2]", "[-1, 2]"),
            "budget.spp",
        ),
        ("truncated", config("")[..60].to_string(), "config.json"),
        (
            "wrong-type",
            config("").replace(r#""spp": 16"#, r#""spp": "16""#),
            "reference.spp",
        ),
    ] {
        let (code, err, d) = experiment(tag, &json, true);
        expect_input_error(tag, (code, err), &["config.json", field]);
        let _ = std::fs::remove_dir_all(&d);
    }
}

#[test]
fn bad_grid_cell_is_found_before_anything_renders() {
    // The last cell is invalid (quantum yield 7); a long reference would render first if the
    // check came late.
    let grid = r#", "grid": {"material": "floor", "rows": {"field": "concentration", "values": [0.1, 1]},
                  "columns": {"field": "quantum_yield", "values": [0.5, 7]}}"#;
    let json = slow_config(grid);
    let t = std::time::Instant::now();
    let (code, err, d) = experiment("grid-late", &json, false);
    expect_input_error(
        "grid",
        (code, err),
        &["config.json", "grid", "cell (0, 1)", "quantum_yield"],
    );
    assert!(t.elapsed().as_secs() < 10, "{:?}", t.elapsed());
    assert!(!d.join("results/t/runs").exists());
    assert!(!d.join("results/references").exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn unwritable_results_folder_is_found_before_anything_renders() {
    let d = common::temp_dir("hard-out-file");
    let cfg = d.join("config.json");
    std::fs::write(&cfg, slow_config("")).unwrap();
    // `--out` is a file: no folder can be made in it.
    let out = d.join("results");
    std::fs::write(&out, "not a folder").unwrap();
    let t = std::time::Instant::now();
    let r = run(&["experiment", s(&cfg), "--out", s(&out)]);
    expect_input_error("--out file", r, &["--out", "results"]);
    assert!(t.elapsed().as_secs() < 10, "{:?}", t.elapsed());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn reference_exr_must_be_finite_and_of_the_right_size() {
    let d = common::temp_dir("hard-ref");
    let mut px = vec![Vec3::splat(0.5); 256 * 256];
    px[1000] = Vec3::new(f32::NAN, 0.0, 0.0);
    stokes::film::output::write_exr(&d.join("nan.exr"), 256, 256, &px).unwrap();
    px[1000] = Vec3::splat(f32::INFINITY);
    stokes::film::output::write_exr(&d.join("inf.exr"), 256, 256, &px).unwrap();
    stokes::film::output::write_exr(&d.join("small.exr"), 2, 2, &[Vec3::ONE; 4]).unwrap();
    std::fs::write(d.join("junk.exr"), b"v/1\x01 not an exr").unwrap();
    for (f, what) in [
        ("nan.exr", "non-finite"),
        ("inf.exr", "non-finite"),
        ("small.exr", "2×2"),
        ("junk.exr", "junk.exr"),
        ("missing.exr", "missing.exr"),
    ] {
        let json = config("").replace(
            r#"{ "integrator": "pt-mono", "spp": 16 }"#,
            &format!(r#"{{ "exr": "{}" }}"#, s(&d.join(f))),
        );
        let (code, err, dir) = experiment(f, &json, false);
        expect_input_error(f, (code, err), &["reference.exr", what]);
        let _ = std::fs::remove_dir_all(&dir);
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A completed quick run of a small config with crop, scanline and regions; its folder.
fn good_run(tag: &str) -> (PathBuf, PathBuf) {
    let extra = r#", "crop": {"x": 10, "y": 10, "w": 20, "h": 20}, "scanline": {"row": 5},
                   "regions": {"by": "shape"}"#;
    let (code, err, d) = experiment(tag, &config(extra), true);
    assert_eq!(code, 0, "{err}");
    let runs = d.join("results/t/runs");
    let run = std::fs::read_dir(&runs)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    assert!(
        !run.join("INCOMPLETE").exists(),
        "a completed run keeps its marker"
    );
    (d, run)
}

fn edit_json(p: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(p, v.to_string()).unwrap();
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.path().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn figures_check_everything_they_read_back() {
    let (d, good) = good_run("hard-figures");
    assert_eq!(run(&["figures", s(&good)]).0, 0);
    type Mutate = Box<dyn Fn(&Path)>;
    let json = |f: fn(&mut serde_json::Value)| -> Mutate {
        Box::new(move |r: &Path| edit_json(&r.join("run.json"), f))
    };
    let cases: Vec<(&str, Mutate, &[&str])> = vec![
        (
            "empty budgets",
            json(|v| v["modes"][0]["budgets"] = serde_json::json!([])),
            &["run.json", "modes[0].budgets"],
        ),
        (
            "nan budget",
            json(|v| v["modes"][0]["budgets"] = serde_json::json!([1, -2])),
            &["run.json", "modes[0].budgets"],
        ),
        (
            "crop overflow",
            json(|v| v["crop"]["x"] = serde_json::json!(4294967290u32)),
            &["run.json", "crop"],
        ),
        (
            "crop outside",
            json(|v| v["crop"]["w"] = serde_json::json!(1000)),
            &["run.json", "crop"],
        ),
        (
            "scanline outside",
            json(|v| v["scanline"]["row"] = serde_json::json!(4000)),
            &["run.json", "scanline"],
        ),
        (
            "scanline both",
            json(|v| v["scanline"]["column"] = serde_json::json!(1)),
            &["run.json", "scanline"],
        ),
        (
            "size mismatch",
            json(|v| v["width"] = serde_json::json!(100)),
            &["reference.exr", "width"],
        ),
        (
            "zero size",
            json(|v| v["height"] = serde_json::json!(0)),
            &["run.json", "width"],
        ),
        (
            "huge size",
            json(|v| v["width"] = serde_json::json!(4000000000u32)),
            &["run.json", "width"],
        ),
        (
            "wrong type",
            json(|v| v["width"] = serde_json::json!("x")),
            &["run.json", "width"],
        ),
        (
            "reference outside",
            json(|v| v["reference_file"] = serde_json::json!("../../x.exr")),
            &["run.json", "reference_file"],
        ),
        (
            "bad variant name",
            json(|v| v["config"]["variants"][0]["name"] = serde_json::json!("../a")),
            &["run.json", "variants[0].name"],
        ),
        (
            "grid cells without grid",
            json(|v| {
                v["grid_cells"] = serde_json::json!([{"row": 0, "column": 0, "file": "x.exr"}])
            }),
            &["run.json", "grid_cells[0]"],
        ),
        (
            "truncated run.json",
            Box::new(|r: &Path| {
                let t = std::fs::read_to_string(r.join("run.json")).unwrap();
                std::fs::write(r.join("run.json"), &t[..t.len() / 2]).unwrap();
            }),
            &["run.json"],
        ),
        (
            "corrupt metrics",
            Box::new(|r: &Path| {
                let p = r.join("metrics.csv");
                let t = std::fs::read_to_string(&p).unwrap();
                std::fs::write(&p, t.replacen(",spp,1,", ",spp,x,", 1)).unwrap();
            }),
            &["metrics.csv", "line 2", "budget"],
        ),
        (
            "nan metrics",
            Box::new(|r: &Path| {
                let p = r.join("metrics.csv");
                let t = std::fs::read_to_string(&p).unwrap();
                let mut l: Vec<String> = t.lines().map(String::from).collect();
                let mut f: Vec<&str> = l[1].split(',').collect();
                f[11] = "NaN";
                l[1] = f.join(",");
                std::fs::write(&p, l.join("\n")).unwrap();
            }),
            &["metrics.csv", "line 2", "mse"],
        ),
        (
            "short metrics line",
            Box::new(|r: &Path| {
                let p = r.join("metrics.csv");
                let t = std::fs::read_to_string(&p).unwrap();
                std::fs::write(&p, format!("{t}a,b\n")).unwrap();
            }),
            &["metrics.csv", "fields"],
        ),
        (
            "wrong header",
            Box::new(|r: &Path| {
                let p = r.join("metrics.csv");
                let t = std::fs::read_to_string(&p).unwrap();
                std::fs::write(&p, t.replacen("variant", "variante", 1)).unwrap();
            }),
            &["metrics.csv", "header"],
        ),
        (
            "missing metrics",
            Box::new(|r: &Path| std::fs::remove_file(r.join("metrics.csv")).unwrap()),
            &["metrics.csv"],
        ),
        (
            "missing reference",
            Box::new(|r: &Path| std::fs::remove_file(r.join("reference.exr")).unwrap()),
            &["reference.exr"],
        ),
        (
            "truncated reference",
            Box::new(|r: &Path| {
                let b = std::fs::read(r.join("reference.exr")).unwrap();
                std::fs::write(r.join("reference.exr"), &b[..b.len() / 2]).unwrap();
            }),
            &["reference.exr"],
        ),
        (
            "nan reference",
            Box::new(|r: &Path| {
                let (w, h, mut px) =
                    stokes::film::output::read_exr(&r.join("reference.exr")).unwrap();
                px[3] = Vec3::splat(f32::NAN);
                stokes::film::output::write_exr(&r.join("reference.exr"), w, h, &px).unwrap();
            }),
            &["reference.exr", "not finite"],
        ),
        (
            "wrong-size snapshot",
            Box::new(|r: &Path| {
                let f = std::fs::read_dir(r.join("images"))
                    .unwrap()
                    .next()
                    .unwrap()
                    .unwrap()
                    .path();
                for e in std::fs::read_dir(r.join("images")).unwrap() {
                    stokes::film::output::write_exr(&e.unwrap().path(), 3, 3, &[Vec3::ONE; 9])
                        .unwrap();
                }
                assert!(f.exists());
            }),
            &["images", "3×3"],
        ),
        (
            "incomplete",
            Box::new(|r: &Path| std::fs::write(r.join("INCOMPLETE"), "experiment 't'\n").unwrap()),
            &["INCOMPLETE", "incomplete"],
        ),
    ];
    for (i, (what, mutate, names)) in cases.iter().enumerate() {
        let r = d.join(format!("case{i}"));
        copy_dir(&good, &r);
        mutate(&r);
        expect_input_error(what, run(&["figures", s(&r)]), names);
    }
    // `latest` is read back too.
    let exp = d.join("results/t");
    std::fs::write(exp.join("latest"), "../../../etc\n").unwrap();
    expect_input_error("latest", run(&["figures", s(&exp)]), &["latest"]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn metrics_csv_with_a_bom_keeps_every_row() {
    let (d, good) = good_run("hard-bom");
    let p = good.join("metrics.csv");
    let rows = stokes::experiment::record::read_metrics(&p).unwrap();
    let t = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, format!("\u{feff}{t}")).unwrap();
    assert_eq!(stokes::experiment::record::read_metrics(&p).unwrap(), rows);
    assert_eq!(run(&["figures", s(&good)]).0, 0);
    let _ = std::fs::remove_dir_all(&d);
}

/// Wait until `f` holds (polling every millisecond), at most `secs` seconds.
fn wait_for(secs: f64, mut f: impl FnMut() -> bool) -> bool {
    let t = std::time::Instant::now();
    while t.elapsed().as_secs_f64() < secs {
        if f() {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    false
}

fn temp_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(temp_files(&p));
        } else if p.to_string_lossy().ends_with(".tmp") {
            out.push(p);
        }
    }
    out
}

fn kill(child: &std::process::Child, sig: &str) {
    let st = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
}

#[test]
fn interrupted_write_leaves_no_temporary_file() {
    // A large image at 1 spp: the EXR takes long enough to write that the signal arrives while
    // its temporary file exists.
    let d = common::temp_dir("hard-sigint");
    let sc = scene(&d, 2048);
    let out = d.join("big.exr");
    let mut caught = false;
    for _ in 0..3 {
        let mut child = Command::new(bin())
            .args([
                "render",
                s(&sc),
                "--spp",
                "1",
                "--threads",
                "2",
                "-o",
                s(&out),
            ])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // The output's own temporary file (not the writability probe made before rendering).
        let writing = || {
            temp_files(&d).iter().any(|p| {
                p.file_name()
                    .unwrap()
                    .to_string_lossy()
                    .starts_with(".big.exr.")
            })
        };
        let seen = wait_for(60.0, || writing() || child.try_wait().unwrap().is_some());
        assert!(seen, "the render neither wrote nor finished");
        if !writing() {
            let _ = std::fs::remove_file(&out);
            continue; // finished before the temporary file was seen: try again
        }
        kill(&child, "-INT");
        let st = child.wait().unwrap();
        if st.code() == Some(0) {
            let _ = std::fs::remove_file(&out);
            continue; // the write won the race
        }
        assert_eq!(st.code(), Some(130), "{st:?}");
        assert!(temp_files(&d).is_empty(), "left {:?}", temp_files(&d));
        assert!(!out.exists(), "a partial output was moved into place");
        caught = true;
        break;
    }
    assert!(caught, "never interrupted a write");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn interrupted_experiment_is_marked_incomplete() {
    let d = common::temp_dir("hard-sigterm");
    let cfg = d.join("config.json");
    // A long reference render (not cached) keeps the run busy until the signal.
    std::fs::write(&cfg, slow_config("")).unwrap();
    let results = d.join("results");
    let mut child = Command::new(bin())
        .args(["experiment", s(&cfg), "--out", s(&results)])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let runs = results.join("t/runs");
    let marker = || -> Option<PathBuf> {
        let run = std::fs::read_dir(&runs).ok()?.next()?.ok()?.path();
        run.join("INCOMPLETE").is_file().then_some(run)
    };
    assert!(
        wait_for(30.0, || marker().is_some()),
        "no INCOMPLETE marker"
    );
    let run_dir = marker().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(200));
    kill(&child, "-TERM");
    let st = child.wait().unwrap();
    assert_eq!(st.code(), Some(143), "{st:?}");
    let text = std::fs::read_to_string(run_dir.join("INCOMPLETE")).unwrap();
    assert!(text.contains("experiment 't'"), "{text}");
    assert!(
        !results.join("t/latest").exists(),
        "latest moved to an incomplete run"
    );
    assert!(
        temp_files(&results).is_empty(),
        "left {:?}",
        temp_files(&results)
    );
    expect_input_error(
        "figures on an incomplete run",
        run(&["figures", s(&run_dir)]),
        &["INCOMPLETE", "incomplete"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn config_with_a_bom_runs_and_sweep_record_is_checked() {
    let json = config(r#", "sweep": {"path": "camera.fov", "values": [40, 45]}"#)
        .replace(r#""name": "t""#, r#""name": "sw""#);
    let (code, err, d) = experiment("hard-sweep", &format!("\u{feff}{json}"), true);
    assert_eq!(code, 0, "a config with a BOM: {err}");
    let runs = d.join("results/sw/runs");
    let run_dir = std::fs::read_dir(&runs)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    assert_eq!(run(&["figures", s(&run_dir)]).0, 0);
    let rec = run_dir.join("sweep.json");
    let good = std::fs::read_to_string(&rec).unwrap();
    edit_json(&rec, |v| v["points"][0]["dir"] = serde_json::json!("/etc"));
    expect_input_error(
        "sweep dir",
        run(&["figures", s(&run_dir)]),
        &["sweep.json", "points[0].dir"],
    );
    std::fs::write(&rec, &good[..good.len() / 2]).unwrap();
    expect_input_error(
        "truncated sweep.json",
        run(&["figures", s(&run_dir)]),
        &["sweep.json"],
    );
    std::fs::write(&rec, &good).unwrap();
    std::fs::remove_file(run_dir.join("sweep/1/metrics.csv")).unwrap();
    expect_input_error(
        "a value's metrics",
        run(&["figures", s(&run_dir)]),
        &["sweep/1/metrics.csv"],
    );
    // A sweep value's folder of an incomplete run is refused too.
    std::fs::write(run_dir.join("INCOMPLETE"), "x").unwrap();
    expect_input_error(
        "incomplete sweep",
        run(&["figures", s(&run_dir.join("sweep/0"))]),
        &["INCOMPLETE"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Region masks that would not fit in memory (here 65 × 65 visible quads at 256 × 256 pixels:
/// 4225 masks of 65,536 bytes, over 256 MB) are refused before the reference renders, naming
/// `regions.by`.
#[test]
fn too_many_region_masks_are_found_before_anything_renders() {
    let d = common::temp_dir("hard-region-masks");
    let n = 65;
    let mut shapes: Vec<String> = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x0, y0) = (
                -1.0 + 2.0 * i as f64 / n as f64,
                -1.0 + 2.0 * j as f64 / n as f64,
            );
            let (x1, y1) = (x0 + 2.0 / n as f64, y0 + 2.0 / n as f64);
            shapes.push(format!(
                r#"{{"type": "quad", "material": "white", "corners": [[{x0}, {y0}, 0], [{x1}, {y0}, 0], [{x1}, {y1}, 0], [{x0}, {y1}, 0]]}}"#
            ));
        }
    }
    shapes.push(
        r#"{"type": "quad", "emission": {"spectrum": 1}, "corners": [[-1, -1, 3.5], [-1, 1, 3.5], [1, 1, 3.5], [1, -1, 3.5]]}"#
            .into(),
    );
    let scene = d.join("tiles.json");
    std::fs::write(
        &scene,
        format!(
            r#"{{"camera": {{"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 256, "height": 256}},
                "materials": {{"white": {{"type": "lambert", "reflectance": 0.5}}}},
                "shapes": [{}]}}"#,
            shapes.join(",\n")
        ),
    )
    .unwrap();
    let cfg = d.join("config.json");
    std::fs::write(
        &cfg,
        r#"{ "name": "t", "scene": "tiles.json",
             "reference": { "integrator": "pt-mono", "spp": 1000000 },
             "variants": [ { "name": "a", "integrator": "pt-mono" } ],
             "budget": { "spp": [1] }, "regions": { "by": "shape" } }"#,
    )
    .unwrap();
    let t = std::time::Instant::now();
    let r = run(&["experiment", s(&cfg), "--out", s(&d.join("results"))]);
    expect_input_error("masks", r, &["config.json", "regions.by", "4225 regions"]);
    assert!(t.elapsed().as_secs() < 10, "{:?}", t.elapsed());
    assert!(!d.join("results/t/runs").exists());
    assert!(!d.join("results/references").exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// Names that become file names (the experiment's, a variant's, a region's) are at most 100
/// bytes long; a longer one is refused before anything renders, naming its field, where it used
/// to fail with "File name too long" (exit 1) after the reference and the first variant had
/// rendered. A name of exactly 100 bytes runs.
#[test]
fn names_too_long_for_a_file_name_are_found_before_anything_renders() {
    let d = common::temp_dir("hard-long-names");
    let sc = scene(&d, 8);
    let long = "x".repeat(300);
    let config = |name: &str, variant: &str, extra: &str| {
        format!(
            r#"{{ "name": "{name}", "scene": "{}",
                "reference": {{ "integrator": "pt-mono", "spp": 16 }},
                "variants": [ {{ "name": "a", "integrator": "pt-mono" }},
                              {{ "name": "{variant}", "integrator": "pt-hero" }} ],
                "budget": {{ "spp": [1] }} {extra} }}"#,
            s(&sc)
        )
    };
    for (tag, json, field) in [
        ("long-variant", config("t", &long, ""), "variants[1].name"),
        ("long-experiment", config(&long, "b", ""), "`name`"),
    ] {
        let (code, err, dir) = experiment(tag, &json, true);
        expect_input_error(
            tag,
            (code, err.clone()),
            &["config.json", field, "100 bytes"],
        );
        assert!(!dir.join("results").exists(), "{tag}: {err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
    // A region's name comes from the scene: a shape named with 300 bytes.
    let text = std::fs::read_to_string(&sc)
        .unwrap()
        .replace(r#""name": "ball""#, &format!(r#""name": "{long}""#));
    std::fs::write(&sc, text).unwrap();
    let json = config("t", "b", r#", "regions": { "by": "shape" }"#);
    let (code, err, dir) = experiment("long-region", &json, true);
    expect_input_error(
        "region",
        (code, err.clone()),
        &["config.json", "regions.by", "300 bytes"],
    );
    assert!(!dir.join("results").exists(), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
    // At the limit, everything runs and is written.
    let v100 = "v".repeat(100);
    let (code, err, dir) = experiment("name-100", &config("t", &v100, ""), true);
    assert_eq!(code, 0, "{err}");
    let latest = std::fs::read_to_string(dir.join("results/t/latest")).unwrap();
    let images = dir.join("results/t").join(latest.trim()).join("images");
    let written = std::fs::read_dir(&images)
        .unwrap()
        .filter(|f| {
            f.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with(&v100)
        })
        .count();
    assert!(written > 0, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&d);
}
