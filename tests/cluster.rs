//! Experiments as planned runs of independent jobs (`stokes experiment --plan`, `stokes job`,
//! `stokes experiment --collect`, `--slurm`), through the binary: a planned run gives the
//! results of a run on one machine; a finished job is skipped; a killed job leaves nothing the
//! collect step accepts, and the collect step names the missing and the failed jobs; the plan
//! files are read back as untrusted input (exit code 2, a message naming the file); Slurm
//! scripts are written without submitting under `--dry-run`.

mod common;

use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{bin, repo, s};

/// What a finished `stokes` process said.
struct Out {
    code: i32,
    stdout: String,
    stderr: String,
}

/// `stokes ARGS` run in the folder `cwd` (so that nothing lands in the repository), without the
/// Slurm variables of the environment the tests run in.
fn cmd(cwd: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(bin());
    c.args(args).current_dir(cwd);
    for v in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_JOB_ID",
        "SLURM_JOB_ID",
        "SLURM_CPUS_PER_TASK",
        "STOKES_JOB_OFFSET",
    ] {
        c.env_remove(v);
    }
    c
}

fn output(mut c: Command) -> Out {
    let o = c.output().unwrap();
    Out {
        code: o.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&o.stdout).to_string(),
        stderr: String::from_utf8_lossy(&o.stderr).to_string(),
    }
}

fn stokes(cwd: &Path, args: &[&str]) -> Out {
    output(cmd(cwd, args))
}

/// `stokes ARGS` must succeed.
fn ok(cwd: &Path, args: &[&str]) -> Out {
    let o = stokes(cwd, args);
    assert_eq!(
        o.code, 0,
        "stokes {args:?}: exit code {}, stderr: {}",
        o.code, o.stderr
    );
    o
}

/// Exit code 2, no panic, and every one of `names` in the message.
fn expect_input_error(what: &str, o: &Out, names: &[&str]) {
    assert_eq!(
        o.code, 2,
        "{what}: exit code {}, stderr: {}",
        o.code, o.stderr
    );
    assert!(
        !o.stderr.contains("panicked"),
        "{what}: panic: {}",
        o.stderr
    );
    for n in names {
        assert!(
            o.stderr.contains(n),
            "{what}: message does not name `{n}`: {}",
            o.stderr
        );
    }
}

/// A test's folders: `root` for its files, `cwd` (empty) to run the binary in.
struct Dirs {
    root: PathBuf,
    cwd: PathBuf,
}

impl Dirs {
    fn new(tag: &str) -> Dirs {
        let root = common::temp_dir(tag);
        let root = std::fs::canonicalize(&root).unwrap();
        let cwd = root.join("cwd");
        std::fs::create_dir_all(&cwd).unwrap();
        Dirs { root, cwd }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.root.join(name)
    }
}

impl Drop for Dirs {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.root);
        }
    }
}

/// `scenes/fluorescent-walls.json` (no external files) with a `size`×`size` camera, written to
/// `dir/walls.json`.
fn walls(dir: &Path, size: u32) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenes/fluorescent-walls.json")).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["camera"]["width"] = size.into();
    v["camera"]["height"] = size.into();
    let p = dir.join("walls.json");
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    p
}

/// Write the config `v` to `dir/file`.
fn config(dir: &Path, file: &str, v: Value) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    p
}

/// Two variants at an spp ladder, two repeats, a rendered reference, regions, crop and scanline
/// on a 24×24 scene: with `--reference-shards 4`, jobs 0–3 are the reference's shards and 4–7
/// the renders.
fn spp_config(d: &Dirs) -> PathBuf {
    let scene = walls(&d.root, 24);
    config(
        &d.root,
        "same.json",
        json!({
            "name": "same",
            "scene": s(&scene),
            "reference": { "integrator": "pt-hero", "spp": 64, "seed": 5 },
            "variants": [
                { "name": "pt-mono", "integrator": "pt-mono" },
                { "name": "bdpt-forward", "integrator": "bdpt-forward" }
            ],
            "budget": { "spp": [2, 4] },
            "repeats": 2,
            "regions": { "by": "shape" },
            "crop": { "x": 4, "y": 4, "w": 8, "h": 8 },
            "scanline": { "row": 8 }
        }),
    )
}

/// Plan `cfg` into `run` (with `extra` options); returns the printed run folder.
fn plan(d: &Dirs, cfg: &Path, run: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec!["experiment", s(cfg), "--plan", "--out", s(run)];
    args.extend_from_slice(extra);
    let o = ok(&d.cwd, &args);
    PathBuf::from(o.stdout.trim())
}

