//! `stokes gmm`: fitting is deterministic, and bad input (BFC files with truncated, NaN,
//! inconsistent or absurd headers, malformed model files, bad options) gets exit code 2 and a
//! message naming the file and the field; nothing is written for a failed file.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

const GOLFYE: &str = include_str!("../data/bispectral/GOLFYE.BFC");

fn tmpdir(name: &str) -> PathBuf {
    common::temp_dir(&format!("gmm-cli-{name}"))
}

fn stokes(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn fits_are_deterministic_and_written_atomically() {
    let d = tmpdir("determinism");
    let bfc = d.join("GOLFYE.BFC");
    std::fs::write(&bfc, GOLFYE).unwrap();
    let (a, b) = (d.join("a.json"), d.join("b.json"));
    for out in [&a, &b] {
        let (code, stdout, err) =
            stokes(&["gmm", "fit", s(&bfc), "--components", "4", "-o", s(out)]);
        assert_eq!(code, 0, "{err}");
        assert!(stdout.contains("4 components"), "{stdout}");
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // No temporary files are left next to the outputs.
    let names: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
    // The dense matrix of the model reads back as a BFC file.
    let dense = d.join("dense.BFC");
    let (code, _, err) = stokes(&["gmm", "dense", s(&a), "--step", "5", "-o", s(&dense)]);
    assert_eq!(code, 0, "{err}");
    let m =
        stokes::material::reradiation::BfcMatrix::parse(&std::fs::read_to_string(&dense).unwrap())
            .unwrap();
    assert_eq!((m.n_em, m.n_ex, m.step), (82, 98, 5.0));
    std::fs::remove_dir_all(&d).unwrap();
}

/// `--restarts 1` is the single start from `--seed` (its model file has no `restarts` field, as
/// the files written before restarts existed), the default keeps a start at least as likely;
/// `--components auto` records every K's BIC and `--scale error` its scale method.
#[test]
fn restarts_automatic_components_and_the_error_scale() {
    let d = tmpdir("restarts");
    let bfc = d.join("GOLFYE.BFC");
    std::fs::write(&bfc, GOLFYE).unwrap();
    let fit = |args: &[&str], name: &str| -> serde_json::Value {
        let out = d.join(name);
        let mut a = vec!["gmm", "fit", s(&bfc), "-o", s(&out)];
        a.extend(args);
        let (code, _, err) = stokes(&a);
        assert_eq!(code, 0, "{args:?}: {err}");
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap()
    };
    let one = fit(&["--components", "2", "--restarts", "1"], "one.json");
    let many = fit(&["--components", "2"], "many.json");
    assert!(one["fit"]["options"].get("restarts").is_none(), "{one}");
    assert!(one["fit"].get("restart").is_none());
    let default = stokes::material::mixture::fit::DEFAULT_RESTARTS;
    assert_eq!(many["fit"]["options"]["restarts"], default);
    let ll = |v: &serde_json::Value| v["fit"]["log_likelihood"].as_f64().unwrap();
    assert!(ll(&many) >= ll(&one), "{} < {}", ll(&many), ll(&one));
    let auto = fit(&["--components", "auto:5"], "auto.json");
    assert_eq!(auto["fit"]["options"]["auto_components"], true);
    assert_eq!(auto["fit"]["options"]["components"], 5);
    let bic = auto["fit"]["bic"].as_array().unwrap();
    assert_eq!(bic.len(), 5);
    let k = auto["components"].as_array().unwrap().len();
    let min = bic
        .iter()
        .map(|b| b.as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert_eq!(bic[k - 1].as_f64().unwrap(), min, "{bic:?}, K = {k}");
    let err = fit(&["--components", "2", "--scale", "error"], "error.json");
    assert_eq!(err["fit"]["options"]["scale_method"], "error");
    assert_ne!(err["scale"], many["scale"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_bfc_files_name_the_file_and_field() {
    let header = "380\t780\t10\t49\t300\t10";
    let truncated: String = GOLFYE.lines().take(30).collect::<Vec<_>>().join("\n");
    let cases = [
        (
            "nan.BFC",
            GOLFYE.replacen(header, "nan\t780\t10\t49\t300\t10", 1),
            "em_lo",
        ),
        (
            "inf.BFC",
            GOLFYE.replacen(header, "380\t780\t10\tinf\t300\t10", 1),
            "n_ex",
        ),
        (
            "absurd.BFC",
            GOLFYE.replacen(header, "380\t1e30\t10\t49\t300\t10", 1),
            "em_hi",
        ),
        (
            "huge.BFC",
            GOLFYE.replacen(header, "380\t780\t10\t1e12\t300\t10", 1),
            "n_ex",
        ),
        (
            "inconsistent.BFC",
            GOLFYE.replacen(header, "380\t790\t10\t49\t300\t10", 1),
            "rows",
        ),
        ("truncated.BFC", truncated, "rows"),
        ("text.BFC", GOLFYE.replacen("0.313414", "x", 1), "line"),
    ];
    let d = tmpdir("bad-bfc");
    for (name, text, field) in cases {
        let f = d.join(name);
        std::fs::write(&f, text).unwrap();
        let out = d.join(format!("{name}.json"));
        let (code, _, err) = stokes(&["gmm", "fit", s(&f), "-o", s(&out)]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(err.contains(name) && err.contains(field), "{name}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists(), "{name}: an output was written");
    }
    // A folder with one bad file: the good one is still fitted, the bad one named.
    let folder = d.join("folder");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::write(folder.join("GOOD.BFC"), GOLFYE).unwrap();
    std::fs::write(folder.join("BAD.BFC"), "BFC-450 Matrix File\n1 2 3\n").unwrap();
    let out = d.join("out");
    let (code, _, err) = stokes(&["gmm", "fit", s(&folder), "--components", "2", "-o", s(&out)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("BAD.BFC"), "{err}");
    assert!(out.join("GOOD.json").exists());
    assert!(!out.join("BAD.json").exists());
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_options_and_model_files_are_input_errors() {
    let d = tmpdir("bad-options");
    let bfc = d.join("GOLFYE.BFC");
    std::fs::write(&bfc, GOLFYE).unwrap();
    let out = d.join("m.json");
    for (args, want) in [
        (vec!["--components", "0"], "components"),
        (vec!["--components", "33"], "components"),
        (vec!["--tolerance=-1"], "tolerance"),
        (vec!["--max-iterations", "0"], "max_iterations"),
        (vec!["--restarts", "0"], "--restarts"),
        (vec!["--restarts", "1001"], "--restarts"),
        (vec!["--components", "auto:0"], "--components"),
        (vec!["--components", "auto:33"], "--components"),
        (vec!["--components", "automatic"], "--components"),
        (vec!["--scale", "l1"], "--scale"),
    ] {
        let mut a = vec!["gmm", "fit", s(&bfc), "-o", s(&out)];
        a.extend(args.iter());
        let (code, _, err) = stokes(&a);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    let (code, _, err) = stokes(&["gmm", "fit", s(&d.join("missing.BFC")), "-o", s(&out)]);
    assert_eq!(code, 2);
    assert!(err.contains("missing.BFC"), "{err}");
    let (code, _, err) = stokes(&["gmm", "eval", s(&d.join("nowhere")), "-o", s(&d)]);
    assert_eq!(code, 2);
    assert!(err.contains("nowhere"), "{err}");
    let (code, _, err) = stokes(&["gmm", "eval", s(&d), "--restarts", "0", "-o", s(&d)]);
    assert_eq!(code, 2);
    assert!(err.contains("--restarts"), "{err}");
    for (args, want) in [
        (vec!["--max-components", "0"], "--max-components"),
        (vec!["--components", "2,0"], "--components"),
        (vec!["--seeds", "0"], "--seeds"),
        (vec!["--restarts", "0"], "--restarts"),
    ] {
        let mut a = vec!["gmm", "robustness", s(&d), "-o", s(&d)];
        a.extend(args.iter());
        let (code, _, err) = stokes(&a);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    let (code, _, err) = stokes(&["gmm", "robustness", s(&d.join("nowhere")), "-o", s(&d)]);
    assert_eq!(code, 2);
    assert!(err.contains("nowhere"), "{err}");
    // Malformed model files, through `gmm dense` and through a scene.
    let (code, _, err) = stokes(&["gmm", "fit", s(&bfc), "--components", "2", "-o", s(&out)]);
    assert_eq!(code, 0, "{err}");
    let good = std::fs::read_to_string(&out).unwrap();
    for (name, text, field) in [
        (
            "format.json",
            good.replacen("stokes-gmm-1", "other", 1),
            "format",
        ),
        (
            "nan.json",
            good.replacen("\"scale\": ", "\"scale\": -", 1),
            "scale",
        ),
        (
            "grid.json",
            good.replacen("\"n_em\": 41", "\"n_em\": 100000000000", 1),
            "grid.n_em",
        ),
        (
            "short.json",
            good[..good.len() / 2].to_string(),
            "short.json",
        ),
    ] {
        let f = d.join(name);
        std::fs::write(&f, text).unwrap();
        let (code, _, err) = stokes(&["gmm", "dense", s(&f), "-o", s(&d.join("x.BFC"))]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(err.contains(name) && err.contains(field), "{name}: {err}");
        let scene = d.join("scene.json");
        std::fs::write(
            &scene,
            format!(
                r#"{{"camera": {{"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4}},
                 "materials": {{"m": {{"type": "reradiation-gmm", "file": "{name}"}}}},
                 "shapes": [{{"type": "sphere", "material": "m", "center": [0, 0, 0], "radius": 1,
                              "emission": {{"spectrum": 1}}}}]}}"#
            ),
        )
        .unwrap();
        let (code, _, err) = stokes(&["inspect", s(&scene)]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(
            err.contains("materials.m.file") && err.contains(field),
            "{name}: {err}"
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A `bfc` material is fitted once and cached by the file's content and the settings: a second
/// load reuses the entry, a damaged entry is fitted again (with a warning) and replaced, and
/// other settings or another file get their own entries.
#[test]
fn fits_at_load_are_cached_by_content_and_settings() {
    let d = tmpdir("cache");
    let cache = d.join("cache");
    std::fs::write(d.join("GOLFYE.BFC"), GOLFYE).unwrap();
    let scene_with = |components: usize, extra: &str| {
        let p = d.join(format!("scene-{components}{}.json", extra.len()));
        std::fs::write(
            &p,
            format!(
                r#"{{"camera": {{"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4}},
                 "materials": {{"m": {{"type": "reradiation-gmm", "bfc": "GOLFYE.BFC", "components": {components}{extra}}}}},
                 "shapes": [{{"type": "sphere", "material": "m", "center": [0, 0, 0], "radius": 1,
                              "emission": {{"spectrum": 1}}}}]}}"#
            ),
        )
        .unwrap();
        p
    };
    let scene = |components: usize| scene_with(components, "");
    let inspect = |p: &Path| {
        let out = Command::new(env!("CARGO_BIN_EXE_stokes"))
            .args(["inspect", s(p)])
            .env("STOKES_CACHE_DIR", &cache)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let entries = || -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(cache.join("gmm"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        v
    };
    let three = scene(3);
    let (out, _) = inspect(&three);
    assert!(out.contains("3 Gaussians"), "{out}");
    let e = entries();
    assert_eq!(e.len(), 1);
    let text = std::fs::read_to_string(&e[0]).unwrap();
    let model = stokes::material::mixture::GmmFile::parse(&text).unwrap();
    assert_eq!(
        model.source.sha256,
        stokes::io::hash::sha256_hex(GOLFYE.as_bytes())
    );
    // Reused as it is.
    let (_, err) = inspect(&three);
    assert!(!err.contains("cached fit"), "{err}");
    assert_eq!(std::fs::read_to_string(&e[0]).unwrap(), text);
    // Damaged: fitted again, with a warning, and replaced by the same fit.
    std::fs::write(&e[0], "{ not json").unwrap();
    let (_, err) = inspect(&three);
    assert!(err.contains("stale or damaged"), "{err}");
    assert_eq!(std::fs::read_to_string(&e[0]).unwrap(), text);
    // Other settings, and the same settings on another file, are other entries: the number of
    // starts is part of the key (and of the model's options).
    inspect(&scene(2));
    assert_eq!(entries().len(), 2);
    inspect(&scene_with(3, r#", "restarts": 1"#));
    let e = entries();
    assert_eq!(e.len(), 3);
    let restarts: Vec<usize> = e
        .iter()
        .map(|p| {
            let f = stokes::material::mixture::GmmFile::parse(&std::fs::read_to_string(p).unwrap())
                .unwrap();
            f.fit.options.restarts
        })
        .collect();
    let default = stokes::material::mixture::fit::DEFAULT_RESTARTS;
    assert_eq!(
        restarts.iter().filter(|&&r| r == 1).count(),
        1,
        "{restarts:?}"
    );
    assert_eq!(restarts.iter().filter(|&&r| r == default).count(), 2);
    std::fs::write(
        d.join("GOLFYE.BFC"),
        GOLFYE.replacen("0.313414", "0.3134", 1),
    )
    .unwrap();
    inspect(&three);
    assert_eq!(entries().len(), 4);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every number of a model file is range-checked on load, naming the field: a huge
/// reflectance, scale, weight, mean or a collapsed covariance used to load and overflow at
/// render time; a bad `grid.step` used to be blamed on `--step`.
#[test]
fn model_numbers_out_of_range_name_the_file_and_field() {
    let d = tmpdir("model-range");
    let bfc = d.join("GOLFYE.BFC");
    std::fs::write(&bfc, GOLFYE).unwrap();
    let model = d.join("m.json");
    let (code, _, err) = stokes(&["gmm", "fit", s(&bfc), "--components", "2", "-o", s(&model)]);
    assert_eq!(code, 0, "{err}");
    let good: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "refl",
            Box::new(|v| v["reflectance"][9] = 3.4e38.into()),
            "reflectance[9]",
        ),
        ("scale", Box::new(|v| v["scale"] = 1e300.into()), "scale"),
        (
            "albedo",
            Box::new(|v| v["scale"] = 9e5.into()),
            "reradiation",
        ),
        (
            "weight",
            Box::new(|v| v["components"][0]["weight"] = 2.0.into()),
            "components[0].weight",
        ),
        (
            "mean",
            Box::new(|v| v["components"][1]["mean"][0] = 1e9.into()),
            "components[1].mean",
        ),
        (
            "cov",
            Box::new(|v| v["components"][0]["cov"] = serde_json::json!([[1e-9, 0.0], [0.0, 1e-9]])),
            "components[0].cov",
        ),
        (
            "step",
            Box::new(|v| v["grid"]["step"] = 1e-7.into()),
            "grid.step",
        ),
    ];
    for (tag, edit, field) in cases {
        let mut v = good.clone();
        edit(&mut v);
        let f = d.join(format!("{tag}.json"));
        std::fs::write(&f, v.to_string()).unwrap();
        let out = d.join(format!("{tag}.BFC"));
        let (code, _, err) = stokes(&["gmm", "dense", s(&f), "--step", "10", "-o", s(&out)]);
        assert_eq!(code, 2, "{tag}: {err}");
        assert!(
            err.contains(&format!("{tag}.json")) && err.contains(field),
            "{tag}: {err}"
        );
        assert!(!err.contains("--step"), "{tag}: {err}");
        assert!(!out.exists(), "{tag}: an output was written");
    }
    // A BFC file with a huge entry is refused naming its line, row and column.
    let row = GOLFYE.lines().find(|l| l.starts_with("750\t")).unwrap();
    let mut cells: Vec<&str> = row.split('\t').collect();
    cells[1 + 34] = "3.4e38";
    let huge = d.join("HUGE.BFC");
    std::fs::write(&huge, GOLFYE.replacen(row, &cells.join("\t"), 1)).unwrap();
    let out = d.join("huge.json");
    let (code, _, err) = stokes(&["gmm", "fit", s(&huge), "-o", s(&out)]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("HUGE.BFC") && err.contains("line 50") && err.contains("row 750 nm"),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `gmm fit -o` and `gmm dense -o` are checked before any work as `render -o` is: the name's
/// extension, a folder that exists and takes files, and no output over an input.
#[test]
fn gmm_outputs_are_checked_before_any_work() {
    let d = tmpdir("outputs");
    let bfc = d.join("GOLFYE.BFC");
    std::fs::write(&bfc, GOLFYE).unwrap();
    let model = d.join("m.json");
    let (code, _, err) = stokes(&["gmm", "fit", s(&bfc), "--components", "2", "-o", s(&model)]);
    assert_eq!(code, 0, "{err}");
    let missing = d.join("missing");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "dense".into(),
                s(&model).into(),
                "-o".into(),
                s(&d.join("x.png")).into(),
            ],
            ".bfc",
        ),
        (
            vec![
                "dense".into(),
                s(&model).into(),
                "-o".into(),
                s(&missing.join("x.BFC")).into(),
            ],
            "does not exist",
        ),
        (
            vec![
                "fit".into(),
                s(&bfc).into(),
                "-o".into(),
                s(&d.join("x.txt")).into(),
            ],
            ".json",
        ),
        (
            vec![
                "fit".into(),
                s(&bfc).into(),
                "-o".into(),
                s(&missing.join("m.json")).into(),
            ],
            "does not exist",
        ),
        // A folder of inputs into a file.
        (
            vec!["fit".into(), s(&d).into(), "-o".into(), s(&model).into()],
            "is a file",
        ),
    ];
    for (args, want) in cases {
        let mut a = vec!["gmm"];
        a.extend(args.iter().map(String::as_str));
        let (code, _, err) = stokes(&a);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            err.contains("-o/--output") && err.contains(want),
            "{args:?}: {err}"
        );
        assert!(!missing.exists(), "{args:?}: a folder was created");
    }
    // An output over its own input.
    let odd = d.join("model.bfc");
    std::fs::copy(&model, &odd).unwrap();
    let (code, _, err) = stokes(&["gmm", "dense", s(&odd), "-o", s(&odd)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is the input file"), "{err}");
    let odd = d.join("golfye.json");
    std::fs::write(&odd, GOLFYE).unwrap();
    let (code, _, err) = stokes(&["gmm", "fit", s(&odd), "-o", s(&odd)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is the input file"), "{err}");
    assert_eq!(std::fs::read_to_string(&odd).unwrap(), GOLFYE);
    // Two inputs of one folder that would write the same model.
    let folder = d.join("two");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::write(folder.join("X.BFC"), GOLFYE).unwrap();
    std::fs::write(folder.join("X.bfc"), GOLFYE).unwrap();
    let (code, _, err) = stokes(&["gmm", "fit", s(&folder), "-o", s(&d.join("out"))]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("both be fitted into"), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// `gmm figures`: a material that is not in the folder, an excitation wavelength outside the
/// matrix's range, and no material to show are input errors naming the flag, before any fit.
#[test]
fn gmm_figures_names_bad_flags() {
    let d = tmpdir("figures");
    std::fs::write(d.join("GOLFYE.BFC"), GOLFYE).unwrap();
    let out = d.join("figs");
    for (extra, want) in [
        (vec!["--material", "NOPE"], "--material 'NOPE'"),
        (
            vec!["--material", "GOLFYE", "--excitation", "200"],
            "--excitation 200",
        ),
        (vec!["--material", "GOLFYE", "--worst", "0"], "--worst"),
    ] {
        let mut a = vec!["gmm", "figures", s(&d), "-o", s(&out)];
        a.extend(extra.iter().copied());
        let (code, _, err) = stokes(&a);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(want), "{extra:?}: {err}");
        assert!(!out.exists(), "{extra:?}: written");
    }
    std::fs::remove_dir_all(&d).unwrap();
}
