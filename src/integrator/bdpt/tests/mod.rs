//! Tests that need the bidirectional integrators' insides (the test hooks `connect_for_test`
//! and `plain_for_test`, which are compiled only here): the plain connections against the
//! full-path evaluation, the media pdfs of connected paths, and the MIS weights of every
//! strategy against each strategy's pdf evaluated on its own.

mod media_pdfs;
mod media_weights;
mod mis_incremental;
mod plain;
mod weights;

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
