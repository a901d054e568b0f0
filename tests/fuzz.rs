//! Seeded mutation fuzzing of everything stokes reads (docs/hardening.md, "Fuzz harness").
//!
//! Mutants of the shipped scenes, experiment configs, spectra CSVs, BFC matrices, `.vol` grids,
//! run records, EXR images, Gaussian-mixture model files and an OBJ mesh are fed to the `stokes`
//! binary, as are inputs that are FIFOs, devices or folders, outputs onto such things or with odd
//! names, and planned run folders edited by hand (tests/fuzz/special.rs, whose guarded paths
//! must not change); each run must end in one of two ways: exit 0 with finite output (for renders,
//! the stats show `nan_inf_rejected == 0` and every EXR value is finite), or exit 2 with a
//! message that names a file. A panic (101), any other exit code, a signal, or more than 10 s
//! is a failure. All failures are collected and printed as one table before the test fails.
//!
//! CI runs a fixed seed and a fixed number of cases. `STOKES_FUZZ_CASES=N` and
//! `STOKES_FUZZ_SEED=S` run a deeper search; `STOKES_FUZZ_KINDS=scene,bfc` restricts the inputs,
//! `STOKES_FUZZ_ONLY=I` runs case I alone, `STOKES_FUZZ_JOBS=J` sets the parallel runs and
//! `STOKES_FUZZ_KEEP=DIR` where failing cases are kept (default: the target's tmp folder),
//! `STOKES_FUZZ_BIN=PATH` fuzzes another build of `stokes`, and `STOKES_FUZZ_VERBOSE=1` prints
//! every case.
#![cfg(unix)]

#[path = "fuzz/corpus.rs"]
mod corpus;
#[path = "fuzz/json.rs"]
mod json;
#[path = "fuzz/mutate.rs"]
mod mutate;
#[path = "fuzz/special.rs"]
mod special;

use corpus::{Base, Case, Check, Kind, s, walk};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use std::collections::BTreeMap;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Cases in CI: about 65 s on 2 idle cores, setup included (docs/hardening.md).
const CI_CASES: u64 = 5000;
const CI_SEED: u64 = 13;
/// Wall-clock limit of one `stokes` run.
const TIMEOUT: Duration = Duration::from_secs(10);
/// Address-space limit of one `stokes` run (KiB): a request for more is a size that should have
/// been bounded and checked before use.
const MEMORY_KIB: u64 = 4 << 20;
/// Failing cases kept on disk per failure class.
const KEEP_PER_CLASS: usize = 3;

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().map(|v| {
        v.parse()
            .unwrap_or_else(|_| panic!("{name} must be a number, got {v:?}"))
    })
}

/// How one run ended.
struct Outcome {
    code: Option<i32>,
    signal: Option<i32>,
    timed_out: bool,
    seconds: f64,
    stderr: String,
}

/// The binary under test: this build's, or `STOKES_FUZZ_BIN` (to fuzz another build).
fn stokes_bin() -> PathBuf {
    std::env::var_os("STOKES_FUZZ_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_stokes")))
}

/// Run `stokes` with `args` in `dir`, under the time and memory limits.
fn run_stokes(args: &[String], dir: &Path, cache: &Path) -> Outcome {
    let stderr_path = dir.join("stderr.txt");
    let start = Instant::now();
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {MEMORY_KIB} 2>/dev/null; exec \"$0\" \"$@\""
        ))
        .arg(stokes_bin())
        .args(args)
        .current_dir(dir)
        .env("STOKES_CACHE_DIR", cache)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(dir.join("stdout.txt")).unwrap())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .expect("cannot start stokes");
    let mut timed_out = false;
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if start.elapsed() > TIMEOUT {
            timed_out = true;
            let _ = child.kill();
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(3));
    };
    let bytes = std::fs::read(&stderr_path).unwrap_or_default();
    Outcome {
        code: status.code(),
        signal: status.signal(),
        timed_out,
        seconds: start.elapsed().as_secs_f64(),
        stderr: String::from_utf8_lossy(&bytes).into_owned(),
    }
}

