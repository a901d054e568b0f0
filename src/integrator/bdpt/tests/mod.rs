//! Tests that need the bidirectional integrators' insides (the test hooks `connect_for_test`
//! and `plain_for_test`, which are compiled only here): the plain connections against the
//! full-path evaluation, the media pdfs of connected paths, and the MIS weights of every
//! strategy against each strategy's pdf evaluated on its own.

mod combined_weights;
mod media_pdfs;
mod media_weights;
mod mis_incremental;
mod plain;
mod weights;

use crate::integrator::MisHeuristic;
use crate::integrator::bdpt::{FullPath, ResetMode};
use crate::scene::Scene;
use std::path::Path;

/// A shipped scene, by file name.
fn load(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    Scene::load(&path).unwrap()
}

/// The dye box of tests/common: a fluorescent Henyey–Greenstein medium in a grey room.
fn dye_box() -> Scene {
    let json = include_str!("../../../../tests/common/dye-box.json");
    Scene::from_str(Path::new("dye-box.json"), json).unwrap()
}

/// The MIS weights of every strategy of path `p` (each from its own pdf) sum to 1, and the
/// ratio walk's weight of the sampling strategy `s` equals its entry; `w` is scratch.
fn assert_weights(
    p: &FullPath,
    s: usize,
    (mode, h): (ResetMode, MisHeuristic),
    w: &mut Vec<f64>,
    what: &str,
) {
    p.strategy_weights(mode, h, w);
    let sum: f64 = w.iter().sum();
    assert!((sum - 1.0).abs() < 1e-4, "{what}: Σw = {sum} ({w:?})");
    let ws = p.mis_weight(s, mode, h);
    let want = w[s - 1];
    assert!(
        (ws - want).abs() < 1e-4,
        "{what}: own weight {ws} vs {want}"
    );
}
