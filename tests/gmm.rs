//! The Gaussian-mixture reradiation material (`reradiation-gmm`, Hua 2022) in every integrator.
//!
//! - Rendering a fitted mixture agrees, per image quadrant and for each of the five integrators,
//!   with rendering the dense 1-nm matrix that the same mixture evaluates to
//!   (`GmmFile::to_matrix_at(1.0)`, as a `reradiation` material): a like-for-like check of the
//!   mixture's sampling, pdfs and evaluation with no fitting error in it. Both renders differ
//!   clearly from the same scene with the fluorescence removed, so a kernel that is silently zero
//!   would fail.
//! - The measured matrix with its shifts drawn from a fitted mixture (`"sampling": {"type":
//!   "mixture"}`, Hua's sampling-only use) agrees per quadrant with the same matrix drawn from
//!   its tables, in each of the five integrators.
//! - A malformed `reradiation-gmm` material, or a malformed `sampling` of a `reradiation`
//!   material, is an input error naming the scene file and the field.

mod common;

use common::{Quadrants, assert_agree, noise_ok, quadrant_stats, quadrant_y};
use std::path::Path;
use std::sync::OnceLock;
use std::time::Instant;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::material::mixture::{FitMethod, FitOptions, GmmFile, fit_matrix};
use stokes::material::reradiation::BfcMatrix;
use stokes::scene::Scene;

/// The measured matrix fitted by the tests: the yellow fluorescent golf ball (strong UV and blue
/// excitation, green–yellow emission).
const BFC: &str = include_str!("../data/bispectral/GOLFYE.BFC");

/// A grey room lit from the ceiling by a 300–700 nm light, three times as strong below 450 nm
/// (UV and blue excite the dye) as above. The fluorescent material `dye`
/// covers the floor and the left half of the back wall; the right half of the back wall is grey.
/// So the top-left quadrant sees the dye directly, the bottom quadrants see it on the floor (and
/// the bottom-left also on the wall), and the top-right quadrant sees only grey surfaces, lit in
/// part by light the dye reradiated. UV reaches the dye directly and after bounces off the grey
/// walls (which reflect UV too), so both sub-path directions and multiple bounces matter.
/// `DYE` is replaced by the material under test.
const ROOM: &str = r#"{
 "domain": [280, 780],
 "camera": {"origin": [0, 0, 3.2], "target": [0, -0.1, 0], "fov": 48, "width": 24, "height": 24},
 "materials": {"grey": {"type": "lambert", "reflectance": 0.6}, "dye": DYE},
 "shapes": [
  {"type": "quad", "name": "floor", "material": "dye",
   "corners": [[-1, -1, -1], [-1, -1, 3.5], [1, -1, 3.5], [1, -1, -1]]},
  {"type": "quad", "name": "ceiling", "material": "grey",
   "corners": [[-1, 1, -1], [1, 1, -1], [1, 1, 3.5], [-1, 1, 3.5]]},
  {"type": "quad", "name": "left", "material": "grey",
   "corners": [[-1, -1, -1], [-1, 1, -1], [-1, 1, 3.5], [-1, -1, 3.5]]},
  {"type": "quad", "name": "right", "material": "grey",
   "corners": [[1, -1, -1], [1, -1, 3.5], [1, 1, 3.5], [1, 1, -1]]},
  {"type": "quad", "name": "back-dye", "material": "dye",
   "corners": [[-1, -1, -1], [0, -1, -1], [0, 1, -1], [-1, 1, -1]]},
  {"type": "quad", "name": "back-grey", "material": "grey",
   "corners": [[0, -1, -1], [1, -1, -1], [1, 1, -1], [0, 1, -1]]},
  {"type": "quad", "name": "light", "material": "grey",
   "corners": [[-0.35, 0.99, 0.2], [0.35, 0.99, 0.2], [0.35, 0.99, 0.9], [-0.35, 0.99, 0.9]],
   "emission": {"spectrum": {"type": "binned", "lo": 300, "width": 50,
                             "values": [1, 1, 1, 0.3, 0.3, 0.3, 0.3, 0.3]}, "scale": 8}}
 ]
}"#;

