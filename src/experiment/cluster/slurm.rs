//! Slurm array jobs for a planned run (`stokes experiment CONFIG --plan --out RUN_DIR`).
//!
//! [`write_scripts`] writes into `RUN_DIR/slurm/`:
//! - `array.sbatch`: one array task per planned job, each running `stokes job RUN_DIR` (the job
//!   index comes from `SLURM_ARRAY_TASK_ID`); logs go to `slurm/logs/job-<index>.out`;
//! - `collect.sbatch`: one task running `stokes experiment --collect RUN_DIR`; log
//!   `slurm/logs/collect.out`;
//! - `submit.sh`: submits the array, then the collect step with `--dependency=afterok:<array>`,
//!   so it starts only when every task succeeded, and prints both job ids.
//!
//! [`submit`] does what `submit.sh` does, directly. Running `submit.sh` again later resubmits
//! the whole run; jobs that already finished are skipped, so only the missing ones render.
//!
//! Paths are written absolute. In the shell lines they are single-quoted. The `#SBATCH` lines
//! are read by `sbatch` with its own rules (whitespace ends an unquoted value, an unescaped `#`
//! starts a comment, `%` in a log name is a pattern, and a backslash anywhere in a log name
//! turns the patterns off), so there the log path is double-quoted with `"`, `\` and `#`
//! escaped and `%` doubled, and a run folder with a backslash is refused. Logs are opened in
//! append mode, so a resubmission keeps the earlier attempt's messages. Slurm limits the array
//! size (`MaxArraySize`, 1001 by default): [`check_array_size`] refuses to submit a larger run
//! (asked from `scontrol`), whose scripts are then submitted in parts with `STOKES_JOB_OFFSET`
//! (docs/cluster.md).

use crate::error::Error;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Slurm settings for the submitted jobs (all optional; unset ones use the cluster's defaults).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SlurmOptions {
    /// `--partition`: the partition (queue) to run in.
    pub partition: Option<String>,
    /// `--time`: the time limit of each job, in a Slurm time format.
    pub time: Option<String>,
    /// `--cpus-per-task`: CPUs for each job (and for the collect step).
    pub cpus_per_task: Option<u32>,
    /// Write the scripts but do not submit them (for the caller; [`submit`] does not read it).
    pub dry_run: bool,
}

/// Files written into `RUN_DIR/slurm/`: `array.sbatch`, `collect.sbatch`, `submit.sh`
/// (executable), and the folder `slurm/logs/`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlurmScripts {
    pub array: PathBuf,
    pub collect: PathBuf,
    pub submit: PathBuf,
}

/// The most CPUs per task accepted by `--cpus-per-task`.
const MAX_CPUS: u32 = 1024;

/// Check the options before anything is written or submitted. Each error names the option, the
/// value and what is wrong with it.
pub fn validate(opts: &SlurmOptions) -> Result<(), Error> {
    if let Some(p) = &opts.partition {
        if p.is_empty() {
            return Err(Error::input("--partition: the partition name is empty"));
        }
        if let Some(c) = p
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-')))
        {
            return Err(Error::input(format!(
                "--partition '{p}': {c:?} is not allowed in a partition name \
                 (use letters, digits, '_', '.' and '-')"
            )));
        }
    }
    if let Some(t) = &opts.time {
        check_time(t).map_err(|why| Error::input(format!("--time '{t}': {why}")))?;
    }
    if let Some(n) = opts.cpus_per_task
        && !(1..=MAX_CPUS).contains(&n)
    {
        return Err(Error::input(format!(
            "--cpus-per-task {n}: must be between 1 and {MAX_CPUS}"
        )));
    }
    Ok(())
}

