//! `stokes png`: an sRGB PNG of an EXR.

use super::{MAX_EXPOSURE, output_error};
use crate::Error;
use crate::film::write_png;
use crate::io::output::check_output;
use crate::io::text::show_path;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct PngArgs {
    /// The image (OpenEXR, linear sRGB).
    pub input: PathBuf,
    /// The 8-bit sRGB PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Exposure in stops; without it the 99th percentile of the brightest channel maps to white.
    #[arg(long)]
    pub exposure: Option<f32>,
}

/// `stokes png`: an sRGB PNG of an EXR (for example a strategy image or `vertices<k>.exr`).
pub fn png(a: &PngArgs) -> Result<(), Error> {
    use crate::film::output::read_exr;
    use crate::io::output::has_extension;
    if !has_extension(&a.output, "png") {
        return Err(Error::input(format!(
            "-o/--output '{}': the name of the PNG must end in .png",
            show_path(&a.output)
        )));
    }
    if let Some(e) = a.exposure
        && !(e.abs() <= MAX_EXPOSURE)
    {
        return Err(Error::input(format!(
            "--exposure must be a finite number of stops in [-{MAX_EXPOSURE}, {MAX_EXPOSURE}], got {e}"
        )));
    }
    let target = check_output(&a.output).map_err(|e| output_error("-o/--output", &a.output, e))?;
    let (w, h, img) = read_exr(&a.input).map_err(Error::input)?;
    // the figures' exposure: the 99th percentile of the brightest channel to white
    let exposure = a
        .exposure
        .unwrap_or_else(|| crate::experiment::figures::exposure(&img).log2());
    write_png(&target, w, h, &img, exposure).map_err(Error::runtime)?;
    println!("{}: exposure {exposure:+.2} stops", show_path(&target));
    Ok(())
}
