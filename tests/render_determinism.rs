//! Rendering is deterministic for a given seed whatever the thread count, and different seeds
//! give independent images.

use std::path::Path;
use stokes::geometry::Camera;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

fn small(path: &str) -> Scene {
    let mut s = Scene::load(Path::new(path)).unwrap();
    let c = &s.camera;
    s.camera = Camera::look_at(c.origin, c.origin + c.forward, c.up, 39.3077, true, 32, 32);
    s
}

#[test]
fn same_seed_same_image_for_any_thread_count() {
    let scene = small("scenes/cornell-box.json");
    let opts = IntegratorOptions::default();
    let img = |threads, seed| {
        let st = RenderSettings {
            first_sample: 0,
            spp: 4,
            seed,
            threads: Some(threads),
            ..Default::default()
        };
        render(&scene, IntegratorKind::PtMono, &opts, &st, None)
            .unwrap()
            .film
            .xyz()
    };
    let a = img(1, 7);
    let b = img(2, 7);
    let c = img(3, 7);
    assert_eq!(a, b);
    assert_eq!(a, c);
    let d = img(2, 8);
    let same = a.iter().zip(&d).filter(|(x, y)| x == y).count();
    // Only pixels that are black in both (none in the Cornell box interior) may coincide.
    assert!(same < a.len() / 10, "{same} identical pixels between seeds");
}

/// Every integrator, on a fluorescent scene and a scene with media: the workers keep their
/// scratch memory (caches, vertex buffers) for the whole render and take rows in any order, so
/// nothing a row computes may depend on what the worker computed before.
#[test]
fn every_integrator_is_deterministic_whatever_the_thread_count() {
    let kinds = [
        IntegratorKind::PtMono,
        IntegratorKind::PtHero,
        IntegratorKind::BdptForward,
        IntegratorKind::BdptBackward,
        IntegratorKind::BdptCombined,
        IntegratorKind::BdptAllbins,
    ];
    for path in ["scenes/fluorescent-walls.json", "scenes/media-cube.json"] {
        let scene = small(path);
        let opts = IntegratorOptions::default();
        for kind in kinds {
            let img = |threads| {
                let st = RenderSettings {
                    spp: 3,
                    seed: 5,
                    threads: Some(threads),
                    ..Default::default()
                };
                render(&scene, kind, &opts, &st, None).map(|o| o.film.xyz())
            };
            let Ok(a) = img(1) else {
                continue; // the integrator refuses the scene (bdpt-allbins and media)
            };
            for threads in [2, 3] {
                assert!(
                    img(threads).unwrap() == a,
                    "{path} {kind:?}: {threads} threads"
                );
            }
        }
    }
}

#[test]
fn time_limit_stops_early() {
    let scene = small("scenes/cornell-box.json");
    let st = RenderSettings {
        first_sample: 0,
        spp: 1_000_000,
        seed: 1,
        time_limit: Some(0.3),
        ..Default::default()
    };
    let out = render(
        &scene,
        IntegratorKind::PtMono,
        &IntegratorOptions::default(),
        &st,
        None,
    )
    .unwrap();
    assert!(out.film.spp >= 1 && out.film.spp < 1_000_000);
    assert!(out.seconds < 5.0);
}

/// A pass's light-tracing splats are added to the film while the next pass renders: the film a
/// render returns, the film a pass callback sees after each pass, and the film of a render
/// stopped by its time limit must all hold every splat of the passes they count.
#[test]
fn every_pass_film_holds_its_splats() {
    let scene = small("scenes/cornell-box.json");
    let opts = IntegratorOptions::default();
    let settings = |spp, time_limit| RenderSettings {
        first_sample: 0,
        spp,
        seed: 3,
        threads: Some(2),
        time_limit,
        ..Default::default()
    };
    let alone = |spp| {
        let out = render(
            &scene,
            IntegratorKind::BdptForward,
            &opts,
            &settings(spp, None),
            None,
        );
        let film = out.unwrap().film;
        assert!(
            film.splat.iter().any(|p| p[0] > 0.0),
            "light tracing splatted nothing"
        );
        film.xyz()
    };
    // each pass as the callback sees it, against a render of that many passes
    let mut seen = Vec::new();
    let mut cb = |film: &stokes::film::Film, _: &stokes::integrator::Stats, _: f64| {
        seen.push((film.spp, film.xyz()));
        true
    };
    let out = render(
        &scene,
        IntegratorKind::BdptForward,
        &opts,
        &settings(3, None),
        Some(&mut cb),
    );
    let last = out.unwrap().film.xyz();
    assert_eq!(seen.len(), 3);
    for (spp, xyz) in &seen {
        assert!(*xyz == alone(*spp), "the callback's film after pass {spp}");
    }
    assert!(last == alone(3), "the film of a render with a callback");
    // a time limit of 0 s stops after the first pass, whose splats must be in the film
    let out = render(
        &scene,
        IntegratorKind::BdptForward,
        &opts,
        &settings(5, Some(0.0)),
        None,
    );
    let film = out.unwrap().film;
    assert_eq!(film.spp, 1);
    assert!(
        film.xyz() == alone(1),
        "the film of a render stopped by its time limit"
    );
}