/// The lines of a run's `jobs.jsonl`.
fn job_lines(run: &Path) -> Vec<Value> {
    std::fs::read_to_string(run.join("jobs.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn job_dir(run: &Path, i: usize) -> PathBuf {
    run.join(format!("jobs/{i:05}"))
}

/// The single run folder `<root>/<name>/runs/<ts>` of a direct run, via `latest`.
fn latest_run(root: &Path, name: &str) -> PathBuf {
    let latest = std::fs::read_to_string(root.join(name).join("latest")).unwrap();
    root.join(name).join(latest.trim())
}

/// Files under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(
                    p.strip_prefix(base)
                        .unwrap()
                        .to_string_lossy()
                        .replace('\\', "/"),
                );
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Columns of metrics.csv that hold measured times, which differ between any two runs.
const TIMED: [&str; 3] = ["seconds", "samples_per_second", "efficiency"];

/// Same header, same rows, every column but the measured times identical as text.
fn assert_same_metrics(what: &str, a: &Path, b: &Path) {
    let (ta, tb) = (
        std::fs::read_to_string(a).unwrap(),
        std::fs::read_to_string(b).unwrap(),
    );
    let (la, lb): (Vec<&str>, Vec<&str>) = (ta.lines().collect(), tb.lines().collect());
    assert_eq!(la[0], lb[0], "{what}: header");
    assert_eq!(la.len(), lb.len(), "{what}: rows");
    let header: Vec<&str> = la[0].split(',').collect();
    for t in TIMED {
        assert!(header.contains(&t), "{what}: no column {t}");
    }
    for (ra, rb) in la[1..].iter().zip(&lb[1..]) {
        let (ca, cb): (Vec<&str>, Vec<&str>) = (ra.split(',').collect(), rb.split(',').collect());
        assert_eq!(ca.len(), header.len(), "{what}: {ra}");
        assert_eq!(cb.len(), header.len(), "{what}: {rb}");
        for (k, h) in header.iter().enumerate() {
            if !TIMED.contains(h) {
                assert_eq!(ca[k], cb[k], "{what}: column {h} of\n  {ra}\n  {rb}");
            }
        }
    }
}

/// A collected planned run (`cluster`) holds the files of the direct run (`direct`) and the
/// plan's own (plan.json, jobs.jsonl, jobs.csv, jobs/), and they are the same: EXRs, PNGs,
/// regions and every figure except those over measured seconds byte-identical; metrics equal
/// but for the measured times; run.json equal but for its start time.
fn assert_same_results(what: &str, cluster: &Path, direct: &Path) {
    let own = ["plan.json", "jobs.jsonl", "jobs.csv"];
    let cf: Vec<String> = files(cluster)
        .into_iter()
        .filter(|f| !own.contains(&f.as_str()) && !f.starts_with("jobs/"))
        .collect();
    let df = files(direct);
    assert_eq!(cf, df, "{what}: the files of the two runs");
    assert!(
        df.iter().any(|f| f.ends_with("metrics.csv")),
        "{what}: {df:?}"
    );
    for f in &df {
        let (a, b) = (cluster.join(f), direct.join(f));
        let name = f.rsplit('/').next().unwrap();
        if name == "metrics.csv" {
            assert_same_metrics(&format!("{what}: {f}"), &a, &b);
        } else if name == "run.json" {
            let strip = |p: &Path| {
                let mut v: Value =
                    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
                v.as_object_mut().unwrap().remove("started");
                v
            };
            assert_eq!(strip(&a), strip(&b), "{what}: {f}");
        } else if name.ends_with(".exr")
            || name.ends_with(".png")
            || name == "regions.json"
            || (f.contains("figures/") && !name.contains("seconds"))
        {
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{what}: {f} differs"
            );
        }
        // summary.json and sweep.json hold the measured times.
    }
}