/// The three scenes of the comparison, loaded from a temporary folder (removed once loaded).
struct Fixture {
    /// `reradiation-gmm` with the fitted model file.
    gmm: Scene,
    /// `reradiation` with the dense 1-nm matrix the model evaluates to.
    dense: Scene,
    /// `reradiation` with that matrix's diagonal only (no fluorescence).
    plain: Scene,
    /// `reradiation` with the measured matrix, sampled by its tables.
    matrix: Scene,
    /// `reradiation` with the measured matrix, its shifts drawn from the fitted model (the
    /// sampling-only mode, Hua §7.6), the tables' share 0.1.
    sampled: Scene,
}

/// The room with `material` (JSON) as the dye, loaded as `dir/scene.json`.
fn room(dir: &Path, material: &str) -> Result<Scene, stokes::io::InputError> {
    let text = ROOM.replace("DYE", material);
    let path = dir.join("scene.json");
    std::fs::write(&path, &text).unwrap();
    Scene::from_str(&path, &text)
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let t = Instant::now();
        let m = BfcMatrix::parse(BFC).unwrap();
        let mut model = fit_matrix(&m, &FitOptions::new(4, FitMethod::Em, 0)).unwrap();
        model.source.file = "GOLFYE.BFC".into();
        model.source.sha256 = stokes::io::hash::sha256_hex(BFC.as_bytes());
        let dense = model.to_matrix_at(1.0).unwrap();
        let mut diag = dense.clone();
        for o in 0..diag.n_em {
            for i in 0..diag.n_ex {
                if !diag.is_diagonal(o, i) {
                    diag.d[o * diag.n_ex + i] = 0.0;
                }
            }
        }
        let dir = common::temp_dir("fixture");
        std::fs::write(dir.join("model.json"), model.to_json()).unwrap();
        std::fs::write(
            dir.join("dense.bfc"),
            dense.to_bfc("GOLFYE, 4 Gaussians, 1 nm"),
        )
        .unwrap();
        std::fs::write(dir.join("plain.bfc"), diag.to_bfc("GOLFYE diagonal")).unwrap();
        std::fs::write(dir.join("golfye.bfc"), BFC).unwrap();
        let f = Fixture {
            gmm: room(&dir, r#"{"type": "reradiation-gmm", "file": "model.json"}"#).unwrap(),
            dense: room(&dir, r#"{"type": "reradiation", "file": "dense.bfc"}"#).unwrap(),
            plain: room(&dir, r#"{"type": "reradiation", "file": "plain.bfc"}"#).unwrap(),
            matrix: room(&dir, r#"{"type": "reradiation", "file": "golfye.bfc"}"#).unwrap(),
            sampled: room(
                &dir,
                r#"{"type": "reradiation", "file": "golfye.bfc",
                    "sampling": {"type": "mixture", "file": "model.json", "defensive": 0.1}}"#,
            )
            .unwrap(),
        };
        std::fs::remove_dir_all(&dir).unwrap();
        eprintln!(
            "fitted and loaded in {:.2} s ({} components, scale {:.3} nm)",
            t.elapsed().as_secs_f64(),
            model.components.len(),
            model.scale
        );
        f
    })
}

/// Seeds per estimate (the standard errors come from their spread).
const SEEDS: u64 = 6;

/// Relative standard error that each side of a comparison must reach in every quadrant.
const REL_SE: f64 = 0.02;

/// Mean Y per image quadrant over [`SEEDS`] renders with seeds `first_seed`, `first_seed + 1`, …:
/// (means, standard errors). Each side of a comparison takes its own seeds, so that the two
/// estimates are independent and the σ of their difference is what [`assert_agree`] assumes.
fn quadrants(
    scene: &Scene,
    kind: IntegratorKind,
    spp: u32,
    seeds: u64,
    first_seed: u64,
) -> Quadrants {
    let opts = IntegratorOptions::default();
    let per_seed: Vec<[f64; 4]> = (0..seeds)
        .map(|k| {
            let settings = RenderSettings {
                first_sample: 0,
                spp,
                seed: first_seed + k,
                ..Default::default()
            };
            let out = render(scene, kind, &opts, &settings, None).unwrap();
            assert_eq!(out.stats.nan_inf_rejected, 0, "{}", kind.name());
            quadrant_y(scene, &out.film.xyz())
        })
        .collect();
    quadrant_stats(&per_seed)
}

fn check_quadrants_meaningful(what: &str, q: Quadrants) {
    for r in 0..4 {
        let rel = q.1[r] / q.0[r].abs().max(1e-6);
        assert!(
            rel < REL_SE,
            "{what}: quadrant {r} has relative standard error {rel:.4} (≥ {REL_SE})"
        );
    }
}

/// GMM against its dense matrix with `kind` at `spp` samples per pixel (× [`SEEDS`] seeds), and
/// both against the render without fluorescence.
fn gmm_agrees_with_its_dense_matrix(kind: IntegratorKind, spp: u32) {
    let f = fixture();
    let t = Instant::now();
    let gmm = quadrants(&f.gmm, kind, spp, SEEDS, 100);
    let t_gmm = t.elapsed().as_secs_f64();
    let dense = quadrants(&f.dense, kind, spp, SEEDS, 200);
    let t_dense = t.elapsed().as_secs_f64() - t_gmm;
    let plain = quadrants(&f.plain, kind, spp / 2, 3, 300);
    eprintln!(
        "{}: {spp} spp × {SEEDS} seeds: gmm {t_gmm:.2} s, dense {t_dense:.2} s, total {:.2} s",
        kind.name(),
        t.elapsed().as_secs_f64()
    );
    let what = format!("{}: gmm vs its dense matrix", kind.name());
    check_quadrants_meaningful(&format!("{what} (gmm)"), gmm);
    check_quadrants_meaningful(&format!("{what} (dense)"), dense);
    assert!(noise_ok(gmm, dense));
    assert_agree(&what, gmm, dense);
    // Fluorescence shows: every quadrant that sees the dye is at least 10 % and 8σ brighter than
    // without it (the top-right quadrant sees it only indirectly: at least 4σ).
    for r in 0..4 {
        for (name, q) in [("gmm", gmm), ("dense", dense)] {
            let sigma = (q.1[r].powi(2) + plain.1[r].powi(2)).sqrt();
            let d = q.0[r] - plain.0[r];
            eprintln!(
                "{}: {name} quadrant {r}: {:.5}, without fluorescence {:.5} ({:+.1} %, {:.1}σ)",
                kind.name(),
                q.0[r],
                plain.0[r],
                100.0 * d / plain.0[r],
                d / sigma
            );
            let (rel, k) = if r == 1 { (0.0, 4.0) } else { (0.1, 8.0) };
            assert!(
                d > k * sigma && d > rel * plain.0[r],
                "{}: {name} quadrant {r} is {} with fluorescence and {} without",
                kind.name(),
                q.0[r],
                plain.0[r]
            );
        }
    }
}

#[test]
fn pt_mono_renders_the_mixture_like_its_dense_matrix() {
    gmm_agrees_with_its_dense_matrix(IntegratorKind::PtMono, 512);
}

#[test]
fn pt_hero_renders_the_mixture_like_its_dense_matrix() {
    gmm_agrees_with_its_dense_matrix(IntegratorKind::PtHero, 256);
}

#[test]
fn bdpt_forward_renders_the_mixture_like_its_dense_matrix() {
    gmm_agrees_with_its_dense_matrix(IntegratorKind::BdptForward, 64);
}

#[test]
fn bdpt_backward_renders_the_mixture_like_its_dense_matrix() {
    gmm_agrees_with_its_dense_matrix(IntegratorKind::BdptBackward, 32);
}

#[test]
fn bdpt_combined_renders_the_mixture_like_its_dense_matrix() {
    gmm_agrees_with_its_dense_matrix(IntegratorKind::BdptCombined, 24);
}

#[test]
fn bdpt_allbins_renders_the_mixture_like_its_dense_matrix() {
    gmm_agrees_with_its_dense_matrix(IntegratorKind::BdptAllbins, 48);
}

/// Seeds per estimate of the sampling-only comparison. Its two sides differ only in how a shift
/// is drawn, so their difference is small and its σ, estimated from the seeds' spread, must be
/// trustworthy: with 6 seeds a side (5 degrees of freedom each) a correct estimator failed 3σ
/// in one quadrant of two integrators, and passed at 0.6–0.9σ with 24 fresh seeds a side.
const SAMPLING_SEEDS: u64 = 12;

/// The measured matrix with its shifts drawn from the mixture (sampling only) against the same
/// matrix drawn from its tables, with `kind` at `spp` samples per pixel × [`SAMPLING_SEEDS`]
/// seeds: the same image (3σ per quadrant), since only the sampling differs and the weights are
/// f_matrix / q.
fn sampling_only_agrees_with_the_matrix(kind: IntegratorKind, spp: u32) {
    let f = fixture();
    let t = Instant::now();
    let sampled = quadrants(&f.sampled, kind, spp, SAMPLING_SEEDS, 400);
    let t_sampled = t.elapsed().as_secs_f64();
    let matrix = quadrants(&f.matrix, kind, spp, SAMPLING_SEEDS, 500);
    eprintln!(
        "{}: {spp} spp × {SAMPLING_SEEDS} seeds: mixture-sampled {t_sampled:.2} s, table-sampled {:.2} s",
        kind.name(),
        t.elapsed().as_secs_f64() - t_sampled
    );
    let what = format!("{}: mixture-sampled matrix vs table-sampled", kind.name());
    check_quadrants_meaningful(&format!("{what} (mixture)"), sampled);
    check_quadrants_meaningful(&format!("{what} (tables)"), matrix);
    assert_agree(&what, sampled, matrix);
}

#[test]
fn pt_mono_samples_the_matrix_with_the_mixture_without_bias() {
    sampling_only_agrees_with_the_matrix(IntegratorKind::PtMono, 512);
}

#[test]
fn pt_hero_samples_the_matrix_with_the_mixture_without_bias() {
    sampling_only_agrees_with_the_matrix(IntegratorKind::PtHero, 256);
}

#[test]
fn bdpt_forward_samples_the_matrix_with_the_mixture_without_bias() {
    sampling_only_agrees_with_the_matrix(IntegratorKind::BdptForward, 64);
}

#[test]
fn bdpt_backward_samples_the_matrix_with_the_mixture_without_bias() {
    sampling_only_agrees_with_the_matrix(IntegratorKind::BdptBackward, 32);
}

#[test]
fn bdpt_combined_samples_the_matrix_with_the_mixture_without_bias() {
    sampling_only_agrees_with_the_matrix(IntegratorKind::BdptCombined, 24);
}

#[test]
fn bdpt_allbins_samples_the_matrix_with_the_mixture_without_bias() {
    sampling_only_agrees_with_the_matrix(IntegratorKind::BdptAllbins, 48);
}

/// A malformed-material case: tag, material JSON, files beside the scene, what the error names.
type Case<'a> = (&'a str, &'a str, &'a [(&'a str, &'a str)], &'a [&'a str]);

