//! The raster figures carry their own text (column headings, row labels, captions, colour bars
//! with tick labels), every budget of a log axis has a labelled tick, and the signed difference
//! figure is green where `a` is brighter and red where `b` is. Run folders are either made by a
//! `--quick` experiment on a tiny config or written by hand (run.json, metrics.csv, EXRs).

mod common;

use glam::Vec3;
use image::RgbImage;
use std::path::{Path, PathBuf};
use std::process::Command;
use stokes::experiment::record::Row;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_stokes")
}

fn walls() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/fluorescent-walls.json")
        .to_string_lossy()
        .replace('\\', "/")
}

fn white(p: &image::Rgb<u8>) -> bool {
    p.0.iter().all(|&c| c >= 250)
}

/// A text pixel: black text drawn on white (anti-aliased edges excluded).
fn dark(p: &image::Rgb<u8>) -> bool {
    p.0.iter().all(|&c| c < 110)
}

fn count(
    img: &RgbImage,
    xs: std::ops::Range<u32>,
    ys: std::ops::Range<u32>,
    f: fn(&image::Rgb<u8>) -> bool,
) -> usize {
    ys.flat_map(|y| xs.clone().map(move |x| (x, y)))
        .filter(|&(x, y)| x < img.width() && y < img.height() && f(img.get_pixel(x, y)))
        .count()
}

/// The first row of tiles: its top y and the x ranges of its tiles (runs of at least 80
/// non-white pixels that stay non-white for 40 rows; text is never that tall).
fn first_tiles(img: &RgbImage) -> (u32, Vec<std::ops::Range<u32>>) {
    for y in 0..img.height().saturating_sub(40) {
        let mut runs = Vec::new();
        let mut x = 0;
        while x < img.width() {
            let start = x;
            while x < img.width() && !white(img.get_pixel(x, y)) {
                x += 1;
            }
            if x - start >= 80
                && (y..y + 40).all(|yy| (start..start + 80).all(|xx| !white(img.get_pixel(xx, yy))))
            {
                runs.push(start..x);
            }
            x += 1;
        }
        if !runs.is_empty() {
            return (y, runs);
        }
    }
    panic!("no tiles found");
}

/// The colour bar: the lowest row with at least 150 pixels of its grey frame is its bottom edge.
/// Returns the x range of its inside, the first row of its inside and its bottom edge.
fn colour_bar(img: &RgbImage) -> (std::ops::Range<u32>, u32, u32) {
    for y in (0..img.height()).rev() {
        let grey: Vec<u32> = (0..img.width())
            .filter(|&x| img.get_pixel(x, y).0 == [90, 90, 90])
            .collect();
        if grey.len() >= 150 {
            let (x0, x1) = (grey[0], *grey.last().unwrap());
            let mut top = y - 1;
            while img.get_pixel(x0 + 5, top).0 != [90, 90, 90] {
                top -= 1;
            }
            return (x0 + 1..x1, top + 1, y);
        }
    }
    panic!("no colour bar found");
}

/// Tick labels under the bar and its title over it: text pixels across most of its width.
fn assert_bar_labelled(img: &RgbImage, what: &str) -> (std::ops::Range<u32>, u32, u32) {
    let (xs, top, bottom) = colour_bar(img);
    assert!(xs.len() >= 200, "{what}: bar {xs:?}");
    let below: Vec<u32> = (xs.start.saturating_sub(30)..xs.end + 30)
        .filter(|&x| count(img, x..x + 1, bottom + 5..bottom + 24, dark) > 0)
        .collect();
    assert!(
        below.len() > 30,
        "{what}: tick labels under the bar: {}",
        below.len()
    );
    assert!(
        *below.first().unwrap() <= xs.start + 10 && *below.last().unwrap() + 10 >= xs.end,
        "{what}: labels at both ends of the bar {xs:?}: {}..{}",
        below.first().unwrap(),
        below.last().unwrap()
    );
    let above = count(img, xs.clone(), top.saturating_sub(16)..top - 1, dark);
    assert!(above > 30, "{what}: bar title pixels {above}");
    (xs, top, bottom)
}

/// The text lines of an SVG written by plotters (each text element's content on its own line).
fn svg_texts(path: &Path) -> Vec<String> {
    let s = std::fs::read_to_string(path).unwrap();
    let mut out = Vec::new();
    let mut lines = s.lines();
    while let Some(l) = lines.next() {
        if l.starts_with("<text") {
            out.push(lines.next().unwrap_or("").to_string());
        }
    }
    out
}

