//! `splatphys align`: the rotation that puts a capture's ground down
//! ([`splatphys_core::scene::up`]: the best of the largest planes of Gaussian centres, turned
//! onto z = 0, normal up), printed as the `[[source]]` keys that do it (`rotation_deg`,
//! `translation_m`), and optionally the levelled cloud as a PLY. A scene gets the same with
//! `up = "auto"` on its source.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use splatphys_core::formats::ply::write_ply;
use splatphys_core::formats::read_gaussians;
use splatphys_core::gaussians::GaussianCloud;
use splatphys_core::scene::transform::{apply_similarity, euler_xyz_deg};
use splatphys_core::scene::up::{Leveling, Plane, UpError, choose_up, planes_of};

/// Arguments of `splatphys align`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys align ../shared/data/playbot.ply
  splatphys align capture.spz --up-hint 0,-1,0 --out aligned.ply
  splatphys align scene.sog --scale 0.5")]
pub struct AlignArgs {
    /// The 3DGS file (any format splatphys reads).
    pub file: PathBuf,
    /// Roughly which way is up in the file's frame (x,y,z): chooses among the planes found the
    /// one whose normal is nearest, and points it that way. Without it the plane with the best
    /// share of Gaussians times one-sidedness wins, its normal to the fuller side.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up_hint: Option<Vec3>,
    /// Scale of the source (file units to metres) for the printed translation.
    #[arg(long, default_value_t = 1.0)]
    pub scale: f32,
    /// Only Gaussians at least this opaque take part (0..1).
    #[arg(long, default_value_t = 0.5)]
    pub min_opacity: f32,
    /// Write the aligned cloud (scaled, turned and moved, SH turned too) as an INRIA PLY.
    #[arg(long, short)]
    pub out: Option<PathBuf>,
}

fn parse_vec3(text: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|s| s.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{text:?}: expected three numbers x,y,z"))?;
    match v[..] {
        [x, y, z] if Vec3::new(x, y, z).length() > 0.0 && v.iter().all(|c| c.is_finite()) => {
            Ok(Vec3::new(x, y, z).normalize())
        }
        _ => Err(format!(
            "{text:?}: expected three numbers x,y,z, not all zero"
        )),
    }
}

/// Runs `splatphys align`.
///
/// # Errors
/// An unreadable file, a cloud with no plane, an unwritable output.
pub fn run(args: &AlignArgs) -> Result<()> {
    if !(args.scale.is_finite() && args.scale > 0.0) {
        bail!("--scale must be > 0");
    }
    let mut cloud = read_gaussians(&args.file)?;
    let leveling = leveling(&cloud, args.min_opacity, args.up_hint, args.scale)
        .with_context(|| format!("levelling {}", args.file.display()))?;
    eprint!("{}", describe(&leveling));
    let [rx, ry, rz] = leveling.rotation_deg;
    let [tx, ty, tz] = leveling.translation_m;
    println!(
        "[[source]]\nname = \"capture\"\npath = {:?}\nscale = {}\nrotation_deg = [{rx:.2}, {ry:.2}, {rz:.2}]\ntranslation_m = [{tx:.4}, {ty:.4}, {tz:.4}]",
        args.file.display().to_string(),
        args.scale
    );
    if let Some(out) = &args.out {
        apply_similarity(
            &mut cloud,
            args.scale,
            euler_xyz_deg(leveling.rotation_deg),
            Vec3::from(leveling.translation_m),
        );
        write_ply(
            out,
            &cloud,
            &["levelled by splatphys align: z up, metres".into()],
        )
        .with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// The levelling of a cloud's ground (see [`splatphys_core::scene::up`]).
///
/// # Errors
/// Too few opaque Gaussians, or no dominant plane.
pub fn leveling(
    cloud: &GaussianCloud,
    min_opacity: f32,
    hint: Option<Vec3>,
    scale: f32,
) -> Result<Leveling, UpError> {
    let (planes, _) = planes_of(&cloud.positions, |i| cloud.opacity(i), min_opacity)?;
    choose_up(&planes, hint, scale)
}

/// What was found, for people: the chosen plane and the runners-up.
pub fn describe(l: &Leveling) -> String {
    let line = |p: &Plane| {
        format!(
            "normal [{:.3}, {:.3}, {:.3}], {:.1} % of the Gaussians on it, {:.0} % of the rest on its up side",
            p.normal.x,
            p.normal.y,
            p.normal.z,
            100.0 * p.inlier_share,
            100.0 * p.one_sidedness
        )
    };
    let mut s = format!("ground       {}\n", line(&l.plane));
    let [x, y, z] = l.rotation_deg;
    s += &format!(
        "rotation_deg [{x:.2}, {y:.2}, {z:.2}] puts it down (splatphys align prints the [[source]])\n"
    );
    for p in l.runners_up.iter().flatten() {
        s += &format!("runner-up    {}\n", line(p));
    }
    s
}
