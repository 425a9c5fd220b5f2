//! `splatphys inspect FILE`: what a 3DGS file holds (count, SH degree, bounds, scales, opacity,
//! extra properties, a guess of the up axis, and the ground that `up = "auto"` would level).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

/// Arguments of `splatphys inspect`.
#[derive(Args, Debug)]
#[command(after_help = "Example:\n  splatphys inspect ../shared/data/v3dg_donut.ply")]
pub struct InspectArgs {
    /// A 3DGS file: INRIA PLY, SuperSplat compressed PLY, antimatter15 .splat, SPZ, glTF/GLB
    /// (KHR_gaussian_splatting), a SOG folder, meta.json or .sog bundle, or a streamed SOG.
    pub file: PathBuf,
}

/// Prints the report, and the ground `up = "auto"` would level (or why there is none).
pub fn run(args: &InspectArgs) -> Result<()> {
    let report = splatphys_core::formats::inspect::inspect(&args.file)
        .with_context(|| format!("inspecting {}", args.file.display()))?;
    println!("{report}");
    let cloud = splatphys_core::formats::read_gaussians(&args.file)?;
    match crate::align::leveling(&cloud, 0.5, None, 1.0) {
        Ok(l) => print!("{}", crate::align::describe(&l)),
        Err(e) => println!("ground       none found: {e}"),
    }
    Ok(())
}
