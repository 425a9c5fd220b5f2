//! Which way is up in a capture. Reconstructions inherit COLMAP's arbitrary frame, while a
//! scene's world is z up; the ground (or a table top) is a large plane of Gaussian centres that
//! the rest of the capture stands on. RANSAC finds the largest few planes, each on what the
//! previous ones left ([`find_planes`]); each is scored by its share of the centres times how
//! one-sided the rest of the capture lies about it (a floor has everything above it; a table top
//! with the floor under it, or a wall between two rooms, less so), its normal pointing to the
//! fuller side ([`choose_up`]). The chosen plane is turned onto z = 0, normal up, its inliers'
//! centroid over the origin ([`Leveling`]).

use glam::{EulerRot, Quat, Vec3};

use super::SceneError;
use super::context::Ctx;
use super::schema::{SourceToml, UpToml};
use super::transform::euler_xyz_deg;
use crate::gaussians::GaussianCloud;
use crate::selection::auto::ransac_plane;

/// The smallest share of the (sampled) centres a plane must hold to be taken as ground.
pub const MIN_GROUND_SHARE: f32 = 0.05;

/// Centres sampled at most (evenly strided, so the result does not depend on anything else).
pub const MAX_SAMPLES: usize = 200_000;

/// A plane found among the centres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal (file frame), pointing to the side with more of the capture.
    pub normal: Vec3,
    /// Share of the sampled centres within the tolerance, 0..1.
    pub inlier_share: f32,
    /// Of the centres off the plane, the share on the normal's side, 0.5..1.
    pub one_sidedness: f32,
    /// Centroid of the inliers (file units).
    pub centroid: Vec3,
}

impl Plane {
    /// How much this plane looks like the ground: inlier share × one-sidedness.
    pub fn score(&self) -> f32 {
        self.inlier_share * self.one_sidedness
    }
}

/// The rotation and translation that put a plane at z = 0, normal up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leveling {
    /// The plane chosen.
    pub plane: Plane,
    /// The other planes found, best first.
    pub runners_up: [Option<Plane>; 3],
    /// Rotation taking the plane's normal onto +z (the shortest arc), as Euler angles in
    /// degrees about the fixed world axes, x, then y, then z: a `[[source]]`'s `rotation_deg`.
    pub rotation_deg: [f32; 3],
    /// Translation after scaling by `scale` and rotating, m: the plane to z = 0, its inliers'
    /// centroid over the origin.
    pub translation_m: [f32; 3],
}

/// Up to `count` planes among `points`, largest first, each searched (300 RANSAC hypotheses,
/// `tolerance` in file units) on what the previous ones left; planes holding less than a
/// hundredth of the points are not reported.
pub fn find_planes(points: &[[f32; 3]], tolerance: f32, count: usize) -> Vec<Plane> {
    let total = points.len().max(1) as f32;
    let mut left: Vec<[f32; 3]> = points.to_vec();
    let mut planes = Vec::new();
    for k in 0..count {
        let Some(fit) = ransac_plane(&left, 300, tolerance, 0x5eed + k as u64) else {
            break;
        };
        let share = fit.inliers.len() as f32 / total;
        if share < 0.01 {
            break;
        }
        let normal = Vec3::from(fit.normal);
        let centroid = fit
            .inliers
            .iter()
            .fold(Vec3::ZERO, |s, &i| s + Vec3::from(left[i]))
            / fit.inliers.len() as f32;
        // Sidedness over all points (not only those left), so every plane sees the whole capture.
        let (mut above, mut below) = (0usize, 0usize);
        for p in points {
            let h = normal.dot(Vec3::from(*p)) - fit.offset_m;
            if h > tolerance {
                above += 1;
            } else if h < -tolerance {
                below += 1;
            }
        }
        let (normal, one_sidedness) = if below > above {
            (-normal, below as f32 / (above + below) as f32)
        } else {
            (normal, above as f32 / (above + below).max(1) as f32)
        };
        planes.push(Plane {
            normal,
            inlier_share: share,
            one_sidedness,
            centroid,
        });
        let mut inlier = vec![false; left.len()];
        for &i in &fit.inliers {
            inlier[i] = true;
        }
        left = left
            .iter()
            .zip(&inlier)
            .filter(|(_, i)| !**i)
            .map(|(p, _)| *p)
            .collect();
    }
    planes
}

