//! Cases about files rather than their contents (docs/hardening.md, second round):
//!
//! - `special-file`: an input that is a FIFO with no writer, `/dev/zero`, `/dev/urandom`, a
//!   link to a device, or a folder, in the place of a scene, a file a scene names (spectrum CSV,
//!   BFC matrix, `.vol` grid, OBJ mesh, Gaussian-mixture model), a config, a file given to
//!   `gmm fit`/`gmm dense`, or a file of a run record;
//! - `output`: an output of `render` or `gmm dense` onto a device, a FIFO, a folder, a dangling
//!   link or a link to a device, or with a name too long for the file system (all refused), or a
//!   non-ASCII name in a folder of that kind (written);
//! - `run-folder`: a finished planned run whose files or links are edited by hand (links out of
//!   the run folder and its results root, FIFOs, mutated `plan.json` and `jobs.jsonl` fields),
//!   then `stokes job`, `--collect`, `figures` or `report`.
//!
//! Each case guards the paths it must not change: the special files themselves, and for run
//! folders a folder outside the results root that the links point into plus every file beside
//! the results root. A guard that changed fails the case whatever the exit code.

use super::corpus::{
    Base, Case, Check, Kind, experiment_case, has_key_with_ext, plain_case, render_case,
    replace_one_file, s, walk,
};
use super::json::Json;
use super::mutate;
use rand::Rng;
use rand::seq::IndexedRandom;
use rand_pcg::Pcg64;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};

/// What is at `p` now, not following links: its type, and a hash of a file's bytes or of a
/// folder's whole tree.
pub fn fingerprint(p: &Path) -> String {
    let Ok(m) = std::fs::symlink_metadata(p) else {
        return "absent".into();
    };
    let ft = m.file_type();
    if ft.is_symlink() {
        format!("link {:?}", std::fs::read_link(p).ok())
    } else if ft.is_file() {
        let b = std::fs::read(p).unwrap_or_default();
        format!("file {} {:x}", b.len(), fnv(&b))
    } else if ft.is_dir() {
        let mut entries: Vec<String> = std::fs::read_dir(p)
            .map(|rd| {
                rd.flatten()
                    .map(|e| format!("{:?}={}", e.file_name(), fingerprint(&e.path())))
                    .collect()
            })
            .unwrap_or_default();
        entries.sort();
        format!("dir [{}]", entries.join(", "))
    } else if ft.is_fifo() {
        "fifo".into()
    } else if ft.is_char_device() {
        use std::os::unix::fs::MetadataExt;
        format!("char device {}", m.rdev())
    } else {
        "special".into()
    }
}

fn fnv(b: &[u8]) -> u64 {
    b.iter().fold(0xcbf29ce484222325u64, |h, &x| {
        (h ^ x as u64).wrapping_mul(0x100000001b3)
    })
}

/// Guard `p`: the case fails if it is not the same after the run.
pub fn guard(c: &mut Case, p: &Path) {
    c.guards.push((p.to_path_buf(), fingerprint(p)));
}

/// The guards of `case` that changed, described.
pub fn changed_guards(case: &Case) -> Vec<String> {
    case.guards
        .iter()
        .filter(|(p, before)| fingerprint(p) != *before)
        .map(|(p, before)| {
            // what it is, without hashes and sizes (the failure classes group by message)
            let kind = |f: &str| {
                f.split([' ', '['])
                    .take(if f.starts_with("char") { 2 } else { 1 })
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            let now = fingerprint(p);
            let (a, b) = (kind(before), kind(&now));
            if a == b {
                format!("{} changed: its {a} contents changed", p.display())
            } else {
                format!("{} changed: was {a}, now {b}", p.display())
            }
        })
        .collect()
}

fn mkfifo(p: &Path) {
    let _ = std::fs::remove_file(p);
    if let Some(d) = p.parent() {
        std::fs::create_dir_all(d).unwrap();
    }
    let ok = std::process::Command::new("mkfifo")
        .arg(p)
        .status()
        .is_ok_and(|st| st.success());
    assert!(ok, "mkfifo {}", p.display());
}

/// A character device named `p` (the null device) where this process may make one (root),
/// else a link to /dev/null.
fn device(p: &Path) {
    let _ = std::fs::remove_file(p);
    let made = std::process::Command::new("mknod")
        .args([&s(p), "c", "1", "3"])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|st| st.success());
    if !made {
        std::os::unix::fs::symlink("/dev/null", p).unwrap();
    }
}

