//! The data plots of Jung 2017 (Figs. 4.8, 4.9, 5.1, 7.2, 7.3, 7.9, 7.11).

use super::*;

// ---------------------------------------------------------------- Jung

/// Jung Fig. 4.8 (whole table) and Fig. 4.9 (700–780 nm): the library's CIE 1931 2° table.
pub(super) fn jung_cmf(dir: &Path, name: &str, d: Domain, fig: &str) -> R<()> {
    let cs = [
        curve("x̄", sampled(|l| cmf(l).x as f64, d, 1.0), colour(0)),
        curve("ȳ", sampled(|l| cmf(l).y as f64, d, 1.0), colour(2)),
        curve("z̄", sampled(|l| cmf(l).z as f64, d, 1.0), colour(1)),
    ];
    let (a, b) = (d.min, d.max);
    let t = format!("{fig}: CIE 1931 colour-matching functions ({a}–{b} nm)");
    plot(dir, name, &t, wl(d, top_of(&cs), "value"), &cs)
}

/// The material of the shape named `shape`.
fn material<'s>(scene: &'s Scene, shape: &str) -> R<&'s Material> {
    let s = scene.shapes.iter().find(|s| s.name == shape);
    let m = s.and_then(|s| scene.material(s.material));
    m.ok_or_else(|| {
        format!(
            "{}: no shape '{shape}' with a material",
            scene.file.display()
        )
    })
}

/// The fluorescent-diffuse material of the shape named `shape`.
pub(super) fn fluorescent<'s>(scene: &'s Scene, shape: &str) -> R<&'s FluorescentDiffuse> {
    match material(scene, shape)? {
        Material::Fluorescent(f) => Ok(f),
        _ => Err(format!(
            "{}: '{shape}' is not fluorescent",
            scene.file.display()
        )),
    }
}

/// The scene's first light's emitted spectrum (scale included).
fn light(scene: &Scene) -> R<&Spectrum> {
    let l = scene.lights.first().map(|l| &l.spectrum);
    l.ok_or_else(|| format!("{}: no light", scene.file.display()))
}

/// The factor that scales a spectrum to peak 1 on `d`.
fn to_peak(s: &Spectrum, d: Domain) -> f64 {
    1.0 / s.max_value(d).max(1e-30) as f64
}

/// Jung Fig. 7.2: absorption and emission of the fluorescent walls, the light's emission and
/// the back wall's reflectance, as loaded from scenes/fluorescent-walls.json.
pub(super) fn jung_fig7_2(dir: &Path, scene: &Scene) -> R<()> {
    let d = scene.domain;
    let (mut top, mut bottom) = (Vec::new(), Vec::new());
    let walls = ["floor", "left", "ceiling", "right"];
    for (j, wall) in walls.into_iter().enumerate() {
        let f = fluorescent(scene, wall)?;
        let (a, e) = (sp(&f.a, 1.0, d), sp(&f.e, 1.0, d));
        top.push(curve(format!("{wall}: absorption a"), a, colour(j)));
        bottom.push(curve(format!("{wall}: emission e"), e, colour(j)));
    }
    let (e, k) = (light(scene)?, to_peak(light(scene)?, d));
    top.push(curve(format!("light emission ×{k:.3}"), sp(e, k, d), BLACK).look(Look::Dashed));
    let back = material(scene, "back")?;
    let r = sampled(|l| back.diagonal(l) as f64, d, 1.0);
    top.push(curve("back wall reflectance", r, GREY).look(Look::Dashed));
    svg(dir, "jung-fig7-2-walls-spectra.svg", (1000, 760), |r| {
        let t = "Jung Fig. 7.2: spectra of scenes/fluorescent-walls.json";
        let (a, b) = titled(r, t)?.split_vertically(370);
        let t = "absorption (peak 1), light emission (scaled to peak 1), back wall reflectance";
        lines(&a, t, wl(d, 1.45, "value"), &top, UR)?;
        let ax = wl(d, top_of(&bottom), "emission (1/nm)");
        lines(&b, "emission of the walls (unit area)", ax, &bottom, UR)
    })
}

