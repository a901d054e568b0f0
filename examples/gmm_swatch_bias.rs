//! The bias of the Gaussian-mixture reradiation models (Hua 2022) on the gmm-vs-matrix swatch
//! chart, as the CIEDE2000 difference of each swatch's converged colour.
//!
//! Renders the matrix scene (scenes/gmm-swatches.json) and each mixture scene
//! (scenes/gmm-swatches-{2,4,8}.json) at high spp with pt-hero and the same seed, takes each
//! swatch's mean XYZ over its region (the pixels whose centre sees the swatch, less a one-pixel
//! border), and converts it to CIELAB relative to the white that a perfect white Lambertian
//! swatch gives at that spot (the same scene with every swatch `{"type": "lambert",
//! "reflectance": 1}`). Prints ΔE00 per swatch and K with the mean and max over swatches, and a
//! noise floor: ΔE00 between two renders of the matrix scene with different seeds (the mixtures
//! share the matrix render's seed, so their difference to it is if anything less noisy). Writes
//! the table as CSV and prints the memory per material: the matrix's values and its sampling
//! tables against the mixture's `ReradiationGmm::model_bytes`.
//!
//! With `--sampled`, the variants are the sampling-only scenes instead
//! (scenes/gmm-swatches-sampled-{2,4,8}.json: the matrices evaluated exactly, their shifts drawn
//! from the mixtures), which must converge to the matrix's colours: their ΔE00 is noise alone.
//!
//! `cargo run --release --example gmm_swatch_bias -- [spp] [out.csv] [--sampled]`
//! (defaults: 1024 spp, results/gmm-vs-matrix/swatch-bias.csv, or
//! results/gmm-sampling/swatch-bias.csv with `--sampled`).

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;
use stokes::integrator::{IntegratorKind, IntegratorOptions, RenderSettings, render};
use stokes::material::Material;
use stokes::scene::Scene;
use stokes::spectrum::colorimetry::{delta_e00, xyz_to_lab};
use stokes::spectrum::xyz_to_linear_srgb;

const MATRIX: &str = "scenes/gmm-swatches.json";
const MIXTURES: [(usize, &str); 3] = [
    (2, "scenes/gmm-swatches-2.json"),
    (4, "scenes/gmm-swatches-4.json"),
    (8, "scenes/gmm-swatches-8.json"),
];
const SAMPLED: [(usize, &str); 3] = [
    (2, "scenes/gmm-swatches-sampled-2.json"),
    (4, "scenes/gmm-swatches-sampled-4.json"),
    (8, "scenes/gmm-swatches-sampled-8.json"),
];
const SEED: u64 = 7;

/// Shape names that are not swatches.
fn is_swatch(name: &str) -> bool {
    !matches!(name, "backdrop" | "lamp-uv" | "lamp-d65")
}

/// The scene text with every swatch's material replaced by a perfect white Lambertian.
fn white_scene(text: &str) -> String {
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    let names: Vec<String> = v["shapes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|s| s["material"].as_str().map(str::to_string))
        .filter(|n| is_swatch(n) && n != "black")
        .collect();
    for n in names {
        v["materials"][&n] = serde_json::json!({"type": "lambert", "reflectance": 1});
    }
    v.to_string()
}

/// Per swatch shape (in scene order), the pixels whose centre and four neighbours' centres all
/// see it.
fn swatch_masks(scene: &Scene) -> Vec<(String, Vec<usize>)> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let mut ids = vec![u32::MAX; w * h];
    for y in 0..h {
        for x in 0..w {
            let ray = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
            if let Some(hit) = scene.first_visible(&ray) {
                ids[y * w + x] = scene.prims[hit.prim as usize].shape;
            }
        }
    }
    let mut out = Vec::new();
    for (k, s) in scene.shapes.iter().enumerate() {
        if !is_swatch(&s.name) {
            continue;
        }
        let k = k as u32;
        let mut px = Vec::new();
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let i = y * w + x;
                if [i, i - 1, i + 1, i - w, i + w].iter().all(|&j| ids[j] == k) {
                    px.push(i);
                }
            }
        }
        assert!(!px.is_empty(), "swatch {} covers no pixel", s.name);
        out.push((s.name.clone(), px));
    }
    out
}