/// A special input at `p` (made there, or a system path): its description and its path.
fn special_input(rng: &mut Pcg64, p: &Path) -> (String, PathBuf) {
    match rng.random_range(0..6) {
        0 | 1 => {
            mkfifo(p);
            ("a FIFO with no writer".into(), p.to_path_buf())
        }
        2 => ("/dev/zero".into(), "/dev/zero".into()),
        3 => ("/dev/urandom".into(), "/dev/urandom".into()),
        4 => {
            let _ = std::fs::remove_file(p);
            std::os::unix::fs::symlink("/dev/zero", p).unwrap();
            ("a link to /dev/zero".into(), p.to_path_buf())
        }
        _ => {
            std::fs::create_dir_all(p).unwrap();
            ("a folder".into(), p.to_path_buf())
        }
    }
}

/// The text of `p` if it is a regular file (an earlier edit may have made it a FIFO).
fn read_regular(p: &Path) -> Result<String, ()> {
    if !std::fs::symlink_metadata(p).is_ok_and(|m| m.is_file()) {
        return Err(());
    }
    std::fs::read_to_string(p).map_err(drop)
}

impl Base {
    /// An input that is not a regular file.
    pub fn special_case(&self, rng: &mut Pcg64, dir: &Path) -> Case {
        let slot = rng.random_range(0..10);
        let ext = [
            "json", "csv", "BFC", "vol", "obj", "json", "json", "BFC", "json", "json",
        ][slot];
        let (what, special) = special_input(rng, &dir.join(format!("special.{ext}")));
        let mut c = match slot {
            0 => {
                let mut c = render_case(rng, dir, &special);
                c.input = "a scene".into();
                c
            }
            1..=3 => {
                let scenes: Vec<&(String, Json)> = self
                    .scenes
                    .iter()
                    .filter(|(_, d)| !super::corpus::file_strings(d, ext).is_empty())
                    .collect();
                let (name, scene) = *scenes.choose(rng).unwrap();
                let path = dir.join("scene.json");
                let note = replace_one_file(rng, scene, ext, &special, &path);
                let mut c = render_case(rng, dir, &path);
                c.input = format!("a .{ext} of {name} ({note})");
                c
            }
            4 => {
                let mut c = self.obj_unmutated(&dir.join("obj"));
                let scene = c.args[1].clone();
                let text = std::fs::read_to_string(&scene).unwrap();
                let obj = s(&dir.join("obj").join("cube.obj"));
                std::fs::write(&scene, text.replace(&obj, &s(&special))).unwrap();
                c.input = "an OBJ mesh".into();
                c
            }
            5 => {
                let scenes: Vec<&(String, Json)> = self
                    .scenes
                    .iter()
                    .filter(|(_, d)| has_key_with_ext(d, "bfc", "BFC"))
                    .collect();
                let (name, scene) = *scenes.choose(rng).unwrap();
                let mut scene = scene.clone();
                if let Some(Json::Obj(m)) = scene.get_mut("materials")
                    && let Some((_, v)) = m.iter_mut().find(|(_, v)| v.get("bfc").is_some())
                {
                    *v = Json::Obj(vec![
                        ("type".into(), Json::Str("reradiation-gmm".into())),
                        ("file".into(), Json::Str(s(&special))),
                    ]);
                }
                let path = dir.join("scene.json");
                std::fs::write(&path, scene.to_text()).unwrap();
                let mut c = render_case(rng, dir, &path);
                c.input = format!("a Gaussian-mixture model of {name}");
                c
            }
            6 => {
                let mut c = experiment_case(dir, &special);
                c.input = "a config".into();
                c
            }
            7 | 8 => {
                let (sub, out, what) = if slot == 7 {
                    ("fit", "fit.json", "the BFC of gmm fit")
                } else {
                    ("dense", "dense.bfc", "the model of gmm dense")
                };
                let args = ["gmm", sub, &s(&special), "-o", &s(&dir.join(out))];
                let mut c = plain_case(dir, args.map(String::from).to_vec());
                c.input = what.into();
                c
            }
            _ => {
                // A file of a run record, for `stokes figures`.
                let (label, src) = self.runs.choose(rng).unwrap();
                let run = dir.join("run");
                super::corpus::copy_run(src, &run);
                let files: Vec<PathBuf> = walk(&run)
                    .into_iter()
                    .filter(|p| p.extension().is_some_and(|e| e == "json" || e == "csv"))
                    .collect();
                let f = files.choose(rng).unwrap().clone();
                std::fs::remove_file(&f).unwrap();
                match rng.random_range(0..3) {
                    0 => mkfifo(&f),
                    1 => std::os::unix::fs::symlink("/dev/zero", &f).unwrap(),
                    _ => std::fs::create_dir(&f).unwrap(),
                }
                let mut c = plain_case(dir, vec!["figures".into(), s(&run)]);
                c.input = format!("{} of {label}", f.strip_prefix(&run).unwrap().display());
                c
            }
        };
        guard(&mut c, &special);
        c.kind = Kind::Special;
        c.mutation = format!("as {what}");
        c
    }

