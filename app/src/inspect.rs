//! `splatphys inspect FILE`: what a 3DGS file holds (count, SH degree, bounds, scales, opacity,
//! extra properties, a guess of the up axis).

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

/// Prints the report.
pub fn run(args: &InspectArgs) -> Result<()> {
    let report = splatphys_core::formats::inspect::inspect(&args.file)
        .with_context(|| format!("inspecting {}", args.file.display()))?;
    println!("{report}");
    Ok(())
}
