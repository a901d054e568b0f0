//! The source keeps its shape: modules import only from layers below them, sibling modules do not
//! import each other in a cycle, the bidirectional integrators do not reach into the
//! uni-directional ones, and no function outside tests runs past about 120 lines.
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

/// The code of a file without comments and without its `#[cfg(test)]` module.
fn code(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = Vec::new();
    for l in text.lines() {
        if l.starts_with("#[cfg(test)]") {
            break;
        }
        let l = match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        };
        lines.push(l.to_string());
    }
    lines
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

/// Every `crate::a::b…` path named in `lines`, as its identifiers.
fn crate_paths(lines: &[String]) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for l in lines {
        let mut rest = l.as_str();
        while let Some(i) = rest.find("crate::") {
            let tail = &rest[i + "crate::".len()..];
            let path: Vec<String> = tail
                .split("::")
                .map(|s| {
                    s.chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect::<String>()
                })
                .take_while(|s| !s.is_empty())
                .collect();
            out.push(path);
            rest = tail;
        }
    }
    out
}

/// The names right after `super::` (a plain name, or each first name inside `super::{…}`).
fn super_names(lines: &[String]) -> BTreeSet<String> {
    let text = lines.join("\n");
    let mut out = BTreeSet::new();
    let mut rest = text.as_str();
    while let Some(i) = rest.find("super::") {
        let tail = &rest[i + "super::".len()..];
        if let Some(inner) = tail.strip_prefix('{') {
            // Top-level items of the brace group.
            let mut depth = 0;
            let mut item = String::new();
            for c in inner.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.insert(first_ident(&item));
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                item.push(c);
            }
            out.insert(first_ident(&item));
        } else {
            out.insert(first_ident(tail));
        }
        rest = tail;
    }
    out.remove("");
    out
}

fn first_ident(s: &str) -> String {
    s.trim_start()
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect()
}

#[test]
fn modules_import_only_from_lower_layers() {
    let layers: BTreeMap<&str, u32> = LAYERS.iter().copied().collect();
    let mut files = Vec::new();
    rust_files(Path::new("src"), &mut files);
    let mut problems = Vec::new();
    for f in &files {
        let m = module_path(f);
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
        let lines = code(f);
        for p in crate_paths(&lines) {
            let Some(target) = p.first() else { continue };
            if target == top {
                // Within a module: the bidirectional integrators never use the uni-directional.
                if m.get(1).is_some_and(|s| s == "bdpt") && p.get(1).is_some_and(|s| s == "pt") {
                    problems.push(format!(
                        "{}: bdpt imports crate::{}",
                        f.display(),
                        p.join("::")
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
                    "{}: `{top}` (layer {own}) imports crate::{} (layer {l})",
                    f.display(),
                    p.join("::")
                )),
                None => problems.push(format!(
                    "{}: unknown module crate::{}",
                    f.display(),
                    p.join("::")
                )),
            }
        }
    }
    assert!(problems.is_empty(), "layering:\n{}", problems.join("\n"));
}

#[test]
fn sibling_modules_have_no_import_cycles() {
    let mut files = Vec::new();
    rust_files(Path::new("src"), &mut files);
    // Edges between sibling modules (files or folders under the same parent), by name.
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_path(f)).collect();
    for f in &files {
        let m = module_path(f);
        if m.is_empty() || f.file_name().is_some_and(|n| n == "mod.rs") {
            continue; // a parent may name its children
        }
        let parent = &m[..m.len() - 1];
        let lines = code(f);
        let mut targets: Vec<Vec<String>> = Vec::new();
        for name in super_names(&lines) {
            let mut t = parent.to_vec();
            t.push(name);
            targets.push(t);
        }
        for p in crate_paths(&lines) {
            // The longest module prefix of the path.
            for k in (1..=p.len()).rev() {
                if modules.contains(&p[..k]) {
                    targets.push(p[..k].to_vec());
                    break;
                }
            }
        }
        for t in targets {
            // Reduce both ends to the children of their common parent.
            let common = m.iter().zip(&t).take_while(|(a, b)| a == b).count();
            if common >= m.len() || common >= t.len() {
                continue; // an ancestor or descendant
            }
            let (a, b) = (m[..=common].to_vec(), t[..=common].to_vec());
            if modules.contains(&b) || modules.iter().any(|x| x.starts_with(&b)) {
                edges.entry(a).or_default().insert(b);
            }
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

#[test]
fn no_function_is_longer_than_the_limit() {
    let mut files = Vec::new();
    rust_files(Path::new("src"), &mut files);
    let mut long = Vec::new();
    for f in &files {
        let lines = code(f);
        for (i, l) in lines.iter().enumerate() {
            let t = l.trim_start();
            let indent = &l[..l.len() - t.len()];
            let is_fn = [
                "fn ",
                "pub fn ",
                "pub(crate) fn ",
                "pub(super) fn ",
                "const fn ",
            ]
            .iter()
            .any(|p| t.starts_with(p));
            if !is_fn {
                continue;
            }
            // A declaration without a body (a trait's required method) ends its signature, which
            // may span lines, with `;` before any `{`.
            let sig_end = (i..lines.len()).find(|&j| {
                let e = lines[j].trim_end();
                e.ends_with(';') || e.ends_with('{')
            });
            if sig_end.is_some_and(|j| lines[j].trim_end().ends_with(';')) {
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
                    t
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
