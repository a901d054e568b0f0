//! `stokes diff`: the signed luminance difference of two EXRs as a figure, with their SNR.

use super::output_error;
use crate::Error;
use crate::io::output::check_output;
use crate::io::text::show_path;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct DiffArgs {
    /// The first image (OpenEXR, linear sRGB).
    pub a: PathBuf,
    /// The second image, of the same size.
    pub b: PathBuf,
    /// The figure: a PNG (and an SVG beside it) with both images and Y(a) − Y(b).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The figure's title (default: the two file names).
    #[arg(long)]
    pub title: Option<String>,
}

/// `stokes diff`: the signed luminance difference of two EXRs as a figure (red/green diverging,
/// symmetric scale at the 99th percentile of |difference|; Mojzík 2018 Fig. 11d/f).
pub fn diff(a: &DiffArgs) -> Result<(), Error> {
    use crate::film::output::read_exr;
    use crate::io::output::has_extension;
    if !has_extension(&a.output, "png") {
        return Err(Error::input(format!(
            "-o/--output '{}': the figure is a PNG, so its name must end in .png",
            show_path(&a.output)
        )));
    }
    let target = check_output(&a.output).map_err(|e| output_error("-o/--output", &a.output, e))?;
    let (wa, ha, ia) = read_exr(&a.a).map_err(Error::input)?;
    let (wb, hb, ib) = read_exr(&a.b).map_err(Error::input)?;
    if (wa, ha) != (wb, hb) {
        return Err(Error::input(format!(
            "'{}' is {wa}×{ha} and '{}' is {wb}×{hb}: a difference needs images of one size",
            show_path(&a.a),
            show_path(&a.b)
        )));
    }
    let name = |p: &Path| {
        p.file_stem()
            .map_or_else(|| show_path(p), |s| s.to_string_lossy().into_owned())
    };
    let (na, nb) = (name(&a.a), name(&a.b));
    let title = a.title.clone().unwrap_or_else(|| format!("{na} − {nb}"));
    let dir = target.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or(Path::new("."));
    let stem = target
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (_, m) = crate::experiment::figures::difference_of_images(
        (&na, &ia),
        (&nb, &ib),
        (wa, ha),
        &title,
        (dir, &stem),
    )?;
    use crate::experiment::figures::luminance;
    let y = |img: &[glam::Vec3]| {
        img.iter().map(|c| luminance(*c)).sum::<f64>() / img.len().max(1) as f64
    };
    println!(
        "mean Y: {na} {:.6}, {nb} {:.6}, difference {:+.6}; scale ±{m:.4} (99th percentile of |ΔY|)",
        y(&ia),
        y(&ib),
        y(&ia) - y(&ib)
    );
    // SNR of a against b as the experiments measure it, and of its luminance alone (spatial
    // noise without colour noise)
    let rgb = crate::experiment::metrics::compare(&ia, &ib, None).snr_db;
    let (sig, noise) = ia.iter().zip(&ib).fold((0.0, 0.0), |(s, n), (p, q)| {
        let (lp, lq) = (luminance(*p), luminance(*q));
        (s + lq * lq, n + (lp - lq).powi(2))
    });
    let y_snr = crate::experiment::metrics::snr_db(sig, noise);
    println!("SNR of {na} against {nb}: {rgb:.2} dB (linear sRGB), {y_snr:.2} dB (luminance Y)");
    Ok(())
}
