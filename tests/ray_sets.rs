//! Check the BVH against the stored reference hits (produced with Embree) of the bench ray sets.

mod common;

use common::ray_sets::{compare, load, try_load};
use stokes::geometry::Accel;

/// A missing or malformed ray set is an error that names the set, the file and what is wrong
/// (examples/raybench prints it and exits 2), not a panic.
#[test]
fn bad_ray_sets_are_named_errors() {
    let e = try_load("no-such-set")
        .err()
        .expect("a missing set is an error");
    assert!(e.contains("no-such-set_tris.bin"), "{e}");
    assert!(e.contains("make_rayset no-such-set"), "{e}");
    // a set of its own under target/rays (where examples/make_rayset writes), removed after
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/rays");
    std::fs::create_dir_all(&dir).unwrap();
    let name = format!("bad-set-{}", std::process::id());
    let write = |part: &str, floats: usize, extra: usize| {
        let mut b = vec![0u8; 4 * floats + extra];
        b.iter_mut()
            .enumerate()
            .for_each(|(i, x)| *x = (i % 7) as u8);
        std::fs::write(dir.join(format!("{name}_{part}.bin")), b).unwrap();
    };
    write("tris", 9, 0);
    write("rays", 6 * 2, 0);
    write("hits_t", 2, 0);
    write("hits_prim", 2, 0);
    assert!(try_load(&name).is_ok());
    // a ray cut short
    write("rays", 6 * 2 - 1, 0);
    let e = try_load(&name).err().expect("a partial ray is an error");
    assert!(
        e.contains(&format!("{name}_rays.bin")) && e.contains("records of 6"),
        "{e}"
    );
    // a torn word
    write("rays", 6 * 2, 3);
    let e = try_load(&name).err().expect("a torn word is an error");
    assert!(e.contains("not a whole number of 4-byte words"), "{e}");
    // hits that do not match the rays
    write("rays", 6 * 3, 0);
    let e = try_load(&name).err().expect("a count mismatch is an error");
    assert!(e.contains("3 rays but 2 hit distances"), "{e}");
    for part in ["tris", "rays", "hits_t", "hits_prim"] {
        std::fs::remove_file(dir.join(format!("{name}_{part}.bin"))).unwrap();
    }
}

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