/// Whether an error message names a file: a token with a data-file extension, or a path.
fn names_file(stderr: &str) -> bool {
    const EXTS: &[&str] = &[
        ".json", ".csv", ".bfc", ".vol", ".exr", ".png", ".svg", ".obj", ".txt",
    ];
    let lines: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    let text = if lines.is_empty() {
        stderr.to_string()
    } else {
        lines.join("\n")
    };
    text.split(|c: char| c.is_whitespace() || "'\"`()[]{},;".contains(c))
        .map(|t| t.trim_end_matches([':', '.', '!', '?']))
        .any(|t| {
            let l = t.to_lowercase();
            EXTS.iter().any(|e| l.ends_with(e) && l.len() > e.len())
                || t.starts_with('/')
                || t.starts_with("./")
                || t.starts_with("../")
        })
}

/// The line of stderr that says what went wrong: the panic message, a failed allocation, else
/// the first error line, else the last line (the backtrace note left out).
fn key_line(stderr: &str) -> String {
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with("note: run with `RUST_BACKTRACE"))
        .collect();
    if let Some(i) = lines.iter().position(|l| l.contains("panicked at")) {
        let at = lines[i].split("panicked at").nth(1).unwrap_or("").trim();
        let msg = lines.get(i + 1).copied().unwrap_or("");
        return format!("panicked at {at} {msg}");
    }
    if let Some(l) = lines
        .iter()
        .find(|l| l.starts_with("memory allocation of") || l.starts_with("error"))
    {
        return l.to_string();
    }
    lines
        .last()
        .map(|l| l.to_string())
        .unwrap_or_else(|| "(no stderr)".into())
}

/// A message with paths, quoted values and numbers blanked (and serde's "at line N column M"
/// cut), so that failures of one class group together.
fn normalise(line: &str) -> String {
    let line = line.split(" at line ").next().unwrap_or(line);
    let mut out = String::new();
    let mut quote: Option<char> = None;
    let mut prev_digit = false;
    for tok in line.split(' ') {
        if !out.is_empty() {
            out.push(' ');
        }
        let t = tok.trim_start_matches(|c: char| "'\"`(".contains(c));
        if quote.is_none() && t.starts_with('/') {
            out.push_str("<path>");
            continue;
        }
        for c in tok.chars() {
            match quote {
                Some(q) if c == q => {
                    quote = None;
                    out.push(c);
                }
                Some(_) => {}
                None if c == '`' || c == '"' => {
                    quote = Some(c);
                    out.push(c);
                    out.push('…');
                }
                None if c.is_ascii_digit() => {
                    if !prev_digit {
                        out.push('N');
                    }
                    prev_digit = true;
                    continue;
                }
                None => out.push(c),
            }
            prev_digit = false;
        }
    }
    mutate::clip(&out, 110)
}

/// The fields a mutation description names (`reflectance`, `value`, `domain`, `line`), for
/// grouping failures.
fn mutated_fields(mutation: &str) -> String {
    let mut out: Vec<String> = Vec::new();
    for part in mutation.split("; ") {
        let part = part.trim_start_matches("text: ");
        let words: Vec<&str> = part.split(' ').collect();
        let path = match words.as_slice() {
            ["all", _, "like", p, ..] => p,
            ["delete" | "duplicate" | "rename", p, ..] => p,
            ["used" | "as" | "stokes", ..] => continue,
            [w, ..] if w.ends_with(':') => "text",
            [p, ..] => p,
            [] => continue,
        };
        let last = path.rsplit('.').next().unwrap_or(path);
        let f = last.split('[').next().unwrap_or(last).to_string();
        if !f.is_empty() && !out.contains(&f) {
            out.push(f);
        }
    }
    out.join(",")
}