    /// An output that is not a regular file, or whose name is odd.
    pub fn output_case(&self, rng: &mut Pcg64, dir: &Path) -> Case {
        let (_, scene) = self
            .scenes
            .iter()
            .find(|(n, _)| n.ends_with("cornell-box.json"))
            .unwrap();
        let scene_path = dir.join("scene.json");
        std::fs::write(&scene_path, scene.to_text()).unwrap();
        let mut c = render_case(rng, dir, &scene_path);
        let which = *["-o", "--stats", "--png"].choose(rng).unwrap();
        let ext = match which {
            "-o" => "exr",
            "--stats" => "json",
            _ => "png",
        };
        let how = rng.random_range(0..9);
        let target = match how {
            7 => {
                // non-ASCII names in a non-ASCII folder: written
                let d = dir.join("场景 ☃");
                std::fs::create_dir_all(&d).unwrap();
                d.join(format!("ä😀.{ext}"))
            }
            8 => dir.join(format!("{}.{ext}", "n".repeat(rng.random_range(250..6000)))),
            _ => dir.join(format!("target.{ext}")),
        };
        let what = match how {
            0 | 1 => {
                device(&target);
                "a device (or a link to /dev/null)"
            }
            2 => {
                mkfifo(&target);
                "a FIFO"
            }
            3 => {
                std::fs::create_dir_all(&target).unwrap();
                "a folder"
            }
            4 => {
                std::os::unix::fs::symlink(dir.join("missing/none"), &target).unwrap();
                "a dangling link"
            }
            5 => {
                std::os::unix::fs::symlink("/dev/full", &target).unwrap();
                "a link to /dev/full"
            }
            6 => {
                std::fs::write(&target, "an earlier output").unwrap();
                "an existing regular file"
            }
            7 => "a non-ASCII name",
            _ => "a name too long for the file system",
        };
        match which {
            "-o" => {
                let i = c.args.iter().position(|a| a == "-o").unwrap();
                c.args[i + 1] = s(&target);
                if let Check::Render { exr, .. } = &mut c.check {
                    *exr = target.clone();
                }
            }
            "--stats" => {
                let i = c.args.iter().position(|a| a == "--stats").unwrap();
                c.args[i + 1] = s(&target);
                if let Check::Render { stats, .. } = &mut c.check {
                    *stats = target.clone();
                }
            }
            _ => {
                c.args.push("--png".into());
                c.args.push(s(&target));
            }
        }
        if how <= 5 {
            guard(&mut c, &target);
            if how == 5 {
                guard(&mut c, Path::new("/dev/full"));
            }
        }
        c.kind = Kind::Output;
        c.input = format!("render {which}");
        c.mutation = format!("onto {what}");
        c
    }

