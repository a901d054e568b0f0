//! `stokes merge`: sample-range shards of one render merged into one EXR, exactly.

use super::output_error;
use crate::Error;
use crate::film::write_png;
use crate::io::output::{canonical_output, check_output};
use crate::io::text::show_path;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Shard EXRs written by `stokes render --samples FROM..TO` (or by an experiment's jobs).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// The merged EXR: a shard of the union of the ranges.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write an sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
}

/// `stokes merge`: add the exact sums of shards of one render (same scene, seed, integrator,
/// options and size; ranges neither overlapping nor leaving gaps) into one EXR.
pub fn merge(a: &MergeArgs) -> Result<(), Error> {
    use crate::io::output::has_extension;
    if !has_extension(&a.output, "exr") {
        return Err(Error::input(format!(
            "-o/--output '{}': the merged image is written as OpenEXR, so its name must end in .exr",
            a.output.display()
        )));
    }
    if let Some(p) = &a.png
        && !has_extension(p, "png")
    {
        return Err(Error::input(format!(
            "--png '{}': the name of the PNG preview must end in .png",
            p.display()
        )));
    }
    let mut outs = vec![("-o/--output", check_output(&a.output), &a.output)];
    if let Some(p) = &a.png {
        outs.push(("--png", check_output(p), p));
    }
    let mut targets: Vec<PathBuf> = Vec::new();
    for (opt, checked, given) in outs {
        let t = checked.map_err(|e| output_error(opt, given, e))?;
        let c = canonical_output(&t);
        if a.shards.iter().any(|s| canonical_output(s) == c) {
            return Err(Error::input(format!(
                "{opt} '{}' is also an input shard: it would be replaced; give the merge its own path",
                show_path(given)
            )));
        }
        if targets.iter().any(|q| canonical_output(q) == c) {
            return Err(Error::input(format!(
                "{opt} '{}' is the same file as -o/--output: give each output its own path",
                show_path(given)
            )));
        }
        targets.push(t);
    }
    let shards = a
        .shards
        .iter()
        .map(|p| crate::film::shard::read_shard(p).map_err(Error::input))
        .collect::<Result<Vec<_>, _>>()?;
    let n = shards.len();
    let merged = crate::film::shard::merge(shards).map_err(Error::input)?;
    merged.write(&targets[0]).map_err(Error::runtime)?;
    if let Some(p) = targets.get(1) {
        let f = merged.film();
        write_png(p, f.width, f.height, &f.rgb(), 0.0).map_err(Error::runtime)?;
    }
    eprintln!(
        "merged {n} shards: samples {}..{} ({} spp) of {} with {}, seed {} -> {}",
        merged.info.from,
        merged.info.to,
        merged.info.to - merged.info.from,
        crate::io::text::escape_control(&merged.info.scene, false),
        crate::io::text::escape_control(&merged.info.integrator, false),
        merged.info.seed,
        show_path(&a.output)
    );
    Ok(())
}
