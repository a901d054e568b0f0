//! The figures of the report: every SVG and PNG of the run's `figures/` folder, embedded as
//! `data:` URLs in `<img>` elements (so an SVG's scripts and ids stay out of the page). An SVG
//! that links a PNG of the folder gets that PNG embedded in its place, and a PNG that an SVG
//! shows is not shown again.

use super::encode::{data_url, html};
use crate::error::Error;
use crate::experiment::record::safe_relative;
use std::collections::BTreeSet;
use std::fmt::Write;
use std::path::Path;

/// Largest figure file the report embeds.
const MAX_FIGURE_BYTES: u64 = 64 << 20;

fn read_figure(p: &Path) -> Result<Vec<u8>, Error> {
    const FIGURE: crate::io::input::Kind =
        crate::io::input::Kind::new("figure the report embeds", MAX_FIGURE_BYTES);
    crate::io::input::read_bytes(p, FIGURE).map_err(Error::input)
}

/// `svg` with every `href="NAME.png"` naming a PNG of `fig` replaced by its data URL, and an
/// `xlink:href` to the same PNG dropped where a plain `href` has it (SVG 2 browsers read `href`),
/// so the PNG is embedded once; the names replaced are added to `used`.
fn embed_links(svg: &str, fig: &Path, used: &mut BTreeSet<String>) -> Result<String, Error> {
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(i) = rest.find("href=\"") {
        let start = i + "href=\"".len();
        let Some(len) = rest[start..].find('"') else {
            break;
        };
        let target = &rest[start..start + len];
        let local = safe_relative(target)
            && target.to_ascii_lowercase().ends_with(".png")
            && fig.join(target).is_file();
        let xlink = rest[..i].ends_with(" xlink:");
        if local && xlink && svg.contains(&format!(" href=\"{target}\"")) {
            out.push_str(&rest[..i - " xlink:".len()]);
        } else if local {
            out.push_str(&rest[..start]);
            out.push_str(&data_url("image/png", &read_figure(&fig.join(target))?));
            out.push('"');
            used.insert(target.to_string());
        } else {
            out.push_str(&rest[..start + len + 1]);
        }
        rest = &rest[start + len + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// An SVG as a `data:` URL for an `src` attribute: the text as it is but for what a URL or the
/// attribute cannot hold (`%`, `#`, line breaks, tabs; `&` and `"` as HTML entities), so that a
/// PNG embedded in it as base64 is not encoded a second time.
fn svg_url(svg: &str) -> String {
    let mut out = String::with_capacity(svg.len() + 64);
    out.push_str("data:image/svg+xml;charset=utf-8,");
    for c in svg.chars() {
        match c {
            '%' => out.push_str("%25"),
            '#' => out.push_str("%23"),
            '\n' => out.push_str("%0A"),
            '\r' => out.push_str("%0D"),
            '\t' => out.push_str("%09"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// The figures section of the run folder `dir`, and the number of figures in it.
pub fn section(dir: &Path) -> Result<(String, usize), Error> {
    let fig = dir.join("figures");
    let Ok(list) = std::fs::read_dir(&fig) else {
        return Ok(("<p>No figures folder.</p>".to_string(), 0));
    };
    let mut names: Vec<String> = list
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut used = BTreeSet::new();
    let mut svgs = Vec::new();
    for n in names
        .iter()
        .filter(|n| n.to_ascii_lowercase().ends_with(".svg"))
    {
        let p = fig.join(n);
        let text = String::from_utf8(read_figure(&p)?)
            .map_err(|_| Error::input(format!("'{}' is not UTF-8 text", p.display())))?;
        svgs.push((n, embed_links(&text, &fig, &mut used)?));
    }
    let mut out = String::new();
    let mut count = 0;
    for (n, svg) in svgs {
        figure(n, &svg_url(&svg), &mut out);
        count += 1;
    }
    for n in &names {
        if n.to_ascii_lowercase().ends_with(".png") && !used.contains(n) {
            figure(
                n,
                &data_url("image/png", &read_figure(&fig.join(n))?),
                &mut out,
            );
            count += 1;
        }
    }
    if count == 0 {
        out.push_str("<p>No figures.</p>");
    }
    Ok((out, count))
}

fn figure(name: &str, url: &str, out: &mut String) {
    let _ = writeln!(
        out,
        "<figure><img src=\"{url}\" alt=\"{n}\"><figcaption>{n}</figcaption></figure>",
        n = html(name)
    );
}