/// Jung Fig. 7.9a/c: the green-spheres fluorescent material (r, a, e) and the light's spectrum.
pub(super) fn jung_fig7_9(dir: &Path, scene: &Scene, f: &FluorescentDiffuse) -> R<()> {
    let (d, light) = (scene.domain, light(scene)?);
    let (k, kl) = (to_peak(&f.e, d), to_peak(light, d));
    let (r, e) = (sp(&f.r, 1.0, d), sp(&f.e, k, d));
    let cs = [
        curve("reflectance r (ColorChecker 11)", r, colour(2)),
        curve("absorption a", sp(&f.a, 1.0, d), colour(1)),
        curve(format!("emission e ×{k:.1} (1/nm)"), e, colour(0)),
        curve(format!("light (D65) ×{kl:.3}"), sp(light, kl, d), BLACK).look(Look::Dashed),
    ];
    let t = "Jung Fig. 7.9a/c: fluorescent material and light of scenes/green-spheres.json";
    plot(dir, "jung-fig7-9-spectra.svg", t, wl(d, 1.2, "value"), &cs)
}

/// Exitant radiance at λo of a BBRRDF lit by `light`: diagonal·E(λo) + ∫ ρ(λi → λo)·E(λi) dλi
/// (midpoint rule, 0.5 nm).
fn exitant(m: &impl Bbrrdf, light: &Spectrum, d: Domain, lo: f32) -> f64 {
    let n = (d.width() * 2.0).round() as usize;
    let li = |k: usize| d.min + (k as f32 + 0.5) * d.width() / n as f32;
    let term = |k: usize| (m.kernel(li(k), lo) * light.eval(li(k))) as f64;
    let shifted: f64 = (0..n).map(term).sum();
    m.diagonal(lo) as f64 * light.eval(lo) as f64 + shifted * d.width() as f64 / n as f64
}

/// Jung Fig. 7.11b: exitant/incident ratio of the fluorescent BBRRDF under a constant light,
/// through the library's kernel, checked against (1 − c·a)·r + Φ·c·e·∫a.
pub(super) fn jung_fig7_11b(dir: &Path, f: &FluorescentDiffuse, d: Domain) -> R<Value> {
    let ratio = sampled(|l| exitant(f, &Spectrum::Constant(1.0), d, l), d, 0.5);
    let int_a = f.a.integral(d.min, d.max);
    let (c, phi) = (f.c as f64, f.phi as f64);
    let closed = |l: f32| {
        let (r, a, e) = (f.r.eval(l) as f64, f.a.eval(l) as f64, f.e.eval(l) as f64);
        (1.0 - c * a) * r + phi * c * e * int_a
    };
    let err = ratio.iter().map(|&(l, v)| (v - closed(l as f32)).abs());
    let err = err.fold(0.0, f64::max);
    let (lmax, vmax) = argmax(&ratio);
    let mut above: Vec<[f64; 2]> = Vec::new();
    for w in ratio.windows(2).filter(|w| w[1].1 > 1.0) {
        match above.last_mut() {
            Some(r) if r[1] == w[0].0 => r[1] = w[1].0,
            _ => above.push([w[1].0, w[1].0]),
        }
    }
    let one = vec![(d.min as f64, 1.0), (d.max as f64, 1.0)];
    let cs = [
        curve("exitant / incident, fluorescent", ratio, colour(0)),
        curve("plain reflectance r", sp(&f.r, 1.0, d), colour(2)),
        curve("", one, BLACK).look(Look::Dashed),
    ];
    let t = format!("max {vmax:.3} at {lmax} nm, above 1 on {above:?} nm");
    println!("Jung Fig. 7.11b: exitant/incident {t}");
    let t = format!("Jung Fig. 7.11b: reflectivity under constant light ({t})");
    let ax = wl(d, top_of(&cs), "exitant / incident");
    plot(dir, "jung-fig7-11b-reflectivity.svg", &t, ax, &cs)?;
    let v = json!({"max_ratio": r4(vmax), "at_nm": lmax, "ranges_above_1_nm": above,
        "integral_a_nm": r4(int_a), "kernel_vs_closed_form_max_diff": err,
        "thesis": "around 570 nm for measured fluorescein; ours is designed Gaussians"});
    Ok(v)
}

/// (x, y) chromaticity of XYZ.
fn xy(c: glam::Vec3) -> (f64, f64) {
    let s = (c.x + c.y + c.z) as f64;
    (c.x as f64 / s, c.y as f64 / s)
}