/// Whether `t` is a Slurm time limit: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`, or
/// `UNLIMITED` / `infinite` (any case). The leading number may be any size; the ones after it
/// are clock fields (hours below 24 after days, minutes and seconds below 60).
fn check_time(t: &str) -> Result<(), String> {
    const FORMATS: &str = "use minutes (M), M:S, H:M:S, D-H, D-H:M, D-H:M:S, UNLIMITED or infinite";
    if t.eq_ignore_ascii_case("unlimited") || t.eq_ignore_ascii_case("infinite") {
        return Ok(());
    }
    if t.is_empty() {
        return Err(format!("the time is empty; {FORMATS}"));
    }
    let num = |s: &str| -> Result<u64, String> {
        if s.is_empty() || s.len() > 9 || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(format!("'{s}' is not a whole number; {FORMATS}"));
        }
        s.parse::<u64>().map_err(|e| format!("'{s}': {e}"))
    };
    let (days, clock) = match t.split_once('-') {
        Some((d, rest)) => (Some(d), rest),
        None => (None, t),
    };
    let fields: Vec<&str> = clock.split(':').collect();
    let names: &[&str] = match (days.is_some(), fields.len()) {
        (false, 1) => &["minutes"],
        (false, 2) => &["minutes", "seconds"],
        (false, 3) | (true, 3) => &["hours", "minutes", "seconds"],
        (true, 1) => &["hours"],
        (true, 2) => &["hours", "minutes"],
        _ => return Err(format!("not a Slurm time; {FORMATS}")),
    };
    if let Some(d) = days {
        num(d)?;
    }
    for (i, (f, name)) in fields.iter().zip(names).enumerate() {
        let v = num(f)?;
        // The first field may exceed its clock range (e.g. 90:00 is 90 minutes) unless days
        // come before it.
        let limit = match *name {
            "hours" => 24,
            _ => 60,
        };
        if (i > 0 || days.is_some()) && v >= limit {
            return Err(format!("{name} must be below {limit}, not {v}; {FORMATS}"));
        }
    }
    Ok(())
}

/// Write `array.sbatch`, `collect.sbatch` and `submit.sh` into `run_dir/slurm/` (and create
/// `slurm/logs/`) for a run of `jobs` jobs named `name`, run by the program `exe`.
pub fn write_scripts(
    run_dir: &Path,
    jobs: usize,
    name: &str,
    exe: &Path,
    opts: &SlurmOptions,
) -> Result<SlurmScripts, Error> {
    validate(opts)?;
    if jobs == 0 {
        return Err(Error::input(
            "the planned run has no jobs, so there is nothing to submit to Slurm",
        ));
    }
    let run_dir = run_dir.canonicalize().map_err(|e| {
        Error::input(format!(
            "cannot find the run folder '{}': {e}",
            run_dir.display()
        ))
    })?;
    let exe = std::path::absolute(exe).map_err(|e| {
        Error::runtime(format!(
            "cannot make the program path '{}' absolute: {e}",
            exe.display()
        ))
    })?;
    let run = script_path(&run_dir, "run folder")?;
    let program = script_path(&exe, "program")?;
    // A backslash in a log name makes Slurm leave its `%` patterns (the task index) unexpanded.
    if run.contains('\\') {
        return Err(Error::input(format!(
            "the run folder '{run}' contains a backslash, which Slurm does not allow in log \
             file names; use a folder without one"
        )));
    }
    let dir = run_dir.join("slurm");
    let logs = dir.join("logs");
    std::fs::create_dir_all(&logs)
        .map_err(|e| Error::runtime(format!("cannot create folder '{}': {e}", logs.display())))?;
    let t = Texts {
        run: &run,
        exe: &program,
        jobs,
        name: &job_name(name),
        opts,
    };
    let s = SlurmScripts {
        array: dir.join("array.sbatch"),
        collect: dir.join("collect.sbatch"),
        submit: dir.join("submit.sh"),
    };
    write_executable(&s.array, &t.array())?;
    write_executable(&s.collect, &t.collect())?;
    write_executable(&s.submit, &t.submit())?;
    Ok(s)
}

/// Submit the run as `submit.sh` does: `sbatch --parsable array.sbatch`, then
/// `sbatch --parsable --dependency=afterok:<ARRAY_ID> collect.sbatch`. Returns the array job id
/// and the collect job id.
pub fn submit(s: &SlurmScripts) -> Result<(String, String), Error> {
    let array = sbatch(&["--parsable".into(), s.array.display().to_string()])?;
    let collect = sbatch(&[
        "--parsable".into(),
        format!("--dependency=afterok:{array}"),
        s.collect.display().to_string(),
    ])
    .map_err(|e| {
        Error::runtime(format!(
            "{e}\nThe array job {array} is queued; submit the collect step alone with \
             `sbatch --dependency=afterok:{array} {}`",
            shell_word(&s.collect.display().to_string())
        ))
    })?;
    Ok((array, collect))
}

/// The cluster's `MaxArraySize` (`scontrol show config`), when `scontrol` answers.
pub fn max_array_size() -> Option<usize> {
    let out = Command::new("scontrol")
        .args(["show", "config"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    String::from_utf8_lossy(&out.stdout).lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "MaxArraySize").then(|| v.trim().parse().ok())?
    })
}