/// The error of a `reradiation-gmm` material `material` (JSON) in the room, with `files`
/// written beside the scene.
fn scene_error(tag: &str, material: &str, files: &[(&str, &str)]) -> String {
    let dir = common::temp_dir(tag);
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let r = room(&dir, material);
    std::fs::remove_dir_all(&dir).unwrap();
    match r {
        Ok(_) => panic!("{tag}: the scene loaded"),
        Err(e) => e.to_string(),
    }
}

/// A `reradiation-gmm` material with both `file` and `bfc`, with neither, with `components: 0`
/// or `restarts: 0`, with settings of a fit beside a fitted `file`, with a missing file or with a malformed model file fails naming the scene file and the field.
#[test]
fn malformed_gmm_materials_name_the_scene_file_and_the_field() {
    let fitted = fit_matrix(
        &BfcMatrix::parse(BFC).unwrap(),
        &FitOptions::new(2, FitMethod::Em, 0),
    )
    .unwrap();
    let model = fitted.to_json();
    let edited = |edit: fn(&mut GmmFile)| {
        let mut f = fitted.clone();
        edit(&mut f);
        f.to_json()
    };
    let bad_model = edited(|f| f.scale = -1.0);
    let bad_weight = edited(|f| f.components[0].weight = -0.5);
    let cases: [Case; 9] = [
        (
            "both",
            r#"{"type": "reradiation-gmm", "file": "m.json", "bfc": "g.bfc"}"#,
            &[("m.json", &model), ("g.bfc", BFC)],
            &["materials.dye.bfc", "`file`", "`bfc`"],
        ),
        (
            "neither",
            r#"{"type": "reradiation-gmm", "components": 4}"#,
            &[],
            &["materials.dye.file", "`file`", "`bfc`"],
        ),
        (
            "zero-components",
            r#"{"type": "reradiation-gmm", "bfc": "g.bfc", "components": 0}"#,
            &[("g.bfc", BFC)],
            &["materials.dye.components"],
        ),
        (
            "zero-restarts",
            r#"{"type": "reradiation-gmm", "bfc": "g.bfc", "restarts": 0}"#,
            &[("g.bfc", BFC)],
            &["materials.dye.restarts", "1..="],
        ),
        (
            "restarts-with-file",
            r#"{"type": "reradiation-gmm", "file": "m.json", "restarts": 4}"#,
            &[("m.json", &model)],
            &["materials.dye.restarts", "`bfc`"],
        ),
        (
            "components-with-file",
            r#"{"type": "reradiation-gmm", "file": "m.json", "components": 4}"#,
            &[("m.json", &model)],
            &["materials.dye.components"],
        ),
        (
            "missing-file",
            r#"{"type": "reradiation-gmm", "file": "none.json"}"#,
            &[],
            &["materials.dye.file", "none.json"],
        ),
        (
            "missing-bfc",
            r#"{"type": "reradiation-gmm", "bfc": "none.bfc", "components": 2}"#,
            &[],
            &["materials.dye.bfc", "none.bfc"],
        ),
        (
            "malformed-model",
            r#"{"type": "reradiation-gmm", "file": "m.json"}"#,
            &[("m.json", &bad_model)],
            &["materials.dye.file", "m.json", "scale"],
        ),
    ];
    for (tag, material, files, want) in cases {
        let e = scene_error(tag, material, files);
        eprintln!("{tag}: {e}");
        assert!(e.contains("scene.json"), "{tag}: names no scene file: {e}");
        for w in want {
            assert!(e.contains(w), "{tag}: should name {w}: {e}");
        }
    }
    // A `reradiation` material's `sampling`: a share of 0 (nothing would bound f/q), a kind
    // that does not exist, an unknown field, settings beside a fitted file, a missing model,
    // no components.
    let sampling =
        |s: &str| format!(r#"{{"type": "reradiation", "file": "g.bfc", "sampling": {s}}}"#);
    let files: &[(&str, &str)] = &[("g.bfc", BFC), ("m.json", &model)];
    for (tag, s, want) in [
        (
            "zero-share",
            r#"{"type": "mixture", "components": 2, "defensive": 0}"#,
            "materials.dye.sampling.defensive",
        ),
        (
            "share-above-one",
            r#"{"type": "mixture", "file": "m.json", "defensive": 1.5}"#,
            "materials.dye.sampling.defensive",
        ),
        (
            "unknown-kind",
            r#"{"type": "gmm"}"#,
            "materials.dye.sampling.type",
        ),
        (
            "unknown-field",
            r#"{"type": "mixture", "components": 2, "alpha": 0.2}"#,
            "materials.dye.sampling.alpha",
        ),
        (
            "settings-with-file",
            r#"{"type": "mixture", "file": "m.json", "seed": 3}"#,
            "materials.dye.sampling.seed",
        ),
        (
            "missing-model",
            r#"{"type": "mixture", "file": "none.json"}"#,
            "materials.dye.sampling.file",
        ),
        (
            "zero-components",
            r#"{"type": "mixture", "components": 0}"#,
            "materials.dye.sampling.components",
        ),
    ] {
        let e = scene_error(tag, &sampling(s), files);
        eprintln!("{tag}: {e}");
        assert!(e.contains("scene.json") && e.contains(want), "{tag}: {e}");
    }
    // A model fitted to another matrix loads (it still samples without bias), with a warning.
    let dir = common::temp_dir("other-model");
    std::fs::write(dir.join("g.bfc"), BFC).unwrap();
    let mut other = fitted.clone();
    other.source.sha256 = "0".repeat(64);
    std::fs::write(dir.join("m.json"), other.to_json()).unwrap();
    let scene = room(&dir, &sampling(r#"{"type": "mixture", "file": "m.json"}"#)).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("materials.dye.sampling.file") && w.contains("not fitted")),
        "{:?}",
        scene.warnings
    );

    // A model file that is not JSON at all, and one with a bad component.
    let e = scene_error(
        "not-json",
        r#"{"type": "reradiation-gmm", "file": "m.json"}"#,
        &[("m.json", "not a model")],
    );
    assert!(
        e.contains("materials.dye.file") && e.contains("scene.json"),
        "{e}"
    );
    let e = scene_error(
        "bad-component",
        r#"{"type": "reradiation-gmm", "file": "m.json"}"#,
        &[("m.json", &bad_weight)],
    );
    assert!(
        e.contains("materials.dye.file") && e.contains("components[0]"),
        "{e}"
    );
}
