//! `splatphys align`: finds the rotation that puts a capture's ground down. Captures come in
//! their reconstruction's frame (COLMAP's is arbitrary; often y down, rarely level), while a
//! scene's world is z up. The ground or table top is the largest plane of Gaussian centres:
//! RANSAC finds the largest few (each search runs on what the previous ones left), the chosen
//! plane's normal is turned onto +z by the shortest rotation, and the plane is moved to z = 0
//! with its inliers' centroid over the origin. The command prints the `[[source]]` keys that
//! do this (`rotation_deg`, `translation_m`) and can write the aligned cloud as a PLY.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::{EulerRot, Quat, Vec3};
use splatphys_core::formats::ply::write_ply;
use splatphys_core::formats::read_gaussians;
use splatphys_core::scene::transform::{apply_similarity, euler_xyz_deg};
use splatphys_core::selection::auto::ransac_plane;

/// Arguments of `splatphys align`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys align ../shared/data/playbot.ply
  splatphys align capture.spz --up-hint 0,-1,0 --out aligned.ply
  splatphys align scene.sog --scale 0.5 --tolerance 0.01")]
pub struct AlignArgs {
    /// The 3DGS file (any format splatphys reads).
    pub file: PathBuf,
    /// Roughly which way is up in the file's frame (x,y,z): chooses among the planes found the
    /// one whose normal is nearest, and points it that way. Without it the largest plane wins,
    /// its normal pointing to the side with more Gaussians.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up_hint: Option<Vec3>,
    /// Plane tolerance in file units (default: 0.5 % of the cloud's extent).
    #[arg(long)]
    pub tolerance: Option<f32>,
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

/// A plane found in the cloud.
#[derive(Debug, Clone, Copy)]
pub struct Plane {
    /// Unit normal in the file's frame.
    pub normal: Vec3,
    /// Offset along the normal (file units).
    pub offset: f32,
    /// Fraction of the sampled Gaussians within the tolerance.
    pub inlier_fraction: f32,
    /// Centroid of the inliers (file units).
    pub centroid: Vec3,
}

/// The alignment of a capture: scene keys that put `plane` at z = 0, normal up.
#[derive(Debug, Clone, Copy)]
pub struct Alignment {
    /// The plane chosen.
    pub plane: Plane,
    /// Rotation taking the plane's normal onto +z (shortest arc).
    pub rotation: Quat,
    /// `rotation_deg` of a `[[source]]` (x, y, z, applied in that order about world axes).
    pub rotation_deg: [f32; 3],
    /// `translation_m` of a `[[source]]` for the given scale.
    pub translation_m: [f32; 3],
}

/// Up to `count` planes, largest first, each searched on the points the previous ones left.
pub fn find_planes(points: &[[f32; 3]], tolerance: f32, count: usize) -> Vec<Plane> {
    let total = points.len().max(1) as f32;
    let mut left: Vec<[f32; 3]> = points.to_vec();
    let mut planes = Vec::new();
    for k in 0..count {
        let Some(fit) = ransac_plane(&left, 300, tolerance, 0x5eed + k as u64) else {
            break;
        };
        let fraction = fit.inliers.len() as f32 / total;
        if fraction < 0.02 {
            break;
        }
        let centroid = fit
            .inliers
            .iter()
            .fold(Vec3::ZERO, |s, &i| s + Vec3::from(left[i]))
            / fit.inliers.len() as f32;
        planes.push(Plane {
            normal: Vec3::from(fit.normal),
            offset: fit.offset_m,
            inlier_fraction: fraction,
            centroid,
        });
        let mut is_inlier = vec![false; left.len()];
        for &i in &fit.inliers {
            is_inlier[i] = true;
        }
        left = left
            .iter()
            .zip(&is_inlier)
            .filter(|(_, inl)| !**inl)
            .map(|(p, _)| *p)
            .collect();
    }
    planes
}

/// The alignment that puts `plane` (normal pointing up) at z = 0, its centroid over the origin,
/// for a source of scale `scale`.
pub fn align_to(plane: Plane, scale: f32) -> Alignment {
    let rotation = Quat::from_rotation_arc(plane.normal, Vec3::Z);
    let (z, y, x) = rotation.to_euler(EulerRot::ZYX);
    let rotation_deg = [x, y, z].map(f32::to_degrees);
    let rotated = euler_xyz_deg(rotation_deg);
    let c = rotated * plane.centroid * scale;
    Alignment {
        plane,
        rotation: rotated,
        rotation_deg,
        translation_m: [-c.x, -c.y, -c.z],
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
    let mut points: Vec<[f32; 3]> = (0..cloud.len())
        .filter(|&i| cloud.opacity(i) >= args.min_opacity)
        .map(|i| cloud.positions[i])
        .collect();
    // At most 200k points, evenly strided (deterministic).
    let stride = points.len().div_ceil(200_000).max(1);
    points = points.into_iter().step_by(stride).collect();
    if points.len() < 3 {
        bail!(
            "{}: only {} Gaussians at least {} opaque; lower --min-opacity",
            args.file.display(),
            points.len(),
            args.min_opacity
        );
    }
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
    );
    let tolerance = args.tolerance.unwrap_or(0.005 * (hi - lo).length());
    let planes = find_planes(&points, tolerance, 4);
    if planes.is_empty() {
        bail!(
            "{}: no plane holds 2 % of the Gaussians at tolerance {tolerance} (try --tolerance)",
            args.file.display()
        );
    }
    eprintln!("planes found (file frame, tolerance {tolerance:.4}):");
    for (k, p) in planes.iter().enumerate() {
        eprintln!(
            "  {k}: normal [{:.3}, {:.3}, {:.3}], {:.1} % of the Gaussians",
            p.normal.x,
            p.normal.y,
            p.normal.z,
            100.0 * p.inlier_fraction
        );
    }
    let mut chosen = planes[0];
    if let Some(hint) = args.up_hint {
        chosen = *planes
            .iter()
            .max_by(|a, b| {
                a.normal
                    .dot(hint)
                    .abs()
                    .total_cmp(&b.normal.dot(hint).abs())
            })
            .unwrap_or(&planes[0]);
        if chosen.normal.dot(hint) < 0.0 {
            chosen.normal = -chosen.normal;
            chosen.offset = -chosen.offset;
        }
    }
    let a = align_to(chosen, args.scale);
    let [rx, ry, rz] = a.rotation_deg;
    let [tx, ty, tz] = a.translation_m;
    eprintln!(
        "chosen: normal [{:.3}, {:.3}, {:.3}] goes up, its centroid to the origin",
        chosen.normal.x, chosen.normal.y, chosen.normal.z
    );
    println!(
        "[[source]]\nname = \"capture\"\npath = {:?}\nscale = {}\nrotation_deg = [{rx:.2}, {ry:.2}, {rz:.2}]\ntranslation_m = [{tx:.4}, {ty:.4}, {tz:.4}]",
        args.file.display().to_string(),
        args.scale
    );
    if let Some(out) = &args.out {
        apply_similarity(
            &mut cloud,
            args.scale,
            a.rotation,
            Vec3::from(a.translation_m),
        );
        write_ply(
            out,
            &cloud,
            &["aligned by splatphys align: z up, metres".into()],
        )
        .with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tilted_table_comes_out_level_with_the_object_on_top() {
        // A 1 × 1 table (2,500 points) with a 0.2-wide box of points above it, in a frame that is
        // y down and tilted by 17° about x and 8° about z.
        let tilt = Quat::from_rotation_z(0.14)
            * Quat::from_rotation_x(0.3)
            * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let mut points = Vec::new();
        for i in 0..50 {
            for j in 0..50 {
                points.push(Vec3::new(i as f32 / 50.0 - 0.5, j as f32 / 50.0 - 0.5, 0.3));
            }
        }
        for i in 0..1200 {
            let f = i as f32;
            points.push(Vec3::new(
                0.1 * (f * 0.37).sin(),
                0.1 * (f * 0.71).cos(),
                0.35 + 0.2 * ((f * 0.13).sin() * 0.5 + 0.5),
            ));
        }
        let file: Vec<[f32; 3]> = points.iter().map(|p| (tilt * *p).to_array()).collect();
        let planes = find_planes(&file, 0.005, 3);
        let a = align_to(planes[0], 2.0);
        for (p, f) in points.iter().zip(&file) {
            let q = a.rotation * Vec3::from(*f) * 2.0 + Vec3::from(a.translation_m);
            if (p.z - 0.3).abs() < 1e-6 {
                assert!(q.z.abs() < 1e-3, "table point at z {}", q.z);
            } else {
                assert!(q.z > 0.09, "object point below the table: {}", q.z);
            }
        }
        // The printed Euler angles rebuild the same rotation.
        let n = a.rotation * planes[0].normal;
        assert!(n.dot(Vec3::Z) > 1.0 - 1e-5, "{n}");
    }
}