fn latest_run(out: &Path, name: &str) -> PathBuf {
    let latest = std::fs::read_to_string(out.join(name).join("latest")).expect("latest written");
    out.join(name).join(latest.trim())
}

#[test]
fn quick_run_pngs_label_themselves() {
    let t = std::time::Instant::now();
    let d = common::temp_dir("figpng");
    let cfg = d.join("config.json");
    std::fs::write(
        &cfg,
        format!(
            r#"{{ "name": "f", "scene": "{}",
                "reference": {{ "integrator": "pt-mono", "spp": 16 }},
                "variants": [ {{ "name": "mono", "integrator": "pt-mono" }},
                              {{ "name": "hero", "integrator": "pt-hero" }} ],
                "budget": {{ "spp": [1, 4, 16, 64, 256, 1024] }},
                "crop": {{ "x": 64, "y": 64, "w": 64, "h": 64 }},
                "difference": {{ "a": "hero" }} }}"#,
            walls()
        ),
    )
    .unwrap();
    let o = common::quick_experiment(&cfg, &d.join("results"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run = latest_run(&d.join("results"), "f");
    let fig = run.join("figures");

    // Image grid: a heading over each of the three columns (reference, mono, hero), a row label
    // left of the first row, a caption (SNR) under each image, the error colour bar.
    let img = image::open(fig.join("image-grid.png")).unwrap().to_rgb8();
    let (y0, cols) = first_tiles(&img);
    assert_eq!(cols.len(), 3, "columns {cols:?}");
    for c in &cols {
        let n = count(&img, c.clone(), y0.saturating_sub(20)..y0, dark);
        assert!(n > 15, "heading over {c:?}: {n} text pixels");
    }
    let th = (y0..img.height())
        .find(|&y| white(img.get_pixel(cols[0].start + 5, y)))
        .unwrap()
        - y0;
    for c in &cols {
        let n = count(&img, c.clone(), y0 + th..y0 + th + 16, dark);
        assert!(n > 15, "caption under {c:?}: {n} text pixels");
    }
    let label = count(&img, 0..cols[0].start, y0..y0 + 20, dark);
    assert!(label > 15, "row label: {label} text pixels");
    let (xs, top, _) = assert_bar_labelled(&img, "image grid");
    // The error ramp runs from black to yellow.
    let (l, r) = (
        img.get_pixel(xs.start + 1, top + 5).0,
        img.get_pixel(xs.end - 2, top + 5).0,
    );
    assert!(l.iter().all(|&c| c < 20), "left end {l:?}");
    assert!(r[0] > 200 && r[1] > 200 && r[2] < 200, "right end {r:?}");

    // Crops: headings too.
    let img = image::open(fig.join("crops.png")).unwrap().to_rgb8();
    let (y0, cols) = first_tiles(&img);
    assert_eq!(cols.len(), 3);
    for c in &cols {
        assert!(count(&img, c.clone(), y0.saturating_sub(20)..y0, dark) > 15);
    }

    // The difference against the reference, with its bar: red, black, green.
    let img = image::open(fig.join("difference.png")).unwrap().to_rgb8();
    let (xs, top, _) = assert_bar_labelled(&img, "difference");
    let mid = (xs.start + xs.end) / 2;
    assert_eq!(img.get_pixel(xs.start + 1, top + 5).0[1], 0);
    assert!(img.get_pixel(xs.start + 1, top + 5).0[0] > 200);
    assert!(img.get_pixel(xs.end - 2, top + 5).0[1] > 200);
    assert!(img.get_pixel(mid, top + 5).0.iter().all(|&c| c < 40));

    // Every budget of the run labels a tick of the spp axis.
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("run.json")).unwrap()).unwrap();
    let budgets = info["modes"][0]["budgets"].as_array().unwrap();
    assert_eq!(budgets.len(), 2, "quick ladder {budgets:?}");
    let texts = svg_texts(&fig.join("snr-vs-spp.svg"));
    for b in budgets {
        let b = b.as_f64().unwrap().to_string();
        assert!(texts.contains(&b), "tick {b} in {texts:?}");
    }
    eprintln!("quick run and checks: {:?}", t.elapsed());
    let _ = std::fs::remove_dir_all(&d);
}