/// The verdict on one case: Ok(exit code) or Err((what failed, detail)).
fn judge(case: &Case, o: &Outcome) -> Result<i32, (String, String)> {
    // Whatever the exit code: what the case guards (special files, the folder outside a run's
    // results root) is as it was.
    let changed = special::changed_guards(case);
    if !changed.is_empty() {
        return Err(("changed a guarded path".into(), changed.join("; ")));
    }
    if o.timed_out {
        return Err((
            format!("timeout > {} s", TIMEOUT.as_secs()),
            key_line(&o.stderr),
        ));
    }
    if let Some(sig) = o.signal {
        return Err((format!("signal {sig}"), key_line(&o.stderr)));
    }
    match o.code {
        Some(0) => check_success(&case.check).map(|_| 0),
        Some(2) if names_file(&o.stderr) => Ok(2),
        Some(2) => Err(("exit 2, no file named".into(), key_line(&o.stderr))),
        Some(101) => Err(("exit 101 (panic)".into(), key_line(&o.stderr))),
        Some(c) => Err((format!("exit {c}"), key_line(&o.stderr))),
        None => Err(("no exit code".into(), key_line(&o.stderr))),
    }
}

fn check_success(check: &Check) -> Result<(), (String, String)> {
    let fail = |what: &str, detail: String| Err((format!("exit 0, {what}"), detail));
    match check {
        Check::Render { stats, exr } => {
            let Ok(text) = std::fs::read_to_string(stats) else {
                return fail("no stats file", s(stats));
            };
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            let rejected = v["nan_inf_rejected"].as_u64();
            if rejected != Some(0) {
                return fail(
                    "NaN/Inf rejected",
                    format!("nan_inf_rejected = {}", v["nan_inf_rejected"]),
                );
            }
            match stokes::film::output::read_exr(exr) {
                Err(e) => fail("unreadable EXR", e),
                Ok((w, h, px)) => {
                    if Some(w as u64) != v["width"].as_u64()
                        || Some(h as u64) != v["height"].as_u64()
                    {
                        return fail(
                            "EXR size differs from stats",
                            format!("{w}×{h} vs {}×{}", v["width"], v["height"]),
                        );
                    }
                    match px.iter().position(|p| !p.is_finite()) {
                        Some(i) => fail("non-finite pixel", format!("pixel {i} = {}", px[i])),
                        None => Ok(()),
                    }
                }
            }
        }
        Check::Experiment { out } => {
            for f in walk(out)
                .into_iter()
                .filter(|f| f.file_name().unwrap() == "metrics.csv")
            {
                let text = std::fs::read_to_string(&f).unwrap();
                let mut lines = text.lines();
                let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
                for line in lines {
                    for (col, v) in header.iter().zip(line.split(',')) {
                        let bad = match *col {
                            "mse" | "rel_mse" => v.parse::<f64>().map_or(true, |x| !x.is_finite()),
                            "snr_db" | "efficiency" => v.parse::<f64>().map_or(true, f64::is_nan),
                            _ => false,
                        };
                        if bad {
                            return fail("non-finite metric", format!("{col} = {v} in {line}"));
                        }
                    }
                }
            }
            Ok(())
        }
        Check::Output(p) => {
            if p.is_file() {
                Ok(())
            } else {
                fail("no output file", s(p))
            }
        }
        Check::Nothing => Ok(()),
    }
}

struct Failure {
    index: u64,
    kind: Kind,
    input: String,
    mutation: String,
    result: String,
    detail: String,
    class: String,
    kept: Option<PathBuf>,
}

