//! The heterogeneous density grid (`stokes::medium::grid`): Mitsuba 3 `.vol` files and their
//! malformed variants, the cell-centred trilinear convention, the majorant DDA, and
//! ratio-tracking transmittance against a ray-marched reference.

use std::path::{Path, PathBuf};

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use stokes::medium::grid::{
    DensityGrid, MAJORANT_RES, MajorantGrid, ratio_tracking, ray_marched_transmittance,
};

/// A fresh path in this process's temporary folder.
fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("stokes-medium-grid-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A rippled ball of density: zero outside a sphere (so some majorant cells are 0), with
/// sharp-ish variation inside. The box is not a cube and the resolution not a multiple of 16.
fn rippled_ball(res: [usize; 3]) -> DensityGrid {
    let (min, max) = (Vec3::new(-1.0, -0.5, 0.0), Vec3::new(1.0, 1.5, 3.0));
    DensityGrid::from_fn(res, min, max, |p| {
        let q = (p - Vec3::new(0.0, 0.5, 1.5)) / Vec3::new(1.0, 1.0, 1.5);
        let ball = (1.0 - q.length_squared()).max(0.0);
        ball * (1.0 + 0.8 * (7.0 * p.x).sin() * (5.0 * p.y).cos() * (3.0 * p.z).sin())
    })
}

/// A grid whose voxel (x, y, z) holds x + 10y + 100z + 1 on the box [0,4]×[0,3]×[0,2].
fn indexed_grid() -> DensityGrid {
    DensityGrid::from_fn([4, 3, 2], Vec3::ZERO, Vec3::new(4.0, 3.0, 2.0), |p| {
        let i = (p - 0.5).round();
        i.x + 10.0 * i.y + 100.0 * i.z + 1.0
    })
}

/// A ray from around the box of [`rippled_ball`] towards a point near it (most hit, some
/// miss), with a direction of random length.
fn random_ray(rng: &mut Pcg32) -> (Vec3, Vec3) {
    let mut v = |s: Vec3| (Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0) * s;
    let centre = Vec3::new(0.0, 0.5, 1.5);
    let o = centre + v(Vec3::splat(3.0));
    let target = centre + v(Vec3::new(1.3, 1.3, 1.8));
    let d = (target - o) * (0.2 + 3.0 * rng.random::<f32>()); // not normalised
    (o, d)
}

// ---------------------------------------------------------------------------------------------
// .vol files

#[test]
fn vol_round_trip_is_identical() {
    let g = rippled_ball([13, 7, 5]);
    let path = temp_path("round-trip.vol");
    g.write_vol(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes.len(), 48 + 4 * 13 * 7 * 5);
    assert_eq!(&bytes[..4], b"VOL\x03");
    let int = |i: usize| i32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
    let float = |i: usize| f32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
    assert_eq!(
        [int(4), int(8), int(12), int(16), int(20)],
        [1, 13, 7, 5, 1]
    );
    assert_eq!(
        (0..6).map(|k| float(24 + 4 * k)).collect::<Vec<_>>(),
        [-1.0, -0.5, 0.0, 1.0, 1.5, 3.0]
    );
    let back = DensityGrid::read_vol(&path).unwrap();
    assert_eq!(back, g);
    assert_eq!(back.data(), g.data());
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn vol_data_is_x_fastest() {
    // Written by hand: data[((z·yres + y)·xres + x)] = x + 10y + 100z + 1.
    let mut bytes = b"VOL\x03".to_vec();
    for n in [1i32, 4, 3, 2, 1] {
        bytes.extend(n.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 0.0, 4.0, 3.0, 2.0] {
        bytes.extend(v.to_le_bytes());
    }
    for z in 0..2 {
        for y in 0..3 {
            for x in 0..4 {
                bytes.extend(((x + 10 * y + 100 * z + 1) as f32).to_le_bytes());
            }
        }
    }
    let path = temp_path("x-fastest.vol");
    std::fs::write(&path, &bytes).unwrap();
    let g = DensityGrid::read_vol(&path).unwrap();
    assert_eq!(g, indexed_grid());
    assert_eq!(g.density(Vec3::new(1.5, 2.5, 0.5)), 22.0);
    assert_eq!(g.max_density(), 124.0);
    std::fs::remove_file(&path).unwrap();
}

/// The error for a valid 4×3×2 file changed by `edit`.
fn error_for(name: &str, edit: impl FnOnce(&mut Vec<u8>)) -> String {
    let path = temp_path(name);
    indexed_grid().write_vol(&path).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    edit(&mut bytes);
    std::fs::write(&path, &bytes).unwrap();
    let e = DensityGrid::read_vol(&path).expect_err(name);
    std::fs::remove_file(&path).unwrap();
    e
}

fn put_i32(b: &mut [u8], at: usize, v: i32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn put_f32(b: &mut [u8], at: usize, v: f32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn assert_mentions(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "error {e:?} does not mention {p:?}");
    }
}

#[test]
fn read_vol_rejects_a_missing_file() {
    let e = DensityGrid::read_vol(Path::new("/nonexistent/stokes/smoke.vol")).unwrap_err();
    assert_mentions(&e, &["cannot open"]);
}

#[test]
fn read_vol_rejects_bad_magic_version_encoding_and_channels() {
    let e = error_for("magic.vol", |b| b[..3].copy_from_slice(b"VOX"));
    assert_mentions(&e, &["not a Mitsuba .vol file", "VOX"]);
    let e = error_for("version.vol", |b| b[3] = 2);
    assert_mentions(&e, &["version 2", "only version 3"]);
    let e = error_for("encoding.vol", |b| put_i32(b, 4, 2));
    assert_mentions(&e, &["encoding 2", "float32"]);
    let e = error_for("channels.vol", |b| put_i32(b, 20, 3));
    assert_mentions(&e, &["3 channels", "exactly 1"]);
}

#[test]
fn read_vol_rejects_zero_negative_and_absurd_resolutions() {
    let e = error_for("zero-res.vol", |b| put_i32(b, 12, 0));
    assert_mentions(&e, &["4×0×2", "zero or negative"]);
    let e = error_for("negative-res.vol", |b| put_i32(b, 16, -2));
    assert_mentions(&e, &["4×3×-2", "zero or negative"]);
    // 10⁵ voxels a side: rejected from the header, before any allocation.
    let e = error_for("absurd-res.vol", |b| {
        (8..20).step_by(4).for_each(|at| put_i32(b, at, 100_000))
    });
    assert_mentions(
        &e,
        &["100000×100000×100000", "more than the 134217728 (512³)"],
    );
    let e = error_for("big-res.vol", |b| {
        (8..20).step_by(4).for_each(|at| put_i32(b, at, 513))
    });
    assert_mentions(&e, &["513×513×513", "more than"]);
}

#[test]
fn read_vol_checks_the_length_against_the_header() {
    let e = error_for("short.vol", |b| {
        (8..20).step_by(4).for_each(|at| put_i32(b, at, 64))
    });
    assert_mentions(
        &e,
        &["header says 64×64×64 voxels (1048576 bytes of data) but the file holds 96 bytes"],
    );
    let e = error_for("truncated.vol", |b| b.truncate(b.len() - 3));
    assert_mentions(
        &e,
        &[
            "4×3×2 voxels (96 bytes of data)",
            "holds 93 bytes",
            "truncated",
        ],
    );
    let e = error_for("trailing.vol", |b| b.extend([0u8; 4]));
    assert_mentions(&e, &["holds 100 bytes", "4 trailing bytes"]);
    let e = error_for("header.vol", |b| b.truncate(20));
    assert_mentions(&e, &["20 bytes", "48-byte .vol header"]);
}

#[test]
fn read_vol_rejects_bad_bounding_boxes() {
    let e = error_for("flat-box.vol", |b| put_f32(b, 36, 0.0)); // max.x = min.x
    assert_mentions(&e, &["bounding box", "empty or inverted along x"]);
    let e = error_for("inverted-box.vol", |b| put_f32(b, 28, 5.0)); // min.y > max.y
    assert_mentions(&e, &["bounding box", "empty or inverted along y"]);
    let e = error_for("nan-box.vol", |b| put_f32(b, 44, f32::NAN));
    assert_mentions(&e, &["bounding box", "not finite"]);
    let e = error_for("inf-box.vol", |b| put_f32(b, 24, f32::NEG_INFINITY));
    assert_mentions(&e, &["bounding box", "not finite"]);
}

#[test]
fn read_vol_rejects_negative_and_non_finite_densities_by_voxel() {
    let e = error_for("negative.vol", |b| put_f32(b, 48 + 4 * 5, -1.0));
    assert_mentions(&e, &["voxel 5 (x 1, y 1, z 0)", "density -1", "≥ 0"]);
    let e = error_for("nan.vol", |b| put_f32(b, 48 + 4 * 23, f32::NAN));
    assert_mentions(&e, &["voxel 23 (x 3, y 2, z 1)", "NaN"]);
    let e = error_for("inf.vol", |b| put_f32(b, 48, f32::INFINITY));
    assert_mentions(&e, &["voxel 0 (x 0, y 0, z 0)", "inf"]);
}

// ---------------------------------------------------------------------------------------------
// The lookup convention

#[test]
fn density_is_cell_centred_trilinear_with_clamp_to_edge() {
    let g = indexed_grid(); // voxel size 1: sample (x, y, z) sits at (x + ½, y + ½, z + ½)
    let f = |x: f32, y: f32, z: f32| g.density(Vec3::new(x, y, z));
    // Samples at voxel centres.
    assert_eq!(f(0.5, 0.5, 0.5), 1.0);
    assert_eq!(f(3.5, 2.5, 1.5), 124.0);
    // Linear between centres: an affine function is reproduced exactly.
    let mut rng = Pcg32::seed_from_u64(3);
    for _ in 0..1000 {
        let p = Vec3::new(0.5, 0.5, 0.5)
            + Vec3::new(3.0, 2.0, 1.0) * Vec3::new(rng.random(), rng.random(), rng.random());
        let want = (p.x - 0.5) + 10.0 * (p.y - 0.5) + 100.0 * (p.z - 0.5) + 1.0;
        assert!(
            (g.density(p) - want).abs() < 1e-4,
            "{p}: {} vs {want}",
            g.density(p)
        );
    }
    // Clamp to edge in the outer half voxel (a vertex convention would not be flat there).
    assert_eq!(f(0.0, 0.5, 0.5), 1.0);
    assert_eq!(f(0.2, 0.1, 0.3), 1.0);
    assert_eq!(f(4.0, 3.0, 2.0), 124.0);
    assert_eq!(f(3.8, 2.5, 0.5), 24.0);
    // Zero outside the box.
    for p in [
        (-0.01, 1.0, 1.0),
        (4.01, 1.0, 1.0),
        (1.0, 3.01, 1.0),
        (1.0, 1.0, -1e-3),
    ] {
        assert_eq!(f(p.0, p.1, p.2), 0.0);
    }
    assert_eq!(f(f32::NAN, 1.0, 1.0), 0.0);
}

#[test]
fn from_fn_samples_voxel_centres() {
    let min = Vec3::new(-1.0, 2.0, 0.0);
    let g = DensityGrid::from_fn([5, 2, 3], min, Vec3::new(1.0, 3.0, 6.0), |p| {
        (p - min).dot(Vec3::new(1.0, 10.0, 100.0))
    });
    // Voxel (x, y, z) has centre min + ((x, y, z) + ½)·(0.4, 0.5, 2).
    let centre = |x: f32, y: f32, z: f32| (Vec3::new(x, y, z) + 0.5) * Vec3::new(0.4, 0.5, 2.0);
    let want = |c: Vec3| c.x + 10.0 * c.y + 100.0 * c.z;
    assert!((g.data()[0] - want(centre(0.0, 0.0, 0.0))).abs() < 1e-4);
    let i = (2 * 2 + 1) * 5 + 3; // (x 3, y 1, z 2)
    assert!((g.data()[i] - want(centre(3.0, 1.0, 2.0))).abs() < 1e-3);
}

// ---------------------------------------------------------------------------------------------
// The majorant grid and its DDA

/// The segments of a ray, checked to be ordered, non-empty, contiguous and to cover exactly the
/// clipped interval.
fn checked_segments(
    g: &DensityGrid,
    m: &MajorantGrid,
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Vec<(f32, f32, f32)> {
    let segs: Vec<_> = m.segments(o, d, t_min, t_max).collect();
    let Some((a, b)) = g.clip(o, d, t_min, t_max) else {
        assert!(segs.is_empty(), "{o} {d}: a miss gave {segs:?}");
        return segs;
    };
    assert!(!segs.is_empty(), "{o} {d}: a hit [{a}, {b}] gave nothing");
    assert_eq!(segs[0].0, a, "{o} {d}: starts late");
    assert_eq!(segs.last().unwrap().1, b, "{o} {d}: ends early");
    for s in &segs {
        assert!(s.0 < s.1, "{o} {d}: empty segment {s:?}");
    }
    for w in segs.windows(2) {
        assert_eq!(w[0].1, w[1].0, "{o} {d}: gap or overlap");
    }
    assert!(
        segs.len() <= 3 * m.res + 1,
        "{o} {d}: {} segments",
        segs.len()
    );
    segs
}

#[test]
fn segments_are_contiguous_and_cover_the_clipped_interval() {
    let g = rippled_ball([37, 23, 29]);
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    let mut rng = Pcg32::seed_from_u64(1);
    let (mut hits, mut misses) = (0, 0);
    for i in 0..4000 {
        let (o, d) = random_ray(&mut rng);
        let (t_min, t_max) = match i % 4 {
            0 => (0.0, f32::INFINITY),
            1 => (f32::NEG_INFINITY, f32::INFINITY),
            2 => (rng.random::<f32>(), 0.5 + rng.random::<f32>()),
            _ => (-1.0, 2.0),
        };
        match checked_segments(&g, &m, o, d, t_min, t_max).len() {
            0 => misses += 1,
            _ => hits += 1,
        }
    }
    assert!(hits > 2000 && misses > 200, "{hits} hits, {misses} misses");
}

#[test]
fn majorants_bound_the_density_along_every_segment() {
    for (res, mres) in [
        ([37, 23, 29], MAJORANT_RES),
        ([8, 8, 8], 16),
        ([64, 5, 17], 7),
    ] {
        let g = rippled_ball(res);
        let m = MajorantGrid::new(&g, mres);
        let mut rng = Pcg32::seed_from_u64(2);
        let mut checked = 0;
        for _ in 0..2000 {
            let (o, d) = random_ray(&mut rng);
            for (t0, t1, maj) in checked_segments(&g, &m, o, d, 0.0, f32::INFINITY) {
                assert!(maj <= g.max_density());
                for k in 0..12 {
                    let t = match k {
                        0 => t0,
                        1 => t1,
                        _ => t0 + (t1 - t0) * rng.random::<f32>(),
                    };
                    let rho = g.density(o + d * t);
                    assert!(rho <= maj, "{res:?}/{mres}: density {rho} > majorant {maj}");
                    checked += (rho > 0.0) as usize;
                }
            }
        }
        assert!(checked > 10_000, "only {checked} non-zero samples");
    }
}

#[test]
fn axis_parallel_rays_and_rays_in_the_faces() {
    let g = rippled_ball([20, 20, 20]); // box [-1,1]×[-0.5,1.5]×[0,3]
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    // Along x through the middle, with −0 and 0 components: 16 equal cells.
    for d in [Vec3::new(2.0, 0.0, -0.0), Vec3::new(2.0, -0.0, 0.0)] {
        let segs = checked_segments(&g, &m, Vec3::new(-3.0, 0.3, 1.1), d, 0.0, f32::INFINITY);
        assert_eq!(segs.len(), 16);
        for (k, s) in segs.iter().enumerate() {
            let want = (2.0 + k as f32 / 8.0) / 2.0; // enters at x = −1, t = 1
            assert!((s.0 - want).abs() < 1e-5, "cell {k}: {} vs {want}", s.0);
        }
    }
    // Backwards along z, starting inside.
    let segs = checked_segments(&g, &m, Vec3::new(0.1, 0.2, 1.4), -Vec3::Z, 0.0, 100.0);
    assert!((segs.last().unwrap().1 - 1.4).abs() < 1e-6);
    assert_eq!(segs.len(), 8); // z = 1.4 lies in cell 7 of 16 over [0, 3]
    // In a face, on an edge and along the far face: the box is closed.
    for o in [
        Vec3::new(-5.0, -0.5, 1.0),
        Vec3::new(-5.0, -0.5, 0.0),
        Vec3::new(-5.0, 1.5, 3.0),
    ] {
        assert_eq!(checked_segments(&g, &m, o, Vec3::X, 0.0, 1e9).len(), 16);
    }
    // Just outside a face: nothing.
    let o = Vec3::new(-5.0, 1.5001, 1.0);
    assert!(checked_segments(&g, &m, o, Vec3::X, 0.0, 1e9).is_empty());
    // Starting on a face and leaving: nothing.
    assert!(checked_segments(&g, &m, Vec3::new(1.0, 0.0, 1.0), Vec3::X, 0.0, 9.0).is_empty());
}

#[test]
fn grazing_and_diagonal_rays() {
    let g = rippled_ball([20, 20, 20]);
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    // Touching only the corner (1, 1.5, 3): a single point, so nothing.
    let o = Vec3::new(2.0, 0.5, 3.0);
    assert!(checked_segments(&g, &m, o, Vec3::new(-1.0, 1.0, 0.0), 0.0, 9.0).is_empty());
    // The main diagonal passes through the cells' corners: 16 cells, the empty ones skipped.
    let (min, max) = (g.min, g.max);
    let segs = checked_segments(&g, &m, min - (max - min), max - min, 0.0, f32::INFINITY);
    assert_eq!(segs.len(), 16);
    assert_eq!((segs[0].0, segs[15].1), (1.0, 2.0));
    // Nearly parallel to a face, just inside it.
    let d = Vec3::new(1.0, 1e-7, 0.0);
    checked_segments(&g, &m, Vec3::new(-2.0, 1.4999, 2.0), d, 0.0, f32::INFINITY);
}

#[test]
fn missing_and_degenerate_rays_yield_nothing() {
    let g = rippled_ball([10, 10, 10]);
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    let inf = f32::INFINITY;
    let o = Vec3::new(-3.0, 0.5, 1.5);
    assert_eq!(m.segments(o, Vec3::Y, 0.0, inf).count(), 0); // beside the box
    assert_eq!(m.segments(o, -Vec3::X, 0.0, inf).count(), 0); // pointing away
    assert_eq!(m.segments(o, Vec3::X, 0.0, 1.5).count(), 0); // stops short
    assert_eq!(m.segments(o, Vec3::X, 5.0, 1.0).count(), 0); // t_min > t_max
    assert_eq!(m.segments(o, Vec3::NAN, 0.0, inf).count(), 0);
    assert_eq!(m.segments(Vec3::NAN, Vec3::X, 0.0, inf).count(), 0);
    assert_eq!(m.segments(o, Vec3::X, f32::NAN, inf).count(), 0);
    assert_eq!(m.segments(o, Vec3::ZERO, 0.0, inf).count(), 0); // a point outside
    // A point inside: one cell for all t.
    let p = Vec3::new(0.0, 0.5, 1.5);
    let segs: Vec<_> = m.segments(p, Vec3::ZERO, 0.0, inf).collect();
    assert_eq!(segs.len(), 1);
    assert_eq!((segs[0].0, segs[0].1), (0.0, inf));
}

// ---------------------------------------------------------------------------------------------
// Transmittance

/// Mean and standard error of `n` ratio-tracking estimates.
fn ratio_tracking_mean(
    g: &DensityGrid,
    m: &MajorantGrid,
    ray: (Vec3, Vec3, f32, f32),
    sigma_t: f32,
    n: usize,
    rng: &mut Pcg32,
) -> (f64, f64) {
    let (o, d, t_min, t_max) = ray;
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let t = ratio_tracking(g, m, o, d, t_min, t_max, sigma_t, || rng.random()) as f64;
        assert!((0.0..=1.0).contains(&t), "estimate {t}");
        sum += t;
        sum2 += t * t;
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(0.0) * n as f64 / (n - 1) as f64;
    (mean, (var / n as f64).sqrt())
}

#[test]
fn ratio_tracking_matches_ray_marching() {
    let g = rippled_ball([24, 20, 28]);
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    let sigma_t = 2.0;
    let inf = f32::INFINITY;
    let rays = [
        (Vec3::new(-3.0, 0.5, 1.5), Vec3::X, 0.0, inf),
        (
            Vec3::new(-3.0, 0.4, 1.2),
            Vec3::new(2.0, 0.1, 0.3),
            0.0,
            inf,
        ),
        (
            Vec3::new(0.1, 0.6, 1.5),
            Vec3::new(0.0, 0.0, -0.5),
            0.0,
            inf,
        ), // starts inside
        (
            Vec3::new(0.3, -2.0, 0.9),
            Vec3::new(-0.1, 1.0, 0.4),
            1.0,
            3.0,
        ), // clipped
        (
            Vec3::new(-1.0, -0.5, 0.0),
            Vec3::new(2.0, 2.0, 3.0),
            0.0,
            1.0,
        ), // diagonal
        (Vec3::new(0.0, 0.5, -4.0), Vec3::Z * 3.0, 0.0, inf), // through the centre
    ];
    let mut rng = Pcg32::seed_from_u64(2014);
    let mut attenuated = 0;
    for (i, &(o, d, t_min, t_max)) in rays.iter().enumerate() {
        let want = ray_marched_transmittance(&g, o, d, t_min, t_max, sigma_t, 200_000) as f64;
        let (mean, se) =
            ratio_tracking_mean(&g, &m, (o, d, t_min, t_max), sigma_t, 20_000, &mut rng);
        println!("ray {i}: ratio tracking {mean:.5} ± {se:.5}, ray marching {want:.5}");
        assert!(
            (mean - want).abs() <= 3.0 * se,
            "ray {i}: {mean} ± {se} vs {want}"
        );
        attenuated += (want < 0.9 && se > 0.0) as usize;
    }
    assert!(attenuated >= 4, "the rays barely cross the medium");
}

#[test]
fn ratio_tracking_of_a_constant_grid_is_beer_lambert() {
    let g = DensityGrid::from_fn([5, 5, 5], Vec3::ZERO, Vec3::ONE, |_| 0.7);
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    let (o, d) = (Vec3::new(-1.0, 0.5, 0.5), Vec3::new(0.5, 0.0, 0.0)); // |d| = 0.5
    let want = (-1.5f64 * 0.7 * 1.0).exp(); // length 1 inside the box
    let marched = ray_marched_transmittance(&g, o, d, 0.0, f32::INFINITY, 1.5, 1000) as f64;
    assert!((marched - want).abs() < 1e-6, "{marched} vs {want}");
    let mut rng = Pcg32::seed_from_u64(7);
    let (mean, se) = ratio_tracking_mean(&g, &m, (o, d, 0.0, f32::INFINITY), 1.5, 20_000, &mut rng);
    assert!((mean - want).abs() <= 3.0 * se, "{mean} ± {se} vs {want}");
}

#[test]
fn transmittance_is_one_where_there_is_nothing() {
    let g = rippled_ball([16, 16, 16]);
    let m = MajorantGrid::new(&g, MAJORANT_RES);
    let mut calls = 0;
    let mut rng = || {
        calls += 1;
        0.5
    };
    let inf = f32::INFINITY;
    // Missing the box, and crossing only its empty corner.
    let t = ratio_tracking(
        &g,
        &m,
        Vec3::new(-3.0, 3.0, 0.0),
        Vec3::X,
        0.0,
        inf,
        2.0,
        &mut rng,
    );
    assert_eq!(t, 1.0);
    let corner = Vec3::new(-3.0, -0.45, 0.05);
    let t = ratio_tracking(&g, &m, corner, Vec3::X, 0.0, inf, 2.0, &mut rng);
    assert_eq!(t, 1.0);
    assert_eq!(calls, 0, "cells with majorant 0 are skipped");
    assert_eq!(
        ray_marched_transmittance(&g, corner, Vec3::X, 0.0, inf, 2.0, 100),
        1.0
    );
}

// ---------------------------------------------------------------------------------------------
// The committed smoke grid

#[test]
fn committed_smoke_grid_reads() {
    let path: PathBuf = [env!("CARGO_MANIFEST_DIR"), "scenes", "media", "smoke.vol"]
        .iter()
        .collect();
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(size <= 2 << 20, "{size} bytes");
    let g = DensityGrid::read_vol(&path).unwrap();
    // Inside the Cornell box's interior [-1, 1]³, standing on its floor.
    assert!(g.min.cmpge(Vec3::splat(-1.0)).all() && g.max.cmple(Vec3::splat(1.0)).all());
    assert_eq!(g.min.y, -1.0);
    assert_eq!(g.max_density(), 1.0);
    let mean = g.data().iter().map(|&v| v as f64).sum::<f64>() / g.data().len() as f64;
    println!(
        "smoke.vol: {size} bytes, {:?} voxels, box {} .. {}, max {}, mean {mean:.4}",
        g.res,
        g.min,
        g.max,
        g.max_density()
    );
    assert!(mean > 0.01 && mean < 0.5, "mean {mean}");
    // Zero on the sides and the top, so clamp-to-edge (Mitsuba) and zero-outside agree there.
    let [nx, ny, nz] = g.res;
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let side = x == 0 || x == nx - 1 || z == 0 || z == nz - 1 || y == ny - 1;
                if side {
                    assert_eq!(g.data()[(z * ny + y) * nx + x], 0.0, "voxel {x} {y} {z}");
                }
            }
        }
    }
}