/// A run folder written by hand: `run.json` with the given config fields and budgets,
/// `metrics.csv` with a row per variant and budget (seconds and SNR grow with the budget).
fn hand_run(tag: &str, mode: &str, budgets: &[f64], extra: serde_json::Value) -> PathBuf {
    let d = common::temp_dir(tag);
    let budget = if mode == "time" {
        serde_json::json!({ "seconds": budgets })
    } else {
        let spp: Vec<u32> = budgets.iter().map(|&b| b as u32).collect();
        serde_json::json!({ "spp": spp })
    };
    let mut config = serde_json::json!({
        "name": "hand",
        "scene": "scene.json",
        "reference": { "integrator": "pt-mono", "spp": 16 },
        "variants": [
            { "name": "a", "integrator": "pt-mono" },
            { "name": "b", "integrator": "pt-hero" }
        ],
        "budget": budget
    });
    for (k, v) in extra.as_object().unwrap() {
        config[k] = v.clone();
    }
    let info = serde_json::json!({
        "config": config, "config_file": "config.json", "quick": false,
        "width": 16, "height": 16, "crop": null, "scanline": null, "region_names": [],
        "modes": [{ "mode": mode, "budgets": budgets }],
        "reference_file": null, "grid_cells": [], "started": "now", "threads": 1
    });
    std::fs::write(d.join("run.json"), info.to_string()).unwrap();
    let mut csv = String::from(stokes::experiment::record::CSV_HEADER);
    for v in ["a", "b"] {
        for &b in budgets {
            let (spp, seconds) = if mode == "time" {
                ((b * 100.0) as u32, b * 1.004)
            } else {
                (b as u32, b * 0.01)
            };
            let row = Row {
                variant: v.into(),
                integrator: "pt-mono".into(),
                mode: mode.into(),
                budget: b,
                repeat: 0,
                seed: 0,
                spp,
                seconds,
                samples_per_second: 256.0 * spp as f64 / seconds,
                region: "all".into(),
                pixels: 256,
                mse: 0.1 / b,
                rel_mse: 0.2 / b,
                snr_db: 10.0 * b.log10(),
                efficiency: b / (0.2 * seconds),
            };
            csv += &format!("\n{}", row.to_csv());
        }
    }
    csv.push('\n');
    std::fs::write(d.join("metrics.csv"), csv).unwrap();
    d
}

fn figures(dir: &Path) -> std::process::Output {
    Command::new(bin())
        .arg("figures")
        .arg(dir)
        .output()
        .unwrap()
}

/// `stokes figures --plots-only DIR`: a hand-made run has no images.
fn plots(dir: &Path) -> std::process::Output {
    Command::new(bin())
        .args(["figures", "--plots-only"])
        .arg(dir)
        .output()
        .unwrap()
}