/// Check that an array of `jobs` tasks fits the cluster's `MaxArraySize` (when known): task
/// ids run 0 to jobs − 1 and must stay below it.
pub fn check_array_size(jobs: usize, max: Option<usize>) -> Result<(), Error> {
    match max {
        Some(m) if jobs > m => Err(Error::input(format!(
            "the run has {jobs} jobs, but this cluster's MaxArraySize is {m} (array task ids must stay below it): \
             use fewer repeats or --reference-shards, or submit the run's scripts in parts with \
             STOKES_JOB_OFFSET (docs/cluster.md, \"Plans larger than MaxArraySize\")"
        ))),
        _ => Ok(()),
    }
}

/// Run `sbatch ARGS` and return the job id it prints with `--parsable` (`ID` or `ID;CLUSTER`).
fn sbatch(args: &[String]) -> Result<String, Error> {
    let words: Vec<String> = args.iter().map(|a| shell_word(a)).collect();
    let shown = format!("sbatch {}", words.join(" "));
    let out = Command::new("sbatch").args(args).output().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::runtime(format!(
                "cannot run `{shown}`: the Slurm command `sbatch` is not installed or not on \
                 PATH (submit from a machine of the Slurm cluster, or run the scripts in the \
                 run folder's slurm/ folder there)"
            ))
        } else {
            Error::runtime(format!("cannot run `{shown}`: {e}"))
        }
    })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(Error::runtime(format!(
            "`{shown}` failed ({}): {}",
            out.status,
            stderr.trim()
        )));
    }
    let id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(Error::runtime(format!(
            "`{shown}` printed no job id (stdout: '{}', stderr: '{}')",
            stdout.trim(),
            stderr.trim()
        )));
    }
    Ok(id)
}

/// `path` as text for a script: it must be UTF-8 and free of control characters (a newline
/// would end an `#SBATCH` line or a comment).
fn script_path(path: &Path, what: &str) -> Result<String, Error> {
    let s = path.to_str().ok_or_else(|| {
        Error::input(format!(
            "the {what} path '{}' is not valid UTF-8, which the Slurm scripts cannot hold",
            path.display()
        ))
    })?;
    if s.chars().any(char::is_control) {
        return Err(Error::input(format!(
            "the {what} path {s:?} contains a control character (such as a newline), which \
             the Slurm scripts cannot hold"
        )));
    }
    Ok(s.to_string())
}

/// `s` single-quoted for bash: `it's` becomes `'it'\''s'`.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// `s` as a bash word: as it is when it holds only safe characters, otherwise single-quoted.
fn shell_word(s: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "_./:=@%+-,".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_string()
    } else {
        quote(s)
    }
}

/// `s` as one argument of an `#SBATCH` line: in double quotes, with `"`, `\` and `#` escaped
/// by a backslash (sbatch ends an unquoted argument at whitespace, even an escaped one).
fn sbatch_arg(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        if matches!(c, '\\' | '"' | '#') {
            out.push('\\');
        }
        out.push(c);
    }
    out.push('"');
    out
}

/// `stokes-<name>` with every character other than letters, digits, `_`, `.` and `-` replaced
/// by `_`, at most 64 characters.
fn job_name(name: &str) -> String {
    let clean: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-') {
                c
            } else {
                '_'
            }
        })
        .take(57)
        .collect();
    if clean.is_empty() {
        "stokes-run".to_string()
    } else {
        format!("stokes-{clean}")
    }
}

/// Write `text` to `path` atomically, executable (0o755).
fn write_executable(path: &Path, text: &str) -> Result<(), Error> {
    crate::io::output::write_atomic(path, |tmp| {
        std::fs::write(tmp, text).map_err(|e| format!("cannot write '{}': {e}", path.display()))?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(tmp, std::fs::Permissions::from_mode(0o755))
                .map_err(|e| format!("cannot make '{}' executable: {e}", path.display()))?;
        }
        Ok(())
    })
    .map_err(Error::runtime)
}

/// What the three scripts are made of.
struct Texts<'a> {
    /// The absolute run folder.
    run: &'a str,
    /// The absolute program.
    exe: &'a str,
    jobs: usize,
    /// The sanitised job name (`stokes-<name>`).
    name: &'a str,
    opts: &'a SlurmOptions,
}

