//! The command line of sample-range shards: `stokes render --samples FROM..TO` and
//! `stokes merge`. Shards of one render merge into the render of the whole range, bit for bit,
//! and the merge refuses, with exit code 2 and a message naming the files, anything that is not
//! a set of shards of one render.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use stokes::film::output::read_exr;
use stokes::film::shard::read_shard;
use stokes::io::hash::text_hash;

use common::{bin, expect_input_error, repo, s};

/// `scenes/fluorescent-walls.json` (no external files) with a `size`×`size` camera, written to
/// `dir/name`.
fn walls(dir: &Path, name: &str, size: u32) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenes/fluorescent-walls.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["camera"]["width"] = size.into();
    v["camera"]["height"] = size.into();
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    p
}

/// Exit code and stderr of `stokes ARGS`.
fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(bin()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

/// `stokes ARGS` must succeed.
fn ok(args: &[&str]) {
    let (code, err) = run(args);
    assert_eq!(code, 0, "stokes {args:?}: exit code {code}, stderr: {err}");
}

/// `stokes render SCENE --samples RANGE -o OUT --quiet` plus `extra`.
fn render_range(scene: &Path, range: &str, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "render",
        s(scene),
        "--samples",
        range,
        "-o",
        s(out),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    ok(&args);
}

/// The RGB pixels of an EXR as bit patterns.
fn pixel_bits(p: &Path) -> (u32, u32, Vec<[u32; 3]>) {
    let (w, h, px) = read_exr(p).unwrap();
    (
        w,
        h,
        px.iter().map(|c| c.to_array().map(f32::to_bits)).collect(),
    )
}

fn assert_same_pixels(what: &str, a: &Path, b: &Path) {
    let (wa, ha, pa) = pixel_bits(a);
    let (wb, hb, pb) = pixel_bits(b);
    assert_eq!((wa, ha), (wb, hb), "{what}: sizes");
    let differ = pa.iter().zip(&pb).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{what}: {differ} of {} pixels differ", pa.len());
}

/// Shards 0..8 and 8..16 (rendered with different thread counts, given to `merge` out of order)
/// merge into the pixels of `--samples 0..16`, bit for bit, for a path tracer and for a BDPT
/// (whose light-tracing strategies splat); the merged file is itself a shard of 0..16 that
/// merges on with 16..24 into the render of 0..24.
#[test]
fn merged_shards_equal_the_render_of_the_whole_range() {
    let d = common::temp_dir("shards-cli-merge");
    let scene = walls(&d, "walls.json", 16);
    for kind in ["pt-mono", "bdpt-forward"] {
        let p = |n: &str| d.join(format!("{kind}-{n}"));
        let ik = ["--integrator", kind, "--seed", "11"];
        render_range(
            &scene,
            "0..8",
            &p("a.exr"),
            &[&ik[..], &["--threads", "1"][..]].concat(),
        );
        render_range(
            &scene,
            "8..16",
            &p("b.exr"),
            &[&ik[..], &["--threads", "2"][..]].concat(),
        );
        render_range(&scene, "16..24", &p("c.exr"), &ik);
        render_range(&scene, "0..16", &p("whole16.exr"), &ik);
        render_range(&scene, "0..24", &p("whole24.exr"), &ik);
        ok(&[
            "merge",
            s(&p("b.exr")),
            s(&p("a.exr")),
            "-o",
            s(&p("m16.exr")),
            "--png",
            s(&p("m16.png")),
        ]);
        assert!(p("m16.png").is_file(), "{kind}: the PNG preview");
        assert_same_pixels(kind, &p("m16.exr"), &p("whole16.exr"));
        let m = read_shard(&p("m16.exr")).unwrap();
        assert_eq!((m.info.from, m.info.to), (0, 16), "{kind}");
        assert_eq!(m.info.seed, 11, "{kind}");
        assert_eq!(m.info.integrator, kind);
        assert_eq!((m.width, m.height), (16, 16), "{kind}");
        let w = read_shard(&p("whole16.exr")).unwrap();
        assert_eq!(m.info.scene_hash, w.info.scene_hash, "{kind}");
        assert_eq!(m.info.options, w.info.options, "{kind}");

        ok(&[
            "merge",
            s(&p("m16.exr")),
            s(&p("c.exr")),
            "-o",
            s(&p("m24.exr")),
        ]);
        assert_same_pixels(kind, &p("m24.exr"), &p("whole24.exr"));
        let m = read_shard(&p("m24.exr")).unwrap();
        assert_eq!((m.info.from, m.info.to), (0, 24), "{kind}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Three shards of uneven length in one merge equal the whole range.
#[test]
fn three_uneven_shards_merge_in_one_call() {
    let d = common::temp_dir("shards-cli-three");
    let scene = walls(&d, "walls.json", 12);
    let ik = ["--integrator", "pt-hero"];
    for (r, n) in [
        ("0..5", "a"),
        ("5..11", "b"),
        ("11..16", "c"),
        ("0..16", "w"),
    ] {
        render_range(&scene, r, &d.join(format!("{n}.exr")), &ik);
    }
    ok(&[
        "merge",
        s(&d.join("c.exr")),
        s(&d.join("a.exr")),
        s(&d.join("b.exr")),
        "-o",
        s(&d.join("m.exr")),
    ]);
    assert_same_pixels("pt-hero 3 shards", &d.join("m.exr"), &d.join("w.exr"));
    let _ = std::fs::remove_dir_all(&d);
}

/// A plain render (without --samples) says what it holds in its header (samples 0..spp, seed,
/// integrator, options, scene and the hash of the scene's text) but holds no sums, so it cannot
/// be merged; with --time-limit the range is the samples actually rendered.
#[test]
fn plain_render_carries_the_attributes_but_not_the_sums() {
    let d = common::temp_dir("shards-cli-plain");
    let scene = walls(&d, "walls.json", 8);
    let out = d.join("plain.exr");
    ok(&[
        "render",
        s(&scene),
        "--spp",
        "6",
        "--seed",
        "4",
        "--integrator",
        "pt-hero",
        "-o",
        s(&out),
        "--quiet",
    ]);
    let film = film_attribute(&out);
    assert_eq!(film["samples"], "0..6");
    assert_eq!(film["spp"], 6);
    assert_eq!(film["seed"], 4);
    assert_eq!(film["integrator"], "pt-hero");
    assert!(film["scene"].as_str().unwrap().ends_with("walls.json"));
    assert_eq!(
        film["sceneHash"],
        text_hash(&std::fs::read_to_string(&scene).unwrap())
    );
    // the options in effect, defaults included
    let lanes = stokes::integrator::IntegratorOptions::default().lanes;
    assert_eq!(film["options"]["lanes"], lanes);
    let e = read_shard(&out)
        .err()
        .expect("a plain render holds no sums");
    assert!(e.contains("plain.exr") && e.contains("--samples"), "{e}");

    // Time limit: the header says how many samples were rendered.
    let timed = d.join("timed.exr");
    ok(&[
        "render",
        s(&scene),
        "--spp",
        "16000000",
        "--time-limit",
        "0.2",
        "-o",
        s(&timed),
        "--quiet",
    ]);
    let film = film_attribute(&timed);
    let spp = film["spp"].as_u64().unwrap();
    assert!((1..16_000_000).contains(&spp), "spp {spp}");
    assert_eq!(film["samples"], format!("0..{spp}"));
    let _ = std::fs::remove_dir_all(&d);
}

/// The `stokes.film` attribute of an EXR, parsed.
fn film_attribute(p: &Path) -> serde_json::Value {
    let attrs = attributes(p);
    let (_, v) = attrs
        .iter()
        .find(|(n, _)| n == stokes::film::shard::ATTRIBUTE)
        .unwrap_or_else(|| panic!("attribute stokes.film missing: {attrs:?}"));
    serde_json::from_str(v).unwrap()
}

/// The text attributes of an EXR's first header.
fn attributes(p: &Path) -> Vec<(String, String)> {
    let meta = exr::meta::MetaData::read_from_file(p, false).unwrap();
    stokes::film::shard::text_attributes(&meta.headers[0])
        .into_iter()
        .collect()
}

/// Every refusal of `merge`: exit code 2, a message naming the files concerned and what
/// differs, and no output written.
#[test]
fn merge_refuses_what_is_not_one_render() {
    let d = common::temp_dir("shards-cli-refuse");
    let scene = walls(&d, "walls.json", 8);
    // The same scene text plus a space: another hash, same relative references (there are none).
    let other = d.join("walls-other.json");
    std::fs::write(&other, std::fs::read_to_string(&scene).unwrap() + " ").unwrap();
    let a = d.join("a.exr");
    render_range(&scene, "0..8", &a, &[]);
    let shard = |name: &str, sc: &Path, range: &str, extra: &[&str]| {
        let p = d.join(name);
        render_range(sc, range, &p, extra);
        p
    };
    let out = d.join("merged.exr");
    let merge = |b: &Path| run(&["merge", s(&a), s(b), "-o", s(&out)]);
    let cases: Vec<(&str, PathBuf, &[&str])> = vec![
        (
            "seed",
            shard("seed.exr", &scene, "8..16", &["--seed", "3"]),
            &["the seed", "0 / 3"],
        ),
        (
            "integrator",
            shard("integ.exr", &scene, "8..16", &["--integrator", "pt-hero"]),
            &["the integrator", "pt-mono", "pt-hero"],
        ),
        (
            "options",
            shard("opts.exr", &scene, "8..16", &["--max-depth", "3"]),
            &["options", "\"max_depth\":3"],
        ),
        (
            "scene",
            shard("scene.exr", &other, "8..16", &[]),
            &["the scene", "walls-other.json"],
        ),
        (
            "overlap",
            shard("overlap.exr", &scene, "4..16", &[]),
            &["overlap", "0..8", "4..16"],
        ),
        (
            "gap",
            shard("gap.exr", &scene, "9..16", &[]),
            &["samples 8..9 are in no shard"],
        ),
    ];
    for (what, b, names) in &cases {
        let mut all = vec![s(&a), s(b)];
        all.extend_from_slice(names);
        expect_input_error(what, merge(b), &all);
        assert!(!out.exists(), "{what}: an output was written");
    }
    // The same shard twice overlaps itself.
    expect_input_error("same shard twice", merge(&a), &[s(&a), "overlap"]);

    // A plain render has no sums.
    let plain = d.join("plain.exr");
    ok(&[
        "render",
        s(&scene),
        "--spp",
        "8",
        "-o",
        s(&plain),
        "--quiet",
    ]);
    expect_input_error(
        "plain render",
        run(&["merge", s(&plain), s(&cases[0].1), "-o", s(&out)]),
        &[s(&plain), "sums", "--samples"],
    );

    let b = shard("b.exr", &scene, "8..16", &[]);
    // The output is an input (also when spelled another way): refused before anything is read,
    // the input untouched.
    let before = std::fs::read(&a).unwrap();
    expect_input_error(
        "output is an input",
        run(&["merge", s(&a), s(&b), "-o", s(&a)]),
        &["-o/--output", s(&a), "input"],
    );
    let dotted = d.join(".").join("b.exr");
    expect_input_error(
        "output is an input, spelled with ./",
        run(&["merge", s(&a), s(&b), "-o", s(&dotted)]),
        &["-o/--output", "input"],
    );
    assert_eq!(std::fs::read(&a).unwrap(), before, "the input was modified");

    // The output name must say EXR.
    let png = d.join("merged.png");
    expect_input_error(
        "output not .exr",
        run(&["merge", s(&a), s(&b), "-o", s(&png)]),
        &[s(&png), ".exr"],
    );
    assert!(!png.exists());
    // A --png preview must end in .png.
    expect_input_error(
        "--png not .png",
        run(&[
            "merge",
            s(&a),
            s(&b),
            "-o",
            s(&out),
            "--png",
            s(&d.join("p.jpg")),
        ]),
        &["--png", "p.jpg"],
    );

    // An input that is not an EXR, and one that does not exist.
    let junk = d.join("junk.exr");
    std::fs::write(&junk, "not an image").unwrap();
    expect_input_error(
        "not an EXR",
        run(&["merge", s(&a), s(&junk), "-o", s(&out)]),
        &[s(&junk)],
    );
    let missing = d.join("missing.exr");
    expect_input_error(
        "missing input",
        run(&["merge", s(&a), s(&missing), "-o", s(&out)]),
        &[s(&missing)],
    );
    // An output folder that does not exist.
    let nowhere = d.join("nowhere").join("m.exr");
    expect_input_error(
        "output folder missing",
        run(&["merge", s(&a), s(&b), "-o", s(&nowhere)]),
        &["-o/--output", "nowhere"],
    );
    assert!(!out.exists(), "an output was written");
    // And the pair that belongs together still merges.
    ok(&["merge", s(&a), s(&b), "-o", s(&out)]);
    let _ = std::fs::remove_dir_all(&d);
}

/// `--samples` must be a non-empty range FROM..TO of at most the largest spp, and excludes
/// --spp and --time-limit: exit code 2 naming the option, nothing written.
#[test]
fn sample_range_option_is_checked() {
    let d = common::temp_dir("shards-cli-range");
    let scene = walls(&d, "walls.json", 8);
    let out = d.join("out.exr");
    for (extra, names) in [
        (
            &["--samples", "5..5"][..],
            &["--samples", "5..5", "empty"][..],
        ),
        (&["--samples", "8..4"], &["--samples", "8..4", "empty"]),
        (&["--samples", "3"], &["--samples", "'3'", "FROM..TO"]),
        (&["--samples", "a..4"], &["--samples", "'a'"]),
        (&["--samples=-1..4"], &["--samples", "'-1'"]),
        (
            &["--samples", "0..16", "--spp", "4"],
            &["--samples", "--spp"],
        ),
        (
            &["--samples", "0..16", "--time-limit", "1"],
            &["--samples", "--time-limit"],
        ),
        (&["--samples", "0..4294967295"], &["--samples", "at most"]),
    ] {
        let mut args = vec!["render", s(&scene), "-o", s(&out)];
        args.extend_from_slice(extra);
        expect_input_error(&format!("{extra:?}"), run(&args), names);
        assert!(!out.exists(), "{extra:?}: an output was written");
    }
    let _ = std::fs::remove_dir_all(&d);
}
