//! A planned run folder is untrusted input (docs/hardening.md): after any hand edit of its files
//! or links, `stokes job`, `stokes experiment --collect`, `stokes figures` and `stokes report`
//! write nothing outside the run folder and the results root it lies in. Each edit below is made
//! on a fresh copy of one finished planned run; a folder outside the results root (which the
//! links point into, holding a `reference.exr` of its own) and every file outside the results
//! root are compared before and after. Each command must end within 20 s with exit 0, or with
//! exit 2 and a message naming the file.
#![cfg(unix)]

mod common;

use common::{bin, repo, s};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn run_in(cwd: &Path, args: &[&str]) -> (i32, String) {
    common::run_limited(cwd, args)
}

/// Every entry under `dir` (not following links) with what it is and, for a file, its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    fn walk(base: &Path, d: &Path, out: &mut BTreeMap<PathBuf, String>) {
        let Ok(rd) = std::fs::read_dir(d) else {
            return;
        };
        for e in rd.flatten() {
            let p = e.path();
            let ft = e.file_type().unwrap();
            let rel = p.strip_prefix(base).unwrap().to_path_buf();
            if ft.is_symlink() {
                out.insert(rel, format!("link {:?}", std::fs::read_link(&p).unwrap()));
            } else if ft.is_dir() {
                out.insert(rel, "dir".into());
                walk(base, &p, out);
            } else if ft.is_file() {
                let bytes = std::fs::read(&p).unwrap();
                out.insert(rel, format!("file {} {:x}", bytes.len(), hash(&bytes)));
            } else {
                out.insert(rel, "special".into());
            }
        }
    }
    walk(dir, dir, &mut out);
    out
}

fn hash(b: &[u8]) -> u64 {
    b.iter().fold(0xcbf29ce484222325u64, |h, &x| {
        (h ^ x as u64).wrapping_mul(0x100000001b3)
    })
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let (p, t) = (e.path(), to.join(e.file_name()));
        if e.file_type().unwrap().is_dir() {
            copy_tree(&p, &t);
        } else {
            std::fs::copy(&p, &t).unwrap();
        }
    }
}