impl Texts<'_> {
    /// `RUN_DIR/slurm/<file>`, single-quoted for bash.
    fn quoted(&self, file: &str) -> String {
        quote(&format!("{}/slurm/{file}", self.run))
    }

    /// `#SBATCH --output=RUN_DIR/slurm/logs/<file>` (with `%` in the folder doubled, so that
    /// only the pattern in `file` is expanded) and the options shared by both sbatch scripts.
    fn sbatch_lines(&self, job_name: &str, log: &str) -> String {
        let out = format!("{}/slurm/logs/{log}", self.run.replace('%', "%%"));
        let mut s = format!(
            "#SBATCH --job-name={job_name}\n\
             #SBATCH --output={}\n\
             #SBATCH --open-mode=append\n",
            sbatch_arg(&out)
        );
        if let Some(p) = &self.opts.partition {
            s += &format!("#SBATCH --partition={p}\n");
        }
        if let Some(t) = &self.opts.time {
            s += &format!("#SBATCH --time={t}\n");
        }
        if let Some(n) = self.opts.cpus_per_task {
            s += &format!("#SBATCH --cpus-per-task={n}\n");
        }
        s
    }

    fn array(&self) -> String {
        format!(
            "#!/bin/bash\n\
             # stokes: Slurm array job for the planned run in\n\
             #   {run}\n\
             # Task N runs job N of {jobs} (`stokes job RUN_DIR` reads SLURM_ARRAY_TASK_ID).\n\
             # Submit or resubmit the run (this array, then collect.sbatch) with\n\
             #   bash {submit}\n\
             # Jobs that already finished are skipped, so a resubmission only runs the rest.\n\
             # Logs: {logs}job-<N>.out\n\
             #SBATCH --array=0-{last}\n\
             {lines}\
             set -euo pipefail\n\
             echo \"== job ${{SLURM_ARRAY_TASK_ID:-?}} (Slurm job ${{SLURM_JOB_ID:-?}}) on \
             $(hostname) at $(date)\"\n\
             cd {run}\n\
             exec {exe} job {run}\n",
            run = quote(self.run),
            jobs = self.jobs,
            submit = self.quoted("submit.sh"),
            logs = self.quoted("logs/"),
            last = self.jobs - 1,
            lines = self.sbatch_lines(self.name, "job-%a.out"),
            exe = quote(self.exe),
        )
    }

    fn collect(&self) -> String {
        format!(
            "#!/bin/bash\n\
             # stokes: collects the planned run in\n\
             #   {run}\n\
             # after every job of array.sbatch finished (`stokes experiment --collect RUN_DIR`).\n\
             # submit.sh submits it with --dependency=afterok on the array job.\n\
             #SBATCH --ntasks=1\n\
             {lines}\
             set -euo pipefail\n\
             echo \"== collect (Slurm job ${{SLURM_JOB_ID:-?}}) on $(hostname) at $(date)\"\n\
             cd {run}\n\
             exec {exe} experiment --collect {run}\n",
            run = quote(self.run),
            lines = self.sbatch_lines(&format!("{}-collect", self.name), "collect.out"),
            exe = quote(self.exe),
        )
    }

    fn submit(&self) -> String {
        format!(
            "#!/bin/bash\n\
             # stokes: submits the planned run in\n\
             #   {run}\n\
             # to Slurm: the array job ({jobs} tasks, array.sbatch), then the collect step\n\
             # (collect.sbatch), which starts only when every task succeeded (afterok).\n\
             # Running it again is safe: jobs that already finished are skipped.\n\
             set -euo pipefail\n\
             array_id=$(sbatch --parsable {array})\n\
             array_id=${{array_id%%;*}}\n\
             collect_id=$(sbatch --parsable --dependency=\"afterok:$array_id\" {collect})\n\
             collect_id=${{collect_id%%;*}}\n\
             echo \"array job: $array_id ({jobs} tasks)\"\n\
             echo \"collect job: $collect_id (after every task succeeded)\"\n\
             echo \"logs: \"{logs}\n",
            run = quote(self.run),
            jobs = self.jobs,
            array = self.quoted("array.sbatch"),
            collect = self.quoted("collect.sbatch"),
            logs = self.quoted("logs/"),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_size_is_checked_when_known() {
        assert!(check_array_size(1001, Some(1001)).is_ok());
        assert!(check_array_size(1002, Some(1001)).is_err());
        assert!(check_array_size(1_000_000, None).is_ok());
    }

    fn opts(partition: Option<&str>, time: Option<&str>, cpus: Option<u32>) -> SlurmOptions {
        SlurmOptions {
            partition: partition.map(str::to_string),
            time: time.map(str::to_string),
            cpus_per_task: cpus,
            dry_run: false,
        }
    }

    fn err(o: &SlurmOptions) -> String {
        validate(o).unwrap_err().message
    }

    #[test]
    fn validate_accepts_slurm_values() {
        assert!(validate(&SlurmOptions::default()).is_ok());
        for t in [
            "0",
            "30",
            "90",
            "5:30",
            "90:00",
            "1:00:00",
            "48:00:00",
            "2-0",
            "2-12",
            "1-12:30",
            "1-0:0:1",
            "UNLIMITED",
            "infinite",
            "Infinite",
        ] {
            assert!(validate(&opts(None, Some(t), None)).is_ok(), "{t}");
        }
        for p in ["debug", "gpu_a100", "long.q", "x-1"] {
            assert!(validate(&opts(Some(p), None, None)).is_ok(), "{p}");
        }
        assert!(validate(&opts(None, None, Some(1))).is_ok());
        assert!(validate(&opts(None, None, Some(1024))).is_ok());
    }

    #[test]
    fn validate_names_option_value_and_problem() {
        let e = err(&opts(Some(""), None, None));
        assert!(e.contains("--partition") && e.contains("empty"), "{e}");
        let e = err(&opts(Some("de bug"), None, None));
        assert!(
            e.contains("--partition 'de bug'") && e.contains("' '"),
            "{e}"
        );
        let e = err(&opts(Some("a;rm"), None, None));
        assert!(e.contains("--partition 'a;rm'") && e.contains("';'"), "{e}");
        for t in [
            "",
            "1:2:3:4",
            "1-2-3",
            "1h",
            "-5",
            "1:",
            ":5",
            "1-",
            "a-1",
            "1-1:2:3:4",
            "1.5",
        ] {
            let e = err(&opts(None, Some(t), None));
            assert!(
                e.contains(&format!("--time '{t}'")) && e.contains("H:M:S"),
                "{e}"
            );
        }
        let e = err(&opts(None, Some("1:75:00"), None));
        assert!(e.contains("--time '1:75:00'") && e.contains("minutes must be below 60"));
        let e = err(&opts(None, Some("1-24"), None));
        assert!(e.contains("hours must be below 24"), "{e}");
        let e = err(&opts(None, Some("5:60"), None));
        assert!(e.contains("seconds must be below 60"), "{e}");
        for n in [0, 1025] {
            let e = err(&opts(None, None, Some(n)));
            assert!(e.contains(&format!("--cpus-per-task {n}")) && e.contains("1 and 1024"));
        }
        assert_eq!(
            validate(&opts(None, None, Some(0)))
                .unwrap_err()
                .exit_code(),
            2
        );
    }

    #[test]
    fn quoting_for_bash_and_sbatch() {
        assert_eq!(quote("/a b/it's"), r"'/a b/it'\''s'");
        assert_eq!(quote(""), "''");
        assert_eq!(
            shell_word("--dependency=afterok:12"),
            "--dependency=afterok:12"
        );
        assert_eq!(shell_word("/a b"), "'/a b'");
        assert_eq!(sbatch_arg("/a b/it's#1\"\\"), r#""/a b/it's\#1\"\\""#);
        assert_eq!(
            job_name("walls integrators/ü"),
            "stokes-walls_integrators__"
        );
        assert_eq!(job_name(""), "stokes-run");
        assert_eq!(job_name(&"x".repeat(100)).len(), 64);
    }

    fn texts<'a>(run: &'a str, jobs: usize, o: &'a SlurmOptions) -> Texts<'a> {
        Texts {
            run,
            exe: "/opt/st okes/bin/stokes",
            jobs,
            name: "stokes-walls",
            opts: o,
        }
    }

    #[test]
    fn array_script_text() {
        let o = SlurmOptions::default();
        let t = texts("/data/my run's/20%", 12, &o);
        let a = t.array();
        assert!(a.starts_with("#!/bin/bash\n# stokes"), "{a}");
        assert!(a.contains("\n#SBATCH --array=0-11\n"), "{a}");
        assert!(a.contains("\n#SBATCH --job-name=stokes-walls\n"), "{a}");
        assert!(
            a.contains(r#"#SBATCH --output="/data/my run's/20%%/slurm/logs/job-%a.out""#),
            "{a}"
        );
        assert!(
            a.contains(r"bash '/data/my run'\''s/20%/slurm/submit.sh'"),
            "{a}"
        );
        assert!(a.contains(r"exec '/opt/st okes/bin/stokes' job '/data/my run'\''s/20%'"));
        for opt in ["--partition", "--time", "--cpus-per-task"] {
            assert!(!a.contains(opt), "{opt} in {a}");
        }
        // sbatch reads #SBATCH lines only before the first command.
        let first_cmd = a.find("set -euo").unwrap();
        assert!(a.rfind("#SBATCH").unwrap() < first_cmd);
        assert!(texts("/r", 1, &o).array().contains("--array=0-0\n"));
    }

    #[test]
    fn collect_and_submit_script_text() {
        let o = opts(Some("debug"), Some("1-00:00:00"), Some(4));
        let t = texts("/data/a b", 3, &o);
        let a = t.array();
        let c = t.collect();
        for s in [&a, &c] {
            assert!(s.contains("\n#SBATCH --partition=debug\n"), "{s}");
            assert!(s.contains("\n#SBATCH --time=1-00:00:00\n"), "{s}");
            assert!(s.contains("\n#SBATCH --cpus-per-task=4\n"), "{s}");
        }
        assert!(!c.contains("--array"), "{c}");
        assert!(
            c.contains("#SBATCH --job-name=stokes-walls-collect\n"),
            "{c}"
        );
        assert!(c.contains(r#"#SBATCH --output="/data/a b/slurm/logs/collect.out""#));
        assert!(c.contains("exec '/opt/st okes/bin/stokes' experiment --collect '/data/a b'\n"));
        let s = t.submit();
        assert!(s.contains("array_id=$(sbatch --parsable '/data/a b/slurm/array.sbatch')\n"));
        assert!(
            s.contains("--dependency=\"afterok:$array_id\" '/data/a b/slurm/collect.sbatch')\n")
        );
        assert!(s.contains("set -euo pipefail\n"));
    }

    #[test]
    fn write_scripts_files_and_errors() {
        let base = std::env::temp_dir().join(format!("stokes-slurm-{}", std::process::id()));
        let run = base.join("run 'one'");
        std::fs::create_dir_all(&run).unwrap();
        let o = opts(None, Some("10"), None);
        let s = write_scripts(&run, 2, "walls", Path::new("/usr/bin/stokes"), &o).unwrap();
        let real = run.canonicalize().unwrap();
        assert_eq!(s.submit, real.join("slurm/submit.sh"));
        assert!(real.join("slurm/logs").is_dir());
        for p in [&s.array, &s.collect, &s.submit] {
            let text = std::fs::read_to_string(p).unwrap();
            assert!(text.starts_with("#!/bin/bash\n"));
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let mode = std::fs::metadata(p).unwrap().permissions().mode();
                assert_eq!(mode & 0o777, 0o755, "{}", p.display());
            }
        }
        let a = std::fs::read_to_string(&s.array).unwrap();
        assert!(a.contains(&quote(real.to_str().unwrap())));
        assert!(a.contains("--time=10\n"));
        // Again over the same files: replaced, nothing left over.
        write_scripts(&run, 5, "walls", Path::new("/usr/bin/stokes"), &o).unwrap();
        let a = std::fs::read_to_string(&s.array).unwrap();
        assert!(a.contains("--array=0-4\n"));
        assert_eq!(std::fs::read_dir(real.join("slurm")).unwrap().count(), 4);

        let e = write_scripts(&run, 0, "w", Path::new("/x"), &o).unwrap_err();
        assert!(e.message.contains("no jobs"), "{}", e.message);
        let e = write_scripts(&base.join("missing"), 1, "w", Path::new("/x"), &o).unwrap_err();
        assert!(
            e.message.contains("cannot find the run folder"),
            "{}",
            e.message
        );
        let bad = opts(Some("a b"), None, None);
        assert!(write_scripts(&run, 1, "w", Path::new("/x"), &bad).is_err());
        let nl = base.join("new\nline");
        std::fs::create_dir_all(&nl).unwrap();
        let e = write_scripts(&nl, 1, "w", Path::new("/x"), &o).unwrap_err();
        assert!(e.message.contains("control character"), "{}", e.message);
        std::fs::remove_dir_all(&base).unwrap();
    }
}