/// Why no up could be found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UpError {
    /// Fewer than three centres took part.
    #[error("only {count} Gaussians at least {min_opacity} opaque: too few to find a ground")]
    TooFewPoints {
        /// Centres that took part.
        count: usize,
        /// The opacity floor used.
        min_opacity: f32,
    },
    /// No plane holds [`MIN_GROUND_SHARE`] of the centres.
    #[error(
        "no dominant plane: the largest holds {:.1} % of the Gaussians (at least {:.0} % needed); give the rotation by hand",
        100.0 * largest_share,
        100.0 * MIN_GROUND_SHARE
    )]
    NoDominantPlane {
        /// Share of the largest plane found (0 when none).
        largest_share: f32,
    },
}

/// The planes of the centres of Gaussians at least `min_opacity` opaque (`positions` and
/// `opacity`, `[N]` each), with the default tolerance, 0.5 % of the centres' bounding-box
/// diagonal.
pub fn planes_of(
    positions: &[[f32; 3]],
    opacity: impl Fn(usize) -> f32,
    min_opacity: f32,
) -> Result<(Vec<Plane>, f32), UpError> {
    let kept: Vec<[f32; 3]> = (0..positions.len())
        .filter(|&i| opacity(i) >= min_opacity)
        .map(|i| positions[i])
        .collect();
    let stride = kept.len().div_ceil(MAX_SAMPLES).max(1);
    let points: Vec<[f32; 3]> = kept.into_iter().step_by(stride).collect();
    if points.len() < 3 {
        return Err(UpError::TooFewPoints {
            count: points.len(),
            min_opacity,
        });
    }
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
    );
    let tolerance = 0.005 * (hi - lo).length();
    Ok((
        find_planes(&points, tolerance.max(f32::MIN_POSITIVE), 4),
        tolerance,
    ))
}

/// Chooses the ground among `planes`: the best [`Plane::score`], or with `hint` (a rough up
/// direction in the file's frame) the plane whose normal is nearest to it, turned to point its
/// way. Then levels it for a source of scale `scale`.
///
/// # Errors
/// [`UpError::NoDominantPlane`] when no plane holds [`MIN_GROUND_SHARE`] of the centres.
pub fn choose_up(planes: &[Plane], hint: Option<Vec3>, scale: f32) -> Result<Leveling, UpError> {
    let largest_share = planes.iter().map(|p| p.inlier_share).fold(0.0, f32::max);
    let mut ranked: Vec<Plane> = planes
        .iter()
        .copied()
        .filter(|p| p.inlier_share >= MIN_GROUND_SHARE)
        .collect();
    if ranked.is_empty() {
        return Err(UpError::NoDominantPlane { largest_share });
    }
    match hint {
        Some(h) => ranked.sort_by(|a, b| b.normal.dot(h).abs().total_cmp(&a.normal.dot(h).abs())),
        None => ranked.sort_by(|a, b| b.score().total_cmp(&a.score())),
    }
    let mut plane = ranked[0];
    if let Some(h) = hint
        && plane.normal.dot(h) < 0.0
    {
        plane.normal = -plane.normal;
        plane.one_sidedness = 1.0 - plane.one_sidedness;
    }
    let mut runners_up = [None; 3];
    for (slot, p) in runners_up.iter_mut().zip(ranked.iter().skip(1)) {
        *slot = Some(*p);
    }
    Ok(level(plane, runners_up, scale))
}

fn level(plane: Plane, runners_up: [Option<Plane>; 3], scale: f32) -> Leveling {
    let arc = Quat::from_rotation_arc(plane.normal, Vec3::Z);
    let (z, y, x) = arc.to_euler(EulerRot::ZYX);
    let rotation_deg = [x, y, z].map(f32::to_degrees);
    let rotation = euler_xyz_deg(rotation_deg);
    let c = rotation * plane.centroid * scale;
    Leveling {
        plane,
        runners_up,
        rotation_deg,
        translation_m: [-c.x, -c.y, -c.z],
    }
}

