//! The data plots of Mojzík et al. 2018 (Figs. 4–6, 9).

use super::*;

// ---------------------------------------------------------------- Mojzík

/// Mojzík Fig. 4: accumulated absorption (Σ over λo) and re-emission (Σ over λi) of the matrix.
pub(super) fn mojzik_fig4(dir: &Path, s: &Measured, ranking: Value) -> R<Value> {
    let a = on_grid(&sums(&s.m, true), |i| s.m.ex(i));
    let e = on_grid(&sums(&s.m, false), |o| s.m.em(o));
    let (la, le) = (argmax(&a).0, argmax(&e).0);
    let cs = [
        curve("absorption: Σ over emission", a, colour(1)),
        curve("re-emission: Σ over excitation", e, colour(0)),
    ];
    let (stem, title) = (&s.stem, &s.title);
    let t = format!("Mojzík Fig. 4: Stokes shift of {stem} ({title})");
    println!("Mojzík Fig. 4: {stem} ({title}), absorption peak {la} nm, re-emission peak {le} nm");
    let (min, max) = (290.0, 790.0);
    let ax = wl(Domain { min, max }, top_of(&cs), "Σ of matrix entries");
    plot(dir, "mojzik-fig4-stokes-shift.svg", &t, ax, &cs)?;
    Ok(json!({"file": s.stem, "title": s.title,
        "why": "largest sum of off-diagonal entries among the RIT files titled pink, red, orange \
                or cerise (not yellow), leaving out IXCAXORA whose columns re-emit up to 35x \
                the incident light (a measurement artefact, Hua 7.1); the 3M Post-it is not in it",
        "absorption_peak_nm": la, "reemission_peak_nm": le,
        "offdiagonal_sum": r4(s.mass), "peak_fluorescent_albedo": r4(s.peak_albedo),
        "candidates": ranking}))
}

/// Mojzík Fig. 5: the full reradiation matrix as a heat map, values below 0.006 left out.
pub(super) fn mojzik_fig5(dir: &Path, s: &Measured) -> R<()> {
    let (stem, t) = (&s.stem, &s.title);
    let title = format!("Mojzík Fig. 5: reradiation matrix of {stem} ({t}), < {NOISE} not drawn");
    let draw = |r: &Area| heatmap(r, &title, &s.m);
    svg(dir, "mojzik-fig5-matrix.svg", (760, 620), draw)
}

/// Mojzík Fig. 6: re-emission spectra (matrix columns, each normalised to its maximum) for up
/// to six excitation wavelengths where the accumulated absorption is at least half its peak.
pub(super) fn mojzik_fig6(dir: &Path, s: &Measured) -> R<Value> {
    let a = sums(&s.m, true);
    let amax = a.iter().copied().fold(0.0, f64::max);
    let band: Vec<usize> = (0..s.m.n_ex).filter(|&i| a[i] >= 0.5 * amax).collect();
    let k = band.len();
    let cols: Vec<usize> = if k <= 6 {
        band
    } else {
        (0..6).map(|j| band[j * (k - 1) / 5]).collect()
    };
    let column = |j: usize, i: usize| {
        let v: Vec<f64> = (0..s.m.n_em).map(|o| s.m.off(o, i) as f64).collect();
        let max = v.iter().copied().fold(1e-12, f64::max);
        let v: Vec<f64> = v.iter().map(|x| x / max).collect();
        let name = format!("λi = {} nm", s.m.ex(i));
        curve(name, on_grid(&v, |o| s.m.em(o)), colour(j))
    };
    let cs: Vec<Curve> = (0..cols.len()).map(|j| column(j, cols[j])).collect();
    let t = format!("Mojzík Fig. 6: re-emission spectra of {} (columns)", s.stem);
    let ax = [370.0, 790.0, 0.0, 1.1];
    let ax = (ax, ["emission λo (nm)", "re-emission / max"]);
    plot(dir, "mojzik-fig6-reemission.svg", &t, ax, &cs)?;
    Ok(cols.iter().map(|&i| s.m.ex(i)).collect())
}

/// Mojzík eq. 6 below the surface (t ≤ d; the CDF is 1 from d on).
fn eq6(st: f64, ss: f64, d: f64, t: f64) -> f64 {
    if st == 0.0 {
        t * ss / (d * ss + 1.0)
    } else {
        (1.0 - (-t * st).exp()) / (1.0 + (st / ss - 1.0) * (-d * st).exp())
    }
}

/// The ideal CDF at `n` + 1 even steps of [0, d]: collision density ∝ σ̂s·e^(−σ̂t·t) plus the
/// pass-through mass e^(−σ̂t·d), integrated numerically (midpoint rule), not by eq. 6.
fn ideal(st: f64, ss: f64, d: f64, n: usize) -> Vec<f64> {
    let (sub, mut acc, mut cum) = (64, 0.0, vec![0.0]);
    let h = d / (n * sub) as f64;
    for k in 0..n * sub {
        acc += ss * (-(k as f64 + 0.5) * h * st).exp() * h;
        if (k + 1) % sub == 0 {
            cum.push(acc);
        }
    }
    let total = acc + (-d * st).exp();
    cum.iter().map(|c| c / total).collect()
}

