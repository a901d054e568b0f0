use super::*;
use crate::ErrorKind;
use crate::material::mixture::FitMethod;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stokes-gmm-figs-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A folder with three RIT matrices.
fn three_files(name: &str) -> PathBuf {
    let d = tmp(name);
    for f in ["HERPICHA.BFC", "GOLFYE.BFC", "IXCSHPIN.BFC"] {
        std::fs::copy(root().join("data/bispectral/rit").join(f), d.join(f)).unwrap();
    }
    d
}

fn run<'a>(dir: &'a Path, out: &'a Path) -> Run<'a> {
    Run {
        dir,
        components: &[2, 4],
        method: FitMethod::Em,
        seed: 0,
        out,
        illuminants_dir: None,
        restarts: 1,
    }
}

fn herpicha() -> BfcMatrix {
    let text = std::fs::read_to_string(root().join("data/bispectral/rit/HERPICHA.BFC")).unwrap();
    BfcMatrix::parse(&text).unwrap()
}

/// Every figure is written as a PNG that decodes to a drawn image of the figure's size and an
/// SVG that closes; the heat maps and bands are embedded PNGs.
#[test]
fn every_figure_is_written_as_png_and_svg() {
    let dir = three_files("all");
    let out = dir.join("figures");
    let opt = Options {
        run: run(&dir, &out),
        material: "HERPICH",
        excitation: 440.0,
        worst: 2,
    };
    let d = figures(&opt).unwrap();
    assert_eq!(d.material, "HERPICHA");
    assert_eq!(d.components, 4);
    assert_eq!(d.worst_materials.len(), 2);
    assert_eq!(d.worst_illuminants.len(), 10);
    assert!(d.worst_illuminants[0].1 >= d.worst_illuminants[9].1);
    assert_eq!(d.outputs.len(), 10);
    for stem in [
        "fig4-conditional",
        "fig5-bands",
        "fig6-matrices",
        "fig7a-mono-mean",
        "fig8a-worst-illuminants",
    ] {
        let png = out.join(format!("{stem}.png"));
        let img = image::open(&png).unwrap().to_rgb8();
        let (w, h) = img.dimensions();
        assert!(w >= 700 && h >= 380, "{stem}: {w} × {h}");
        let drawn = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(
            drawn > (w * h / 50) as usize,
            "{stem}: {drawn} drawn pixels"
        );
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{stem}"
        );
        assert!(
            svg.contains(&format!("width=\"{w}\" height=\"{h}\"")),
            "{stem}"
        );
        let images = svg.matches("<image ").count();
        let want = match stem {
            "fig5-bands" => 2 * 3 + 1,
            "fig6-matrices" => 2 * 3,
            _ => 0,
        };
        assert_eq!(images, want, "{stem}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Fig. 4's densities of λo given λi integrate to 1 over λo: the matrix's column exactly, the
/// truncated conditional mixtures to the accuracy of the trapezoid rule.
#[test]
fn fig4_densities_integrate_to_one() {
    let m = herpicha();
    let dir = tmp("fig4");
    for l in [440.0, 350.0, 600.0] {
        let c = fig4::curves(&m, l, &run(&dir, &dir)).unwrap();
        let matrix: f64 = c.matrix.iter().map(|(a, b, p)| (b - a) * p).sum();
        assert!((matrix - 1.0).abs() < 1e-9, "{l}: {matrix}");
        assert!(c.matrix.iter().all(|&(a, _, p)| a > l as f64 && p >= 0.0));
        assert_eq!(c.mixtures.len(), 2);
        for (k, p) in &c.mixtures {
            let area: f64 = p
                .windows(2)
                .map(|w| 0.5 * (w[1].0 - w[0].0) * (w[0].1 + w[1].1))
                .sum();
            assert!((area - 1.0).abs() < 2e-3, "{l} nm, K = {k}: {area}");
            assert!(p.iter().all(|&(x, _)| x > l as f64));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A bad material or excitation wavelength is an input error naming the flag, found before
/// anything is fitted or written.
#[test]
fn bad_fig4_options_name_the_flag() {
    let dir = three_files("bad");
    let out = dir.join("figures");
    let check = |material: &str, excitation: f32, flag: &str, want: &str| {
        let opt = Options {
            run: run(&dir, &out),
            material,
            excitation,
            worst: 2,
        };
        let e = figures(&opt).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Input, "{}", e.message);
        assert!(
            e.message.contains(flag) && e.message.contains(want),
            "{material} {excitation}: {}",
            e.message
        );
        assert!(!out.exists(), "nothing written");
    };
    check("NOPE", 440.0, "--material 'NOPE'", "no BFC file");
    check("", 440.0, "--material ''", "no BFC file");
    check(
        "HERPIC",
        900.0,
        "--excitation 900",
        "outside the excitation range",
    );
    check("HERPICHA", 780.0, "--excitation 780", "does not fluoresce");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn names_and_wavelengths_are_checked() {
    let m = herpicha();
    for (l, want) in [
        (
            900.0,
            "outside the excitation range of HERPICHA, 300–780 nm",
        ),
        (299.0, "outside"),
        (f32::NAN, "outside"),
        (780.0, "does not fluoresce"),
    ] {
        let e = fig4::check_excitation(&m, "HERPICHA", l).unwrap_err();
        assert!(
            e.message.starts_with(&format!("--excitation {l}:")) && e.message.contains(want),
            "{l}: {}",
            e.message
        );
    }
    assert!(fig4::check_excitation(&m, "HERPICHA", 440.0).is_ok());
    let dir = three_files("names");
    let ms = crate::gmm::inputs::load_measurements(&dir).unwrap();
    assert_eq!(find_material(&ms, "herpicha").unwrap().name, "HERPICHA");
    assert_eq!(find_material(&ms, "IXC").unwrap().name, "IXCSHPIN");
    let two = dir.join("HERPIGRE.BFC");
    std::fs::copy(root().join("data/bispectral/rit/HERPIGRE.BFC"), &two).unwrap();
    let ms = crate::gmm::inputs::load_measurements(&dir).unwrap();
    let e = find_material(&ms, "HERP").unwrap_err();
    assert!(
        e.message.contains("--material 'HERP'") && e.message.contains("HERPICHA, HERPIGRE"),
        "{}",
        e.message
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Fig. 7a's curves are the per-wavelength means over the materials.
#[test]
fn fig7a_curves_are_the_means_per_wavelength() {
    use crate::gmm::colour::{Comparison, LightKind};
    use crate::gmm::summary::VsRaw;
    let row = |material: &str, k: usize, nm: u32, de00: f64| Row {
        material: material.into(),
        components: k,
        c: Comparison {
            light: format!("mono-{nm}"),
            kind: LightKind::Mono,
            lab_measured: [0.0; 3],
            lab_fitted: [0.0; 3],
            de00,
        },
        raw: VsRaw {
            lab_raw: [0.0; 3],
            de00_fit: 0.0,
            de00_cleaning: 0.0,
        },
    };
    let rows = vec![
        row("A", 2, 310, 1.0),
        row("B", 2, 310, 3.0),
        row("A", 2, 300, 4.0),
        row("B", 2, 300, 6.0),
        row("A", 4, 300, 0.5),
        row("B", 4, 300, 1.5),
    ];
    let c = fig7a::curves(&rows, &[2, 4]);
    assert_eq!(c[0], (2, vec![(300.0, 5.0), (310.0, 2.0)]));
    assert_eq!(c[1], (4, vec![(300.0, 1.0)]));
}

#[test]
fn fig8a_labels_are_short() {
    assert_eq!(
        fig8a::short_name("ISO_7589_Sensitometric_Studio_Tungsten"),
        "ISO Sens. St. Tungsten"
    );
    assert_eq!(fig8a::short_name("LED-B5"), "LED-B5");
    assert_eq!(main_components(&[2, 4, 8]), 4);
    assert_eq!(main_components(&[2, 8, 16]), 8);
}
