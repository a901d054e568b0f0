//! `report.html` of a run: one self-contained page (no network; its script and style inline)
//! with the image viewer, the metrics tables, the figures and the config.
//!
//! The viewer shows the reference and repeat 0's snapshot of every variant at every budget from
//! the run's EXRs, embedded as HDR pixels: half floats, planar, high bytes before low bytes,
//! deflated and base64-encoded ([`encode`]); the page inflates them with the browser's
//! `DecompressionStream` and applies exposure (2^stops on the linear values) and the sRGB
//! transfer function itself, or shows the per-pixel relative error against the reference.
//! `report.html#selftest` runs the page's self-test after loading (tests/report_browser.rs).

mod encode;
mod images;
mod plots;
mod tables;

pub use encode::base64;

use super::figures::resolve_run_dir;
use super::record::{RunInfo, check_complete, read_metrics, write_text};
use super::sweep::SweepRecord;
use crate::error::Error;
use encode::{html, script_json};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// The report's file name inside the run folder.
pub const REPORT_FILE: &str = "report.html";

const CSS: &str = include_str!("viewer.css");
const ERRORS_JS: &str = include_str!("errors.js");
const VIEWER_JS: &str = include_str!("viewer.js");
const SELFTEST_JS: &str = include_str!("selftest.js");

/// What a report holds, for the message of `stokes report`.
pub struct Written {
    pub file: PathBuf,
    pub bytes: usize,
    pub images: usize,
    pub figures: usize,
}

/// Write `report.html` into the run folder `dir` (or the run an experiment folder's `latest`
/// names); a sweep gets one per value (`sweep/<i>/report.html`) and one that links them. A run
/// that is incomplete, or whose files are missing or damaged, is an input error naming the file.
pub fn write(dir: &Path) -> Result<Written, Error> {
    // An interrupted run has no run.json yet: look for its marker first.
    check_complete(dir)?;
    let run = resolve_run_dir(dir)?;
    check_complete(&run)?;
    crate::io::tree::check_run_folder(&run).map_err(Error::input)?;
    let info = RunInfo::read(&run)?;
    if info.config.sweep.is_some() {
        return write_sweep(&run, &info);
    }
    write_run(&run, &info)
}

fn write_run(dir: &Path, info: &RunInfo) -> Result<Written, Error> {
    let rows = read_metrics(&dir.join("metrics.csv"))?;
    let (data, images) = images::viewer_data(dir, info, &rows)?;
    let tables = tables::section(dir, info)?;
    let (figs, figures) = plots::section(dir)?;
    let mut body = String::new();
    header(info, dir, &mut body);
    body.push_str(VIEWER_HTML);
    let _ = write!(
        body,
        "<section id=\"metrics\"><h2>Metrics</h2>\n{tables}</section>\n\
         <section id=\"figures\"><h2>Figures</h2>\n<div class=\"figures\">{figs}</div></section>\n"
    );
    config_section(info, &mut body);
    let _ = write!(
        body,
        "<pre id=\"selftest\" hidden></pre>\n\
         <script type=\"application/json\" id=\"stokes-images\">{}</script>\n\
         <script>{VIEWER_JS}</script>\n<script>{SELFTEST_JS}</script>\n",
        script_json(&data)
    );
    finish(dir, info, &body, images, figures)
}

/// A sweep: a report per value, and the sweep's own with its figures and links to them.
fn write_sweep(dir: &Path, info: &RunInfo) -> Result<Written, Error> {
    let rec = SweepRecord::read(dir)?;
    let mut body = String::new();
    header(info, dir, &mut body);
    let _ = write!(
        body,
        "<section id=\"sweep\"><h2>Sweep over {}</h2><ul>",
        html(&rec.label)
    );
    let mut images = 0;
    for p in &rec.points {
        let d = dir.join(&p.dir);
        check_complete(&d)?;
        let w = write_run(&d, &RunInfo::read(&d)?)?;
        images += w.images;
        let _ = write!(
            body,
            "<li><a href=\"{dir}/{REPORT_FILE}\">{label} = {value}</a> ({dir})</li>",
            dir = html(&p.dir),
            label = html(&rec.label),
            value = html(&super::sweep::compact(&p.value))
        );
    }
    body.push_str("</ul></section>\n");
    let (figs, figures) = plots::section(dir)?;
    let _ = write!(
        body,
        "<section id=\"figures\"><h2>Figures</h2>\n<div class=\"figures\">{figs}</div></section>\n"
    );
    config_section(info, &mut body);
    finish(dir, info, &body, images, figures)
}

