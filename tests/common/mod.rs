//! Helpers shared by the integration tests: the bench ray sets (`ray_sets`), and scenes with
//! participating media and the per-quadrant comparison of two estimators (tests/media.rs,
//! tests/bdpt_media.rs). Each test crate uses only some of them.
#![allow(dead_code)]

pub mod ray_sets;

use glam::Vec3;
use std::path::{Path, PathBuf};
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::scene::Scene;

/// A scene of `scenes/` by file name (with its extension).
pub fn load(name: &str) -> Scene {
    Scene::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(name),
    )
    .unwrap()
}

/// [`load`] with the film resized to `size`×`size` pixels.
pub fn load_sized(name: &str, size: u32) -> Scene {
    sized(load(name), size)
}

/// `scene` with its film resized to `size`×`size` pixels.
pub fn sized(mut scene: Scene, size: u32) -> Scene {
    scene.camera.width = size;
    scene.camera.height = size;
    scene
}

/// The mean XYZ of a render and the standard error of its mean Y over the pixels.
pub fn mean_xyz(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    spp: u32,
    seed: u64,
) -> (Vec3, f32) {
    let settings = RenderSettings {
        first_sample: 0,
        spp,
        seed,
        ..Default::default()
    };
    let out = render(scene, kind, opts, &settings, None).unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0, "{kind:?} {opts:?}");
    let xyz = out.film.xyz();
    assert!(xyz.iter().all(|v| v.is_finite()));
    let n = xyz.len() as f32;
    let mean = xyz.iter().copied().sum::<Vec3>() / n;
    let var = xyz.iter().map(|v| (v.y - mean.y).powi(2)).sum::<f32>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// A small box of fluorescent, forward-scattering medium (σ̂s > σ̂t in its emission band) in a
/// grey room lit by a UV + visible light; the camera outside the medium.
pub const DYE_BOX: &str = include_str!("dye-box.json");

/// The [`DYE_BOX`] scene.
pub fn dye_box() -> Scene {
    Scene::from_str(Path::new("dye-box.json"), DYE_BOX).unwrap()
}

/// Per-quadrant means and their standard errors.
pub type Quadrants = ([f64; 4], [f64; 4]);

/// Mean Y per image quadrant over `seeds` renders: (means, standard errors).
pub fn quadrants(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    spp: u32,
    seeds: u64,
) -> Quadrants {
    let mut per_seed = Vec::new();
    for seed in 0..seeds {
        let settings = RenderSettings {
            first_sample: 0,
            spp,
            seed: 100 + seed,
            ..Default::default()
        };
        let out = render(scene, kind, opts, &settings, None).unwrap();
        assert_eq!(out.stats.nan_inf_rejected, 0, "{kind:?} {opts:?}");
        per_seed.push(quadrant_y(scene, &out.film.xyz()));
    }
    quadrant_stats(&per_seed)
}

/// Mean Y of each image quadrant of an XYZ image of the scene's camera size (index: 2·row + column).
pub fn quadrant_y(scene: &Scene, xyz: &[Vec3]) -> [f64; 4] {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    assert_eq!(xyz.len(), w * h);
    let mut q = [0.0f64; 4];
    for y in 0..h {
        for x in 0..w {
            q[(y * 2 / h) * 2 + x * 2 / w] += xyz[y * w + x].y as f64 / (w * h / 4) as f64;
        }
    }
    q
}

/// Means and standard errors of the means of per-seed quadrant values.
pub fn quadrant_stats(per_seed: &[[f64; 4]]) -> Quadrants {
    let k = per_seed.len() as f64;
    let mut mean = [0.0; 4];
    let mut se = [0.0; 4];
    for r in 0..4 {
        mean[r] = per_seed.iter().map(|q| q[r]).sum::<f64>() / k;
        let var = per_seed
            .iter()
            .map(|q| (q[r] - mean[r]).powi(2))
            .sum::<f64>()
            / (k - 1.0);
        se[r] = (var / k).sqrt();
    }
    (mean, se)
}