/// Jung Fig. 7.11a: chromaticities of the light leaving the fluorescent and the plain sphere
/// under the scene's light (computed spectrally, through the BBRRDFs) in the CIE xy diagram.
pub(super) fn jung_fig7_11a(dir: &Path, scene: &Scene) -> R<Value> {
    let (d, e, obs) = (scene.domain, light(scene)?, &scene.observer);
    let range = format!("spectral locus {}–{} nm", obs.range.min, obs.range.max);
    let mut locus: Pts = sampled(|_| 0.0, obs.range, 1.0);
    locus.iter_mut().for_each(|p| *p = xy(cmf(p.0 as f32)));
    locus.push(locus[0]);
    let srgb = vec![(0.64, 0.33), (0.30, 0.60), (0.15, 0.06), (0.64, 0.33)];
    let locus = curve(range, locus, BLACK).look(Look::Line(1));
    let mut cs = vec![locus, curve("sRGB gamut", srgb, GREY)];
    let mut out = serde_json::Map::new();
    let names = ["fluorescent_sphere", "plain_sphere", "light"];
    for (j, name) in names.into_iter().enumerate() {
        let xyz = if name == "light" {
            obs.spectrum_to_xyz(e)
        } else {
            let m = material(scene, name)?;
            obs.function_to_xyz(|l| exitant(m, e, d, l))
        };
        let (rgb, p) = (xyz_to_linear_srgb(xyz / xyz.y), xy(xyz));
        let neg = rgb.min_element() < 0.0;
        let rgb = rgb.to_array().map(|c| r4(c as f64));
        let v = json!({"xy": [r4(p.0), r4(p.1)], "linear_srgb_y1": rgb, "negative_channel": neg});
        println!("Jung Fig. 7.11a: {name}: linear sRGB (Y = 1) {rgb:?}, negative: {neg}");
        out.insert(name.into(), v);
        let dot = curve(name.replace('_', " "), vec![p], colour([2, 4, 7][j]));
        cs.push(dot.look(Look::Dots));
    }
    let t = "Jung Fig. 7.11a: chromaticity of the green spheres under the scene's light";
    let ax = ([0.0, 0.8, 0.0, 0.9], ["x", "y"]);
    let draw = |r: &Area| lines(r, t, ax, &cs, UR);
    svg(dir, "jung-fig7-11a-chromaticity.svg", (720, 720), draw)?;
    Ok(Value::Object(out))
}

/// Jung Fig. 5.1: a strongly fluorescent and a paper-like measured matrix as heat maps
/// (Hullin's red paint and paper are not available).
pub(super) fn jung_fig5_1(dir: &Path, fl: &Measured, paper: &Measured) -> R<Value> {
    let name = |s: &Measured, what: &str| format!("{what}: {} ({})", s.stem, s.title);
    svg(dir, "jung-fig5-1-matrices.svg", (1400, 600), |r| {
        let t = "Jung Fig. 5.1: reradiation matrices (log colour scale, < 0.006 not drawn)";
        let (a, b) = titled(r, t)?.split_horizontally(700);
        heatmap(&a, &name(fl, "fluorescent"), &fl.m)?;
        heatmap(&b, &name(paper, "paper"), &paper.m)
    })?;
    let (p, t, m) = (&paper.stem, &paper.title, r4(paper.mass));
    println!("Jung Fig. 5.1: {} and {p} ({t})", fl.stem);
    let why = "the RIT file titled white ... paper with the largest sum of off-diagonal entries";
    let v = json!({"fluorescent": fl.stem, "paper": p, "paper_title": t, "paper_why": why,
        "paper_offdiagonal_sum": m});
    Ok(v)
}

// ---------------------------------------------------------------- Jung Fig. 7.3