/// The title and the facts of the run.
fn header(info: &RunInfo, dir: &Path, out: &mut String) {
    let c = &info.config;
    let _ = write!(
        out,
        "<header><h1>{name}</h1>\n<p class=\"facts\">{w}×{h} pixels{quick} · {v} variants · \
         {r} repeat{rs} · started {started} · {threads} threads · config {cfg} · run folder {dir}</p>\n",
        name = html(&c.name),
        w = info.width,
        h = info.height,
        quick = if info.quick { " (--quick)" } else { "" },
        v = c.variants.len(),
        r = c.repeats,
        rs = if c.repeats == 1 { "" } else { "s" },
        started = html(&info.started),
        threads = info.threads,
        cfg = html(&info.config_file.display().to_string()),
        dir = html(&dir.display().to_string()),
    );
    if !c.comment.is_empty() {
        let _ = writeln!(out, "<p class=\"comment\">{}</p>", html(&c.comment));
    }
    out.push_str("</header>\n");
}

/// run.json's `config`, pretty-printed.
fn config_section(info: &RunInfo, out: &mut String) {
    let cfg = serde_json::to_string_pretty(&info.config).expect("a config serialises");
    let _ = writeln!(
        out,
        "<section id=\"config\"><h2>Config</h2>\n<pre class=\"config\">{}</pre></section>",
        html(&cfg)
    );
}

/// The page around `body`, written atomically as the run's report.
fn finish(
    dir: &Path,
    info: &RunInfo,
    body: &str,
    images: usize,
    figures: usize,
) -> Result<Written, Error> {
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; \
         img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{title} — stokes report</title>\n<script>{ERRORS_JS}</script>\n\
         <style>{CSS}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        title = html(&info.config.name)
    );
    let file = dir.join(REPORT_FILE);
    write_text(&file, &page)?;
    Ok(Written {
        file,
        bytes: page.len(),
        images,
        figures,
    })
}

/// The viewer's markup; viewer.js fills it from the `stokes-images` data.
const VIEWER_HTML: &str = r#"<section id="viewer"><h2>Images</h2>
<div class="viewer">
<div class="side">
<div class="group"><div class="label">Method <span class="keys">← → or 1–9</span></div><div id="methods"></div></div>
<div class="group"><div class="label">Budget <span class="keys">↑ ↓</span></div><div id="budgets"></div></div>
<div class="group"><div class="label">Exposure <span id="exposure-value"></span> <span class="keys">+ − a</span></div>
<input type="range" id="exposure" min="-16" max="16" step="0.1" value="0">
<button type="button" id="auto-exposure">auto</button></div>
<div class="group"><button type="button" id="error-toggle">relative error <span class="keys">e</span></button>
<button type="button" id="fit">fit <span class="keys">f</span></button></div>
<div id="legend" hidden><div class="bar"></div><div class="ticks"><span>≤ 0.001</span><span>0.01</span><span>0.1</span><span>≥ 1</span></div>
<p class="note">√(mean over R, G, B of (x − r)² / (r² + 0.01)), r = reference, log scale; magenta: not finite. Its mean square over the image is relMSE.</p></div>
<p class="note">Wheel: zoom (nearest pixel). Drag: pan. The view stays when you flip. Values are linear sRGB; exposure scales them by 2<sup>stops</sup> before the sRGB curve.</p>
</div>
<div class="main">
<div id="caption">loading images…</div>
<canvas id="view"></canvas>
<div id="pixel">&nbsp;</div>
</div>
</div>
</section>
"#;