/// The rotation and translation of a source: `rotation_deg` and `translation_m`, or with `up`
/// the rotation that levels it (and with `"auto"` the translation that puts its ground at
/// z = 0, to which `translation_m` is added).
pub(super) fn placement(
    ctx: &Ctx,
    key: &str,
    s: &SourceToml,
    cloud: &GaussianCloud,
) -> Result<(Quat, Vec3), SceneError> {
    let Some(up) = &s.up else {
        return Ok((euler_xyz_deg(s.rotation_deg), Vec3::from(s.translation_m)));
    };
    ctx.check(
        s.rotation_deg == [0.0; 3],
        format!("{key}.up"),
        "give either up or rotation_deg, not both",
    )?;
    match up {
        UpToml::Direction(d) => {
            let v = Vec3::from(*d);
            ctx.check(
                v.is_finite() && v.length() > 0.0,
                format!("{key}.up"),
                "must be \"auto\" or a non-zero direction [x, y, z]",
            )?;
            Ok((
                Quat::from_rotation_arc(v.normalize(), Vec3::Z),
                Vec3::from(s.translation_m),
            ))
        }
        UpToml::Word(w) => {
            ctx.check(
                w == "auto",
                format!("{key}.up"),
                format!("{w:?}: must be \"auto\" or a direction [x, y, z]"),
            )?;
            let leveling = planes_of(&cloud.positions, |i| cloud.opacity(i), 0.5)
                .and_then(|(planes, _)| choose_up(&planes, None, s.scale))
                .map_err(|e| SceneError::Invalid {
                    file: ctx.file.to_path_buf(),
                    key_path: format!("{key}.up"),
                    message: e.to_string(),
                })?;
            Ok((
                euler_xyz_deg(leveling.rotation_deg),
                Vec3::from(leveling.translation_m) + Vec3::from(s.translation_m),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 × 1 table of 2,500 centres at z = 0.3 with a box of 1,200 above it, and a floor of
    /// 3,600 centres at z = 0 around it (larger than the table, with everything above it).
    fn room() -> Vec<Vec3> {
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
                0.35 + 0.1 * ((f * 0.13).sin() + 1.0),
            ));
        }
        for i in 0..60 {
            for j in 0..60 {
                points.push(Vec3::new(i as f32 / 20.0 - 1.5, j as f32 / 20.0 - 1.5, 0.0));
            }
        }
        points
    }

    #[test]
    fn a_turned_room_comes_out_floor_down() {
        let turn =
            Quat::from_rotation_z(0.14) * Quat::from_rotation_x(0.3) * Quat::from_rotation_y(2.0);
        let world = room();
        let file: Vec<[f32; 3]> = world.iter().map(|p| (turn * *p).to_array()).collect();
        let (planes, _) = planes_of(&file, |_| 1.0, 0.5).unwrap();
        let l = choose_up(&planes, None, 2.0).unwrap();
        let r = super::super::transform::euler_xyz_deg(l.rotation_deg);
        for (p, f) in world.iter().zip(&file) {
            let q = r * Vec3::from(*f) * 2.0 + Vec3::from(l.translation_m);
            if p.z == 0.0 {
                assert!(q.z.abs() < 0.02, "floor point at {}", q.z);
            } else {
                assert!(q.z > 0.5, "a point above the floor ended at {}", q.z);
            }
        }
        // The table top is a runner-up, with the floor under it: less one-sided.
        assert!(
            l.runners_up
                .iter()
                .flatten()
                .any(|p| p.one_sidedness < l.plane.one_sidedness)
        );
    }

    #[test]
    fn a_cloud_without_a_plane_is_refused() {
        // Centres filling a ball: no slab of 0.5 % of the diagonal holds 5 %.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut points = Vec::new();
        while points.len() < 20_000 {
            let p = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if p.length() <= 1.0 {
                points.push(p.to_array());
            }
        }
        let (planes, _) = planes_of(&points, |_| 1.0, 0.5).unwrap();
        let err = choose_up(&planes, None, 1.0).unwrap_err();
        assert!(matches!(err, UpError::NoDominantPlane { .. }), "{err}");
        assert!(err.to_string().contains("no dominant plane"));
    }
}
