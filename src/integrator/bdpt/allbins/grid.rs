//! The bin grid of a scene (docs/allbins.md, "Bins that follow the scene"): edges at every
//! discontinuity of the scene's spectra, so that box spectra are exact at any width, and finer
//! bins where a spectrum changes by more than [`TOL`] of its peak within a bin; a warning names
//! each spectrum that the chosen width alone would have binned coarsely.

use crate::material::Material;
use crate::scene::Scene;
use crate::spectrum::bins::{discontinuities, oscillation};
use crate::spectrum::{BinGrid, Spectrum};

/// Largest change of a spectrum within one bin, as a fraction of its peak on the domain. By
/// Grüss' inequality |avg(fg) − avg f·avg g| ≤ ¼·osc f·osc g, a bin-averaged product of two such
/// spectra is then off by at most ¼·TOL² = 1.6 % of the product of their peaks.
pub const TOL: f32 = 0.25;

/// The spectra that weight transport in `scene`, each named by its place in the scene file.
pub fn scene_spectra(scene: &Scene) -> Vec<(String, &Spectrum)> {
    let mut out = Vec::new();
    for (m, name) in scene.materials.iter().zip(&scene.material_names) {
        let base = format!("materials.{name}");
        match m {
            Material::Lambert(l) => out.push((format!("{base}.reflectance"), &l.reflectance)),
            #[cfg(feature = "fluorescence")]
            Material::Fluorescent(f) => {
                out.push((format!("{base}.reflectance"), &f.r));
                out.push((format!("{base}.absorption"), &f.a));
                out.push((format!("{base}.emission"), &f.e));
            }
            // Measured and fitted matrices: their bin operators integrate the kernel per bin.
            #[cfg(feature = "fluorescence")]
            Material::Reradiation(_) | Material::ReradiationGmm(_) => {}
        }
    }
    for (m, name) in scene.media.iter().zip(&scene.medium_names) {
        let (base, c) = (format!("media.{name}"), &m.coefficients);
        out.push((format!("{base}.sigma_a"), &c.sigma_a));
        out.push((format!("{base}.sigma_s"), &c.sigma_s));
        if let Some(f) = &c.fluorophore {
            out.push((format!("{base}.fluorophore.absorption"), &f.a));
            out.push((format!("{base}.fluorophore.emission"), &f.e));
        }
    }
    for l in scene.lights.iter() {
        out.push((format!("light '{}' emission", l.name), &l.spectrum));
    }
    out
}

/// Largest relative oscillation of `s` (peak `peak`) over the bins of `g`, and that bin.
fn worst_bin(s: &Spectrum, peak: f32, g: &BinGrid) -> (f32, usize) {
    (0..g.len())
        .map(|b| (oscillation(s, g.edge(b), g.edge(b + 1)) / peak, b))
        .fold((0.0, 0), |a, x| if x.0 > a.0 { x } else { a })
}

/// The grid for `scene` at nominal `width`, and warnings naming the spectra that bins of that
/// width would have averaged coarsely (relative oscillation above [`TOL`]).
pub fn scene_grid(scene: &Scene, width: f32) -> (BinGrid, Vec<String>) {
    let d = scene.domain;
    let spectra: Vec<(String, &Spectrum, f32)> = scene_spectra(scene)
        .into_iter()
        .map(|(n, s)| {
            let peak = s.max_value(d).abs().max(s.min_value(d).abs());
            (n, s, peak)
        })
        .filter(|(_, _, p)| *p > 0.0 && p.is_finite())
        .collect();
    let mut breaks = vec![scene.observer.range.min, scene.observer.range.max];
    for (_, s, _) in &spectra {
        discontinuities(s, &mut breaks);
    }
    let variation = |a: f32, b: f32| {
        spectra
            .iter()
            .map(|(_, s, p)| oscillation(s, a, b) / p)
            .fold(0.0, f32::max)
    };
    let uniform = BinGrid::new(d, width).len();
    let max_bins = 4 * uniform + 256;
    let grid = BinGrid::adaptive(d, width, &breaks, variation, TOL, max_bins);
    let base = BinGrid::adaptive(d, width, &breaks, |_, _| 0.0, TOL, max_bins);
    let mut warnings = Vec::new();
    for (name, s, peak) in &spectra {
        let (v, b) = worst_bin(s, *peak, &base);
        if v <= TOL {
            continue;
        }
        let (vf, bf) = worst_bin(s, *peak, &grid);
        let fix = if vf <= TOL {
            format!(
                "bins refined there (narrowest {:.3} nm, {} bins in all)",
                grid.min_bin_width(),
                grid.len()
            )
        } else {
            format!(
                "still {:.0} % in the {:.3} nm bin at {:.1} nm after refinement (bin limit \
                 {max_bins}): use a smaller --bin-width",
                100.0 * vf,
                grid.bin_width(bf),
                grid.edge(bf)
            )
        };
        warnings.push(format!(
            "bdpt-allbins: {name} changes by {:.0} % of its peak within the {:.3} nm bin at \
             {:.1} nm, so a bin-averaged product with it can be off by up to {:.1} % of the \
             peaks' product (Grüss: ¼·osc·osc); {fix}",
            100.0 * v,
            base.bin_width(b),
            base.edge(b),
            25.0 * v * v
        ));
    }
    (grid, warnings)
}