/// Run records and Gaussian-mixture models made by stokes itself, for the base corpus.
fn setup_outputs(base: &mut Base, cache: &Path) {
    let dir = base.dir.join("made");
    std::fs::create_dir_all(&dir).unwrap();
    let bin = |args: Vec<String>, what: &str| {
        let o = run_stokes(&args, &dir, cache);
        assert!(
            o.code == Some(0),
            "fuzz setup: {what} failed ({:?}): {}",
            o.code,
            o.stderr
        );
    };
    // Run records of the small configs: regions, crop and scanline with both budgets; a grid;
    // a sweep.
    for name in [
        "smoke-pt-mono.json",
        "fluorescence-parameters.json",
        "media-emission-width.json",
    ] {
        let cfg = dir.join(name);
        std::fs::write(&cfg, base.config(name).to_text()).unwrap();
        let out = dir.join("runs");
        bin(
            vec![
                "experiment".into(),
                s(&cfg),
                "--quick".into(),
                "--out".into(),
                s(&out),
            ],
            name,
        );
        let stem = base
            .config(name)
            .get("name")
            .and_then(|n| match n {
                json::Json::Str(s) => Some(s.clone()),
                _ => None,
            })
            .unwrap();
        let latest = std::fs::read_to_string(out.join(&stem).join("latest")).unwrap();
        base.runs.push((
            format!("{stem} (quick run)"),
            out.join(&stem).join(latest.trim()),
        ));
    }
    // The committed run records (text only: their images are not in the repository).
    for e in std::fs::read_dir(base.repo.join("results")).unwrap() {
        let p = e.unwrap().path();
        if let Ok(l) = std::fs::read_to_string(p.join("latest")) {
            let run = p.join(l.trim());
            let dst = dir.join("committed").join(p.file_name().unwrap());
            corpus::copy_run(&run, &dst);
            for f in walk(&dst) {
                if !matches!(f.extension().and_then(|e| e.to_str()), Some("json" | "csv")) {
                    std::fs::remove_file(f).unwrap();
                }
            }
            base.runs
                .push((format!("results/{}", rel_to(&base.repo, &run)), dst));
        }
    }
    base.runs.sort();
    // Gaussian-mixture models, EM and variational Bayes.
    for (bfc, k, method) in [("GOLFYE", "4", "em"), ("HERPIGRE", "3", "bayes")] {
        let out = dir.join(format!("{bfc}-{k}-{method}.json"));
        bin(
            vec![
                "gmm".into(),
                "fit".into(),
                s(&base.repo.join(format!("data/bispectral/{bfc}.BFC"))),
                "--components".into(),
                k.into(),
                "--method".into(),
                method.into(),
                "-o".into(),
                s(&out),
            ],
            "gmm fit",
        );
        base.gmm_models.push(out);
    }
    base.strings.push(s(&base.gmm_models[0]));
    // A finished planned run in a results root (every job done, not collected), for the
    // run-folder cases: the smoke config with two reference shards.
    let planned = base.dir.join("planned");
    std::fs::create_dir_all(&planned).unwrap();
    let cfg = planned.join("smoke.json");
    std::fs::write(&cfg, base.config("smoke-pt-mono.json").to_text()).unwrap();
    let args: Vec<String> = vec![
        "experiment".into(),
        s(&cfg),
        "--quick".into(),
        "--plan".into(),
        "--reference-shards".into(),
        "2".into(),
    ];
    let o = run_stokes(&args, &planned, cache);
    assert!(
        o.code == Some(0),
        "fuzz setup: planning failed: {}",
        o.stderr
    );
    let run = std::fs::read_to_string(planned.join("stdout.txt")).unwrap();
    let run = PathBuf::from(run.trim());
    let o = run_stokes(&["job".into(), s(&run), "--all".into()], &planned, cache);
    assert!(
        o.code == Some(0),
        "fuzz setup: the planned jobs failed: {}",
        o.stderr
    );
    let rel = run.strip_prefix(&planned).unwrap().to_path_buf();
    base.planned = Some((planned, rel));
}

fn rel_to(base: &Path, p: &Path) -> String {
    let r = p.strip_prefix(base.join("results")).unwrap_or(p);
    r.display().to_string()
}