/// The XYZ image of `scene` with pt-hero.
fn render_xyz(scene: &Scene, spp: u32, seed: u64, what: &str) -> Vec<Vec3> {
    let t = Instant::now();
    let out = render(
        scene,
        IntegratorKind::PtHero,
        &IntegratorOptions::default(),
        &RenderSettings {
            first_sample: 0,
            spp,
            seed,
            ..Default::default()
        },
        None,
    )
    .unwrap();
    assert_eq!(out.stats.nan_inf_rejected, 0, "{what}");
    eprintln!(
        "{what}: {spp} spp in {:.1} s ({:.2} M samples/s)",
        t.elapsed().as_secs_f64(),
        out.stats.paths as f64 / t.elapsed().as_secs_f64() / 1e6
    );
    out.film.xyz()
}

/// SNR_dB = 10·log10(Σ ref² / Σ (img − ref)²) over pixels and linear-sRGB channels
/// (docs/design.md §6).
fn snr_db(img: &[Vec3], reference: &[Vec3]) -> f64 {
    let (mut s2, mut e2) = (0.0f64, 0.0f64);
    for (a, b) in img.iter().zip(reference) {
        let (a, b) = (xyz_to_linear_srgb(*a), xyz_to_linear_srgb(*b));
        for c in 0..3 {
            let (x, r) = (a[c] as f64, b[c] as f64);
            s2 += r * r;
            e2 += (x - r) * (x - r);
        }
    }
    10.0 * (s2 / e2).log10()
}

fn mean_xyz(img: &[Vec3], px: &[usize]) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for &i in px {
        s[0] += img[i].x as f64;
        s[1] += img[i].y as f64;
        s[2] += img[i].z as f64;
    }
    s.map(|x| x / px.len() as f64)
}

fn load(path: &str) -> (Scene, String) {
    let text = std::fs::read_to_string(path).unwrap();
    (Scene::from_str(Path::new(path), &text).unwrap(), text)
}

fn material_of<'a>(scene: &'a Scene, name: &str) -> &'a Material {
    let i = scene.material_names.iter().position(|n| n == name).unwrap();
    &scene.materials[i]
}