/// Every instruction set the CPU has traces the same hits, so fixed-seed images are the same to
/// the bit: on the flat loop of a tiny scene (cornell-box), of tiny scenes with spheres
/// (uv-sphere, green-spheres; the portable path traverses their trees), a tree of triangles
/// and spheres (hero-vs-mono-checker, too many spheres for the flat loop) and a scene with media.
#[test]
fn every_instruction_set_renders_the_same_image() {
    use stokes::geometry::Isa;
    for path in [
        "scenes/cornell-box.json",
        "scenes/uv-sphere.json",
        "scenes/green-spheres.json",
        "scenes/hero-vs-mono-checker.json",
        "scenes/media-walls-fog.json",
    ] {
        let mut scene = small(path);
        let st = RenderSettings {
            spp: 2,
            seed: 3,
            threads: Some(2),
            ..Default::default()
        };
        let opts = IntegratorOptions::default();
        let mut first = None;
        for isa in Isa::available() {
            scene.accel.set_isa(isa).unwrap();
            for kind in [IntegratorKind::PtHero, IntegratorKind::BdptForward] {
                let img = render(&scene, kind, &opts, &st, None).unwrap().film.xyz();
                assert!(img.iter().any(|v| v.y > 0.0), "{path}: black image");
                match &first {
                    None => first = Some(vec![(kind, img)]),
                    Some(v) => {
                        if let Some((_, a)) = v.iter().find(|(k, _)| *k == kind) {
                            assert!(*a == img, "{path} {kind:?}: {isa} differs");
                        } else {
                            first.as_mut().unwrap().push((kind, img));
                        }
                    }
                }
            }
        }
    }
}

/// A render whose cancel flag is set stops: set from the pass callback after the second pass
/// (no third pass starts), set before the render (no pass runs), or set from another thread in
/// the middle of a long render. Each returns the `CANCELLED` error; an unset flag changes
/// nothing.
#[test]
fn cancel_flag_stops_a_render() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use stokes::integrator::CANCELLED;
    let scene = small("scenes/cornell-box.json");
    let opts = IntegratorOptions::default();
    let flag = Arc::new(AtomicBool::new(false));
    let st = RenderSettings {
        spp: 1000,
        threads: Some(2),
        cancel: Some(flag.clone()),
        ..Default::default()
    };
    let mut passes = 0;
    let f = flag.clone();
    let mut cb = |_: &stokes::film::Film, _: &stokes::integrator::Stats, _: f64| {
        passes += 1;
        if passes == 2 {
            f.store(true, Ordering::Relaxed);
        }
        true
    };
    let r = render(&scene, IntegratorKind::PtMono, &opts, &st, Some(&mut cb));
    assert_eq!(r.err().as_deref(), Some(CANCELLED));
    assert_eq!(passes, 2);
    // already set: nothing renders
    let r = render(&scene, IntegratorKind::PtHero, &opts, &st, None);
    assert_eq!(r.err().as_deref(), Some(CANCELLED));
    // set from another thread during a render of a million passes
    flag.store(false, Ordering::Relaxed);
    let long = RenderSettings {
        spp: 1_000_000,
        ..st.clone()
    };
    let f = flag.clone();
    let stopper = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(200));
        f.store(true, Ordering::Relaxed);
    });
    let r = render(&scene, IntegratorKind::BdptForward, &opts, &long, None);
    stopper.join().unwrap();
    assert_eq!(r.err().as_deref(), Some(CANCELLED));
    // a flag that stays unset: the same image as without one
    let plain = RenderSettings {
        spp: 3,
        seed: 5,
        ..Default::default()
    };
    let with_flag = RenderSettings {
        cancel: Some(Arc::new(AtomicBool::new(false))),
        ..plain.clone()
    };
    let a = render(&scene, IntegratorKind::PtMono, &opts, &plain, None).unwrap();
    let b = render(&scene, IntegratorKind::PtMono, &opts, &with_flag, None).unwrap();
    assert_eq!(a.film.xyz(), b.film.xyz());
}
