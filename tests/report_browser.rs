//! report.html in a real browser: headless Chromium loads the report of a quick run with
//! `#selftest`, which drives the viewer through the events a user makes (keys, the exposure
//! slider's `input`, a click, wheel and drag) and writes its checks into the page; the test reads
//! them from the dumped DOM, and fails on any script error, in the page or in the browser's log.
//!
//! The browser: `STOKES_BROWSER`, else `chromium`, `chromium-browser` or `google-chrome` on the
//! PATH (`scripts/browser-setup.sh` installs Debian's chromium). Without one the tests say so
//! and pass, unless `STOKES_REQUIRE_BROWSER=1` (CI), when they fail.

mod common;

use common::{bin, repo, s, temp_dir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Seconds the browser may take for one page.
const BROWSER_TIMEOUT: u64 = 90;

fn on_path(name: &str) -> Option<PathBuf> {
    let p = Path::new(name);
    if p.components().count() > 1 {
        return p.is_file().then(|| p.to_path_buf());
    }
    std::env::split_paths(&std::env::var_os("PATH")?)
        .map(|d| d.join(name))
        .find(|c| c.is_file())
}

/// The browser to test with; `None` (after saying why) when there is none and none is required.
fn browser(test: &str) -> Option<PathBuf> {
    if let Ok(b) = std::env::var("STOKES_BROWSER")
        && !b.is_empty()
    {
        let found = on_path(&b);
        assert!(found.is_some(), "STOKES_BROWSER={b} is not an executable");
        return found;
    }
    if let Some(b) = ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|n| on_path(n))
    {
        return Some(b);
    }
    let required = std::env::var("STOKES_REQUIRE_BROWSER").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "STOKES_REQUIRE_BROWSER=1 but no browser was found (STOKES_BROWSER, chromium, \
         chromium-browser, google-chrome); install one with scripts/browser-setup.sh"
    );
    eprintln!(
        "SKIPPED {test}: no browser found (STOKES_BROWSER, chromium, chromium-browser, \
         google-chrome); install one with scripts/browser-setup.sh, or set \
         STOKES_REQUIRE_BROWSER=1 to make this a failure"
    );
    None
}

/// `experiments/NAME.json --quick` into `out`; its run folder.
fn quick_run(name: &str, out: &Path) -> PathBuf {
    let cfg = repo().join(format!("experiments/{name}.json"));
    let o = Command::new(bin())
        .args(["experiment", s(&cfg), "--quick", "--out", s(out)])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let latest = std::fs::read_to_string(out.join(name).join("latest")).unwrap();
    out.join(name).join(latest.trim())
}

/// `file://` URL of an absolute path.
fn file_url(p: &Path) -> String {
    let mut u = String::from("file://");
    for b in s(p).bytes() {
        if b.is_ascii_alphanumeric() || b"/._-~".contains(&b) {
            u.push(b as char);
        } else {
            u.push_str(&format!("%{b:02X}"));
        }
    }
    u
}

/// Load `url` headless and return the DOM after the scripts ran, and the browser's log.
fn dump_dom(browser: &Path, url: &str, profile: &Path) -> (String, String) {
    let out = profile.with_extension("dom");
    let err = profile.with_extension("log");
    let mut child = Command::new(browser)
        .args([
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--no-default-browser-check",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=10000",
            "--window-size=1400,1000",
        ])
        .arg(format!("--user-data-dir={}", s(profile)))
        .args(["--dump-dom", url])
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if start.elapsed() > Duration::from_secs(BROWSER_TIMEOUT) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the browser did not finish within {BROWSER_TIMEOUT} s: {url}");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let log = std::fs::read_to_string(&err).unwrap_or_default();
    assert!(status.success(), "the browser failed ({status}):\n{log}");
    (std::fs::read_to_string(&out).unwrap(), log)
}

/// Lines of the browser's log that are messages of the page: with `--enable-logging` Chromium
/// logs every console message as `CONSOLE`, and the report writes none, so each is an error
/// (an uncaught exception, a rejected promise, a blocked resource, console.error).
fn page_messages(log: &str) -> Vec<&str> {
    log.lines()
        .filter(|l| l.contains(":CONSOLE") || l.contains("Uncaught"))
        .collect()
}