/// Whether the standard error of the difference is below 5 % of the value in every quadrant
/// (else the comparison would not mean much).
pub fn noise_ok(a: Quadrants, b: Quadrants) -> bool {
    (0..4).all(|r| (a.1[r].powi(2) + b.1[r].powi(2)).sqrt() < 0.05 * a.0[r].abs().max(1e-3))
}

/// Two estimators agree per quadrant within 3σ of their difference.
pub fn assert_agree(what: &str, a: Quadrants, b: Quadrants) {
    assert_agree_within(what, a, b, 3.0);
}

/// Two estimators agree per quadrant within `k`σ of their difference, and the comparison is
/// meaningful ([`noise_ok`]).
pub fn assert_agree_within(what: &str, a: Quadrants, b: Quadrants, k: f64) {
    for r in 0..4 {
        let sigma = (a.1[r].powi(2) + b.1[r].powi(2)).sqrt();
        let d = (a.0[r] - b.0[r]).abs();
        eprintln!(
            "{what} quadrant {r}: {:.5} vs {:.5} (diff {d:.5}, σ {sigma:.5}, {:.2}σ)",
            a.0[r],
            b.0[r],
            d / sigma
        );
    }
    for r in 0..4 {
        let sigma = (a.1[r].powi(2) + b.1[r].powi(2)).sqrt();
        let d = (a.0[r] - b.0[r]).abs();
        assert!(
            d < k * sigma,
            "{what} quadrant {r}: {} vs {} (diff {d}, σ {sigma}, {:.2}σ > {k}σ)",
            a.0[r],
            b.0[r],
            d / sigma
        );
    }
    assert!(noise_ok(a, b), "{what}: too noisy to compare");
}

/// Every scene file with media, by name, resized to `size`×`size` pixels.
pub fn media_scenes(size: u32) -> Vec<(String, Scene)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .filter_map(|path| {
            let scene = sized(Scene::load(&path).unwrap(), size);
            let stem = path.file_stem().unwrap().to_string_lossy().to_string();
            scene.has_media.then_some((stem, scene))
        })
        .collect()
}

/// A fresh temporary folder `stokes-<tag>-<pid>-<nanoseconds>`.
pub fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "stokes-{tag}-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos()
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The `stokes` binary of this build.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_stokes")
}

/// `stokes experiment CFG --quick --out OUT`, its output.
pub fn quick_experiment(cfg: &Path, out: &Path) -> std::process::Output {
    std::process::Command::new(bin())
        .args(["experiment", s(cfg), "--quick", "--out", s(out)])
        .output()
        .unwrap()
}

/// Exit code and stderr of the `stokes` binary run with `args` in `cwd`, under a 20-second
/// wall-clock and 2 GiB address-space limit, with no standard input and without the Slurm
/// variables of the environment (a time-out is exit code -1, a signal -2).
pub fn run_limited(cwd: &Path, args: &[&str]) -> (i32, String) {
    use std::process::{Command, Stdio};
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2097152 2>/dev/null; exec \"$0\" \"$@\"")
        .arg(bin())
        .args(args)
        .current_dir(cwd)
        .env("STOKES_CACHE_DIR", cwd.join(".cache"))
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_CPUS_PER_TASK")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t = std::time::Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            let mut err = String::new();
            use std::io::Read;
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut err)
                .unwrap();
            return (st.code().unwrap_or(-2), err);
        }
        if t.elapsed() > std::time::Duration::from_secs(20) {
            let _ = child.kill();
            let _ = child.wait();
            return (-1, format!("timed out: stokes {args:?}"));
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Exit code 2, no panic, and every one of `names` in the message.
pub fn expect_input_error(what: &str, (code, err): (i32, String), names: &[&str]) {
    assert_eq!(code, 2, "{what}: exit code {code}, stderr: {err}");
    assert!(!err.contains("panicked"), "{what}: panic: {err}");
    for n in names {
        assert!(
            err.contains(n),
            "{what}: message does not name `{n}`: {err}"
        );
    }
}