/// A planned run (reference in 4 shards, every job run, collected) gives the results of the
/// same experiment run on one machine.
#[test]
fn planned_run_gives_the_results_of_one_machine() {
    let d = Dirs::new("cluster-same");
    let cfg = spp_config(&d);
    let run = d.path("run");
    let printed = plan(&d, &cfg, &run, &["--reference-shards", "4"]);
    assert_eq!(printed, run, "the plan prints the run folder");
    let jobs = job_lines(&run);
    assert_eq!(jobs.len(), 8);
    for (i, j) in jobs.iter().enumerate() {
        assert_eq!(j["index"], i);
        assert_eq!(j["output"], format!("jobs/{i:05}"));
    }
    let shards: Vec<Value> = jobs[..4]
        .iter()
        .map(|j| j["work"]["samples"].clone())
        .collect();
    assert_eq!(
        shards,
        [[0, 16], [16, 32], [32, 48], [48, 64]].map(|r| json!(r))
    );
    assert!(jobs[4..].iter().all(|j| j["work"]["kind"] == "variant"));
    let plan_json: Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("plan.json")).unwrap()).unwrap();
    assert_eq!(plan_json["jobs"], 8);
    assert_eq!(plan_json["shard_spp"], 16);
    assert!(run.join("INCOMPLETE").is_file());

    ok(&d.cwd, &["job", s(&run), "--all"]);
    for i in 0..8 {
        assert!(job_dir(&run, i).join("done.json").is_file(), "job {i}");
    }
    let o = ok(&d.cwd, &["experiment", "--collect", s(&run)]);
    assert!(o.stderr.contains("results:"), "{}", o.stderr);
    assert!(!run.join("INCOMPLETE").exists());
    let timings = std::fs::read_to_string(run.join("jobs.csv")).unwrap();
    assert_eq!(timings.lines().count(), 9, "{timings}");
    assert!(timings.starts_with("index,job,host,cpu_model,threads,seconds"));

    let direct_root = d.path("direct");
    ok(&d.cwd, &["experiment", s(&cfg), "--out", s(&direct_root)]);
    let direct = latest_run(&direct_root, "same");
    assert!(direct.join("reference.exr").is_file());
    // 2 variants × 2 budgets × 2 repeats × (all + 6 shapes) rows.
    let rows = std::fs::read_to_string(direct.join("metrics.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 2 * 2 * 2 * 7);
    assert_same_results("spp ladder", &run, &direct);
    // The collected run is complete: its figures can be made again.
    ok(&d.cwd, &["figures", s(&run)]);
}

/// The same for a sweep (every value's folder; the reference split into uneven shards)
/// and for a parameter grid, under `--quick`.
#[test]
fn planned_sweep_and_grid_give_the_results_of_one_machine() {
    let d = Dirs::new("cluster-sweep-grid");
    let sweep = config(
        &d.root,
        "sweep.json",
        json!({
            "name": "sw",
            "scene": s(&repo().join("scenes/media-divider.json")),
            "reference": { "integrator": "pt-hero", "spp": 16 },
            "variants": [
                { "name": "exp", "integrator": "pt-mono", "options": { "tracking": "exponential" } },
                { "name": "aware", "integrator": "pt-mono" }
            ],
            "budget": { "spp": [1, 2] },
            "regions": { "by": "shape" },
            "sweep": { "path": "media.fluid.sigma_a", "values": [0, 0.5], "label": "σa" }
        }),
    );
    let grid = config(
        &d.root,
        "grid.json",
        json!({
            "name": "grid",
            "scene": s(&repo().join("scenes/green-spheres.json")),
            "variants": [ { "name": "pt-mono", "integrator": "pt-mono" } ],
            "budget": { "spp": [4] },
            "grid": {
                "material": "fluorescein",
                "rows": { "field": "concentration", "values": [0.1, 1.0] },
                "columns": { "field": "quantum_yield", "values": [0.2, 0.6, 1.0] }
            }
        }),
    );
    for (cfg, name, shards, jobs) in [(&sweep, "sw", "3", 10), (&grid, "grid", "8", 7)] {
        let run = d.path(&format!("{name}-run"));
        plan(&d, cfg, &run, &["--quick", "--reference-shards", shards]);
        assert_eq!(job_lines(&run).len(), jobs, "{name}");
        ok(&d.cwd, &["job", s(&run), "--all"]);
        ok(&d.cwd, &["experiment", "--collect", s(&run)]);
        let root = d.path(&format!("{name}-direct"));
        ok(
            &d.cwd,
            &["experiment", s(cfg), "--quick", "--out", s(&root)],
        );
        assert_same_results(name, &run, &latest_run(&root, name));
    }
    // The sweep's reference (quick: 16 spp) in 3 shards: 6 + 6 + 4 samples, per value.
    let samples: Vec<Value> = job_lines(&d.path("sw-run"))
        .iter()
        .filter(|j| j["work"]["kind"] == "reference-shard")
        .map(|j| j["work"]["samples"].clone())
        .collect();
    assert_eq!(
        samples,
        [[0, 6], [6, 12], [12, 16], [0, 6], [6, 12], [12, 16]].map(|r| json!(r))
    );
}

/// Modification time and bytes of a file.
fn stamp(p: &Path) -> (std::time::SystemTime, Vec<u8>) {
    (
        std::fs::metadata(p).unwrap().modified().unwrap(),
        std::fs::read(p).unwrap(),
    )
}

/// A finished job is skipped (exit 0, "already finished"), its files untouched; `--all` and
/// an index from SLURM_ARRAY_TASK_ID skip it too.
#[test]
fn finished_job_is_skipped() {
    let d = Dirs::new("cluster-skip");
    let cfg = spp_config(&d);
    let run = d.path("run");
    plan(&d, &cfg, &run, &["--reference-shards", "4"]);
    let o = ok(&d.cwd, &["job", s(&run), "0"]);
    assert!(
        o.stderr.contains("job 0") && o.stderr.contains("done"),
        "{}",
        o.stderr
    );
    let done = job_dir(&run, 0).join("done.json");
    let exr = job_dir(&run, 0).join("reference.exr");
    let (done0, exr0) = (stamp(&done), stamp(&exr));
    let rec: Value = serde_json::from_str(&String::from_utf8_lossy(&done0.1)).unwrap();
    assert_eq!(rec["index"], 0);
    assert_eq!(rec["files"], json!(["reference.exr"]));
    std::thread::sleep(Duration::from_millis(20));

    let o = ok(&d.cwd, &["job", s(&run), "0"]);
    assert!(o.stderr.contains("already finished"), "{}", o.stderr);
    assert_eq!(stamp(&done), done0, "done.json was rewritten");
    assert_eq!(stamp(&exr), exr0, "the shard was rewritten");

    // The index from Slurm's array: job 1 runs, then is skipped in turn.
    let mut c = cmd(&d.cwd, &["job", s(&run)]);
    c.env("SLURM_ARRAY_TASK_ID", "1");
    let o = output(c);
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(job_dir(&run, 1).join("done.json").is_file());
    let done1 = stamp(&job_dir(&run, 1).join("done.json"));
    // An explicit INDEX wins over SLURM_ARRAY_TASK_ID.
    let mut c = cmd(&d.cwd, &["job", s(&run), "0"]);
    c.env("SLURM_ARRAY_TASK_ID", "not-a-number");
    let o = output(c);
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(o.stderr.contains("already finished"), "{}", o.stderr);

    // --all runs the rest and skips the finished ones.
    let o = ok(&d.cwd, &["job", s(&run), "--all"]);
    assert_eq!(
        o.stderr.matches("already finished").count(),
        2,
        "{}",
        o.stderr
    );
    assert_eq!(stamp(&done), done0);
    assert_eq!(stamp(&job_dir(&run, 1).join("done.json")), done1);
    for i in 0..8 {
        assert!(job_dir(&run, i).join("done.json").is_file(), "job {i}");
    }
    // A second --all has nothing left to do.
    let o = ok(&d.cwd, &["job", s(&run), "--all"]);
    assert_eq!(
        o.stderr.matches("already finished").count(),
        8,
        "{}",
        o.stderr
    );
}

/// Wait (at most a minute) until `p` exists.
fn wait_for(p: &Path) {
    let t = Instant::now();
    while !p.exists() {
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "{} did not appear",
            p.display()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Temporary files (`.NAME.PID.tmp`) under `dir`.
fn temp_files(dir: &Path) -> Vec<String> {
    files(dir)
        .into_iter()
        .filter(|f| f.ends_with(".tmp"))
        .collect()
}

/// Jobs killed mid-render (SIGKILL, SIGTERM) leave no `done.json`; the collect step names
/// them as missing; run again they finish, and the run collects.
#[cfg(unix)]
#[test]
fn killed_jobs_are_missing_until_run_again() {
    use std::os::unix::process::ExitStatusExt;
    let d = Dirs::new("cluster-kill");
    let scene = walls(&d.root, 24);
    // Equal-time budgets of 0.3 s and 2 s: a job writes its first snapshot at 0.3 s and
    // finishes at 2 s, so it is killed mid-render once that snapshot exists.
    let cfg = config(
        &d.root,
        "kill.json",
        json!({
            "name": "kill",
            "scene": s(&scene),
            "reference": { "integrator": "pt-mono", "spp": 16 },
            "variants": [
                { "name": "a", "integrator": "pt-mono" },
                { "name": "b", "integrator": "pt-mono", "options": { "max_depth": 4 } }
            ],
            "budget": { "seconds": [0.3, 2.0] }
        }),
    );
    let run = d.path("run");
    plan(&d, &cfg, &run, &["--reference-shards", "2"]);
    assert_eq!(job_lines(&run).len(), 4);
    ok(&d.cwd, &["job", s(&run), "0"]);
    ok(&d.cwd, &["job", s(&run), "1"]);

    let spawn = |i: &str| {
        cmd(&d.cwd, &["job", s(&run), i])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let mut killed = spawn("2");
    let mut termed = spawn("3");
    wait_for(&job_dir(&run, 2).join("images/a__time0__r0.exr"));
    wait_for(&job_dir(&run, 3).join("images/b__time0__r0.exr"));
    killed.kill().unwrap();
    let st = Command::new("kill")
        .args(["-TERM", &termed.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let (sk, stt) = (killed.wait().unwrap(), termed.wait().unwrap());
    assert_eq!(sk.signal(), Some(9), "{sk:?}");
    // The signal handler removes the temporary files and exits with 128 + 15.
    assert_eq!(stt.code(), Some(143), "{stt:?}");
    assert_eq!(temp_files(&job_dir(&run, 3)), Vec::<String>::new());
    for i in [2, 3] {
        assert!(!job_dir(&run, i).join("done.json").exists(), "job {i}");
        assert!(!job_dir(&run, i).join("failed.json").exists(), "job {i}");
    }

    let o = run_collect(&d, &run);
    expect_input_error(
        "two killed jobs",
        &o,
        &[
            "2 of 4 jobs have not finished",
            "missing (never ran, still running, or killed): 2-3\n",
        ],
    );
    assert!(run.join("INCOMPLETE").is_file());
    assert!(!run.join("metrics.csv").exists());

    ok(&d.cwd, &["job", s(&run), "2"]);
    assert!(job_dir(&run, 2).join("done.json").is_file());
    let o = run_collect(&d, &run);
    expect_input_error(
        "one killed job",
        &o,
        &[
            "1 of 4 jobs",
            "missing (never ran, still running, or killed): 3\n",
        ],
    );

    let o = ok(&d.cwd, &["job", s(&run), "--all"]);
    assert_eq!(
        o.stderr.matches("already finished").count(),
        3,
        "{}",
        o.stderr
    );
    ok(&d.cwd, &["experiment", "--collect", s(&run)]);
    assert!(!run.join("INCOMPLETE").exists());
    let metrics = std::fs::read_to_string(run.join("metrics.csv")).unwrap();
    for v in ["\na,pt-mono,time,", "\nb,pt-mono,time,"] {
        assert!(metrics.contains(v), "{v}: {metrics}");
    }
    assert_eq!(temp_files(&run), Vec::<String>::new());
}

fn run_collect(d: &Dirs, run: &Path) -> Out {
    stokes(&d.cwd, &["experiment", "--collect", s(run)])
}

/// Append a newline to a file (a change of its text, not of its meaning).
fn touch_text(p: &Path) -> Vec<u8> {
    let before = std::fs::read(p).unwrap();
    let mut after = before.clone();
    after.push(b'\n');
    std::fs::write(p, after).unwrap();
    before
}

/// The collect step names the missing jobs as ranges and the failed ones with their error;
/// the run stays INCOMPLETE (and `stokes figures` refuses it) until the collect step succeeds.
/// A config changed after planning fails its jobs, and fails the collect step.
#[test]
fn collect_names_missing_and_failed_jobs() {
    let d = Dirs::new("cluster-missing");
    let cfg = spp_config(&d);
    let run = d.path("run");
    plan(&d, &cfg, &run, &["--reference-shards", "4"]);
    for i in ["0", "2", "6"] {
        ok(&d.cwd, &["job", s(&run), i]);
    }
    let o = run_collect(&d, &run);
    expect_input_error(
        "missing",
        &o,
        &[
            s(&run),
            "5 of 8 jobs have not finished",
            "missing (never ran, still running, or killed): 1, 3-5, 7\n",
            "stokes job",
        ],
    );
    assert!(!o.stderr.contains("failed"), "{}", o.stderr);
    assert!(run.join("INCOMPLETE").is_file());
    for f in ["metrics.csv", "run.json", "reference.exr", "jobs.csv"] {
        assert!(!run.join(f).exists(), "{f}");
    }
    expect_input_error(
        "figures before collect",
        &stokes(&d.cwd, &["figures", s(&run)]),
        &["INCOMPLETE"],
    );

    // The config changes after planning: a job refuses to run, and says so in failed.json.
    let original = touch_text(&cfg);
    let o = stokes(&d.cwd, &["job", s(&run), "3"]);
    expect_input_error(
        "changed config",
        &o,
        &[s(&cfg), "changed since the run was planned"],
    );
    let failed: Value = serde_json::from_str(
        &std::fs::read_to_string(job_dir(&run, 3).join("failed.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(failed["index"], 3);
    assert!(
        failed["error"]
            .as_str()
            .unwrap()
            .contains("changed since the run was planned")
    );
    assert!(!job_dir(&run, 3).join("done.json").exists());
    let o = run_collect(&d, &run);
    expect_input_error(
        "missing and failed",
        &o,
        &[
            "5 of 8 jobs have not finished",
            "missing (never ran, still running, or killed): 1, 4-5, 7\n",
            "job 3 (reference pt-hero samples 48..64) failed on ",
            "changed since the run was planned",
        ],
    );
    // --all fails every job left, names them, and exits non-zero.
    let o = stokes(&d.cwd, &["job", s(&run), "--all"]);
    assert_ne!(o.code, 0, "{}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    assert!(
        o.stderr.contains("5 of 8 jobs failed: 1, 3-5, 7"),
        "{}",
        o.stderr
    );
    let o = run_collect(&d, &run);
    expect_input_error("all failed", &o, &["5 of 8 jobs have not finished"]);
    assert!(!o.stderr.contains("missing ("), "{}", o.stderr);
    for i in [1, 3, 4, 5, 7] {
        assert!(
            o.stderr.contains(&format!("  job {i} (")),
            "job {i}: {}",
            o.stderr
        );
    }
    assert!(run.join("INCOMPLETE").is_file());

    // Restored, the jobs run (their failure records go), but a collect with the config
    // changed again refuses.
    std::fs::write(&cfg, &original).unwrap();
    ok(&d.cwd, &["job", s(&run), "--all"]);
    for i in 0..8 {
        assert!(!job_dir(&run, i).join("failed.json").exists(), "job {i}");
        assert!(job_dir(&run, i).join("done.json").is_file(), "job {i}");
    }
    touch_text(&cfg);
    expect_input_error(
        "collect after a change",
        &run_collect(&d, &run),
        &[s(&cfg), "changed since the run was planned"],
    );
    assert!(run.join("INCOMPLETE").is_file());
    std::fs::write(&cfg, &original).unwrap();
    ok(&d.cwd, &["experiment", "--collect", s(&run)]);
    assert!(!run.join("INCOMPLETE").exists());
    assert!(run.join("metrics.csv").is_file());
    ok(&d.cwd, &["figures", s(&run)]);

    // A job whose output disappeared after it finished is missing again, and runs again.
    let img = job_dir(&run, 5).join("images/pt-mono__spp1__r1.exr");
    std::fs::remove_file(&img).unwrap();
    expect_input_error(
        "output removed",
        &run_collect(&d, &run),
        &["missing (never ran, still running, or killed): 5\n"],
    );
    ok(&d.cwd, &["job", s(&run), "5"]);
    assert!(img.is_file());
    ok(&d.cwd, &["experiment", "--collect", s(&run)]);
}

/// Bad input: exit code 2 and a message naming the file or option.
#[test]
fn bad_plans_and_arguments_are_input_errors() {
    let d = Dirs::new("cluster-bad");
    let cfg = spp_config(&d);
    let nope = d.path("nope");
    for args in [
        &["job", s(&nope), "0"][..],
        &["job", s(&nope), "--all"],
        &["experiment", "--collect", s(&nope)],
    ] {
        expect_input_error(
            &format!("{args:?}"),
            &stokes(&d.cwd, args),
            &[s(&nope), "does not exist"],
        );
    }
    // A folder that is not a run.
    let empty = d.path("empty");
    std::fs::create_dir_all(&empty).unwrap();
    expect_input_error(
        "not a run",
        &stokes(&d.cwd, &["job", s(&empty), "0"]),
        &["plan.json", "--plan"],
    );

    let run_dir = d.path("run");
    plan(&d, &cfg, &run_dir, &["--reference-shards", "4"]);
    let pf = run_dir.join("plan.json");
    let jf = run_dir.join("jobs.jsonl");
    let plan_text = std::fs::read_to_string(&pf).unwrap();
    let jobs_text = std::fs::read_to_string(&jf).unwrap();
    let mut plan_v: Value = serde_json::from_str(&plan_text).unwrap();
    let lines: Vec<&str> = jobs_text.lines().collect();

    let mut wrong_format = plan_v.clone();
    wrong_format["format"] = "stokes-plan-0".into();
    let mut unknown = plan_v.clone();
    unknown["colour"] = "blue".into();
    let mut no_jobs = plan_v.clone();
    no_jobs["jobs"] = 0.into();
    let mut more_jobs = plan_v.clone();
    more_jobs["jobs"] = 9.into();
    let cases_plan: [(&str, String, &[&str]); 5] = [
        ("bad JSON", "{\"format\": ".into(), &["plan.json"]),
        (
            "wrong format",
            wrong_format.to_string(),
            &["plan.json", "format", "stokes-plan-0"],
        ),
        (
            "unknown field",
            unknown.to_string(),
            &["plan.json", "colour"],
        ),
        ("no jobs", no_jobs.to_string(), &["plan.json", "jobs"]),
        (
            "more jobs than lines",
            more_jobs.to_string(),
            &["jobs.jsonl", "holds 8 jobs", "plan.json", "9"],
        ),
    ];
    // Each damaged file must be refused by `job` and by `--collect`, naming what is wrong.
    let refused = |file: &Path, cases: &[(&str, String, &[&str])]| {
        for (what, text, names) in cases {
            std::fs::write(file, text).unwrap();
            for args in [
                &["job", s(&run_dir), "0"][..],
                &["experiment", "--collect", s(&run_dir)],
            ] {
                let label = format!("{} {what}: {args:?}", file.display());
                expect_input_error(&label, &stokes(&d.cwd, args), names);
            }
        }
    };
    refused(&pf, &cases_plan);
    std::fs::write(&pf, &plan_text).unwrap();

    let mut wrong_index: Value = serde_json::from_str(lines[1]).unwrap();
    wrong_index["index"] = 5.into();
    let mut wrong_output: Value = serde_json::from_str(lines[2]).unwrap();
    wrong_output["output"] = "../elsewhere".into();
    let mut empty_range: Value = serde_json::from_str(lines[0]).unwrap();
    empty_range["work"]["samples"] = json!([16, 16]);
    let with_line = |n: usize, v: &Value| {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        l[n] = v.to_string();
        l.join("\n") + "\n"
    };
    let cases_jobs: [(&str, String, &[&str]); 5] = [
        (
            "truncated line",
            lines[0][..lines[0].len() / 2].to_string() + "\n" + &lines[1..].join("\n"),
            &["jobs.jsonl", "line 1"],
        ),
        (
            "wrong index",
            with_line(1, &wrong_index),
            &["jobs.jsonl", "line 2", "index", "is 5"],
        ),
        (
            "wrong output",
            with_line(2, &wrong_output),
            &["jobs.jsonl", "line 3", "output", "../elsewhere"],
        ),
        (
            "empty sample range",
            with_line(0, &empty_range),
            &["jobs.jsonl", "line 1", "samples", "16..16"],
        ),
        (
            "fewer lines",
            lines[..5].join("\n") + "\n",
            &["jobs.jsonl", "holds 5 jobs", "plan.json", "8"],
        ),
    ];
    refused(&jf, &cases_jobs);
    std::fs::write(&jf, &jobs_text).unwrap();
    std::fs::remove_file(&jf).unwrap();
    expect_input_error(
        "no jobs.jsonl",
        &stokes(&d.cwd, &["job", s(&run_dir), "0"]),
        &["jobs.jsonl"],
    );
    std::fs::write(&jf, &jobs_text).unwrap();
    plan_v["config_file"] = s(&d.path("gone.json")).into();
    std::fs::write(&pf, plan_v.to_string()).unwrap();
    expect_input_error(
        "config gone",
        &stokes(&d.cwd, &["job", s(&run_dir), "0"]),
        &["gone.json"],
    );
    std::fs::write(&pf, &plan_text).unwrap();
    for i in 0..8 {
        assert!(!job_dir(&run_dir, i).join("done.json").exists(), "job {i}");
    }

    // Job indices.
    expect_input_error(
        "index out of range",
        &stokes(&d.cwd, &["job", s(&run_dir), "8"]),
        &["job 8", "0–7"],
    );
    let mut c = cmd(&d.cwd, &["job", s(&run_dir)]);
    c.env("SLURM_ARRAY_TASK_ID", "abc");
    expect_input_error(
        "SLURM_ARRAY_TASK_ID=abc",
        &output(c),
        &["SLURM_ARRAY_TASK_ID", "'abc'"],
    );
    let mut c = cmd(&d.cwd, &["job", s(&run_dir)]);
    c.env("SLURM_ARRAY_TASK_ID", "8");
    expect_input_error("SLURM_ARRAY_TASK_ID=8", &output(c), &["job 8", "0–7"]);
    expect_input_error(
        "no index",
        &stokes(&d.cwd, &["job", s(&run_dir)]),
        &["INDEX", "SLURM_ARRAY_TASK_ID", "--all"],
    );
    expect_input_error(
        "index and --all",
        &stokes(&d.cwd, &["job", s(&run_dir), "0", "--all"]),
        &["--all"],
    );
    for i in 0..8 {
        assert!(!job_dir(&run_dir, i).join("done.json").exists(), "job {i}");
    }

    // Planning.
    expect_input_error(
        "--out not empty",
        &stokes(
            &d.cwd,
            &["experiment", s(&cfg), "--plan", "--out", s(&run_dir)],
        ),
        &["--out", s(&run_dir), "not empty"],
    );
    assert_eq!(std::fs::read_to_string(&pf).unwrap(), plan_text);
    let fresh = d.path("fresh");
    for (what, extra, names) in [
        (
            "0 shards",
            &["--reference-shards", "0"][..],
            &["--reference-shards", "0"][..],
        ),
        (
            "too many shards",
            &["--reference-shards", "5000"],
            &["--reference-shards", "5000"],
        ),
    ] {
        let mut args = vec!["experiment", s(&cfg), "--plan", "--out", s(&fresh)];
        args.extend_from_slice(extra);
        expect_input_error(what, &stokes(&d.cwd, &args), names);
        assert!(!fresh.exists(), "{what}: the run folder was made");
    }
    expect_input_error(
        "--time banana",
        &stokes(
            &d.cwd,
            &[
                "experiment",
                s(&cfg),
                "--slurm",
                "--time",
                "banana",
                "--dry-run",
                "--out",
                s(&fresh),
            ],
        ),
        &["--time", "banana"],
    );
    expect_input_error(
        "--partition with a space",
        &stokes(
            &d.cwd,
            &[
                "experiment",
                s(&cfg),
                "--slurm",
                "--partition",
                "a b",
                "--dry-run",
                "--out",
                s(&fresh),
            ],
        ),
        &["--partition", "a b"],
    );
    expect_input_error(
        "--cpus-per-task 0",
        &stokes(
            &d.cwd,
            &[
                "experiment",
                s(&cfg),
                "--slurm",
                "--cpus-per-task",
                "0",
                "--dry-run",
                "--out",
                s(&fresh),
            ],
        ),
        &["--cpus-per-task"],
    );
    assert!(!fresh.exists(), "a bad Slurm option made the run folder");
    for (opt, val) in SLURM_ONLY {
        expect_input_error(
            &format!("{opt} without --slurm"),
            &stokes(
                &d.cwd,
                &["experiment", s(&cfg), opt, val, "--out", s(&fresh)],
            ),
            &[opt, "--slurm"],
        );
    }
    expect_input_error(
        "--dry-run without --slurm",
        &stokes(
            &d.cwd,
            &["experiment", s(&cfg), "--dry-run", "--out", s(&fresh)],
        ),
        &["--dry-run", "--slurm"],
    );
    expect_input_error(
        "--plan and --slurm",
        &stokes(
            &d.cwd,
            &[
                "experiment",
                s(&cfg),
                "--plan",
                "--slurm",
                "--out",
                s(&fresh),
            ],
        ),
        &["--plan", "--slurm"],
    );
    expect_input_error(
        "--collect with a config",
        &stokes(&d.cwd, &["experiment", s(&cfg), "--collect", s(&run_dir)]),
        &["--collect"],
    );
    assert!(!fresh.exists(), "a bad option made the run folder");
}

/// The options that only mean something with `--slurm`, with a value each.
const SLURM_ONLY: [(&str, &str); 3] = [
    ("--partition", "p"),
    ("--time", "10"),
    ("--cpus-per-task", "2"),
];

/// The Slurm options are refused with `--plan` too (it writes no Slurm scripts), not
/// silently dropped.
#[test]
fn slurm_options_with_plan_are_refused() {
    let d = Dirs::new("cluster-plan-slurm-opts");
    let cfg = spp_config(&d);
    let fresh = d.path("fresh");
    let mut cases: Vec<(&str, &str)> = SLURM_ONLY.to_vec();
    cases.push(("--dry-run", ""));
    for (opt, val) in cases {
        let mut args = vec!["experiment", s(&cfg), "--plan", opt];
        if !val.is_empty() {
            args.push(val);
        }
        args.extend_from_slice(&["--out", s(&fresh)]);
        expect_input_error(
            &format!("{opt} with --plan"),
            &stokes(&d.cwd, &args),
            &[opt],
        );
        assert!(!fresh.exists(), "{opt} with --plan: the run was planned");
    }
}

/// `--plan --out RUN` writes into RUN only: nothing in the working folder (not even the
/// default results root), and a file named `results` there does not matter.
#[test]
fn plan_with_out_writes_nothing_outside_the_run_folder() {
    let d = Dirs::new("cluster-plan-out");
    let cfg = spp_config(&d);
    let run_dir = d.path("run");
    plan(&d, &cfg, &run_dir, &[]);
    let dirs: Vec<_> = std::fs::read_dir(&d.cwd).unwrap().collect();
    assert!(
        dirs.is_empty(),
        "the working folder after --plan --out: {dirs:?}"
    );
    // A file named `results` in the working folder is none of the plan's business.
    std::fs::write(d.cwd.join("results"), "").unwrap();
    plan(&d, &cfg, &d.path("run2"), &[]);
}

/// `--slurm --dry-run` plans the run and writes the scripts without submitting (an `sbatch`
/// first on PATH records any call); the scripts run the jobs and the collect step.
#[cfg(unix)]
#[test]
fn slurm_dry_run_writes_scripts_and_submits_nothing() {
    let d = Dirs::new("cluster-slurm");
    let cfg = spp_config(&d);
    let (path, calls) = fake_sbatch(&d, 0);
    let run_dir = d.path("run");
    let mut c = cmd(
        &d.cwd,
        &[
            "experiment",
            s(&cfg),
            "--slurm",
            "--dry-run",
            "--out",
            s(&run_dir),
            "--reference-shards",
            "2",
            "--partition",
            "short",
            "--time",
            "0-01:30:00",
            "--cpus-per-task",
            "2",
        ],
    );
    c.env("PATH", &path);
    let o = output(c);
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(!calls.exists(), "--dry-run ran sbatch");
    assert!(o.stderr.contains("dry run"), "{}", o.stderr);
    let n = job_lines(&run_dir).len();
    assert_eq!(n, 6);
    let slurm = run_dir.join("slurm");
    let array = std::fs::read_to_string(slurm.join("array.sbatch")).unwrap();
    let collect = std::fs::read_to_string(slurm.join("collect.sbatch")).unwrap();
    let submit = std::fs::read_to_string(slurm.join("submit.sh")).unwrap();
    assert!(slurm.join("logs").is_dir());
    assert!(
        array.contains(&format!("#SBATCH --array=0-{}\n", n - 1)),
        "{array}"
    );
    assert!(
        array.contains(&format!(" job '{}'\n", s(&run_dir))),
        "{array}"
    );
    assert!(
        collect.contains(&format!(" experiment --collect '{}'\n", s(&run_dir))),
        "{collect}"
    );
    for text in [&array, &collect] {
        for line in [
            "#SBATCH --partition=short\n",
            "#SBATCH --time=0-01:30:00\n",
            "#SBATCH --cpus-per-task=2\n",
        ] {
            assert!(text.contains(line), "{line}: {text}");
        }
    }
    assert!(
        submit.contains("--dependency=\"afterok:$array_id\""),
        "{submit}"
    );
    // The dry run prints the scripts.
    assert!(o.stdout.contains("--array=0-5"), "{}", o.stdout);

    // The scripts themselves, run by bash as Slurm would: each array task, then the collect.
    for i in 0..n {
        let st = Command::new("bash")
            .arg(slurm.join("array.sbatch"))
            .env("SLURM_ARRAY_TASK_ID", i.to_string())
            .env("SLURM_CPUS_PER_TASK", "2")
            .env_remove("SLURM_JOB_ID")
            .env_remove("SLURM_ARRAY_JOB_ID")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .unwrap();
        assert!(st.success(), "array task {i}: {st:?}");
        let rec: Value = serde_json::from_str(
            &std::fs::read_to_string(job_dir(&run_dir, i).join("done.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(rec["threads"], 2, "task {i}: SLURM_CPUS_PER_TASK");
    }
    let st = Command::new("bash")
        .arg(slurm.join("collect.sbatch"))
        .env_remove("SLURM_ARRAY_TASK_ID")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success(), "collect: {st:?}");
    assert!(!run_dir.join("INCOMPLETE").exists());
    assert!(run_dir.join("metrics.csv").is_file());
    assert!(!calls.exists(), "sbatch was run");
}

/// A folder holding an `sbatch` that appends its arguments to `calls.txt` and prints job ids
/// 101, 102, … as `ID;cluster` (or fails with `fail` set), and the PATH with it first.
#[cfg(unix)]
fn fake_sbatch(d: &Dirs, fail: u8) -> (String, PathBuf) {
    use std::os::unix::fs::PermissionsExt;
    let dir = d.path("fake-bin");
    std::fs::create_dir_all(&dir).unwrap();
    let calls = dir.join("calls.txt");
    let script = format!(
        "#!/bin/sh\necho \"$@\" >> '{}'\nif [ {fail} -ne 0 ]; then echo 'sbatch: error: no partition' >&2; exit {fail}; fi\nn=$(wc -l < '{}')\necho \"$((100 + n));cluster\"\n",
        s(&calls),
        s(&calls)
    );
    let p = dir.join("sbatch");
    std::fs::write(&p, script).unwrap();
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!("{}:{}", s(&dir), std::env::var("PATH").unwrap_or_default());
    (path, calls)
}

/// Without --dry-run the array is submitted, then the collect step after it (afterok); a
/// failing sbatch is an error naming it.
#[cfg(unix)]
#[test]
fn slurm_submits_array_then_collect() {
    let d = Dirs::new("cluster-submit");
    let cfg = spp_config(&d);
    let (path, calls) = fake_sbatch(&d, 0);
    let run_dir = d.path("run");
    let mut c = cmd(
        &d.cwd,
        &["experiment", s(&cfg), "--slurm", "--out", s(&run_dir)],
    );
    c.env("PATH", &path);
    let o = output(c);
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert_eq!(o.stdout.trim(), "101 102");
    let log = std::fs::read_to_string(&calls).unwrap();
    let l: Vec<&str> = log.lines().collect();
    assert_eq!(l.len(), 2, "{log}");
    assert!(
        l[0].contains("--parsable") && l[0].ends_with("array.sbatch"),
        "{log}"
    );
    assert!(
        l[1].contains("--dependency=afterok:101") && l[1].ends_with("collect.sbatch"),
        "{log}"
    );
    // The default CPUs per task: the config has no `threads`, so 1.
    let array = std::fs::read_to_string(run_dir.join("slurm/array.sbatch")).unwrap();
    assert!(array.contains("#SBATCH --cpus-per-task=1\n"), "{array}");

    // submit.sh does the same.
    let o = Command::new("bash")
        .arg(run_dir.join("slurm/submit.sh"))
        .env("PATH", &path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{o:?}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("array job: 103") && out.contains("collect job: 104"),
        "{out}"
    );
    let log = std::fs::read_to_string(&calls).unwrap();
    assert!(log.lines().nth(3).unwrap().contains("afterok:103"), "{log}");

    let (path, _) = fake_sbatch(&d, 1);
    let mut c = cmd(
        &d.cwd,
        &[
            "experiment",
            s(&cfg),
            "--slurm",
            "--out",
            s(&d.path("run2")),
        ],
    );
    c.env("PATH", &path);
    let o = output(c);
    assert_ne!(o.code, 0);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    assert!(
        o.stderr.contains("sbatch") && o.stderr.contains("no partition"),
        "{}",
        o.stderr
    );
}

/// Without --out a planned run goes to `results/quick/<name>/runs/<ts>` of the working
/// folder; the collect step points `latest` at it and caches the merged reference, so the next
/// plan of the experiment has no reference shards, and its reference is the same.
#[test]
fn plan_without_out_uses_the_results_root_and_the_reference_cache() {
    let d = Dirs::new("cluster-default");
    let cfg = spp_config(&d);
    let o = ok(&d.cwd, &["experiment", s(&cfg), "--quick", "--plan"]);
    let run1 = PathBuf::from(o.stdout.trim());
    let runs = d.cwd.join("results/quick/same/runs");
    assert_eq!(run1.parent().unwrap(), runs, "{}", o.stdout);
    let jobs = job_lines(&run1);
    let shards = jobs
        .iter()
        .filter(|j| j["work"]["kind"] == "reference-shard")
        .count();
    assert!(shards > 0, "the first plan renders the reference");
    assert_eq!(jobs.len() - shards, 2, "quick: one repeat of two variants");
    ok(&d.cwd, &["job", s(&run1), "--all"]);
    // Not collected yet: `latest` does not point at an incomplete run.
    assert!(!d.cwd.join("results/quick/same/latest").exists());
    ok(&d.cwd, &["experiment", "--collect", s(&run1)]);
    let latest = std::fs::read_to_string(d.cwd.join("results/quick/same/latest")).unwrap();
    assert_eq!(
        std::fs::canonicalize(d.cwd.join("results/quick/same").join(latest.trim())).unwrap(),
        run1
    );
    let cached = files(&d.cwd.join("results/quick/references"));
    assert_eq!(cached.len(), 1, "{cached:?}");
    assert!(cached[0].ends_with(".exr"));

    let o = ok(&d.cwd, &["experiment", s(&cfg), "--quick", "--plan"]);
    let run2 = PathBuf::from(o.stdout.trim());
    assert_ne!(run1, run2);
    assert_eq!(run2.parent().unwrap(), runs);
    assert!(o.stderr.contains("0 reference shards"), "{}", o.stderr);
    let jobs = job_lines(&run2);
    assert_eq!(jobs.len(), 2);
    assert!(jobs.iter().all(|j| j["work"]["kind"] == "variant"));
    ok(&d.cwd, &["job", s(&run2), "--all"]);
    ok(&d.cwd, &["experiment", "--collect", s(&run2)]);
    assert_eq!(
        std::fs::read(run1.join("reference.exr")).unwrap(),
        std::fs::read(run2.join("reference.exr")).unwrap()
    );
    assert_same_metrics(
        "second run",
        &run1.join("metrics.csv"),
        &run2.join("metrics.csv"),
    );
    let latest = std::fs::read_to_string(d.cwd.join("results/quick/same/latest")).unwrap();
    assert_eq!(
        std::fs::canonicalize(d.cwd.join("results/quick/same").join(latest.trim())).unwrap(),
        run2
    );
    // Only the results root was written in the working folder.
    let top: Vec<String> = std::fs::read_dir(&d.cwd)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(top, ["results"]);
}

/// Options of planned runs are refused where they would be ignored: `--reference-shards` and
/// the Slurm options without `--plan`/`--slurm`, and no results are written.
#[test]
fn cluster_options_without_a_planned_run_are_refused() {
    let d = Dirs::new("cluster-options-direct");
    let cfg = spp_config(&d);
    for (opt, val) in [
        ("--reference-shards", "4"),
        ("--partition", "p"),
        ("--time", "10"),
        ("--cpus-per-task", "2"),
    ] {
        let o = stokes(&d.cwd, &["experiment", s(&cfg), opt, val]);
        expect_input_error(opt, &o, &[opt]);
    }
    let o = stokes(&d.cwd, &["experiment", s(&cfg), "--dry-run"]);
    expect_input_error("--dry-run", &o, &["--dry-run"]);
    assert!(
        !d.cwd.join("results").exists(),
        "a refused option still wrote results"
    );
}

/// `STOKES_JOB_OFFSET` shifts the array task id (plans larger than the cluster's
/// MaxArraySize, submitted in parts); a bad offset is an input error.
#[test]
fn job_offset_shifts_the_array_task_id() {
    let d = Dirs::new("cluster-job-offset");
    let cfg = spp_config(&d);
    let run = plan(&d, &cfg, &d.path("run"), &[]);
    let mut c = cmd(&d.cwd, &["job", s(&run)]);
    c.env("SLURM_ARRAY_TASK_ID", "0")
        .env("STOKES_JOB_OFFSET", "2");
    let o = output(c);
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(o.stderr.contains("job 2 ("), "{}", o.stderr);
    assert!(run.join("jobs/00002/done.json").is_file());
    assert!(!run.join("jobs/00000/done.json").exists());
    let mut c = cmd(&d.cwd, &["job", s(&run)]);
    c.env("SLURM_ARRAY_TASK_ID", "0")
        .env("STOKES_JOB_OFFSET", "x");
    expect_input_error("bad offset", &output(c), &["STOKES_JOB_OFFSET", "'x'"]);
}