/// The luminance along one line through each wall of a walls render (Jung Fig. 7.3): a column
/// through the middle of the left and right walls, a row through the ceiling and the floor, and
/// the floor's row reversed (dashed; the thesis's symmetry check). Pixels are assigned to walls
/// by a primary ray through their centres, and the two at each end of a line (which mix the wall
/// with its neighbour) are left out. Returns each wall's halves' means.
pub(super) fn jung_fig7_3(dir: &Path, scene: &Scene, exr: &Path) -> R<Value> {
    let (w, h, rgb) = stokes::film::output::read_exr(exr)?;
    // a render at another size (`reproduce.sh --quick` renders 64×48): the scene at that size
    let resized;
    let scene = if (w, h) == (scene.camera.width, scene.camera.height) {
        scene
    } else {
        let sets = [
            ("camera.width".to_string(), json!(w)),
            ("camera.height".to_string(), json!(h)),
        ];
        let text = input::read_text(&scene.file, input::SCENE)?;
        let text = stokes::experiment::overrides::apply(
            &text,
            &scene.file,
            &sets,
            stokes::experiment::overrides::Missing::Insert,
        )?;
        resized = Scene::from_str(&scene.file, &text).map_err(|e| e.to_string())?;
        &resized
    };
    let shape_at = |x: u32, y: u32| {
        let ray = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
        let hit = scene.first_visible(&ray)?;
        let p = scene.prims[hit.prim as usize];
        Some(scene.shapes[p.shape as usize].name.as_str())
    };
    let ids: Vec<Option<&str>> = (0..w * h).map(|i| shape_at(i % w, i / w)).collect();
    let lum = |i: u32| stokes::experiment::figures::luminance(rgb[i as usize]);
    let mut panels = Vec::new();
    let mut summary = serde_json::Map::new();
    for (wall, vertical) in [
        ("left", true),
        ("right", true),
        ("ceiling", false),
        ("floor", false),
    ] {
        let pix: Vec<u32> = (0..w * h)
            .filter(|&i| ids[i as usize] == Some(wall))
            .collect();
        if pix.is_empty() {
            return Err(format!(
                "no pixel of '{}' sees the shape '{wall}'",
                exr.display()
            ));
        }
        // the line through the wall's centre of mass
        let (cx, cy) = pix.iter().fold((0.0, 0.0), |(a, b), &i| {
            (a + (i % w) as f64, b + (i / w) as f64)
        });
        let (cx, cy) = (
            (cx / pix.len() as f64) as u32,
            (cy / pix.len() as f64) as u32,
        );
        let line: Pts = if vertical {
            (0..h)
                .filter(|&y| ids[(y * w + cx) as usize] == Some(wall))
                .map(|y| (y as f64, lum(y * w + cx)))
                .collect()
        } else {
            (0..w)
                .filter(|&x| ids[(cy * w + x) as usize] == Some(wall))
                .map(|x| (x as f64, lum(cy * w + x)))
                .collect()
        };
        // the two pixels at each end mix the wall with its neighbour (box filter)
        let line: Pts = if line.len() > 4 {
            line[2..line.len() - 2].to_vec()
        } else {
            line
        };
        let half = line.len() / 2;
        let mean = |p: &[(f64, f64)]| p.iter().map(|q| q.1).sum::<f64>() / p.len().max(1) as f64;
        let (first, second) = (mean(&line[..half]), mean(&line[line.len() - half..]));
        let (a, b) = if vertical {
            ("top_half", "bottom_half")
        } else {
            ("left_half", "right_half")
        };
        let sig = |x: f64| format!("{x:.4e}").parse::<f64>().unwrap_or(x);
        let mut v = json!({ a: sig(first), b: sig(second), "line": if vertical { format!("column {cx}") } else { format!("row {cy}") } });
        if wall == "floor" {
            let n = line.len();
            let asym = (0..n)
                .map(|i| (line[i].1 - line[n - 1 - i].1).abs())
                .sum::<f64>()
                / (n as f64 * mean(&line));
            v["mean_abs_difference_to_reversed_over_mean"] = json!(r4(asym));
        }
        summary.insert(wall.to_string(), v);
        panels.push((wall, vertical, line, if vertical { cx } else { cy }));
    }
    svg(dir, "jung-fig7-3-scanlines.svg", (1000, 760), |root| {
        let root = titled(
            root,
            "Jung Fig. 7.3: luminance along one line through each wall (linear Y)",
        )?;
        for (area, (wall, vertical, line, at)) in root.split_evenly((2, 2)).iter().zip(&panels) {
            let x1 = if *vertical { h } else { w } as f64;
            let y1 = line.iter().map(|p| p.1).fold(0.0, f64::max) * 1.1;
            let xd = if *vertical {
                "image row (top = 0)"
            } else {
                "image column"
            };
            let title = format!(
                "{wall} wall, {} {at}",
                if *vertical { "column" } else { "row" }
            );
            let mut cs = vec![curve(String::new(), line.clone(), colour(1))];
            if *wall == "floor" {
                let n = line.len();
                let rev: Pts = (0..n).map(|i| (line[i].0, line[n - 1 - i].1)).collect();
                cs[0].0 = "row".into();
                cs.push(curve("row reversed", rev, RGBColor(0, 170, 200)).look(Look::Dashed));
            }
            let legend = if *wall == "floor" { UR } else { None };
            lines(
                area,
                &title,
                ([0.0, x1, 0.0, y1.max(1e-9)], [xd, "luminance Y"]),
                &cs,
                legend,
            )?;
        }
        Ok(())
    })?;
    Ok(Value::Object(summary))
}