    /// A finished planned run with one to three hand edits, then a command on it.
    pub fn run_folder_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let (src, run_rel) = self.planned.clone().expect("the planned run of the setup");
        super::corpus::copy_tree(&src.join("results"), &dir.join("results"));
        let run = dir.join(&run_rel);
        // `<root>/<name>/runs/<ts>`
        let root = run.ancestors().nth(3).unwrap().to_path_buf();
        let outside = dir.join("outside");
        std::fs::create_dir_all(outside.join("jobs/00000")).unwrap();
        for f in [
            "reference.exr",
            "done.json",
            "latest",
            "jobs/00000/reference.exr",
        ] {
            std::fs::write(outside.join(f), "outside the run: never written").unwrap();
        }
        let mut done = Vec::new();
        for _ in 0..n {
            done.push(self.edit_run(rng, &run, &root, &outside));
        }
        let njobs = std::fs::read_to_string(src.join(&run_rel).join("jobs.jsonl"))
            .map(|t| t.lines().count())
            .unwrap_or(1);
        let args: Vec<String> = match rng.random_range(0..10) {
            0..=3 => vec![
                "job".into(),
                s(&run),
                rng.random_range(0..njobs).to_string(),
            ],
            4 => vec!["job".into(), s(&run), "--all".into()],
            5..=7 => vec!["experiment".into(), "--collect".into(), s(&run)],
            8 => vec!["figures".into(), s(&run)],
            _ => vec!["report".into(), s(&run)],
        };
        let mut c = plain_case(dir, args);
        guard(&mut c, &outside);
        c.kind = Kind::RunFolder;
        c.input = "a finished planned run".into();
        c.mutation = done.join("; ");
        c
    }

    /// One hand edit of the run folder `run` (in the results root `root`). An edit whose path
    /// passes through a link that an earlier edit made is skipped (it would edit the outside).
    fn edit_run(&self, rng: &mut Pcg64, run: &Path, root: &Path, outside: &Path) -> String {
        let base = root.parent().unwrap().to_path_buf();
        let through_link = |p: &Path| {
            p.ancestors()
                .skip(1)
                .take_while(|a| a.starts_with(&base) && *a != base)
                .any(|a| std::fs::symlink_metadata(a).is_ok_and(|m| m.file_type().is_symlink()))
        };
        let relink = |p: &Path, to: &Path| {
            if std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir()) {
                std::fs::remove_dir_all(p).unwrap();
            } else {
                let _ = std::fs::remove_file(p);
            }
            if let Some(d) = p.parent() {
                std::fs::create_dir_all(d).unwrap();
            }
            std::os::unix::fs::symlink(to, p).unwrap();
        };
        let name = run
            .parent()
            .and_then(Path::parent)
            .and_then(Path::file_name)
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match rng.random_range(0..12) {
            0 => {
                let f = *[
                    "jobs",
                    "jobs/00000",
                    "images",
                    "figures",
                    "jobs/00001/done.json",
                ]
                .choose(rng)
                .unwrap();
                if through_link(&run.join(f)) {
                    return format!("{f} (skipped: behind a link)");
                }
                let to = if f.ends_with(".json") {
                    outside.join("done.json")
                } else {
                    outside.to_path_buf()
                };
                relink(&run.join(f), &to);
                format!("{f} links outside")
            }
            1 => {
                relink(&root.join("references"), outside);
                "references/ links outside".into()
            }
            2 => {
                relink(&root.join(&name).join("latest"), &outside.join("latest"));
                "<name>/latest links outside".into()
            }
            3 => {
                let f = *["plan.json", "jobs.jsonl", "jobs/00000/done.json"]
                    .choose(rng)
                    .unwrap();
                if through_link(&run.join(f)) {
                    return format!("{f} (skipped: behind a link)");
                }
                if rng.random_bool(0.5) {
                    mkfifo(&run.join(f));
                    format!("{f} is a FIFO")
                } else {
                    relink(&run.join(f), Path::new("/dev/zero"));
                    format!("{f} links to /dev/zero")
                }
            }
            4..=7 => {
                // plan.json, field by field: paths, names, numbers
                let p = run.join("plan.json");
                let Ok(text) = read_regular(&p) else {
                    return "plan.json (already edited)".into();
                };
                let Ok(mut doc) = Json::parse(&text) else {
                    return "plan.json (already edited)".into();
                };
                let strings = vec![
                    s(outside),
                    format!("../../../../../../{}", s(outside)),
                    "..".into(),
                    "../x".into(),
                    "/dev/zero".into(),
                    s(root),
                    "results".into(),
                ];
                let d = mutate::json(rng, &mut doc, 1, &strings);
                let tail = if rng.random_bool(0.1) { "\0" } else { "" };
                std::fs::write(&p, format!("{}{tail}", doc.to_text())).unwrap();
                format!(
                    "plan.json: {}{}",
                    d.join("; "),
                    if tail.is_empty() { "" } else { " + NUL" }
                )
            }
            _ => {
                // one line of jobs.jsonl; the job is run again
                let p = run.join("jobs.jsonl");
                let Ok(text) = read_regular(&p) else {
                    return "jobs.jsonl (already edited)".into();
                };
                let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
                if lines.is_empty() {
                    return "jobs.jsonl (empty)".into();
                }
                let i = rng.random_range(0..lines.len());
                let Ok(mut doc) = Json::parse(&lines[i]) else {
                    return "jobs.jsonl (already edited)".into();
                };
                let d = mutate::json(rng, &mut doc, 1, &self.strings);
                lines[i] = doc.to_text().replace('\n', " ");
                std::fs::write(&p, lines.join("\n") + "\n").unwrap();
                let job = run.join(format!("jobs/{i:05}"));
                if !through_link(&job)
                    && !std::fs::symlink_metadata(&job).is_ok_and(|m| m.is_symlink())
                {
                    let _ = std::fs::remove_dir_all(job);
                }
                format!("jobs.jsonl line {}: {}", i + 1, d.join("; "))
            }
        }
    }
}