#[test]
fn every_budget_labels_a_log_axis_tick() {
    for (mode, budgets, svg) in [
        (
            "time",
            vec![2.5, 5.0, 10.0, 20.0, 40.0],
            "relmse-vs-seconds.svg",
        ),
        (
            "spp",
            vec![1.0, 4.0, 16.0, 64.0, 256.0, 1024.0],
            "snr-vs-spp.svg",
        ),
        ("time", vec![0.125, 0.25, 0.5], "relmse-vs-seconds.svg"),
        ("spp", vec![3.0, 7.0, 13.0, 2000.0], "snr-vs-spp.svg"),
    ] {
        let d = hand_run("ticks", mode, &budgets, serde_json::json!({}));
        let o = plots(&d);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let texts = svg_texts(&d.join("figures").join(svg));
        for b in &budgets {
            let label = b.to_string();
            assert!(
                texts.contains(&label),
                "{mode} {budgets:?}: no tick label {label} in {texts:?}"
            );
        }
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// Images of `w`×`h` pixels: `top` in the upper half, `bottom` in the lower half.
fn halves(w: u32, h: u32, top: f32, bottom: f32) -> Vec<Vec3> {
    (0..w * h)
        .map(|i| Vec3::splat(if i / w < h / 2 { top } else { bottom }))
        .collect()
}

/// The rows (above the colour bar) with at least 10 saturated green or red pixels, in order:
/// `true` for green.
fn signed_rows(img: &RgbImage, below: u32) -> Vec<(u32, bool, usize, usize)> {
    let green = |p: &image::Rgb<u8>| p.0[1] > 200 && p.0[0] < 40 && p.0[2] < 40;
    let red = |p: &image::Rgb<u8>| p.0[0] > 200 && p.0[1] < 40 && p.0[2] < 40;
    let mut out = Vec::new();
    for y in 0..below {
        let g = (0..img.width())
            .filter(|&x| green(img.get_pixel(x, y)))
            .count();
        let r = (0..img.width())
            .filter(|&x| red(img.get_pixel(x, y)))
            .count();
        if g >= 10 || r >= 10 {
            out.push((y, g > r, g, r));
        }
    }
    out
}

#[test]
fn difference_is_green_where_a_is_brighter_and_red_where_it_is_darker() {
    for b in [Some("b"), None] {
        let diff = match b {
            Some(b) => serde_json::json!({ "a": "a", "b": b }),
            None => serde_json::json!({ "a": "a" }),
        };
        let d = hand_run(
            "diff",
            "time",
            &[1.0],
            serde_json::json!({ "difference": diff }),
        );
        // a is brighter than b (and the reference) in the upper half, darker in the lower half.
        let a = halves(16, 16, 2.0, 1.0);
        let other = halves(16, 16, 1.0, 2.0);
        stokes::film::write_exr(&d.join("images/a__time0__r0.exr"), 16, 16, &a).unwrap();
        stokes::film::write_exr(&d.join("images/b__time0__r0.exr"), 16, 16, &other).unwrap();
        stokes::film::write_exr(&d.join("reference.exr"), 16, 16, &other).unwrap();
        let mut info: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("run.json")).unwrap()).unwrap();
        info["reference_file"] = "reference.exr".into();
        std::fs::write(d.join("run.json"), info.to_string()).unwrap();
        let o = figures(&d);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = image::open(d.join("figures/difference.png"))
            .unwrap()
            .to_rgb8();
        let (_, bar_top, _) = assert_bar_labelled(&img, "difference");
        let rows = signed_rows(&img, bar_top.saturating_sub(40));
        assert!(!rows.is_empty(), "no saturated rows");
        // Green rows come first (upper half), then red ones; no row mixes them.
        let first_red = rows.iter().position(|r| !r.1).expect("red rows");
        assert!(first_red > 20, "green rows before red: {first_red}");
        assert!(
            rows[..first_red].iter().all(|r| r.1 && r.3 == 0),
            "{rows:?}"
        );
        assert!(
            rows[first_red..].iter().all(|r| !r.1 && r.2 == 0),
            "{rows:?}"
        );
        assert!(rows.len() - first_red > 20);
        let _ = std::fs::remove_dir_all(&d);
    }
}

#[test]
fn unknown_difference_variant_is_an_input_error_naming_the_field() {
    let d = common::temp_dir("diffbad");
    let base = |extra: &str| {
        format!(
            r#"{{ "name": "t", "scene": "{}",
                "reference": {{ "integrator": "pt-mono", "spp": 16 }},
                "variants": [ {{ "name": "a", "integrator": "pt-mono" }},
                              {{ "name": "b", "integrator": "pt-hero" }} ],
                "budget": {{ "spp": [1, 2] }}, {extra} }}"#,
            walls()
        )
    };
    for (extra, field) in [
        (r#""difference": { "a": "nope" }"#, "difference.a"),
        (r#""difference": { "a": "a", "b": "nope" }"#, "difference.b"),
        (r#""difference": { "a": "a", "b": "a" }"#, "difference.b"),
        (r#""difference": { "a": "a", "c": "b" }"#, "difference"),
    ] {
        let cfg = d.join("config.json");
        std::fs::write(&cfg, base(extra)).unwrap();
        let o = common::quick_experiment(&cfg, &d.join("results"));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra}: {err}");
        assert!(
            err.contains(field) && err.contains("config.json"),
            "{extra}: {err}"
        );
    }
    assert!(!d.join("results").join("t").join("latest").exists());
    let _ = std::fs::remove_dir_all(&d);

    // A stored run.json naming a variant the run does not have: `stokes figures` says which.
    let d = hand_run(
        "diffbad-run",
        "time",
        &[1.0],
        serde_json::json!({ "difference": { "a": "zzz" } }),
    );
    for v in ["a", "b"] {
        stokes::film::write_exr(
            &d.join(format!("images/{v}__time0__r0.exr")),
            16,
            16,
            &halves(16, 16, 1.0, 1.0),
        )
        .unwrap();
    }
    let o = figures(&d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("config.difference.a"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}