/// Every base scene renders and every base config runs, unmutated (else the harness, not
/// stokes, is broken). This also fills the Gaussian-mixture cache.
fn check_base(base: &Base, cache: &Path, jobs: usize) {
    let dir = base.dir.join("check");
    std::fs::create_dir_all(&dir).unwrap();
    let mut runs: Vec<(String, Vec<String>)> = Vec::new();
    for (name, _) in &base.scenes {
        let scene = base
            .dir
            .join("scenes")
            .join(Path::new(name).file_name().unwrap());
        runs.push((
            name.clone(),
            vec![
                "render".into(),
                s(&scene),
                "--spp".into(),
                "1".into(),
                "--threads".into(),
                "1".into(),
                "-o".into(),
                s(&dir.join(format!("{}.exr", runs.len()))),
            ],
        ));
    }
    for (i, (name, cfg)) in base.configs.iter().enumerate() {
        let p = dir.join(format!("config-{i}.json"));
        std::fs::write(&p, cfg.to_text()).unwrap();
        runs.push((
            name.clone(),
            vec![
                "experiment".into(),
                s(&p),
                "--quick".into(),
                "--out".into(),
                s(&dir.join("out")),
            ],
        ));
    }
    let obj = base.obj_unmutated(&dir.join("obj"));
    runs.push(("cube.obj".into(), obj.args));
    let next = AtomicU64::new(0);
    let bad = Mutex::new(Vec::new());
    std::thread::scope(|sc| {
        for _ in 0..jobs {
            sc.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed) as usize;
                    let Some((name, args)) = runs.get(i) else {
                        break;
                    };
                    let o = run_stokes(args, &dir, cache);
                    if o.code != Some(0) {
                        bad.lock().unwrap().push(format!(
                            "{name}: {:?} {}",
                            o.code,
                            key_line(&o.stderr)
                        ));
                    }
                }
            });
        }
    });
    let bad = bad.into_inner().unwrap();
    assert!(
        bad.is_empty(),
        "fuzz setup: unmutated inputs fail:\n{}",
        bad.join("\n")
    );
}