/// Sorted distances from the library's free-flight sampler (a pass counts as t = d).
fn flights(mode: Tracking, st: f64, ss: f64, seed: u64) -> Vec<f64> {
    let f = FreeFlight::new(mode, st as f32, ss as f32);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut one = || match f.sample(SURFACE as f32, rng.random::<f32>()) {
        Flight::Collision { t, .. } => t as f64,
        Flight::Pass { .. } => SURFACE,
    };
    let mut t: Vec<f64> = (0..FLIGHTS).map(|_| one()).collect();
    t.sort_by(f64::total_cmp);
    t
}

/// Kolmogorov–Smirnov distance of sorted samples from a CDF `f` below d that jumps to 1 at d.
fn ks(sorted: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    let n = sorted.len() as f64;
    let below = sorted.partition_point(|&t| t < SURFACE);
    let gap = |j: usize, t: f64| ((j as f64 + 1.0) / n - f(t)).max(f(t) - j as f64 / n);
    let k = sorted[..below].iter().enumerate().map(|(j, &t)| gap(j, t));
    let pass = (below as f64 / n - f(SURFACE)).abs();
    k.fold(pass, f64::max)
}

/// A CDF on [0, 12]: `below` at even steps of [0, d], then the jump to 1 at d.
fn with_jump(below: Vec<f64>) -> Pts {
    let n = (below.len() - 1) as f64;
    let mut p = on_grid(&below, |k| (k as f64 * SURFACE / n) as f32);
    p.extend([(SURFACE, 1.0), (12.0, 1.0)]);
    p
}

/// Mojzík Fig. 9: CDFs of the distance sampled towards a surface at d = 10 (exponential
/// tracking, eq. 6, the ideal distribution) and of the library's aware-tracking samples.
pub(super) fn mojzik_fig9(dir: &Path) -> R<Value> {
    let n = 300;
    let ts: Vec<f64> = (0..=n).map(|k| k as f64 * SURFACE / n as f64).collect();
    let grid = |f: &dyn Fn(f64) -> f64| with_jump(ts.iter().map(|&t| f(t)).collect());
    let crit = 1.358 / (FLIGHTS as f64).sqrt();
    let (mut rows, mut panels) = (Vec::new(), Vec::new());
    let pairs = [(0.5, 0.5), (0.1, 0.5), (0.02, 0.5), (0.0, 0.5)];
    for (j, (st, ss)) in pairs.into_iter().enumerate() {
        let aware = flights(Tracking::Aware, st, ss, 42 + j as u64);
        let expo = flights(Tracking::Exponential, st, ss, 4242 + j as u64);
        let f6 = |t: f64| eq6(st, ss, SURFACE, t);
        let fe = |t: f64| 1.0 - (-st * t).exp();
        let (k6, ke) = (ks(&aware, f6), ks(&expo, fe));
        let id = ideal(st, ss, SURFACE, n);
        let id_err = id.iter().zip(&ts).map(|(v, &t)| (v - f6(t)).abs());
        let below = |t: f64| aware.partition_point(|&x| x < t) as f64 / FLIGHTS as f64;
        rows.push(json!({"sigma_t": st, "sigma_s": ss, "samples": FLIGHTS,
            "ks_aware_vs_eq6": r4(k6), "ks_exponential_vs_formula": r4(ke),
            "ks_95pct_critical": r4(crit), "collision_prob_eq6": r4(f6(SURFACE)),
            "collision_prob_library": r4(below(SURFACE)),
            "ideal_vs_eq6_max_diff": id_err.fold(0.0, f64::max)}));
        let cs = vec![
            curve("exponential 1 − e^(−σ̂t·t)", grid(&fe), colour(0)),
            curve("aware (eq. 6)", grid(&f6), colour(1)),
            curve("library aware samples", grid(&below), colour(2)).look(Look::Line(1)),
            curve("ideal ∝ σ̂s·e^(−σ̂t·t) + pass", with_jump(id), GREY).look(Look::Dashed),
        ];
        let t = format!("σ̂t = {st}, σ̂s = {ss}: KS(library, eq. 6) = {k6:.4}");
        println!("Mojzík Fig. 9: {t} (95 % bound {crit:.4})");
        panels.push((t, cs));
    }
    svg(dir, "mojzik-fig9-distance-cdf.svg", (1100, 800), |r| {
        let t = "Mojzík Fig. 9: distance CDFs P(t), surface at d = 10";
        let r = titled(r, t)?;
        let ax = ([0.0, 12.0, 0.0, 1.05], ["distance t", "P(t)"]);
        for (j, (area, (title, cs))) in r.split_evenly((2, 2)).iter().zip(&panels).enumerate() {
            let legend = (j == 0).then_some(SeriesLabelPosition::LowerRight);
            lines(area, title, ax, cs, legend)?;
        }
        Ok(())
    })?;
    Ok(Value::Array(rows))
}
