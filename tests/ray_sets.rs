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

/// Every instruction set this CPU has (AVX-512, AVX2, portable; `STOKES_ISA` forces one in a
/// process, `Accel::set_isa` here) finds the reference hits, on the flat loop of the Cornell box
/// and the BVH of soup100k, and the same hits to the bit as the best one.
#[test]
fn every_instruction_set_matches_reference() {
    use stokes::geometry::Isa;
    for (name, n) in [("cbox", usize::MAX), ("soup100k", 5_000)] {
        let set = load(name);
        let mut accel = Accel::build(&set.tris, &[]);
        let n = n.min(set.rays.len());
        let best: Vec<_> = set.rays[..n]
            .iter()
            .map(|r| {
                accel
                    .intersect(r, f32::INFINITY)
                    .map(|h| (h.t, h.prim, h.u, h.v))
            })
            .collect();
        for isa in Isa::available() {
            accel.set_isa(isa).unwrap();
            assert_eq!(accel.isa(), isa);
            let s = compare(&set, &accel, 0..n);
            println!("{name} {isa}: {s:?}");
            assert!(s.t_rate() >= 0.9999, "{name} {isa}: {s:?}");
            assert!(s.prim_rate() >= 0.9999, "{name} {isa}: {s:?}");
            for (k, r) in set.rays[..n].iter().enumerate() {
                let h = accel.intersect(r, f32::INFINITY);
                assert_eq!(
                    h.map(|h| (h.t, h.prim, h.u, h.v)),
                    best[k],
                    "{name} {isa} ray {k}"
                );
                let t = best[k].map_or(1e30, |b| b.0 * 1.0001);
                assert_eq!(
                    accel.occluded(r, t),
                    best[k].is_some(),
                    "{name} {isa} ray {k}"
                );
            }
        }
    }
}
