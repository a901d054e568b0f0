//! `stokes gmm robustness`: the seed spread of EM fits with one start and with restarts, and
//! BIC's number of Gaussians against where ΔE00 stops improving (`gmm::robust`).

use super::gmm::parse_restarts;
use crate::Error;
use crate::gmm::robust::{DEFAULT_OUT, Settings, robustness};
use crate::material::mixture::fit::DEFAULT_RESTARTS;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct GmmRobustnessArgs {
    /// A folder of BFC files (e.g. data/bispectral/rit).
    pub dir: PathBuf,
    /// Numbers of Gaussians of the seed spread, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
    pub components: Vec<usize>,
    /// Seeds 0..N of the spread.
    #[arg(long, default_value_t = 10)]
    pub seeds: u64,
    /// Starts of the robust fits (the spread is also measured with one start).
    #[arg(long, value_parser = parse_restarts, default_value_t = DEFAULT_RESTARTS)]
    pub restarts: usize,
    /// BIC chooses among 1..=MAX Gaussians.
    #[arg(long, default_value_t = 8)]
    pub max_components: usize,
    /// A folder of illuminant tables instead of the CIE illuminants built into stokes.
    #[arg(long)]
    pub illuminants: Option<PathBuf>,
    /// Output folder: spread.csv, bic.csv, summary.json, summary.md.
    #[arg(short, long, default_value = DEFAULT_OUT)]
    pub output: PathBuf,
}

pub fn gmm_robustness(a: &GmmRobustnessArgs) -> Result<(), Error> {
    let s = Settings {
        components: a.components.clone(),
        seeds: a.seeds,
        restarts: a.restarts,
        max_components: a.max_components,
    };
    let r = robustness(&a.dir, &s, &a.output, a.illuminants.as_deref())?;
    println!(
        "{} matrices, {} illuminants, {:.1} s",
        r.materials, r.illuminants, r.seconds
    );
    print!("{}", crate::gmm::robust::markdown(&r));
    for f in &r.outputs {
        println!("{}", f.display());
    }
    Ok(())
}