fn unescape(t: &str) -> String {
    t.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&#39;", "'")
        .replace("&nbsp;", "\u{a0}")
        .replace("&amp;", "&")
}

/// Run the self-test of the report `file`; its JSON result. Fails on messages in the log.
fn selftest(browser: &Path, file: &Path, tmp: &Path) -> Value {
    let url = format!("{}#selftest", file_url(file));
    let (dom, log) = dump_dom(browser, &url, &tmp.join("profile"));
    let bad = page_messages(&log);
    assert!(
        bad.is_empty(),
        "the page logged errors:\n{}",
        bad.join("\n")
    );
    let open = "<pre id=\"selftest\">";
    let Some(i) = dom.rfind(open) else {
        panic!("the self-test wrote no result (the page's scripts did not run to the end):\n{log}");
    };
    let body = &dom[i + open.len()..];
    let text = unescape(&body[..body.find("</pre>").unwrap()]);
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// The names of the failed checks of a self-test result, and of the skipped ones.
fn failed_and_skipped(r: &Value) -> (Vec<String>, Vec<String>) {
    let checks = r["checks"].as_array().expect("checks");
    let name = |c: &Value| format!("{}: {}", c["name"], c["detail"]);
    (
        checks
            .iter()
            .filter(|c| c["ok"] != true)
            .map(name)
            .collect(),
        checks
            .iter()
            .filter(|c| c.get("skipped").is_some())
            .map(|c| c["name"].to_string())
            .collect(),
    )
}

/// The report of `walls-integrators --quick` (a reference, six variants at three budgets):
/// it renders without errors; flipping changes the canvas and keeps the view; +1 stop on the
/// exposure slider doubles the linear value of every channel that is neither clipped nor near
/// black (each 8-bit value is the true one rounded, so both values are known to ±½ step and a
/// channel passes when the doubled interval of the first overlaps the second's; near black is
/// below 24/255, where ½ step is more than 2 % of the value); the error view shows with its
/// legend; wheel zoom and drag pan stay when flipping; `f` fits again.
#[test]
fn report_works_in_a_browser() {
    let Some(browser) = browser("report_works_in_a_browser") else {
        return;
    };
    let t = Instant::now();
    let d = temp_dir("report-browser");
    let run = quick_run("walls-integrators", &d);
    let r = selftest(&browser, &run.join("report.html"), &d);
    let (failed, skipped) = failed_and_skipped(&r);
    assert!(failed.is_empty(), "failed checks:\n{}", failed.join("\n"));
    assert!(skipped.is_empty(), "skipped checks: {skipped:?}");
    assert_eq!(r["errors"], Value::Array(vec![]), "{}", r["errors"]);
    assert_eq!(r["ok"], true);
    let names: Vec<&str> = r["checks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    for want in [
        "exposure +1 stop doubles the linear values",
        "ArrowRight flips to another method and the canvas changes",
        "the view stays when flipping",
        "e shows the relative error with its legend",
        "the zoom stays when flipping",
        "the pan stays when flipping",
    ] {
        assert!(names.contains(&want), "no check `{want}`: {names:?}");
    }
    let exposure = r["checks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "exposure +1 stop doubles the linear values")
        .unwrap();
    assert!(
        exposure["detail"]["channels"].as_u64().unwrap() >= 1000,
        "too few channels checked: {}",
        exposure["detail"]
    );
    eprintln!(
        "browser self-test: {} checks passed in {:.1} s; exposure: {}",
        names.len(),
        t.elapsed().as_secs_f64(),
        exposure["detail"]
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A run without a reference and with a parameter grid (`fluorescence-parameters --quick`): the
/// grid's cells are methods of the viewer, and every check but the error view's runs.
#[test]
fn grid_report_works_in_a_browser() {
    let Some(browser) = browser("grid_report_works_in_a_browser") else {
        return;
    };
    let d = temp_dir("report-browser-grid");
    let run = quick_run("fluorescence-parameters", &d);
    let r = selftest(&browser, &run.join("report.html"), &d);
    let (failed, skipped) = failed_and_skipped(&r);
    assert!(failed.is_empty(), "failed checks:\n{}", failed.join("\n"));
    assert_eq!(skipped, ["\"the relative error view\""]);
    assert_eq!(r["ok"], true);
    let _ = std::fs::remove_dir_all(&d);
}
