//! The reference image of a run: loaded from the config's EXR (resampled to the run's
//! resolution under `--quick`), or rendered once and cached under `<root>/references/`, keyed by
//! a hash of everything that determines it.

use super::config::{Reference, resolve};
use super::setup::Setup;
use crate::error::Error;
use crate::film::output::{read_exr, write_exr};
use crate::film::shard::ShardInfo;
use crate::integrator::{RenderSettings, render};
use glam::Vec3;
use indicatif::ProgressBar;
use std::path::Path;

/// The run's reference image, when the config has one.
pub fn get(s: &Setup, bar: &ProgressBar) -> Result<Option<Vec<Vec3>>, Error> {
    let Some(r) = &s.cfg.reference else {
        return Ok(None);
    };
    let img = match &r.exr {
        Some(p) => load(s, &resolve(&s.config_path, p))?,
        None => cached_or_rendered(s, r, bar)?,
    };
    Ok(Some(img))
}

/// Read the reference EXR `p`; resample it when it is at another resolution because of `--quick`.
fn load(s: &Setup, p: &Path) -> Result<Vec<Vec3>, Error> {
    let (w, h, fw, fh) = (s.width, s.height, s.full_width, s.full_height);
    let (rw, rh, px) = read_exr(p).map_err(|e| {
        Error::input(format!(
            "{}: field `reference.exr`: {e}",
            s.config_path.display()
        ))
    })?;
    if let Some(i) = px.iter().position(|c| !c.is_finite()) {
        return Err(Error::input(format!(
            "{}: field `reference.exr`: reference image '{}' has a non-finite pixel ({}, {}) = {}: metrics against it would be NaN",
            s.config_path.display(),
            p.display(),
            i % rw as usize,
            i / rw as usize,
            px[i]
        )));
    }
    if (rw, rh) == (w, h) {
        Ok(px)
    } else if s.quick || (rw, rh) == (fw, fh) && (w, h) != (fw, fh) {
        Ok(resample(&px, rw, rh, w, h))
    } else {
        Err(Error::input(format!(
            "{}: field `reference.exr`: image is {rw}×{rh}, the scene renders {w}×{h}",
            s.config_path.display()
        )))
    }
}

/// The cached render of the reference `r`, or a new render (then cached).
fn cached_or_rendered(s: &Setup, r: &Reference, bar: &ProgressBar) -> Result<Vec<Vec3>, Error> {
    let (w, h) = (s.width, s.height);
    let kind = r.integrator.unwrap();
    let spp = r.spp.unwrap();
    let cache = cache_file(s, r);
    // The cache is read back as untrusted: a damaged, resized or non-finite file is rendered anew.
    if let Ok((cw, ch, px)) = read_exr(&cache)
        && (cw, ch) == (w, h)
        && px.iter().all(|c| c.is_finite())
    {
        bar.inc(spp as u64);
        return Ok(px);
    }
    if cache.exists() {
        eprintln!(
            "warning: cached reference '{}' is damaged or not of this run's size: rendering it again",
            cache.display()
        );
    }
    bar.set_message(format!("reference ({}, {spp} spp)", kind.name()));
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: r.seed,
        threads: s.cfg.threads,
        time_limit: None,
        progress: false,
        spectral: None,
        cancel: s.cancel.clone(),
    };
    let b = bar.clone();
    let mut cb = move |_: &crate::film::Film, _: &crate::integrator::Stats, _: f64| {
        b.inc(1);
        true
    };
    let out = render(&s.scene, kind, &r.options, &settings, Some(&mut cb))
        .map_err(|e| Error::runtime(format!("reference: {e}")))?;
    let px = out.film.rgb();
    write_exr(&cache, w, h, &px).map_err(Error::runtime)?;
    Ok(px)
}

/// Where the rendered reference `r` of `s` is cached: `<root>/references/<key>.exr`.
pub fn cache_file(s: &Setup, r: &Reference) -> std::path::PathBuf {
    s.root
        .join("references")
        .join(format!("{:016x}.exr", cache_key(s, r)))
}

/// Whether the cache holds the reference of `s` (a rendered one), readable and of the run's size.
pub fn cached(s: &Setup) -> bool {
    let Some(r) = s.cfg.reference.as_ref().filter(|r| r.integrator.is_some()) else {
        return false;
    };
    read_exr(&cache_file(s, r))
        .is_ok_and(|(w, h, px)| (w, h) == (s.width, s.height) && px.iter().all(|c| c.is_finite()))
}

/// Samples `from..to` of the rendered reference of `s` (a cluster job's shard), with the
/// attributes that let the shards merge.
pub fn render_shard(
    s: &Setup,
    from: u32,
    to: u32,
) -> Result<(crate::film::Film, ShardInfo), Error> {
    let r = s
        .cfg
        .reference
        .as_ref()
        .filter(|r| r.integrator.is_some())
        .ok_or_else(|| Error::input("the experiment has no rendered reference to shard"))?;
    let kind = r.integrator.unwrap();
    let settings = RenderSettings {
        first_sample: from,
        spp: to - from,
        seed: r.seed,
        threads: s.cfg.threads,
        time_limit: None,
        progress: true,
        spectral: None,
        cancel: s.cancel.clone(),
    };
    let out = render(&s.scene, kind, &r.options, &settings, None)
        .map_err(|e| Error::runtime(format!("reference: {e}")))?;
    let info = crate::integrator::shard_info(
        &s.scene_path,
        &s.scene_text,
        kind,
        &r.options,
        r.seed,
        (from, to),
    );
    Ok((out.film, info))
}

/// Cache key of a rendered reference: scene text, integrator, options, spp, seed, resolution.
fn cache_key(s: &Setup, r: &Reference) -> u64 {
    let opts_json = serde_json::to_string(&r.options).unwrap();
    crate::io::hash::fnv1a(&[
        s.scene_text.as_bytes(),
        r.integrator.unwrap().name().as_bytes(),
        opts_json.as_bytes(),
        r.spp.unwrap().to_string().as_bytes(),
        r.seed.to_string().as_bytes(),
        format!("{}x{}", s.width, s.height).as_bytes(),
    ])
}

/// Nearest-neighbour resample (for an EXR reference at another resolution under `--quick`).
fn resample(px: &[Vec3], w: u32, h: u32, nw: u32, nh: u32) -> Vec<Vec3> {
    let mut out = Vec::with_capacity((nw * nh) as usize);
    for y in 0..nh {
        for x in 0..nw {
            let sx = ((x as f64 + 0.5) * w as f64 / nw as f64) as u32;
            let sy = ((y as f64 + 0.5) * h as f64 / nh as f64) as u32;
            out.push(px[(sy.min(h - 1) * w + sx.min(w - 1)) as usize]);
        }
    }
    out
}
