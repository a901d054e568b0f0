//! Loader and checker for the binary ray sets in `benches/data/rays/` (shared by tests and benches).
//!
//! Format (little-endian, no header): `*_tris.bin` 9 f32 per triangle; `*_rays.bin` 6 f32 per
//! ray (origin, unit direction; tnear 0, tfar inf); `*_hits_t.bin` one f32 per ray (inf = miss);
//! `*_hits_prim.bin` one i32 per ray (-1 = miss).
#![allow(dead_code)]

use glam::Vec3;
use std::path::PathBuf;
use stokes::geometry::{Accel, Ray, Triangle};

pub struct RaySet {
    pub tris: Vec<Triangle>,
    pub rays: Vec<Ray>,
    pub hits_t: Vec<f32>,
    pub hits_prim: Vec<i32>,
}

/// The file `name` of a stored set (`benches/data/rays/`), else of a generated one
/// (`target/rays/`, written by examples/make_rayset), as little-endian words.
fn read_words(name: &str) -> Result<Vec<[u8; 4]>, String> {
    let stored: PathBuf = [env!("CARGO_MANIFEST_DIR"), "benches", "data", "rays", name]
        .iter()
        .collect();
    let generated: PathBuf = [env!("CARGO_MANIFEST_DIR"), "target", "rays", name]
        .iter()
        .collect();
    let path = if stored.is_file() { stored } else { generated };
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    if !bytes.len().is_multiple_of(4) {
        return Err(format!(
            "{}: {} bytes, not a whole number of 4-byte words",
            path.display(),
            bytes.len()
        ));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect())
}

/// `name`'s f32s, a whole number of `per` (a record: 9 for a triangle, 6 for a ray).
fn read_f32(name: &str, per: usize) -> Result<Vec<f32>, String> {
    let v: Vec<f32> = read_words(name)?
        .into_iter()
        .map(f32::from_le_bytes)
        .collect();
    if !v.len().is_multiple_of(per) {
        return Err(format!(
            "{name}: {} floats, not a whole number of records of {per}",
            v.len()
        ));
    }
    Ok(v)
}

/// Ray set `set` (panics with [`try_load`]'s message, for tests and benches).
pub fn load(set: &str) -> RaySet {
    try_load(set).unwrap_or_else(|e| panic!("{e}"))
}

/// Ray set `set`, or what is wrong with it: a missing file (for the generated sets, the command
/// that writes it), or files that do not fit the format above or each other.
pub fn try_load(set: &str) -> Result<RaySet, String> {
    let hint = |e: String| {
        format!(
            "ray set {set}: {e} (stored sets are in benches/data/rays; \
             `cargo run --release --example make_rayset {set}` writes the generated ones)"
        )
    };
    let t = read_f32(&format!("{set}_tris.bin"), 9).map_err(hint)?;
    let r = read_f32(&format!("{set}_rays.bin"), 6).map_err(hint)?;
    let v = |s: &[f32]| Vec3::new(s[0], s[1], s[2]);
    let tris = t
        .chunks_exact(9)
        .map(|c| Triangle::new(v(&c[0..3]), v(&c[3..6]), v(&c[6..9])))
        .collect();
    let rays: Vec<Ray> = r
        .chunks_exact(6)
        .map(|c| Ray::new(v(&c[0..3]), v(&c[3..6])))
        .collect();
    let hits_t = read_f32(&format!("{set}_hits_t.bin"), 1).map_err(hint)?;
    let hits_prim: Vec<i32> = read_words(&format!("{set}_hits_prim.bin"))
        .map_err(hint)?
        .into_iter()
        .map(i32::from_le_bytes)
        .collect();
    if rays.len() != hits_t.len() || rays.len() != hits_prim.len() {
        return Err(format!(
            "ray set {set}: {} rays but {} hit distances and {} hit primitives",
            rays.len(),
            hits_t.len(),
            hits_prim.len()
        ));
    }
    Ok(RaySet {
        tris,
        rays,
        hits_t,
        hits_prim,
    })
}

#[derive(Debug, Default)]
pub struct MatchStats {
    pub n: usize,
    /// Hit/miss agrees and t within relative 1e-4 (+ `ABS_EPS`).
    pub t_match: usize,
    /// Hit/miss agrees and t within relative 1e-4, no absolute slack.
    pub t_match_strict: usize,
    /// Primitive id equal, or a tie (the reported primitive is hit at the stored distance).
    pub prim_match: usize,
    /// Primitive id differs but is a tie.
    pub ties: usize,
}

impl MatchStats {
    pub fn t_rate(&self) -> f64 {
        self.t_match as f64 / self.n as f64
    }
    pub fn prim_rate(&self) -> f64 {
        self.prim_match as f64 / self.n as f64
    }
}

fn t_close(a: f32, b: f32) -> bool {
    if a.is_infinite() || b.is_infinite() {
        return a == b;
    }
    (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + ABS_EPS
}

/// Absolute slack for hits very close to the origin (t ~ 1e-5, where f32 rounding in different
/// triangle intersectors alone exceeds a relative 1e-4); the scenes have unit scale.
pub const ABS_EPS: f32 = 1e-6;

/// Strict relative-1e-4 comparison (for reporting).
pub fn t_close_strict(a: f32, b: f32) -> bool {
    if a.is_infinite() || b.is_infinite() {
        return a == b;
    }
    (a - b).abs() <= 1e-4 * a.abs().max(b.abs())
}

/// Compare `accel` against the stored hits for rays `range`.
pub fn compare(set: &RaySet, accel: &Accel, range: std::ops::Range<usize>) -> MatchStats {
    let mut s = MatchStats::default();
    for i in range {
        s.n += 1;
        let ray = &set.rays[i];
        let hit = accel.intersect(ray, f32::INFINITY);
        let (t, prim) = hit.map_or((f32::INFINITY, -1), |h| (h.t, h.prim as i32));
        s.t_match_strict += t_close_strict(t, set.hits_t[i]) as usize;
        if !t_close(t, set.hits_t[i]) {
            continue;
        }
        s.t_match += 1;
        if prim == set.hits_prim[i] {
            s.prim_match += 1;
        } else if prim >= 0 && set.hits_prim[i] >= 0 {
            // Tie: the stored primitive must be hit at (about) the same distance as ours.
            let other = Accel::build(&[set.tris[set.hits_prim[i] as usize]], &[]);
            if let Some(h2) = other.intersect(ray, f32::INFINITY)
                && t_close(h2.t, t)
            {
                s.prim_match += 1;
                s.ties += 1;
            }
        }
    }
    s
}