/// A finished planned run in a results root: `<base>/results/edits/runs/<ts>`, every job done,
/// not yet collected. Returns the run folder's path relative to `base`.
fn finished_run(base: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenes/fluorescent-walls.json")).unwrap();
    let mut scene: Value = serde_json::from_str(&text).unwrap();
    scene["camera"]["width"] = 16.into();
    scene["camera"]["height"] = 16.into();
    let sp = base.join("walls.json");
    std::fs::write(&sp, scene.to_string()).unwrap();
    let cfg = base.join("edits.json");
    let c = json!({
        "name": "edits", "scene": s(&sp),
        "reference": {"integrator": "pt-hero", "spp": 16, "seed": 3},
        "variants": [{"name": "a", "integrator": "pt-mono"}],
        "budget": {"spp": [1, 2], "seconds": [0.05]}, "repeats": 1
    });
    std::fs::write(&cfg, c.to_string()).unwrap();
    std::fs::create_dir_all(base.join("cwd")).unwrap();
    // planned in the default results root of the working folder: `<base>/results`
    let o = Command::new(bin())
        .current_dir(base)
        .args(["experiment", s(&cfg), "--plan", "--reference-shards", "2"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
    let r = run_in(base, &["job", s(&run), "--all"]);
    assert_eq!(r.0, 0, "{}", r.1);
    run.strip_prefix(base).unwrap().to_path_buf()
}

/// What one edit does to a fresh copy of the run (`run` is its folder, `root` the results root,
/// `outside` a folder outside the root), and the commands to try on it.
struct Edit {
    what: &'static str,
    edit: fn(run: &Path, root: &Path, outside: &Path),
    commands: &'static [&'static [&'static str]],
}

fn set_plan(run: &Path, key: &str, v: Value) {
    let p = run.join("plan.json");
    let mut plan: Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    plan[key] = v;
    std::fs::write(&p, serde_json::to_string_pretty(&plan).unwrap()).unwrap();
}

fn edit_job(run: &Path, index: usize, f: impl Fn(&mut Value)) {
    let p = run.join("jobs.jsonl");
    let mut lines: Vec<Value> = std::fs::read_to_string(&p)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    f(&mut lines[index]);
    let text: String = lines.iter().map(|l| l.to_string() + "\n").collect();
    std::fs::write(&p, text).unwrap();
    // the job must run again
    let _ = std::fs::remove_dir_all(run.join(format!("jobs/{index:05}")));
}

fn relink(p: &Path, to: &Path) {
    if p.is_dir() && !p.is_symlink() {
        std::fs::remove_dir_all(p).unwrap();
    } else {
        let _ = std::fs::remove_file(p);
    }
    std::os::unix::fs::symlink(to, p).unwrap();
}

fn mkfifo(p: &Path) {
    let _ = std::fs::remove_file(p);
    assert!(Command::new("mkfifo").arg(p).status().unwrap().success());
}

const JOB0: &[&str] = &["job", "RUN", "0"];
const ALL: &[&str] = &["job", "RUN", "--all"];
const COLLECT: &[&str] = &["experiment", "--collect", "RUN"];
const FIGURES: &[&str] = &["figures", "RUN"];
const REPORT: &[&str] = &["report", "RUN"];

fn edits() -> Vec<Edit> {
    vec![
        Edit {
            what: "jobs/ is a link outside",
            edit: |run, _, out| relink(&run.join("jobs"), out),
            commands: &[JOB0, ALL, COLLECT],
        },
        Edit {
            what: "jobs/00000 is a link to a folder holding a reference.exr",
            edit: |run, _, out| relink(&run.join("jobs/00000"), out),
            commands: &[JOB0, COLLECT],
        },
        Edit {
            what: "images/ is a link outside",
            edit: |run, _, out| relink(&run.join("images"), out),
            commands: &[COLLECT],
        },
        Edit {
            what: "figures/ is a link outside (after collect)",
            edit: |run, _, out| {
                let r = run_in(run, &["experiment", "--collect", s(run)]);
                assert_eq!(r.0, 0, "{}", r.1);
                relink(&run.join("figures"), out)
            },
            commands: &[FIGURES, REPORT],
        },
        Edit {
            what: "a job's done.json is a link to a file outside",
            edit: |run, _, out| relink(&run.join("jobs/00001/done.json"), &out.join("done.json")),
            commands: &[JOB0, COLLECT],
        },
        Edit {
            what: "references/ of the results root is a link outside",
            edit: |_, root, out| relink(&root.join("references"), out),
            commands: &[COLLECT],
        },
        Edit {
            what: "<name>/latest is a link to a file outside",
            edit: |_, root, out| relink(&root.join("edits/latest"), &out.join("latest")),
            commands: &[COLLECT],
        },
        Edit {
            what: "<name>/latest is a FIFO",
            edit: |_, root, _| mkfifo(&root.join("edits/latest")),
            commands: &[COLLECT],
        },
        Edit {
            what: "plan.json `root` names a folder outside",
            edit: |run, _, out| set_plan(run, "root", s(out).into()),
            commands: &[JOB0, COLLECT],
        },
        Edit {
            what: "plan.json `name` climbs out of the root",
            edit: |run, _, out| {
                set_plan(run, "name", format!("../../../../../../{}", s(out)).into())
            },
            commands: &[JOB0, COLLECT],
        },
        Edit {
            what: "plan.json `run_name` holds ..",
            edit: |run, _, _| set_plan(run, "run_name", "../../x".into()),
            commands: &[COLLECT],
        },
        Edit {
            what: "plan.json `config_file` is /dev/zero",
            edit: |run, _, _| set_plan(run, "config_file", "/dev/zero".into()),
            commands: &[JOB0, COLLECT],
        },
        Edit {
            what: "plan.json has trailing data",
            edit: |run, _, _| {
                let p = run.join("plan.json");
                let t = std::fs::read_to_string(&p).unwrap();
                std::fs::write(&p, t + "\0junk").unwrap();
            },
            commands: &[JOB0],
        },
        Edit {
            what: "jobs.jsonl is a FIFO",
            edit: |run, _, _| mkfifo(&run.join("jobs.jsonl")),
            commands: &[JOB0, COLLECT],
        },
        Edit {
            what: "a reference shard of 2³² − 1 samples",
            edit: |run, _, _| edit_job(run, 0, |j| j["work"]["samples"] = json!([0u32, u32::MAX])),
            commands: &[JOB0],
        },
        Edit {
            what: "a reference shard outside the reference",
            edit: |run, _, _| edit_job(run, 0, |j| j["work"]["samples"] = json!([16, 4096])),
            commands: &[JOB0],
        },
        Edit {
            what: "a budget of 10¹² spp",
            edit: |run, _, _| {
                for i in 2..4 {
                    edit_job(run, i, |j| {
                        if j["work"]["mode"] == "spp" {
                            j["work"]["budgets"] = json!([1e12])
                        }
                    })
                }
            },
            commands: &[ALL],
        },
        Edit {
            what: "a time budget of 10⁹ s",
            edit: |run, _, _| {
                for i in 2..4 {
                    edit_job(run, i, |j| {
                        if j["work"]["mode"] == "time" {
                            j["work"]["budgets"] = json!([1e9])
                        }
                    })
                }
            },
            commands: &[ALL],
        },
        Edit {
            what: "a time budget of 1000 s (within the bounds, not the config's)",
            edit: |run, _, _| {
                for i in 2..4 {
                    edit_job(run, i, |j| {
                        if j["work"]["mode"] == "time" {
                            j["work"]["budgets"] = json!([1000.0])
                        }
                    })
                }
            },
            commands: &[ALL],
        },
    ]
}

#[test]
fn no_edit_of_a_run_folder_writes_outside_it() {
    let pristine = common::temp_dir("hr-pristine");
    let pristine = std::fs::canonicalize(&pristine).unwrap();
    let run_rel = finished_run(&pristine);
    let mut failures = Vec::new();
    for (n, e) in edits().into_iter().enumerate() {
        let base = std::fs::canonicalize(common::temp_dir(&format!("hr-edit{n}"))).unwrap();
        copy_tree(&pristine, &base);
        let run = base.join(&run_rel);
        // results/<name>/runs/<ts>: the root is three levels up
        let root = run.ancestors().nth(3).unwrap().to_path_buf();
        let outside = base.join("outside");
        std::fs::create_dir_all(&outside).unwrap();
        std::fs::write(outside.join("reference.exr"), "not to be replaced").unwrap();
        std::fs::write(outside.join("done.json"), "{}").unwrap();
        std::fs::write(outside.join("latest"), "runs/x\n").unwrap();
        (e.edit)(&run, &root, &outside);
        let before_outside = snapshot(&outside);
        let before_base: BTreeMap<PathBuf, String> = snapshot(&base)
            .into_iter()
            .filter(|(p, _)| !p.starts_with(root.strip_prefix(&base).unwrap()))
            .collect();
        for cmd in e.commands {
            let args: Vec<&str> = cmd
                .iter()
                .map(|a| if *a == "RUN" { s(&run) } else { a })
                .collect();
            let (code, err) = run_in(&base.join("cwd"), &args);
            let named = err.contains(".json")
                || err.contains(".jsonl")
                || err.contains(s(&base))
                || err.contains("/dev/zero");
            let fine = code == 0 || (code == 2 && named && !err.contains("panicked"));
            if !fine {
                failures.push(format!("{}: stokes {cmd:?}: exit {code}: {err}", e.what));
            }
        }
        let after_base: BTreeMap<PathBuf, String> = snapshot(&base)
            .into_iter()
            .filter(|(p, _)| !p.starts_with(root.strip_prefix(&base).unwrap()))
            .collect();
        if snapshot(&outside) != before_outside || after_base != before_base {
            failures.push(format!(
                "{}: something outside the results root changed",
                e.what
            ));
        }
        if failures.is_empty() {
            let _ = std::fs::remove_dir_all(&base);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let _ = std::fs::remove_dir_all(&pristine);
}

/// A hand-edited `jobs.jsonl` whose work differs from the config's is refused, naming the job;
/// an untouched copy of the run (the same edits undone) still collects to the same metrics.
#[test]
fn edited_work_is_refused_and_an_intact_copy_still_collects() {
    let base = std::fs::canonicalize(common::temp_dir("hr-intact")).unwrap();
    let run = base.join(finished_run(&base));
    let copy = base.join("copy");
    copy_tree(run.ancestors().nth(3).unwrap(), &copy);
    edit_job(&run, 2, |j| j["work"]["budgets"] = json!([1, 4]));
    let (code, err) = run_in(&base, &["job", s(&run), "2"]);
    common::expect_input_error(
        "edited budgets",
        (code, err),
        &["job 2", "not the config's"],
    );
    let (code, err) = run_in(&base, &["experiment", "--collect", s(&run)]);
    assert_eq!(code, 2, "the edited job has not finished: {err}");
    let moved = copy.join(run.strip_prefix(run.ancestors().nth(3).unwrap()).unwrap());
    let (code, err) = run_in(&base, &["experiment", "--collect", s(&moved)]);
    assert_eq!(
        code, 0,
        "a run copied with its results root collects there: {err}"
    );
    assert!(copy.join("edits/latest").is_file());
    assert!(std::fs::read_dir(copy.join("references")).unwrap().count() > 0);
    let _ = std::fs::remove_dir_all(&base);
}
