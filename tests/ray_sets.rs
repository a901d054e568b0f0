//! Check the BVH against the stored reference hits (produced with Embree) of the bench ray sets.

mod common;

use common::ray_sets::{compare, load};
use stokes::geometry::Accel;

#[test]
fn cbox_matches_reference() {
    let set = load("cbox");
    let accel = Accel::build(&set.tris, &[]);
    let s = compare(&set, &accel, 0..set.rays.len());
    println!("cbox: {s:?}");
    assert!(s.t_rate() >= 0.9999, "{s:?}");
    assert!(s.prim_rate() >= 0.9999, "{s:?}");
}

#[test]
fn soup100k_subset_matches_reference() {
    let set = load("soup100k");
    let accel = Accel::build(&set.tris, &[]);
    let s = compare(&set, &accel, 0..20_000);
    println!("soup100k[..20k]: {s:?}");
    assert!(s.t_rate() >= 0.9999, "{s:?}");
    assert!(s.prim_rate() >= 0.9999, "{s:?}");
}
