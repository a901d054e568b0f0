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

/// A stored set (`benches/data/rays/`), else a generated one (`target/rays/`, written by
/// examples/make_rayset).
fn read_words(name: &str) -> Vec<[u8; 4]> {
    let stored: PathBuf = [env!("CARGO_MANIFEST_DIR"), "benches", "data", "rays", name]
        .iter()
        .collect();
    let generated: PathBuf = [env!("CARGO_MANIFEST_DIR"), "target", "rays", name]
        .iter()
        .collect();
    let path = if stored.is_file() { stored } else { generated };
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(bytes.len() % 4, 0);
    bytes
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

fn read_f32(name: &str) -> Vec<f32> {
    read_words(name)
        .into_iter()
        .map(f32::from_le_bytes)
        .collect()
}

pub fn load(set: &str) -> RaySet {
    let t = read_f32(&format!("{set}_tris.bin"));
    let r = read_f32(&format!("{set}_rays.bin"));
    let v = |s: &[f32]| Vec3::new(s[0], s[1], s[2]);
    let tris = t
        .chunks_exact(9)
        .map(|c| Triangle::new(v(&c[0..3]), v(&c[3..6]), v(&c[6..9])))
        .collect();
    let rays: Vec<Ray> = r
        .chunks_exact(6)
        .map(|c| Ray::new(v(&c[0..3]), v(&c[3..6])))
        .collect();
    let hits_t = read_f32(&format!("{set}_hits_t.bin"));
    let hits_prim: Vec<i32> = read_words(&format!("{set}_hits_prim.bin"))
        .into_iter()
        .map(i32::from_le_bytes)
        .collect();
    assert_eq!(rays.len(), hits_t.len());
    assert_eq!(rays.len(), hits_prim.len());
    RaySet {
        tris,
        rays,
        hits_t,
        hits_prim,
    }
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
