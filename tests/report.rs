//! `report.html` without a browser: `stokes experiment` writes it, `stokes report` writes the
//! same file again, it needs nothing outside itself, its embedded HDR pixels are the run's EXRs
//! to half-float precision, a sweep gets one per value, and a broken run folder is an input error
//! (exit code 2) naming the file. tests/report_browser.rs loads it in a browser.

mod common;

use common::{bin, expect_input_error, repo, s, temp_dir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Run `stokes ARGS`; exit code and stderr.
fn stokes(args: &[&str]) -> (i32, String) {
    let o = Command::new(bin()).args(args).output().unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `experiments/NAME.json --quick` into `out`; its run folder.
fn quick_run(name: &str, out: &Path) -> PathBuf {
    let cfg = repo().join(format!("experiments/{name}.json"));
    let (code, err) = stokes(&["experiment", s(&cfg), "--quick", "--out", s(out)]);
    assert_eq!(code, 0, "{err}");
    let latest = std::fs::read_to_string(out.join(name).join("latest")).unwrap();
    out.join(name).join(latest.trim())
}

/// The viewer's JSON data of a report.
fn viewer_data(html: &str) -> Value {
    let open = "<script type=\"application/json\" id=\"stokes-images\">";
    let i = html.find(open).expect("the viewer's data") + open.len();
    let j = i + html[i..].find("</script>").unwrap();
    serde_json::from_str(&html[i..j]).unwrap()
}

fn base64_decode(t: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let mut out = Vec::new();
    for ch in t.as_bytes().chunks(4) {
        let n = ch.iter().filter(|&&c| c != b'=').count();
        let mut v = 0u32;
        for (k, &c) in ch.iter().enumerate() {
            v |= (if c == b'=' { 0 } else { val(c) } as u32) << (18 - 6 * k);
        }
        out.extend_from_slice(&v.to_be_bytes()[1..n]);
    }
    out
}

/// An embedded image decoded as the viewer decodes it: inflate, then half floats from the high
/// and the low byte planes, planar R, G, B.
fn decode(b64: &str, pixels: usize) -> Vec<f32> {
    let raw = miniz_oxide::inflate::decompress_to_vec_zlib(&base64_decode(b64)).unwrap();
    let n = 3 * pixels;
    assert_eq!(raw.len(), 2 * n);
    (0..n)
        .map(|i| half::f16::from_bits(u16::from_be_bytes([raw[i], raw[n + i]])).to_f32())
        .collect()
}

/// The embedded pixels are the EXR's, rounded to half floats: within half a unit in the last
/// place of an 11-bit significand (2⁻¹¹ relative), or 2⁻²⁵ below the smallest normal.
fn assert_same_pixels(run: &Path, file: &str, b64: &str) {
    let (w, h, px) = stokes::film::output::read_exr(&run.join(file)).unwrap();
    let got = decode(b64, (w * h) as usize);
    let n = px.len();
    for (i, p) in px.iter().enumerate() {
        for c in 0..3 {
            let (x, y) = (p[c], got[c * n + i]);
            let tol = x.abs() * 2f32.powi(-11) + 2f32.powi(-25);
            assert!(
                (x - y).abs() <= tol,
                "{file}: pixel {i} channel {c}: EXR {x}, report {y}"
            );
        }
    }
}

/// `stokes experiment` writes report.html; it is self-contained, holds every variant at every
/// budget and the reference as the EXRs' pixels, and `stokes report` writes it again, byte for
/// byte (also through the experiment folder's `latest`).
#[test]
fn experiment_writes_a_self_contained_report() {
    let d = temp_dir("report");
    let run = quick_run("walls-integrators", &d);
    let file = run.join("report.html");
    let html = std::fs::read_to_string(&file).expect("the experiment writes report.html");
    assert!(html.len() < 4 << 20, "{} bytes for a quick run", html.len());
    for bad in [
        "src=\"http",
        "href=\"http",
        "url(http",
        "@import",
        "<link",
        "<iframe",
    ] {
        assert!(!html.contains(bad), "the report loads `{bad}`…");
    }
    assert!(html.contains("Content-Security-Policy\" content=\"default-src 'none'"));
    for section in [
        "id=\"viewer\"",
        "id=\"metrics\"",
        "id=\"figures\"",
        "id=\"config\"",
    ] {
        assert!(html.contains(section), "no {section}");
    }
    assert!(html.contains("class=\"best\""), "no best value highlighted");
    let svgs = std::fs::read_dir(run.join("figures"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "svg")
        })
        .count();
    assert!(svgs > 0);
    assert!(html.matches("<img src=\"data:image/svg+xml").count() == svgs);

    let data = viewer_data(&html);
    let info: Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("run.json")).unwrap()).unwrap();
    assert_eq!(data["width"], info["width"]);
    let budgets = info["modes"][0]["budgets"].as_array().unwrap().len();
    assert_eq!(data["budgets"].as_array().unwrap().len(), budgets);
    let variants = data["variants"].as_array().unwrap();
    assert_eq!(variants.len(), 6);
    assert_same_pixels(
        &run,
        "reference.exr",
        data["reference"]["data"].as_str().unwrap(),
    );
    for v in variants {
        let images = v["images"].as_array().unwrap();
        assert_eq!(images.len(), budgets);
        for im in images {
            assert_same_pixels(
                &run,
                im["file"].as_str().unwrap(),
                im["data"].as_str().unwrap(),
            );
            assert!(im["metrics"]["snr_db"].is_number(), "{}", im["metrics"]);
        }
    }

    std::fs::remove_file(&file).unwrap();
    let (code, err) = stokes(&["report", s(&d.join("walls-integrators"))]);
    assert_eq!(code, 0, "{err}");
    let again = std::fs::read_to_string(&file).unwrap();
    // The run folder is named as given: absolute from the experiment, through `latest` here.
    let norm = |t: &str| t.replace(s(&run), "RUN");
    assert!(
        norm(&again) == norm(&html),
        "stokes report writes another report"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A sweep: a report per value, and the sweep's report links them.
#[test]
fn sweep_reports_link_every_value() {
    let d = temp_dir("report-sweep");
    let run = quick_run("media-absorption-sweep", &d);
    let top = std::fs::read_to_string(run.join("report.html")).unwrap();
    let points = std::fs::read_dir(run.join("sweep")).unwrap().count();
    assert!(points > 1);
    for i in 0..points {
        assert!(
            top.contains(&format!("href=\"sweep/{i}/report.html\"")),
            "value {i}"
        );
        let page = std::fs::read_to_string(run.join(format!("sweep/{i}/report.html"))).unwrap();
        assert!(
            !viewer_data(&page)["variants"]
                .as_array()
                .unwrap()
                .is_empty()
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A copy of the run folder `run` in `d/name`, changed by `f`.
fn broken(run: &Path, d: &Path, name: &str, f: impl Fn(&Path)) -> PathBuf {
    let to = d.join(name);
    copy_dir(run, &to);
    f(&to);
    to
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let t = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &t);
        } else {
            std::fs::copy(&p, &t).unwrap();
        }
    }
}

/// A broken run folder: its name, how to break a copy of a run, and the words of the message.
type Case = (&'static str, Box<dyn Fn(&Path)>, Vec<&'static str>);

/// `stokes report` on a broken run folder: exit code 2 and a message naming the file and what
/// is wrong with it; nothing written.
#[test]
fn broken_run_folders_are_input_errors() {
    let d = temp_dir("report-broken");
    let run = quick_run("smoke-pt-mono", &d.join("results"));
    let exr = "images/pt-mono__time1__r0.exr";
    let cases: Vec<Case> = vec![
        (
            "no run",
            Box::new(|p: &Path| std::fs::remove_file(p.join("run.json")).unwrap()),
            vec!["no run.json"],
        ),
        (
            "incomplete",
            Box::new(|p: &Path| std::fs::write(p.join("INCOMPLETE"), "experiment 'x'\n").unwrap()),
            vec!["INCOMPLETE", "incomplete run"],
        ),
        (
            "missing image",
            Box::new(move |p: &Path| std::fs::remove_file(p.join(exr)).unwrap()),
            vec![exr, "missing"],
        ),
        (
            "damaged image",
            Box::new(move |p: &Path| {
                let b = std::fs::read(p.join(exr)).unwrap();
                std::fs::write(p.join(exr), &b[..b.len() / 3]).unwrap();
            }),
            vec![exr, "damaged"],
        ),
        (
            "not an image",
            Box::new(|p: &Path| std::fs::write(p.join("reference.exr"), "hello").unwrap()),
            vec!["reference.exr", "not an OpenEXR"],
        ),
        (
            "damaged run.json",
            Box::new(|p: &Path| std::fs::write(p.join("run.json"), "{\"config\": 3").unwrap()),
            vec!["run.json"],
        ),
        (
            "damaged summary",
            Box::new(|p: &Path| {
                std::fs::write(p.join("summary.json"), "[{\"variant\": 1}]").unwrap()
            }),
            vec!["summary.json", "variant"],
        ),
        (
            "no metrics",
            Box::new(|p: &Path| std::fs::remove_file(p.join("metrics.csv")).unwrap()),
            vec!["metrics.csv"],
        ),
    ];
    for (name, f, words) in cases {
        let dir = broken(&run, &d, &name.replace(' ', "-"), f);
        let _ = std::fs::remove_file(dir.join("report.html"));
        expect_input_error(name, stokes(&["report", s(&dir)]), &words);
        assert!(
            !dir.join("report.html").exists(),
            "{name}: a report was written"
        );
    }
    let (code, err) = stokes(&["report", s(&d.join("nothing-here"))]);
    expect_input_error("no folder", (code, err), &["nothing-here", "no run.json"]);
    let _ = std::fs::remove_dir_all(&d);
}

/// Committed results stay lean (results/README.md, "What is committed"): every run committed
/// under `results/` has its `run.json` and figures, every image figure as a PNG (with its text in
/// the pixels), no `report.html` or EXR (both are regenerated: `stokes report`, a new run), and
/// at most 4 MB in all; a run added with a report or large files fails here. What git tracks is
/// checked (`git ls-files`), not what a local run left beside it.
#[test]
fn committed_runs_are_lean() {
    let root = repo();
    let out = std::process::Command::new("git")
        .args(["ls-files", "-z", "results"])
        .current_dir(&root)
        .output();
    let Some(out) = out.ok().filter(|o| o.status.success()) else {
        eprintln!("skipped: not a git work tree (or no git), so nothing committed to check");
        return;
    };
    let files: Vec<String> = out
        .stdout
        .split(|b| *b == 0)
        .filter(|f| !f.is_empty())
        .map(|f| String::from_utf8_lossy(f).into_owned())
        .collect();
    // the run folders: results/<experiment>/runs/<run>/
    let mut runs: std::collections::BTreeMap<String, u64> = Default::default();
    for f in &files {
        let name = f.rsplit('/').next().unwrap();
        assert!(
            name != "report.html" && !name.ends_with(".exr"),
            "{f}: regenerated files are not committed"
        );
        let parts: Vec<&str> = f.split('/').collect();
        if parts.len() > 4 && parts[2] == "runs" {
            let run = parts[..4].join("/");
            let len = std::fs::metadata(root.join(f)).map_or(0, |m| m.len());
            *runs.entry(run).or_default() += len;
        }
    }
    assert!(runs.len() >= 10, "committed runs: {runs:?}");
    for (run, total) in &runs {
        assert!(
            *total <= 4 << 20,
            "{run}: {total} bytes committed (at most 4 MB a run)"
        );
        let dir = root.join(run);
        let info: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("run.json")).unwrap()).unwrap();
        assert!(info["config"]["name"].is_string(), "{run}");
        let figures = dir.join("figures");
        for f in std::fs::read_dir(&figures).unwrap() {
            let p = f.unwrap().path();
            let stem = p.file_stem().unwrap().to_str().unwrap().to_string();
            let image = ["image-grid", "crops", "parameter-grid", "difference"];
            if p.extension().is_some_and(|e| e == "svg") && image.contains(&stem.as_str()) {
                assert!(
                    figures.join(format!("{stem}.png")).is_file(),
                    "{run}: {stem}.svg without its PNG"
                );
            }
        }
    }
}
