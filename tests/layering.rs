//! The source keeps its shape. Outside `#[cfg(test)]` modules and comments, for every file
//! under `src/`:
//!
//! - **Layers.** A module imports only from layers below its own. Every module path counts:
//!   `crate::…`, and `super::…`, `super::super::…` and `self::…` resolved against the module the
//!   path is written in (the file's, and any inline `mod x { … }` around it), with `{…}` groups
//!   expanded (a path through a `pub use` counts as one to the module that re-exports it).
//!   Within `integrator`, the bidirectional integrators (`bdpt`) never use the
//!   uni-directional ones (`pt`).
//! - **Sibling cycles.** Sibling modules (files or folders under the same parent) do not import
//!   each other in a cycle, seen through the same resolved paths.
//! - **Third-party crates.** Each dependency of `Cargo.toml` is used only where [`CRATES`] allows
//!   it (a list of module paths, each allowing the module and everything under it): `clap` only in
//!   the CLI, image formats only where images are read or written, fonts and plots only in figure
//!   code, and so on. A new dependency must be given its places there.
//! - **Function length.** No function runs past [`MAX_FN_LINES`] lines, whatever its qualifiers
//!   (`pub(crate)`, `const`, `async`, `unsafe`, `extern "C"`, …).
//!
//! Layers, lowest first: `io` (files), `spectrum`, `geometry` < `film`, `material`, `medium` <
//! `scene` < `error`, `transport` < `integrator` < `experiment` < `gmm` < `cli` < `main`. A new
//! top-level module must be given a layer here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const LAYERS: &[(&str, u32)] = &[
    ("io", 0),
    ("spectrum", 0),
    ("geometry", 0),
    ("film", 1),
    ("material", 1),
    ("medium", 1),
    ("scene", 2),
    ("error", 3),
    ("transport", 3),
    ("integrator", 4),
    ("experiment", 5),
    ("gmm", 6),
    ("cli", 7),
];

/// Where each dependency of `Cargo.toml` may be used: module paths (`main` and `lib` are the
/// crate's root files), each allowing that module and everything under it. Empty: nowhere in
/// `src/`.
const CRATES: &[(&str, &[&str])] = &[
    // Font drawing of the PNG figures.
    ("ab_glyph", &["experiment::figures::text", "gmm::canvas"]),
    // Not used by the crate.
    ("anyhow", &[]),
    // Command-line parsing.
    ("clap", &["cli", "main"]),
    // OpenEXR images of the film.
    ("exr", &["film::output", "film::shard", "film::spectral"]),
    (
        "glam",
        &[
            "spectrum",
            "geometry",
            "film",
            "medium::grid",
            "scene",
            "transport",
            "integrator",
            "experiment",
            "cli",
        ],
    ),
    // Half floats of the report's pixel encoding.
    ("half", &["experiment::report::encode"]),
    // PNG images: the film's preview, the figures, the box plots.
    (
        "image",
        &["film::output", "experiment::figures", "gmm::canvas"],
    ),
    // Progress bars: of a render, of a run and its steps, of a fit.
    (
        "indicatif",
        &[
            "integrator::render",
            "experiment::progress",
            "experiment::reference",
            "experiment::grid",
            "experiment::runner",
            "experiment::variants",
            "experiment::cluster::job",
            "experiment::cluster::collect",
            "gmm::fit",
        ],
    ),
    // File-system calls of inputs and outputs; the BVH's huge-page mappings.
    ("libc", &["io::input", "io::output", "geometry::bvh"]),
    ("mimalloc", &["main"]),
    // Deflate of the report's pixel encoding.
    ("miniz_oxide", &["experiment::report::encode"]),
    // The binary BVH.
    ("obvhs", &["geometry::bvh"]),
    ("palette", &["spectrum::colorimetry"]),
    // Plots.
    (
        "plotters",
        &[
            "experiment::figures::plots",
            "gmm::boxplot",
            "gmm::canvas",
            "gmm::figures",
        ],
    ),
    ("plotters_backend", &["gmm::boxplot", "gmm::canvas"]),
    // Random streams: of the samplers, and of the mixtures' fits.
    ("rand", &["integrator", "material::mixture::em"]),
    ("rand_pcg", &["integrator", "material::mixture::em"]),
    // Parallel work: the BVH build, renders, runs and jobs, fits and their evaluation.
    (
        "rayon",
        &[
            "geometry::bvh",
            "integrator::render",
            "experiment::runner",
            "experiment::cluster::job",
            "gmm::evaluate",
            "gmm::fit",
            "gmm::robust",
            "material::mixture::fit",
        ],
    ),
    // Types read from and written as JSON.
    (
        "serde",
        &[
            "io::json",
            "spectrum::cie",
            "geometry::bvh",
            "material",
            "medium::tracking",
            "scene::format",
            "scene::lights",
            "scene::spectra",
            "integrator",
            "experiment",
            "gmm::boxplot",
            "gmm::colour",
            "gmm::evaluate",
            "gmm::robust",
            "gmm::summary",
        ],
    ),
    (
        "serde_json",
        &[
            "io::json",
            "film::shard",
            "material::mixture::file",
            "scene",
            "integrator::render",
            "experiment",
            "gmm::evaluate",
            "gmm::robust",
            "cli",
        ],
    ),
    // JSON paths of input errors.
    ("serde_path_to_error", &["io::json"]),
    // Content hashes.
    ("sha2", &["io::hash"]),
    ("signal_hook", &["main"]),
    // OBJ meshes of a scene.
    ("tobj", &["scene::shape_geometry"]),
];

