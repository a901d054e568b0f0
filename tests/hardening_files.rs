//! Files that are not what they seem (docs/hardening.md, second round), through the binary:
//! inputs that are FIFOs, devices or folders are refused at once (no hang, no unbounded read);
//! outputs onto a device, a FIFO, a folder or a name too long for the file system are refused
//! before the first sample, and nothing that is not a regular file is ever replaced; a path
//! outside Latin-1 round-trips through the EXR header; trailing data after a JSON document,
//! mislabelled BFC columns and a run without its images are errors; messages name the field
//! that is wrong and never pass control bytes to the terminal; the illuminants of `gmm eval`
//! are found wherever stokes runs.
#![cfg(unix)]

mod common;

use common::{bin, repo, s};
use serde_json::Value;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn run_in(cwd: &Path, args: &[&str]) -> (i32, String) {
    common::run_limited(cwd, args)
}

/// `stokes gmm fit` of GOLFYE with two Gaussians into `model`, which must succeed.
fn fit_golfye(d: &Path, model: &Path) {
    let golfye = repo().join("data/bispectral/GOLFYE.BFC");
    let r = run_in(
        d,
        &[
            "gmm",
            "fit",
            s(&golfye),
            "--components",
            "2",
            "-o",
            s(model),
        ],
    );
    assert_eq!(r.0, 0, "{}", r.1);
}

/// Exit code 2 within the limits, no panic, and every one of `names` in the message.
fn refused(what: &str, r: (i32, String), names: &[&str]) {
    common::expect_input_error(what, r, names);
}

fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success());
}

/// A character device named `p` (the null device), where this process may make one (root).
fn mknod_null(p: &Path) -> bool {
    Command::new("mknod")
        .args([s(p), "c", "1", "3"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|st| st.success())
}

fn is_char_device(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_char_device())
}

/// `scenes/NAME` with its relative paths made absolute and a `size`×`size` camera, as JSON.
fn scene_json(name: &str, size: u32) -> Value {
    let p = repo().join("scenes").join(name);
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    v["camera"]["width"] = size.into();
    v["camera"]["height"] = size.into();
    absolute(&mut v, p.parent().unwrap());
    v
}

/// Every string that names an existing file relative to `dir`, made absolute.
fn absolute(v: &mut Value, dir: &Path) {
    match v {
        Value::String(t) if !t.is_empty() && dir.join(&*t).is_file() => {
            *t = s(&dir.join(&*t)).to_string()
        }
        Value::Array(a) => a.iter_mut().for_each(|x| absolute(x, dir)),
        Value::Object(m) => m.values_mut().for_each(|x| absolute(x, dir)),
        _ => {}
    }
}

fn write_json(p: &Path, v: &Value) -> PathBuf {
    std::fs::write(p, serde_json::to_string_pretty(v).unwrap()).unwrap();
    p.to_path_buf()
}

/// The first string value under `v` that ends in `ext`, replaced by `with`.
fn replace_file(v: &mut Value, ext: &str, with: &str) -> bool {
    match v {
        Value::String(t) if t.to_lowercase().ends_with(ext) => {
            *t = with.to_string();
            true
        }
        Value::Array(a) => a.iter_mut().any(|x| replace_file(x, ext, with)),
        Value::Object(m) => m.values_mut().any(|x| replace_file(x, ext, with)),
        _ => false,
    }
}