fn main() {
    let all: Vec<String> = std::env::args().collect();
    let sampled = all.iter().any(|a| a == "--sampled");
    let args: Vec<&String> = all.iter().filter(|a| *a != "--sampled").collect();
    let spp: u32 = args.get(1).map_or(1024, |s| s.parse().unwrap());
    let (variants, default_out) = if sampled {
        (SAMPLED, "results/gmm-sampling/swatch-bias.csv")
    } else {
        (MIXTURES, "results/gmm-vs-matrix/swatch-bias.csv")
    };
    let out: PathBuf = args.get(2).map_or(default_out.into(), PathBuf::from);
    let t0 = Instant::now();
    let (matrix, text) = load(MATRIX);
    let white = Scene::from_str(Path::new(MATRIX), &white_scene(&text)).unwrap();
    let masks = swatch_masks(&matrix);
    let region =
        |img: &[Vec3]| -> Vec<[f64; 3]> { masks.iter().map(|(_, px)| mean_xyz(img, px)).collect() };
    let w = region(&render_xyz(&white, spp, SEED, "white"));
    let lab = |xyz: &[[f64; 3]]| -> Vec<[f64; 3]> {
        xyz.iter()
            .zip(&w)
            .map(|(x, w)| xyz_to_lab(*x, *w))
            .collect()
    };
    let m_img = render_xyz(&matrix, spp, SEED, "matrix");
    let m_lab = lab(&region(&m_img));
    let noise_img = render_xyz(&matrix, spp, SEED + 1000, "matrix, other seed");
    let noise_lab = lab(&region(&noise_img));
    let mut scenes = Vec::new();
    let mut g_lab = Vec::new();
    let mut snr = vec![("matrix, other seed".to_string(), snr_db(&noise_img, &m_img))];
    for (k, path) in variants {
        let (s, _) = load(path);
        let img = render_xyz(&s, spp, SEED, &format!("K = {k}"));
        g_lab.push(lab(&region(&img)));
        snr.push((format!("K = {k}"), snr_db(&img, &m_img)));
        scenes.push(s);
    }
    let de = |a: &[[f64; 3]], b: &[[f64; 3]]| -> Vec<f64> {
        a.iter().zip(b).map(|(x, y)| delta_e00(*x, *y)).collect()
    };
    let noise = de(&m_lab, &noise_lab);
    let per_k: Vec<Vec<f64>> = g_lab.iter().map(|g| de(&m_lab, g)).collect();

    // The table.
    println!(
        "\nΔE00 of each swatch's converged colour, mixture vs matrix (pt-hero, {spp} spp, seed {SEED}); \
         noise: matrix vs matrix at another seed\n"
    );
    print!("{:<10} {:>20}", "swatch", "matrix L* a* b*");
    for (k, _) in variants {
        print!(" {:>7}", format!("K={k}"));
    }
    println!(" {:>7}", "noise");
    let mut csv = String::from("swatch,L,a,b");
    for (k, _) in variants {
        csv += &format!(",L_k{k},a_k{k},b_k{k},de00_k{k}");
    }
    csv += ",de00_noise\n";
    for (s, (name, _)) in masks.iter().enumerate() {
        let l = m_lab[s];
        print!("{:<10} {:>6.1} {:>6.1} {:>6.1}", name, l[0], l[1], l[2]);
        csv += &format!("{name},{:.3},{:.3},{:.3}", l[0], l[1], l[2]);
        for (j, _) in variants.iter().enumerate() {
            let g = g_lab[j][s];
            print!(" {:>7.3}", per_k[j][s]);
            csv += &format!(",{:.3},{:.3},{:.3},{:.4}", g[0], g[1], g[2], per_k[j][s]);
        }
        println!(" {:>7.3}", noise[s]);
        csv += &format!(",{:.4}\n", noise[s]);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    print!("{:<10} {:>20}", "mean", "");
    for v in &per_k {
        print!(" {:>7.3}", mean(v));
    }
    println!(" {:>7.3}", mean(&noise));
    print!("{:<10} {:>20}", "max", "");
    for v in &per_k {
        print!(" {:>7.3}", max(v));
    }
    println!(" {:>7.3}", max(&noise));
    for (j, (k, _)) in variants.iter().enumerate() {
        let worst = (0..masks.len())
            .max_by(|&a, &b| per_k[j][a].total_cmp(&per_k[j][b]))
            .unwrap();
        println!(
            "K = {k}: worst swatch {} (ΔE00 {:.2}); {} of {} swatches above ΔE00 = 1",
            masks[worst].0,
            per_k[j][worst],
            per_k[j].iter().filter(|&&d| d > 1.0).count(),
            masks.len()
        );
    }
    println!(
        "\nwhole-image SNR against the matrix render (linear sRGB, dB; the ceiling a mixture \
         can reach against a matrix reference, and the noise of one {spp}-spp render pair):"
    );
    for (what, db) in &snr {
        println!("  {what:<20} {db:6.2} dB");
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).unwrap();
    }
    std::fs::write(&out, csv).unwrap();
    println!("wrote {}", out.display());
    if sampled {
        eprintln!("total {:.1} s", t0.elapsed().as_secs_f64());
        return;
    }

    // Memory per material.
    println!("\nmemory per material (bytes)");
    print!("{:<10} {:>8}", "swatch", "matrix");
    for (k, _) in variants {
        print!(" {:>7}", format!("K={k}"));
    }
    println!();
    let mut totals = [0usize; 4];
    for (name, _) in &masks {
        let Material::Reradiation(r) = material_of(&matrix, name) else {
            panic!("{name} is not a matrix in {MATRIX}");
        };
        let (n_em, n_ex) = r.shape();
        // Values, the per-column and per-row CDFs, the column and row totals; f32 each.
        let mb = 4 * (n_em * n_ex + 2 * n_em * n_ex + n_em + n_ex);
        print!("{:<10} {:>8}", name, mb);
        totals[0] += mb;
        for (j, s) in scenes.iter().enumerate() {
            let Material::ReradiationGmm(g) = material_of(s, name) else {
                panic!("{name} is not a mixture in {}", MIXTURES[j].1);
            };
            print!(" {:>7}", g.model_bytes());
            totals[j + 1] += g.model_bytes();
        }
        println!();
    }
    println!(
        "{:<10} {:>8} {:>7} {:>7} {:>7}",
        "total", totals[0], totals[1], totals[2], totals[3]
    );
    println!(
        "(matrix: 4 bytes × (n_em·n_ex values + 2·n_em·n_ex CDF entries + n_em + n_ex totals); \
         mixture: ReradiationGmm::model_bytes = 8 bytes × (1 + 7K) + 4 bytes × the {} reflectance values)",
        match material_of(&matrix, &masks[0].0) {
            Material::Reradiation(r) => r.shape().0,
            _ => 0,
        }
    );
    eprintln!("total {:.1} s", t0.elapsed().as_secs_f64());
}