#[test]
fn fuzz_inputs() {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let seed = env_u64("STOKES_FUZZ_SEED").unwrap_or(CI_SEED);
    let cases = env_u64("STOKES_FUZZ_CASES").unwrap_or(CI_CASES);
    let only = env_u64("STOKES_FUZZ_ONLY");
    let jobs = env_u64("STOKES_FUZZ_JOBS")
        .map(|j| j as usize)
        .unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
                .min(2)
        })
        .max(1);
    let kinds: Vec<Kind> = match std::env::var("STOKES_FUZZ_KINDS") {
        Ok(list) => list
            .split(',')
            .map(|k| {
                *Kind::ALL
                    .iter()
                    .find(|x| x.name() == k.trim())
                    .unwrap_or_else(|| panic!("unknown kind {k:?} in STOKES_FUZZ_KINDS"))
            })
            .collect(),
        Err(_) => Kind::ALL.to_vec(),
    };
    let work_root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
    remove_stale(&work_root);
    let work = work_root.join(format!("{seed}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    let keep_root = std::env::var_os("STOKES_FUZZ_KEEP")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures"));
    let cache = work.join("cache");
    let verbose = std::env::var_os("STOKES_FUZZ_VERBOSE").is_some();
    let t0 = Instant::now();
    let mut base = Base::new(&repo, &work.join("base"));
    setup_outputs(&mut base, &cache);
    if only.is_none() {
        check_base(&base, &cache, jobs);
    }
    let setup_secs = t0.elapsed().as_secs_f64();

    let indices: Vec<u64> = match only {
        Some(i) => vec![i],
        None => (0..cases).collect(),
    };
    let next = AtomicU64::new(0);
    let failures = Mutex::new(Vec::<Failure>::new());
    let kept_per_class = Mutex::new(BTreeMap::<String, usize>::new());
    // (kind, exit code) -> count, for the summary.
    let tally = Mutex::new(BTreeMap::<(Kind, i32), u64>::new());
    let slowest = Mutex::new((0.0f64, 0u64));
    std::thread::scope(|sc| {
        for _ in 0..jobs {
            sc.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed) as usize;
                    let Some(&index) = indices.get(k) else {
                        break;
                    };
                    let mut rng =
                        Pcg64::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index);
                    let dir = work.join("cases").join(format!("case-{index}"));
                    let case = base.case(&mut rng, index, &kinds, &dir);
                    let o = run_stokes(&case.args, &case.dir, &cache);
                    {
                        let mut sl = slowest.lock().unwrap();
                        if o.seconds > sl.0 {
                            *sl = (o.seconds, index);
                        }
                    }
                    let verdict = judge(&case, &o);
                    if verbose {
                        println!(
                            "case {index} | {} | {} | {} | {:?} {:.2} s | {}",
                            case.kind.name(),
                            case.input,
                            case.mutation,
                            o.code,
                            o.seconds,
                            key_line(&o.stderr)
                        );
                    }
                    match verdict {
                        Ok(code) => {
                            *tally.lock().unwrap().entry((case.kind, code)).or_default() += 1;
                            let _ = std::fs::remove_dir_all(&case.dir);
                        }
                        Err((result, detail)) => {
                            *tally.lock().unwrap().entry((case.kind, -1)).or_default() += 1;
                            // Exit 0 with bad output and time-outs say little on stderr: the
                            // mutated fields tell those classes apart.
                            let fields =
                                if result.starts_with("exit 0") || result.starts_with("timeout") {
                                    format!(" [{}]", mutated_fields(&case.mutation))
                                } else {
                                    String::new()
                                };
                            let class = format!(
                                "{} | {result} | {}{fields}",
                                case.kind.name(),
                                normalise(&detail)
                            );
                            let keep = {
                                let mut m = kept_per_class.lock().unwrap();
                                let n = m.entry(class.clone()).or_default();
                                *n += 1;
                                *n <= KEEP_PER_CLASS || only.is_some()
                            };
                            let kept = if keep {
                                let dst = keep_root.join(format!("seed{seed}-case{index}"));
                                let _ = std::fs::remove_dir_all(&dst);
                                std::fs::create_dir_all(&keep_root).unwrap();
                                keep_case(&case, &dst, &cache);
                                Some(dst)
                            } else {
                                None
                            };
                            failures.lock().unwrap().push(Failure {
                                index,
                                kind: case.kind,
                                input: case.input.clone(),
                                mutation: case.mutation.clone(),
                                result,
                                detail,
                                class,
                                kept,
                            });
                        }
                    }
                }
            });
        }
    });
    let total_secs = t0.elapsed().as_secs_f64();
    let mut failures = failures.into_inner().unwrap();
    failures.sort_by(|a, b| a.class.cmp(&b.class).then(a.index.cmp(&b.index)));
    let tally = tally.into_inner().unwrap();
    let slowest = slowest.into_inner().unwrap();

    // Summary.
    let mut summary = format!(
        "fuzz: seed {seed}, {} cases in {total_secs:.1} s (setup {setup_secs:.1} s, {jobs} jobs; slowest run {:.2} s, case {})\n",
        indices.len(),
        slowest.0,
        slowest.1
    );
    summary.push_str("  kind         cases   exit 0   exit 2   failed\n");
    for kind in Kind::ALL {
        let get = |c: i32| tally.get(&(kind, c)).copied().unwrap_or(0);
        let n = get(0) + get(2) + get(-1);
        if n > 0 {
            summary.push_str(&format!(
                "  {:<12} {n:>5} {:>8} {:>8} {:>8}\n",
                kind.name(),
                get(0),
                get(2),
                get(-1)
            ));
        }
    }
    let get_all = |c: i32| {
        tally
            .iter()
            .filter(|(k, _)| k.1 == c)
            .map(|(_, v)| v)
            .sum::<u64>()
    };
    summary.push_str(&format!(
        "  {:<12} {:>5} {:>8} {:>8} {:>8}\n",
        "all",
        indices.len(),
        get_all(0),
        get_all(2),
        get_all(-1)
    ));
    if failures.is_empty() {
        println!("{summary}");
        let _ = std::fs::remove_dir_all(&work);
        return;
    }
    let mut classes: BTreeMap<&str, (usize, u64)> = BTreeMap::new();
    for f in &failures {
        let e = classes.entry(&f.class).or_insert((0, f.index));
        e.0 += 1;
    }
    summary.push_str(&format!(
        "\n{} failures in {} classes (kind | result | message; count; first case):\n",
        failures.len(),
        classes.len()
    ));
    for (c, (n, first)) in &classes {
        summary.push_str(&format!("  {n:>5}  {c}  (case {first})\n"));
    }
    summary.push_str("\ncase | kind | input | mutation | result | message\n");
    const MAX_ROWS: usize = 400;
    for f in failures.iter().take(MAX_ROWS) {
        summary.push_str(&format!(
            "{} | {} | {} | {} | {} | {}{}\n",
            f.index,
            f.kind.name(),
            f.input,
            mutate::clip(&f.mutation, 120),
            f.result,
            mutate::clip(&f.detail, 160),
            f.kept
                .as_ref()
                .map(|k| format!(" [kept: {}]", k.display()))
                .unwrap_or_default()
        ));
    }
    if failures.len() > MAX_ROWS {
        summary.push_str(&format!("… and {} more\n", failures.len() - MAX_ROWS));
    }
    summary.push_str(&format!(
        "\nRe-run one case: STOKES_FUZZ_SEED={seed} STOKES_FUZZ_ONLY=<case> cargo test --release --test fuzz\nKept cases (with repro.sh): {}\n",
        keep_root.display()
    ));
    // The base corpus stays next to the kept cases, which refer to it.
    let _ = std::fs::remove_dir_all(work.join("cases"));
    panic!("{summary}");
}