#[test]
fn inputs_that_are_not_regular_files_are_refused_at_once() {
    let d = common::temp_dir("hf-inputs");
    let fifo = d.join("fifo");
    mkfifo(&fifo);
    let out = d.join("o.exr");
    let render = |scene: &Path| run_in(&d, &["render", s(scene), "--spp", "1", "-o", s(&out)]);
    for special in [fifo.as_path(), Path::new("/dev/zero"), d.as_path()] {
        let t = Instant::now();
        // The scene itself.
        refused(
            "scene",
            render(special),
            &[s(special), "not a regular file"],
        );
        // A file a scene names: a spectrum CSV, a BFC matrix, a `.vol` grid, an OBJ mesh, a
        // Gaussian-mixture model.
        for (scene, ext) in [
            ("gmm-swatches.json", ".bfc"),
            ("media-smoke.json", ".vol"),
            ("cornell-box.json", ".obj"),
            ("gmm-swatches-2.json", ".json"),
        ] {
            let mut v = scene_json(scene, 8);
            if ext == ".obj" {
                let material = v["shapes"][0]["material"].clone();
                v["shapes"].as_array_mut().unwrap().push(serde_json::json!({
                    "type": "obj", "name": "mesh", "file": s(special), "material": material
                }));
            } else if ext == ".json" {
                // a fitted model in place of the matrix to fit
                let m = v["materials"].as_object_mut().unwrap();
                let k = m
                    .keys()
                    .find(|k| m[*k]["type"] == "reradiation-gmm")
                    .cloned();
                m[&k.unwrap()] = serde_json::json!({"type": "reradiation-gmm", "file": s(special)});
            } else {
                assert!(
                    replace_file(&mut v, ext, s(special)),
                    "{scene} names no {ext}"
                );
            }
            let p = write_json(&d.join(format!("with{ext}.json")), &v);
            refused(scene, render(&p), &[s(special)]);
        }
        let mut v = scene_json("cornell-box.json", 8);
        v["spectra"]["csv"] = serde_json::json!({"type": "tabulated", "file": s(special)});
        let p = write_json(&d.join("csv.json"), &v);
        refused("csv", render(&p), &[s(special), "spectra.csv.file"]);
        // Files given to commands.
        refused(
            "gmm fit",
            run_in(&d, &["gmm", "fit", s(special), "-o", s(&d.join("m.json"))]),
            &[s(special)],
        );
        refused(
            "gmm dense",
            run_in(&d, &["gmm", "dense", s(special), "-o", s(&d.join("m.bfc"))]),
            &[s(special)],
        );
        refused(
            "config",
            run_in(&d, &["experiment", s(special), "--quick", "--out", s(&d)]),
            &[s(special)],
        );
        refused(
            "inspect",
            run_in(&d, &["inspect", s(special)]),
            &[s(special)],
        );
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "{}: {:?}",
            special.display(),
            t.elapsed()
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn outputs_are_checked_before_the_first_sample_and_never_replace_special_files() {
    let d = common::temp_dir("hf-outputs");
    let scene = write_json(&d.join("box.json"), &scene_json("cornell-box.json", 8));
    let render = |extra: &[&str]| {
        let mut a = vec!["render", s(&scene), "--spp", "1"];
        a.extend_from_slice(extra);
        run_in(&d, &a)
    };
    let ok = d.join("ok.exr");
    // A device: /dev/full itself, and one of our own named like an output.
    refused(
        "--stats /dev/full",
        render(&["-o", s(&ok), "--stats", "/dev/full"]),
        &["/dev/full", "character device"],
    );
    assert!(is_char_device(Path::new("/dev/full")), "/dev/full replaced");
    let dev = d.join("x.exr");
    if mknod_null(&dev) {
        refused(
            "-o device",
            render(&["-o", s(&dev)]),
            &["x.exr", "character device"],
        );
        let png = d.join("x.png");
        assert!(mknod_null(&png));
        refused(
            "--png device",
            render(&["-o", s(&ok), "--png", s(&png)]),
            &["x.png", "character device"],
        );
        assert!(
            is_char_device(&dev) && is_char_device(&png),
            "a device was replaced"
        );
    }
    // A link to a device, a FIFO, a folder.
    let link = d.join("link.exr");
    std::os::unix::fs::symlink("/dev/null", &link).unwrap();
    refused(
        "-o link to a device",
        render(&["-o", s(&link)]),
        &["/dev/null"],
    );
    let fifo = d.join("f.json");
    mkfifo(&fifo);
    refused(
        "--stats FIFO",
        render(&["-o", s(&ok), "--stats", s(&fifo)]),
        &["f.json", "FIFO"],
    );
    std::fs::create_dir(d.join("dir.exr")).unwrap();
    refused(
        "-o folder",
        render(&["-o", s(&d.join("dir.exr"))]),
        &["dir.exr", "folder"],
    );
    // A strategy image's name taken by a FIFO.
    let strat = d.join("strategies");
    std::fs::create_dir(&strat).unwrap();
    mkfifo(&strat.join("s1_t1.exr"));
    refused(
        "--strategy-images",
        render(&[
            "-o",
            s(&ok),
            "--integrator",
            "bdpt-forward",
            "--strategy-images",
            s(&strat),
        ]),
        &["s1_t1.exr", "FIFO"],
    );
    // A name too long for the file system fails at once, not after the render.
    let long = d.join(format!("{}.exr", "n".repeat(5000)));
    let t = Instant::now();
    let r = run_in(
        &d,
        &["render", s(&scene), "--spp", "16777216", "-o", s(&long)],
    );
    refused("long -o", r, &["too long"]);
    assert!(t.elapsed() < Duration::from_secs(10), "{:?}", t.elapsed());
    // gmm dense and merge check theirs the same way.
    let model = d.join("m.json");
    fit_golfye(&d, &model);
    if is_char_device(&dev) {
        let bfc = d.join("x.bfc");
        assert!(mknod_null(&bfc));
        refused(
            "gmm dense onto a device",
            run_in(&d, &["gmm", "dense", s(&model), "-o", s(&bfc)]),
            &["x.bfc", "character device"],
        );
        assert!(is_char_device(&bfc));
    }
    refused(
        "merge --png FIFO",
        run_in(
            &d,
            &[
                "merge",
                s(&ok),
                "-o",
                s(&d.join("m.exr")),
                "--png",
                s(&fifo),
            ],
        ),
        &["f.json"],
    );
    let left: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_path_outside_latin1_round_trips_through_render_shards_and_merge() {
    let d = common::temp_dir("hf-unicode");
    let dir = d.join("场景");
    std::fs::create_dir(&dir).unwrap();
    let scene = write_json(&dir.join("☃.json"), &scene_json("cornell-box.json", 8));
    let (a, b) = (dir.join("ä.exr"), dir.join("b.exr"));
    for (range, out) in [("0..2", &a), ("2..4", &b)] {
        let r = run_in(&d, &["render", s(&scene), "--samples", range, "-o", s(out)]);
        assert_eq!(r.0, 0, "{}", r.1);
    }
    let merged = dir.join("m.exr");
    let r = run_in(&d, &["merge", s(&a), s(&b), "-o", s(&merged)]);
    assert_eq!(r.0, 0, "{}", r.1);
    let shard = stokes::film::shard::read_shard(&merged).unwrap();
    assert_eq!(shard.info.scene, s(&scene), "the scene path round-trips");
    assert_eq!((shard.info.from, shard.info.to), (0, 4));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn trailing_data_labels_and_top_level_types_are_checked() {
    let d = common::temp_dir("hf-silent");
    let out = d.join("o.exr");
    let text = serde_json::to_string(&scene_json("cornell-box.json", 8)).unwrap();
    for (tail, what) in [
        ("\0\0", "NUL"),
        ("\nextra", "text"),
        ("{}", "second object"),
    ] {
        let p = d.join("t.json");
        std::fs::write(&p, format!("{text}{tail}")).unwrap();
        refused(
            what,
            run_in(&d, &["render", s(&p), "--spp", "1", "-o", s(&out)]),
            &["t.json", "trailing"],
        );
    }
    // A config and a Gaussian-mixture model too.
    let cfg = d.join("c.json");
    let smoke = std::fs::read_to_string(repo().join("experiments/smoke-pt-mono.json")).unwrap();
    std::fs::write(&cfg, format!("{smoke}\0")).unwrap();
    refused(
        "config",
        run_in(&d, &["experiment", s(&cfg), "--quick"]),
        &["c.json", "trailing"],
    );
    let model = d.join("g.json");
    fit_golfye(&d, &model);
    let m = std::fs::read_to_string(&model).unwrap();
    std::fs::write(&model, format!("{m} trailing")).unwrap();
    refused(
        "model",
        run_in(&d, &["gmm", "dense", s(&model), "-o", s(&d.join("x.bfc"))]),
        &["g.json", "trailing"],
    );
    // A scene that is an array names what the file must hold.
    let arr = d.join("arr.json");
    std::fs::write(&arr, "[1, 2]").unwrap();
    refused(
        "array",
        run_in(&d, &["render", s(&arr), "-o", s(&out)]),
        &["arr.json", "one JSON object", "array"],
    );
    // BFC column labels must be the header's grid; a byte-order mark is fine.
    let golf = std::fs::read_to_string(repo().join("data/bispectral/GOLFYE.BFC")).unwrap();
    let bfc = d.join("rev.BFC");
    std::fs::write(&bfc, golf.replacen("r:c:\t300\t310", "r:c:\t310\t300", 1)).unwrap();
    refused(
        "reversed labels",
        run_in(&d, &["gmm", "fit", s(&bfc), "-o", s(&d.join("r.json"))]),
        &["rev.BFC", "r:c:", "300"],
    );
    std::fs::write(&bfc, format!("\u{feff}{golf}")).unwrap();
    let r = run_in(
        &d,
        &[
            "gmm",
            "fit",
            s(&bfc),
            "--components",
            "2",
            "-o",
            s(&d.join("r.json")),
        ],
    );
    assert_eq!(r.0, 0, "a BOM is skipped: {}", r.1);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn messages_name_the_field_and_escape_control_bytes() {
    let d = common::temp_dir("hf-messages");
    let out = d.join("o.exr");
    let render = |v: &Value| {
        let p = write_json(&d.join("m.json"), v);
        run_in(&d, &["render", s(&p), "--spp", "1", "-o", s(&out)])
    };
    let mut v = scene_json("fluorescent-walls.json", 8);
    let m = v["materials"].as_object_mut().unwrap();
    let dye = m
        .keys()
        .find(|k| m[*k]["type"] == "fluorescent-diffuse")
        .cloned()
        .unwrap();
    m[&dye]["quantum_yield"] = "high".into();
    refused(
        "quantum_yield",
        render(&v),
        &[&format!("materials.{dye}.quantum_yield")],
    );
    let mut v = scene_json("media-scattering.json", 8);
    v["media"]["fluid"]["phase"] = serde_json::json!({"type": "henyey-greenstein", "g": "x"});
    refused("HG g", render(&v), &["media.fluid.phase.g"]);
    let mut v = scene_json("media-smoke.json", 8);
    let media = v["media"].as_object_mut().unwrap();
    let grid = media
        .keys()
        .find(|k| media[*k]["type"] == "grid")
        .cloned()
        .unwrap();
    media[&grid]["density_scale"] = "big".into();
    refused(
        "density_scale",
        render(&v),
        &[&format!("media.{grid}.density_scale")],
    );
    // An unknown type is the `type` field's error.
    let mut v = scene_json("media-scattering.json", 8);
    v["media"]["fluid"]["phase"] = serde_json::json!({"type": "rayleigh"});
    refused(
        "unknown type",
        render(&v),
        &["media.fluid.phase.type", "rayleigh"],
    );
    // Control bytes of a scene's names and of a message never reach the terminal raw.
    let mut v = scene_json("cornell-box.json", 8);
    let evil = "\u{1b}]0;owned\u{7}\u{1b}[31m";
    let mats = v["materials"].as_object_mut().unwrap();
    let first = mats.keys().next().cloned().unwrap();
    let m = mats[&first].clone();
    mats.insert(evil.to_string(), m);
    let p = write_json(&d.join("evil.json"), &v);
    let o = Command::new(bin())
        .args(["inspect", s(&p)])
        .output()
        .unwrap();
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("\\x1b]0;owned\\x07"), "{text}");
    assert!(
        !text.contains('\u{1b}') && !text.contains('\u{7}'),
        "{text}"
    );
    v["shapes"][0]["material"] = evil.into();
    v["materials"].as_object_mut().unwrap().remove(evil);
    let (code, err) = render(&v);
    assert_eq!(code, 2, "{err}");
    assert!(!err.contains('\u{1b}') && err.contains("\\x1b"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn figures_of_a_run_without_its_images_is_an_error_and_plots_only_is_not() {
    let d = common::temp_dir("hf-figures");
    let scene = write_json(
        &d.join("walls.json"),
        &scene_json("fluorescent-walls.json", 16),
    );
    let cfg = write_json(
        &d.join("c.json"),
        &serde_json::json!({
            "name": "imgs", "scene": s(&scene),
            "reference": {"integrator": "pt-hero", "spp": 8},
            "variants": [{"name": "a", "integrator": "pt-mono"}],
            "budget": {"spp": [1, 2]}, "repeats": 1
        }),
    );
    let out = d.join("res");
    let o = common::quick_experiment(&cfg, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let latest = std::fs::read_to_string(out.join("imgs/latest")).unwrap();
    let run = out.join("imgs").join(latest.trim());
    let grid = run.join("figures/image-grid.png");
    let before = std::fs::read(&grid).unwrap();
    std::fs::remove_dir_all(run.join("images")).unwrap();
    refused(
        "figures without images",
        run_in(&d, &["figures", s(&run)]),
        &["images/", "missing", "--plots-only"],
    );
    assert_eq!(std::fs::read(&grid).unwrap(), before, "old figures kept");
    let r = run_in(&d, &["figures", "--plots-only", s(&run)]);
    assert_eq!(r.0, 0, "{}", r.1);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn gmm_eval_finds_its_illuminants_from_any_folder() {
    let d = common::temp_dir("hf-illuminants");
    let bfcs = d.join("bfc");
    std::fs::create_dir(&bfcs).unwrap();
    std::fs::copy(
        repo().join("data/bispectral/GOLFYE.BFC"),
        bfcs.join("GOLFYE.BFC"),
    )
    .unwrap();
    let r = run_in(
        &d,
        &[
            "gmm",
            "eval",
            s(&bfcs),
            "--components",
            "2",
            "-o",
            s(&d.join("eval")),
        ],
    );
    assert_eq!(r.0, 0, "{}", r.1);
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("eval/summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["illuminants"].as_array().unwrap().len(), 59);
    let _ = std::fs::remove_dir_all(&d);
}