const MAX_FN_LINES: usize = 120;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn src_files() -> Vec<PathBuf> {
    let mut files = Vec::new();
    rust_files(Path::new("src"), &mut files);
    files.sort();
    files
}

/// The code of a file, line by line, without its `#[cfg(test)]` module, without comments, and
/// with the contents of string and character literals blanked (their quotes and line breaks
/// kept), so that no path, brace or `fn` inside them is seen.
fn code(path: &Path) -> Vec<String> {
    // a file of a test module (`tests.rs`, or under a `tests/` folder) is test code throughout
    if path.iter().any(|c| c == "tests" || c == "tests.rs") {
        return Vec::new();
    }
    let text = std::fs::read_to_string(path).unwrap();
    // the test module: `#[cfg(test)]` on an inline `mod … {` (a `#[cfg(test)]` item or
    // `mod x;` declaration elsewhere is read on)
    let mut end = text.len();
    let mut offset = 0;
    let mut lines = text.split_inclusive('\n').peekable();
    while let Some(line) = lines.next() {
        let next = lines.peek().map_or("", |l| l.trim_end());
        if line.trim_end() == "#[cfg(test)]" && next.starts_with("mod ") && next.ends_with('{') {
            end = offset;
            break;
        }
        offset += line.len();
    }
    let s: Vec<char> = text[..end].chars().collect();
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    let mut out = String::with_capacity(s.len());
    let mut i = 0;
    while i < s.len() {
        let c = s[i];
        let prev_ident = i > 0 && is_ident_char(s[i - 1]);
        if at(&s, i, "//") {
            while i < s.len() && s[i] != '\n' {
                i += 1;
            }
        } else if at(&s, i, "/*") {
            let mut depth = 0;
            while i < s.len() {
                if at(&s, i, "/*") {
                    depth += 1;
                    i += 2;
                } else if at(&s, i, "*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(s[i]));
                    i += 1;
                }
            }
        } else if c == 'r'
            && (!prev_ident || (i >= 2 && s[i - 1] == 'b' && !is_ident_char(s[i - 2])))
            && {
                let h = s[i + 1..].iter().take_while(|&&x| x == '#').count();
                s.get(i + 1 + h) == Some(&'"')
            }
        {
            // A raw string: r"…", r#"…"#, br"…".
            let h = s[i + 1..].iter().take_while(|&&x| x == '#').count();
            let close: String = std::iter::once('"')
                .chain(std::iter::repeat_n('#', h))
                .collect();
            out.push('r');
            out.push('"');
            i += 2 + h;
            while i < s.len() && !at(&s, i, &close) {
                out.push(blank(s[i]));
                i += 1;
            }
            out.push('"');
            i += close.len();
        } else if c == '"' {
            out.push('"');
            i += 1;
            while i < s.len() && s[i] != '"' {
                if s[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < s.len() {
                    out.push(blank(s[i]));
                    i += 1;
                }
            }
            out.push('"');
            i += 1;
        } else if c == '\'' && (s.get(i + 1) == Some(&'\\') || s.get(i + 2) == Some(&'\'')) {
            // A character literal ('x', '\n', '\u{…}'); a lifetime has no closing quote.
            out.push('\'');
            i += 1;
            while i < s.len() && s[i] != '\'' {
                if s[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                out.push(' ');
                i += 1;
            }
            out.push('\'');
            i += 1;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out.lines().map(str::to_string).collect()
}

/// The module path of a source file: `src/integrator/bdpt/mis.rs` → [integrator, bdpt, mis].
fn module_path(file: &Path) -> Vec<String> {
    let rel = file.strip_prefix("src").unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

fn is_ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Whether a path may start at `i`: not inside an identifier or after `::`.
fn starts_path(s: &[char], i: usize) -> bool {
    i == 0 || !(is_ident_char(s[i - 1]) || s[i - 1] == ':')
}

fn skip_space(s: &[char], i: &mut usize) {
    while *i < s.len() && s[*i].is_whitespace() {
        *i += 1;
    }
}

fn ident(s: &[char], i: &mut usize) -> String {
    let start = *i;
    while *i < s.len() && is_ident_char(s[*i]) {
        *i += 1;
    }
    s[start..*i].iter().collect()
}

/// Whether `s[i..]` starts with `pat`.
fn at(s: &[char], i: usize, pat: &str) -> bool {
    (i..).zip(pat.chars()).all(|(k, c)| s.get(k) == Some(&c))
}

/// The paths of a path tree starting at `i` (`a::b::{c, d::{e, self}}` → a::b::c, a::b::d::e,
/// a::b::d::self), each as its identifiers; a glob or a generic argument ends a path.
fn path_tree(s: &[char], i: &mut usize) -> Vec<Vec<String>> {
    skip_space(s, i);
    if *i < s.len() && s[*i] == '{' {
        *i += 1;
        let mut out = Vec::new();
        loop {
            skip_space(s, i);
            match s.get(*i) {
                None => break,
                Some('}') => {
                    *i += 1;
                    break;
                }
                Some(',') => *i += 1,
                Some(_) => {
                    let before = *i;
                    out.extend(path_tree(s, i));
                    // `x as y`: skip to the next item.
                    while *i < s.len() && !matches!(s[*i], ',' | '}') {
                        if s[*i] == '{' {
                            break;
                        }
                        *i += 1;
                    }
                    if *i == before {
                        *i += 1; // never stall on an unexpected character
                    }
                }
            }
        }
        return out;
    }
    let name = ident(s, i);
    if name.is_empty() {
        return vec![Vec::new()];
    }
    let mut j = *i;
    skip_space(s, &mut j);
    if at(s, j, "::") {
        *i = j + 2;
        return path_tree(s, i)
            .into_iter()
            .map(|mut p| {
                p.insert(0, name.clone());
                p
            })
            .collect();
    }
    vec![vec![name]]
}

/// A module path written in a file, resolved: absolute, from the crate root.
#[derive(Clone, Debug)]
struct Resolved {
    path: Vec<String>,
    /// As written, for messages (`super::super::config::MAX_SPP`).
    written: String,
    /// How many `super` it starts with.
    supers: usize,
}

/// Every `crate::…`, `super::…` and `self::…` path in `lines` (the code of the file of module
/// `module`), resolved against the module it is written in: the file's, or an inline `mod x { …
/// }` inside it.
fn resolved_paths(module: &[String], lines: &[String]) -> Vec<Resolved> {
    let s: Vec<char> = lines.join("\n").chars().collect();
    let mut out = Vec::new();
    // Inline modules: their names and the brace depth inside them.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut pending_mod: Option<String> = None;
    let mut depth = 0usize;
    let mut i = 0;
    while i < s.len() {
        let c = s[i];
        if c == '{' {
            depth += 1;
            if let Some(m) = pending_mod.take() {
                inline.push((m, depth));
            }
            i += 1;
            continue;
        }
        if c == '}' {
            if inline.last().is_some_and(|(_, d)| *d == depth) {
                inline.pop();
            }
            depth = depth.saturating_sub(1);
            i += 1;
            continue;
        }
        if c == ';' {
            pending_mod = None; // `mod x;`
        }
        if !starts_path(&s, i) || !is_ident_char(c) {
            i += 1;
            continue;
        }
        let start = i;
        if at(&s, i, "mod") && s.get(i + 3).is_some_and(|c| c.is_whitespace()) {
            i += 3;
            skip_space(&s, &mut i);
            pending_mod = Some(ident(&s, &mut i));
            continue;
        }
        let anchor = ["crate", "super", "self"]
            .into_iter()
            .find(|k| at(&s, i, k) && at(&s, i + k.len(), "::"));
        let Some(_) = anchor else {
            ident(&s, &mut i);
            continue;
        };
        let here: Vec<String> = module
            .iter()
            .cloned()
            .chain(inline.iter().map(|(m, _)| m.clone()))
            .collect();
        let trees = path_tree(&s, &mut i);
        let written: String = s[start..i].iter().collect();
        for raw in trees {
            let mut base: Vec<String> = Vec::new();
            let mut k = 0;
            let mut supers = 0;
            match raw.first().map(String::as_str) {
                Some("crate") => k = 1,
                Some("self") => {
                    base = here.clone();
                    k = 1;
                }
                _ => {
                    base = here.clone();
                    while raw.get(k).is_some_and(|x| x == "super") {
                        base.pop();
                        supers += 1;
                        k += 1;
                    }
                }
            }
            base.extend(raw[k..].iter().filter(|x| *x != "self").cloned());
            out.push(Resolved {
                path: base,
                written: written.split_whitespace().collect::<Vec<_>>().join(" "),
                supers,
            });
        }
    }
    out
}

/// Each file's module path and its resolved paths.
fn all_paths() -> Vec<(PathBuf, Vec<String>, Vec<Resolved>)> {
    src_files()
        .into_iter()
        .map(|f| {
            let m = module_path(&f);
            let p = resolved_paths(&m, &code(&f));
            (f, m, p)
        })
        .collect()
}

#[test]
fn modules_import_only_from_lower_layers() {
    let layers: BTreeMap<&str, u32> = LAYERS.iter().copied().collect();
    let mut problems = Vec::new();
    for (f, m, paths) in all_paths() {
        let Some(top) = m.first() else { continue };
        if top == "lib" || top == "main" {
            continue;
        }
        let Some(&own) = layers.get(top.as_str()) else {
            problems.push(format!(
                "{}: module `{top}` has no layer in LAYERS",
                f.display()
            ));
            continue;
        };
        for r in paths {
            let p = &r.path;
            let Some(target) = p.first() else { continue };
            if target == top {
                // Within a module: the bidirectional integrators never use the uni-directional.
                if m.get(1).is_some_and(|s| s == "bdpt") && p.get(1).is_some_and(|s| s == "pt") {
                    problems.push(format!(
                        "{}: bdpt imports crate::{} (`{}`)",
                        f.display(),
                        p.join("::"),
                        r.written
                    ));
                }
                continue;
            }
            // Items re-exported at the crate root (`crate::Error`) belong to their module.
            let target = if target == "Error" || target == "ErrorKind" {
                "error"
            } else {
                target
            };
            match layers.get(target) {
                Some(&l) if l < own => {}
                Some(&l) => problems.push(format!(
                    "{}: `{top}` (layer {own}) imports crate::{} (layer {l}; `{}`)",
                    f.display(),
                    p.join("::"),
                    r.written
                )),
                None => problems.push(format!(
                    "{}: unknown module crate::{} (`{}`)",
                    f.display(),
                    p.join("::"),
                    r.written
                )),
            }
        }
    }
    assert!(problems.is_empty(), "layering:\n{}", problems.join("\n"));
}

#[test]
fn paths_are_resolved_against_their_module() {
    let m = |p: &str| p.split("::").map(str::to_string).collect::<Vec<_>>();
    let lines: Vec<String> = [
        "use super::super::config::{BudgetMode, Config};",
        "use super::super::{figures, sweep::{self, Point}};",
        "use crate::io::limits::MAX_SPP;",
        "use super::plan::Job as J;",
        "fn f() { let x = self::g(); }",
        "mod inner {",
        "    use super::Job;",
        "}",
        "use super::collect;",
    ]
    .iter()
    .map(|l| l.to_string())
    .collect();
    let got: Vec<(Vec<String>, usize)> = resolved_paths(&m("experiment::cluster::job"), &lines)
        .into_iter()
        .map(|r| (r.path, r.supers))
        .collect();
    let want = [
        ("experiment::config::BudgetMode", 2),
        ("experiment::config::Config", 2),
        ("experiment::figures", 2),
        ("experiment::sweep", 2),
        ("experiment::sweep::Point", 2),
        ("io::limits::MAX_SPP", 0),
        ("experiment::cluster::plan::Job", 1),
        ("experiment::cluster::job::g", 0),
        ("experiment::cluster::job::Job", 1),
        ("experiment::cluster::collect", 1),
    ]
    .map(|(p, n)| (m(p), n));
    assert_eq!(got, want);
}

#[test]
fn sibling_modules_have_no_import_cycles() {
    let files = all_paths();
    // Edges between sibling modules (files or folders under the same parent), by name.
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|(_, m, _)| m.clone()).collect();
    for (_, m, paths) in &files {
        if m.is_empty() {
            continue;
        }
        for r in paths {
            // The longest module prefix of the path.
            let p = &r.path;
            let Some(t) = (1..=p.len())
                .rev()
                .find(|&k| modules.contains(&p[..k]))
                .map(|k| p[..k].to_vec())
            else {
                continue;
            };
            // Reduce both ends to the children of their common parent; a parent may name its
            // children, and a child its parent.
            let common = m.iter().zip(&t).take_while(|(a, b)| a == b).count();
            if common >= m.len() || common >= t.len() {
                continue; // an ancestor or descendant
            }
            let (a, b) = (m[..=common].to_vec(), t[..=common].to_vec());
            edges.entry(a).or_default().insert(b);
        }
    }
    // Depth-first search for a cycle.
    fn visit(
        n: &Vec<String>,
        edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        state: &mut BTreeMap<Vec<String>, u8>,
        stack: &mut Vec<Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        match state.get(n) {
            Some(1) => {
                let i = stack.iter().position(|x| x == n).unwrap();
                let mut c = stack[i..].to_vec();
                c.push(n.clone());
                return Some(c);
            }
            Some(2) => return None,
            _ => {}
        }
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for m in edges.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, edges, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in edges.keys() {
        if let Some(c) = visit(n, &edges, &mut state, &mut Vec::new()) {
            let names: Vec<String> = c.iter().map(|p| p.join("::")).collect();
            panic!("import cycle: {}", names.join(" → "));
        }
    }
}

/// The names of `[dependencies]` in Cargo.toml, as Rust spells them (`-` → `_`).
fn dependencies() -> BTreeSet<String> {
    let toml = std::fs::read_to_string("Cargo.toml").unwrap();
    let mut in_deps = false;
    let mut out = BTreeSet::new();
    for l in toml.lines() {
        let l = l.trim();
        if l.starts_with('[') {
            in_deps = l == "[dependencies]";
            continue;
        }
        if !in_deps || l.is_empty() || l.starts_with('#') {
            continue;
        }
        if let Some((name, _)) = l.split_once('=') {
            out.insert(name.trim().replace('-', "_"));
        }
    }
    out
}

/// The third-party crates `lines` name: `name::…` outside any longer path, and `extern crate`.
fn crates_used(lines: &[String], deps: &BTreeSet<String>) -> BTreeSet<String> {
    let s: Vec<char> = lines.join("\n").chars().collect();
    let mut out = BTreeSet::new();
    let mut i = 0;
    while i < s.len() {
        if !starts_path(&s, i) || !is_ident_char(s[i]) {
            i += 1;
            continue;
        }
        let name = ident(&s, &mut i);
        let mut j = i;
        skip_space(&s, &mut j);
        if name == "crate" {
            // `extern crate x`
            let next = ident(&s, &mut j);
            if deps.contains(&next) {
                out.insert(next);
            }
        } else if at(&s, j, "::") && deps.contains(&name) {
            out.insert(name);
        }
    }
    out
}

#[test]
fn third_party_crates_are_used_only_where_allowed() {
    let deps = dependencies();
    let table: BTreeMap<&str, &[&str]> = CRATES.iter().copied().collect();
    let mut problems = Vec::new();
    for d in &deps {
        if !table.contains_key(d.as_str()) {
            problems.push(format!(
                "Cargo.toml: dependency `{d}` has no entry in CRATES (say where it may be used)"
            ));
        }
    }
    for name in table.keys() {
        if !deps.contains(*name) {
            problems.push(format!(
                "CRATES names `{name}`, which is not a dependency in Cargo.toml"
            ));
        }
    }
    for f in src_files() {
        let m = module_path(&f);
        for c in crates_used(&code(&f), &deps) {
            let allowed = table.get(c.as_str()).copied().unwrap_or(&[]);
            let ok = allowed.iter().any(|a| {
                let a: Vec<&str> = a.split("::").collect();
                m.len() >= a.len() && m.iter().zip(&a).all(|(x, y)| x == y)
            });
            if !ok {
                let places = if allowed.is_empty() {
                    "nowhere in src/".to_string()
                } else {
                    allowed.join(", ")
                };
                problems.push(format!(
                    "{}: uses `{c}`, which may be used only in: {places}",
                    f.display()
                ));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "third-party crates:\n{}",
        problems.join("\n")
    );
}

/// Whether `t` (a trimmed line) declares a function: any visibility (`pub`, `pub(crate)`,
/// `pub(in …)`), then any of `default`, `const`, `async`, `unsafe`, `safe` and `extern`
/// (with or without an ABI string), then `fn`.
fn declares_fn(t: &str) -> bool {
    let mut t = t;
    if let Some(rest) = t.strip_prefix("pub") {
        let rest_trim = rest.trim_start();
        if let Some(inner) = rest_trim.strip_prefix('(') {
            let Some(close) = inner.find(')') else {
                return false;
            };
            t = inner[close + 1..].trim_start();
        } else if rest.starts_with(char::is_whitespace) {
            t = rest_trim;
        } else {
            return false; // `pubx`
        }
    }
    loop {
        if t.starts_with("fn ") || t.starts_with("fn\t") {
            return true;
        }
        let Some(q) = ["default", "const", "async", "unsafe", "safe", "extern"]
            .into_iter()
            .find(|q| {
                t.strip_prefix(q)
                    .is_some_and(|r| r.starts_with(char::is_whitespace))
            })
        else {
            return false;
        };
        t = t[q.len()..].trim_start();
        if q == "extern"
            && let Some(abi) = t.strip_prefix('"')
        {
            let Some(end) = abi.find('"') else {
                return false;
            };
            t = abi[end + 1..].trim_start();
        }
    }
}

#[test]
fn functions_of_every_kind_are_seen() {
    for t in [
        "fn f() {",
        "pub fn f() {",
        "pub(crate) fn f() {",
        "pub(super) fn f() {",
        "pub(in crate::scene) fn f() {",
        "const fn f() {",
        "pub const fn f() {",
        "unsafe fn f() {",
        "pub(crate) unsafe fn f() {",
        "async fn f() {",
        "pub async unsafe fn f() {",
        "extern \"C\" fn f() {",
        "pub unsafe extern \"C\" fn f() {",
        "pub(crate) const unsafe extern \"C\" fn f() {",
        "extern fn f() {",
        "default fn f() {",
    ] {
        assert!(declares_fn(t), "{t}");
    }
    for t in [
        "const F: u32 = 1;",
        "pub struct Fn;",
        "extern \"C\" {",
        "unsafe impl Send for X {}",
        "let f = fn_pointer;",
        "pubfn f() {",
    ] {
        assert!(!declares_fn(t), "{t}");
    }
}

#[test]
fn no_function_is_longer_than_the_limit() {
    let mut long = Vec::new();
    for f in src_files() {
        let lines = code(&f);
        let text = std::fs::read_to_string(&f).unwrap();
        let source: Vec<&str> = text.lines().collect();
        for (i, l) in lines.iter().enumerate() {
            let t = l.trim_start();
            let indent = &l[..l.len() - t.len()];
            if !declares_fn(t) {
                continue;
            }
            // The signature, which may span lines, ends with `{` (a body), `;` (a trait's
            // required method) or `}` (a body on the same line, as `fn f() {}`).
            let sig_end = (i..lines.len()).find(|&j| {
                let e = lines[j].trim_end();
                e.ends_with(';') || e.ends_with('{') || e.ends_with('}')
            });
            if !sig_end.is_some_and(|j| lines[j].trim_end().ends_with('{')) {
                continue;
            }
            // rustfmt closes a function body at the indentation of its signature.
            let close = format!("{indent}}}");
            let end = (i + 1..lines.len())
                .find(|&j| lines[j].starts_with(&close) && lines[j].trim() == "}");
            if let Some(end) = end
                && end - i + 1 > MAX_FN_LINES
            {
                long.push(format!(
                    "{}:{} {} lines: {}",
                    f.display(),
                    i + 1,
                    end - i + 1,
                    source[i].trim()
                ));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines:\n{}",
        long.join("\n")
    );
}

/// The SIMD code (intrinsics, target features, CPU feature detection) stays in the BVH, whose
/// instruction set is chosen once per process (`geometry/bvh/isa.rs`): everything above it is
/// portable Rust.
#[test]
fn simd_stays_in_the_bvh() {
    let bvh = Path::new("src").join("geometry").join("bvh");
    let mut offenders = Vec::new();
    for f in src_files() {
        if f.starts_with(&bvh) {
            continue;
        }
        for (n, line) in code(&f).iter().enumerate() {
            if [
                "std::arch",
                "core::arch",
                "target_feature",
                "is_x86_feature_detected",
            ]
            .iter()
            .any(|p| line.contains(p))
            {
                offenders.push(format!("{}:{}: {line}", f.display(), n + 1));
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "SIMD outside geometry/bvh:\n{}",
        offenders.join("\n")
    );
}