/// Remove the work folders of earlier runs (a failing run leaves its base corpus, which its kept
/// cases refer to) once they are a day old.
fn remove_stale(root: &Path) {
    let Ok(rd) = std::fs::read_dir(root) else {
        return;
    };
    for e in rd.flatten() {
        let old = e
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age > Duration::from_secs(24 * 3600));
        if old {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Keep a failing case: its folder (mutant, outputs, stderr) and a `repro.sh` with the command.
fn keep_case(case: &Case, dst: &Path, cache: &Path) {
    let dir = &case.dir;
    std::fs::create_dir_all(dst).unwrap();
    // Regular files only: a FIFO would block the copy (links and special files are named in
    // the mutation, and repro.sh makes none of them again).
    let regular = |f: &Path| std::fs::symlink_metadata(f).is_ok_and(|m| m.is_file());
    for f in walk(dir) {
        let r = f.strip_prefix(dir).unwrap();
        let t = dst.join(r);
        std::fs::create_dir_all(t.parent().unwrap()).unwrap();
        if regular(&f) {
            let _ = std::fs::copy(&f, &t);
        }
    }
    let from = s(dir);
    let to = s(dst);
    let args: Vec<String> = case
        .args
        .iter()
        .map(|a| format!("'{}'", a.replace(&from, &to)))
        .collect();
    // Mutants that refer to each other (a scene and its data file) move together.
    for f in walk(dst) {
        if regular(&f)
            && let Ok(t) = std::fs::read_to_string(&f)
            && t.contains(&from)
        {
            std::fs::write(&f, t.replace(&from, &to)).unwrap();
        }
    }
    std::fs::write(
        dst.join("repro.sh"),
        format!(
            "#!/bin/sh\n# case {} ({}: {}): {}\nSTOKES_CACHE_DIR='{}' exec '{}' {}\n",
            case.index,
            case.kind.name(),
            case.input,
            case.mutation.replace('\n', " "),
            s(cache),
            s(&stokes_bin()),
            args.join(" ")
        ),
    )
    .unwrap();
}
