//! No contribution of bdpt-forward/backward is lost to an unusable pdf on any shipped scene:
//! `Stats::dropped_strategy_pdfs` counts connections that carry light (f > 0) but whose own
//! strategy's pdf (eq. 6.14; with media, also with the free-flight pdfs of the sampled segments)
//! is NaN, infinite or 0, and were dropped. Such a pdf is never legitimate: the strategy has just
//! sampled the path. Other strategies' pdfs may well be 0 in the MIS sum (a strategy that cannot
//! make the path); those are not counted (docs/bdpt.md).
//!
//! bdpt-allbins has no strategy pdf of its own to check (its throughput is a ratio of the
//! sampling weights) and is not covered here.

mod common;

use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, check, render};

/// Every scene of `scenes/` at 16×16 pixels, 4 spp, max depth 8 (and 32 for the scenes with
/// media), both resets: the count is 0, and so is `nan_inf_rejected`. `STOKES_DROPPED_DEEP=1`
/// renders every scene at 32×32, 64 spp, max depths 8 and 32 instead (about 5 minutes).
#[test]
fn no_strategy_pdf_is_dropped_on_the_shipped_scenes() {
    let deep = std::env::var_os("STOKES_DROPPED_DEEP").is_some();
    let (size, spp) = if deep { (32, 64) } else { (16, 4) };
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".json"))
        .collect();
    names.sort();
    assert!(names.len() >= 20, "{names:?}");
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed: 3,
        ..Default::default()
    };
    let (mut rendered, mut contributions) = (0, 0);
    for name in &names {
        let scene = common::load_sized(name, size);
        let depths: &[u32] = if deep || scene.has_media {
            &[8, 32]
        } else {
            &[8]
        };
        for &max_depth in depths {
            let opts = IntegratorOptions {
                max_depth,
                ..Default::default()
            };
            for kind in [
                IntegratorKind::BdptForward,
                IntegratorKind::BdptBackward,
                IntegratorKind::BdptCombined,
            ] {
                if let Err(e) = check(&scene, kind, &opts) {
                    eprintln!("{name}: {} refuses the scene ({e})", kind.name());
                    continue;
                }
                let out = render(&scene, kind, &opts, &settings, None).unwrap();
                let s = &out.stats;
                let what = format!("{name} {} depth {max_depth}", kind.name());
                assert_eq!(s.dropped_strategy_pdfs, 0, "{what}");
                assert_eq!(s.nan_inf_rejected, 0, "{what}");
                rendered += 1;
                contributions += s.contributing_paths;
            }
        }
    }
    eprintln!("{rendered} renders, {contributions} contributions");
    assert!(
        rendered >= if deep { 88 } else { 60 },
        "only {rendered} renders"
    );
    assert!(contributions > 100_000, "{contributions} contributions");
}

/// The cause of the drops the deep mode found (media-cube-600, bdpt-forward, depth 32): a light
/// sub-path entered the dye cube within 10⁻⁴ of an edge, the crossing's ray (stepped 10⁻⁴ along
/// its direction) skipped the face it left by, and the walk carried the dye out into the room and
/// off its open side, to a collision 10¹⁸ away (σ = 5·10⁻¹⁷ at 603 nm), where consecutive vertices
/// coincide in f32 and the area pdfs are ∞ and NaN. Rays that enter the cube through its bottom
/// face at 10⁻⁷ … 10⁻³ from the edge it shares with the face x = 0.3, continued past each
/// index-matched boundary by `cross_boundary_ray`, must leave the cube through that face and reach
/// the room in vacuum.
#[test]
fn a_crossing_near_an_edge_does_not_carry_the_medium_out() {
    use glam::Vec3;
    use stokes::geometry::Ray;
    use stokes::scene::NONE;
    use stokes::transport::media::cross_boundary_ray;
    let scene = common::load("media-cube-600.json");
    let (mut near, mut rays) = (0, 0);
    for i in 0..400 {
        let gap = 10f32.powf(-7.0 + 4.0 * (i as f32 + 0.5) / 400.0);
        let z = -0.25 + 0.5 * ((i * 37 % 400) as f32 / 400.0);
        let entry = Vec3::new(0.3 - gap, -0.45, z);
        // up and out through x = 0.3 at 20°…70° from the bottom face
        let a = (20.0 + 50.0 * ((i * 13 % 400) as f32 / 400.0)).to_radians();
        let d = Vec3::new(a.cos(), a.sin(), 0.1).normalize();
        let mut ray = Ray::new(entry - d * 0.3, d);
        let mut medium = scene.camera_medium;
        let mut crossings = 0;
        let wall = loop {
            let it = scene
                .intersect(&ray, f32::INFINITY)
                .expect("the room is closed there");
            if it.material != NONE || it.light != NONE {
                break it;
            }
            crossings += 1;
            assert!(crossings <= 4, "ray {i}: {crossings} crossings");
            medium = scene.medium_after(&it, ray.d, medium);
            ray = cross_boundary_ray(it.p, it.n, ray.d);
        };
        rays += 1;
        near += (crossings == 2) as u32;
        assert_eq!(
            medium, NONE,
            "ray {i} (gap {gap:e}) reaches {:?} in the dye",
            wall.p
        );
    }
    // at the smallest gaps the entry and exit may round into one corner hit
    assert!(near >= 350, "{near} of {rays} rays crossed twice");
}
