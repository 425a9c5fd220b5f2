//! Building a [`Scene`] from a parsed scene file: load each source once (clones share the
//! file), place it, select objects in file order (a Gaussian belongs to the first object that
//! selects it), build procedural objects, give the rest to the background, validate every value.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::SceneError;
use super::context::Ctx;
use super::model::*;
use super::schema::{MaterialToml, ObjectToml, PlaneChoice, SceneFile, SelectToml, SpzFrameToml};
use super::transform::{apply_similarity, concat, euler_xyz_deg, subset, voxel_subsample};
use crate::formats::spz::SpzFrame;
use crate::formats::{ReadOptions, read_gaussians_noted};
use crate::gaussians::GaussianCloud;
use crate::procedural::shape_gaussians;
use crate::selection::auto::{AutoParams, detect_objects};
use crate::selection::semantic::{self, QueryEmbeddings, SemanticParams};
use crate::selection::{SelectionError, geometric};

/// Default material when an object gives none: jelly, E = 1e5 Pa, ν = 0.3, ρ = 1000 kg/m³.
pub fn default_material() -> MaterialSpec {
    MaterialSpec::default()
}

/// A placed source: world-frame cloud and which Gaussians an object already took.
struct Placed {
    name: String,
    cloud: GaussianCloud,
    claimed: Vec<bool>,
}

/// Validates and converts a material table.
fn material(ctx: &Ctx, m: &MaterialToml, key: &str) -> Result<MaterialSpec, SceneError> {
    // The bounds a material edit command gets (`splatphys_types::limits`).
    use splatphys_types::limits::{DENSITY_RANGE_KG_M3, MAX_POISSON_RATIO, MAX_YOUNGS_MODULUS_PA};
    ctx.check(
        m.youngs_modulus_pa > 0.0 && m.youngs_modulus_pa <= MAX_YOUNGS_MODULUS_PA,
        format!("{key}.youngs_modulus_pa"),
        format!("must be > 0 and at most {MAX_YOUNGS_MODULUS_PA:e} Pa"),
    )?;
    ctx.check(
        m.poisson_ratio > -1.0 && m.poisson_ratio <= MAX_POISSON_RATIO,
        format!("{key}.poisson_ratio"),
        format!("must be in (-1, {MAX_POISSON_RATIO}]"),
    )?;
    let (lo, hi) = DENSITY_RANGE_KG_M3;
    ctx.check(
        (lo..=hi).contains(&m.density_kg_m3),
        format!("{key}.density_kg_m3"),
        format!("must be in [{lo}, {hi}] kg/m³"),
    )?;
    let opts = [
        ("friction_angle_deg", m.friction_angle_deg),
        ("yield_stress_pa", m.yield_stress_pa),
        ("softening", m.softening),
        ("viscosity_pa_s", m.viscosity_pa_s),
        ("damping_viscosity_pa_s", m.damping_viscosity_pa_s),
        ("hardening", m.hardening),
        ("critical_compression", m.critical_compression),
        ("critical_stretch", m.critical_stretch),
    ];
    for (name, v) in opts {
        if let Some(v) = v {
            ctx.check(
                v.is_finite() && v >= 0.0,
                format!("{key}.{name}"),
                "must be finite and >= 0",
            )?;
        }
    }
    if let Some(eta) = m.damping_viscosity_pa_s {
        let max = crate::material::MAX_DAMPING_VISCOSITY_PA_S;
        ctx.check(
            eta <= max,
            format!("{key}.damping_viscosity_pa_s"),
            format!("must be at most {max:e} Pa·s"),
        )?;
    }
    Ok(m.clone())
}

fn settings(ctx: &Ctx, f: &SceneFile) -> Result<SimulationSettings, SceneError> {
    let s = &f.simulation;
    let pos = |v: f64| v.is_finite() && v > 0.0;
    ctx.check(pos(s.duration_s), "simulation.duration_s", "must be > 0")?;
    ctx.check(
        pos(s.frame_rate_hz),
        "simulation.frame_rate_hz",
        "must be > 0",
    )?;
    ctx.check(pos(s.grid_dx_m), "simulation.grid_dx_m", "must be > 0")?;
    ctx.check(
        pos(s.cfl) && s.cfl <= 1.0,
        "simulation.cfl",
        "must be in (0, 1]",
    )?;
    if let Some(dt) = s.dt_s {
        ctx.check(pos(dt), "simulation.dt_s", "must be > 0")?;
    }
    ctx.check(
        !s.force_dt || s.dt_s.is_some(),
        "simulation.force_dt",
        "needs simulation.dt_s",
    )?;
    ctx.finite3(s.gravity_m_s2, "simulation.gravity_m_s2".into())?;
    if let Some([lo, hi]) = s.domain_m {
        ctx.check(
            (0..3).all(|k| lo[k] < hi[k]),
            "simulation.domain_m",
            "min must be below max on every axis",
        )?;
    }
    if let Some(h) = s.physics_spacing_m {
        ctx.check(
            h.is_finite() && h > 0.0,
            "simulation.physics_spacing_m",
            "must be > 0",
        )?;
    }
    if let Some(h) = s.collision_dx_m {
        ctx.check(pos(h), "simulation.collision_dx_m", "must be > 0")?;
    }
    if let Some(fps) = s.budget_fps {
        ctx.check(pos(fps), "simulation.budget_fps", "must be > 0")?;
    }
    ctx.check(
        (0.0..=1.0).contains(&s.background_min_opacity),
        "simulation.background_min_opacity",
        "must be in [0, 1]",
    )?;
    Ok(SimulationSettings {
        method: s.method,
        device: s.device,
        duration_s: s.duration_s,
        frame_rate_hz: s.frame_rate_hz,
        grid_dx_m: s.grid_dx_m,
        cfl: s.cfl,
        dt_s: s.dt_s,
        force_dt: s.force_dt,
        gravity_m_s2: s.gravity_m_s2,
        domain_m: s.domain_m,
        seed: s.seed,
        physics_spacing_m: s.physics_spacing_m,
        sleep: s.sleep,
        islands: s.islands,
        background_collision: s.background_collision,
        background_min_opacity: s.background_min_opacity,
        collision_dx_m: s.collision_dx_m,
        budget_fps: s.budget_fps,
        contact_solver: s.contact_solver,
        surface_contact: s.surface_contact,
    })
}

fn place_sources(
    ctx: &Ctx,
    base: &Path,
    f: &SceneFile,
    warnings: &mut Vec<String>,
) -> Result<Vec<Placed>, SceneError> {
    let mut cache: HashMap<(PathBuf, ReadOptions), GaussianCloud> = HashMap::new();
    let mut out: Vec<Placed> = Vec::new();
    for (i, s) in f.source.iter().enumerate() {
        let key = format!("source[{i}]");
        ctx.check(
            !s.name.is_empty(),
            format!("{key}.name"),
            "must not be empty",
        )?;
        ctx.check(
            !out.iter().any(|p| p.name == s.name),
            format!("{key}.name"),
            format!("duplicate source name {:?}", s.name),
        )?;
        ctx.check(
            s.scale.is_finite() && s.scale > 0.0,
            format!("{key}.scale"),
            "must be > 0",
        )?;
        ctx.finite3(s.rotation_deg, format!("{key}.rotation_deg"))?;
        ctx.finite3(s.translation_m, format!("{key}.translation_m"))?;
        ctx.check(
            (0.0..=1.0).contains(&s.min_opacity),
            format!("{key}.min_opacity"),
            "must be in [0, 1]",
        )?;
        let path = base.join(&s.path);
        let options = ReadOptions {
            lod: s.lod,
            spz_frame: match s.spz_frame {
                Some(SpzFrameToml::AsStored) => SpzFrame::AsStored,
                Some(SpzFrameToml::Rub) | None => SpzFrame::Rub,
            },
        };
        let cache_key = (path.clone(), options);
        let raw = match cache.get(&cache_key) {
            Some(c) => c.clone(),
            None => {
                let (c, _, notes) =
                    read_gaussians_noted(&path, &options).map_err(|source| SceneError::Source {
                        file: ctx.file.to_path_buf(),
                        key_path: format!("{key}.path"),
                        source: Box::new(source),
                    })?;
                warnings.extend(notes.into_iter().map(|n| format!("{key}: {n}")));
                cache.insert(cache_key, c.clone());
                c
            }
        };
        let all: Vec<usize> = (0..raw.len()).collect();
        let kept = if s.min_opacity > 0.0 {
            geometric::opacity_at_least(&raw, &all, s.min_opacity)
        } else {
            all
        };
        let mut cloud = if kept.len() == raw.len() {
            raw
        } else {
            subset(&raw, &kept)
        };
        let (rotation, translation) = super::up::placement(ctx, &key, s, &cloud)?;
        apply_similarity(&mut cloud, s.scale, rotation, translation);
        if let Some(v) = s.voxel_m {
            ctx.check(
                v.is_finite() && v > 0.0,
                format!("{key}.voxel_m"),
                "must be > 0",
            )?;
            let idx: Vec<usize> = (0..cloud.len()).collect();
            cloud = subset(&cloud, &voxel_subsample(&cloud, &idx, v));
        }
        let n = cloud.len();
        out.push(Placed {
            name: s.name.clone(),
            cloud,
            claimed: vec![false; n],
        });
    }
    Ok(out)
}

/// Selected `(source index, Gaussian indices)` for one object.
fn select(
    ctx: &Ctx,
    base: &Path,
    key: &str,
    sel: &SelectToml,
    sources: &[Placed],
    seed: u64,
) -> Result<Vec<(usize, Vec<usize>)>, SceneError> {
    let skey = format!("{key}.select");
    let sel_err = |source: SelectionError| SceneError::Selection {
        file: ctx.file.to_path_buf(),
        key_path: skey.clone(),
        source: Box::new(source),
    };
    ctx.check(
        !(sel.auto.is_some() && sel.query.is_some()),
        &skey,
        "`auto` and `query` cannot be combined",
    )?;
    let which: Vec<usize> = match &sel.source {
        Some(name) => vec![
            sources
                .iter()
                .position(|p| &p.name == name)
                .ok_or_else(|| {
                    ctx.invalid(
                        format!("{skey}.source"),
                        format!("no source named {name:?}"),
                    )
                })?,
        ],
        None => (0..sources.len()).collect(),
    };
    ctx.check(!which.is_empty(), &skey, "no [[source]] to select from")?;
    let mut cand: Vec<(usize, Vec<usize>)> = Vec::new();
    for &s in &which {
        let p = &sources[s];
        let mut idx: Vec<usize> = (0..p.cloud.len()).filter(|&i| !p.claimed[i]).collect();
        if let Some([lo, hi]) = sel.box_m {
            idx = geometric::in_box(&p.cloud, &idx, lo, hi);
        }
        if let Some(sp) = sel.sphere {
            idx = geometric::in_sphere(&p.cloud, &idx, sp.center_m, sp.radius_m);
        }
        if let Some(o) = sel.min_opacity {
            ctx.check(
                (0.0..=1.0).contains(&o),
                format!("{skey}.min_opacity"),
                "must be in [0, 1]",
            )?;
            idx = geometric::opacity_at_least(&p.cloud, &idx, o);
        }
        cand.push((s, idx));
    }
    // Flattened candidate points for the automatic and semantic steps.
    let flat: Vec<(usize, usize)> = cand
        .iter()
        .flat_map(|(s, v)| v.iter().map(move |&i| (*s, i)))
        .collect();
    let points: Vec<[f32; 3]> = flat
        .iter()
        .map(|&(s, i)| sources[s].cloud.positions[i])
        .collect();
    let regroup = |chosen: &[usize]| -> Vec<(usize, Vec<usize>)> {
        let mut m: Vec<(usize, Vec<usize>)> = which.iter().map(|&s| (s, Vec::new())).collect();
        for &j in chosen {
            let (s, i) = flat[j];
            if let Some(e) = m.iter_mut().find(|e| e.0 == s) {
                e.1.push(i);
            }
        }
        m
    };
    if let Some(k) = sel.auto {
        let d = AutoParams::default();
        let params = AutoParams {
            cluster_eps_m: sel.cluster_eps_m.unwrap_or(d.cluster_eps_m),
            plane_tolerance_m: sel.plane_tolerance_m.unwrap_or(d.plane_tolerance_m),
            min_cluster: sel.min_cluster.unwrap_or(d.min_cluster),
            seed,
            ..d
        };
        let found = detect_objects(&points, &params);
        let obj = found
            .objects
            .get(k)
            .ok_or(SelectionError::NoSuchCluster {
                k,
                found: found.objects.len(),
            })
            .map_err(sel_err)?;
        return Ok(regroup(obj));
    }
    if let Some(query) = &sel.query {
        let emb_path = sel
            .embeddings
            .as_ref()
            .ok_or_else(|| ctx.invalid(format!("{skey}.embeddings"), "required with `query`"))?;
        let mut q = QueryEmbeddings::load(&base.join(emb_path), query, sel.negatives.as_deref())
            .map_err(sel_err)?;
        let (mut feats, mut dim) = features(base, sel, sources, &flat).map_err(sel_err)?;
        if let Some(pca) = &sel.pca {
            let (basis, full_dim) = semantic::read_npy_matrix(&base.join(pca)).map_err(sel_err)?;
            q = q.reduced(pca, &basis, full_dim).map_err(sel_err)?;
            (feats, dim) = semantic::pad_reduced_features(&feats, dim);
        }
        let d = SemanticParams::default();
        let params = SemanticParams {
            temperature: sel.temperature.unwrap_or(d.temperature),
            threshold: sel.threshold.unwrap_or(d.threshold),
            eps_m: sel.eps_m.unwrap_or(d.eps_m),
            min_samples: sel.min_samples.unwrap_or(d.min_samples),
            knn: sel.knn.unwrap_or(d.knn),
        };
        let prob =
            semantic::positive_probability(&feats, dim, &q, params.temperature).map_err(sel_err)?;
        let chosen = semantic::select(&points, &prob, &params).map_err(sel_err)?;
        return Ok(regroup(&chosen));
    }
    Ok(cand)
}

/// Features `[M][D]` for the flattened candidates: from a sidecar `.npy` (rows follow the
/// source's Gaussians after `min_opacity`/`voxel_m` filtering, so only usable without them)
/// or from `feat_*` extra properties.
fn features(
    base: &Path,
    sel: &SelectToml,
    sources: &[Placed],
    flat: &[(usize, usize)],
) -> Result<(Vec<f32>, usize), SelectionError> {
    if let Some(f) = &sel.features {
        let (all, dim) = semantic::read_npy_matrix(&base.join(f))?;
        let rows = all.len() / dim.max(1);
        let mut out = Vec::with_capacity(flat.len() * dim);
        for &(s, i) in flat {
            if sources.len() > 1 && sel.source.is_none() {
                return Err(SelectionError::File {
                    file: f.clone(),
                    message: "a features file needs `source`".into(),
                });
            }
            if i >= rows {
                return Err(SelectionError::Shape {
                    what: format!("{f} rows"),
                    expected: sources[s].cloud.len(),
                    found: rows,
                });
            }
            out.extend_from_slice(&all[i * dim..(i + 1) * dim]);
        }
        return Ok((out, dim));
    }
    let mut dim = usize::MAX;
    for &(s, _) in flat.iter().take(1) {
        let c = &sources[s].cloud;
        dim = (0..)
            .take_while(|d| c.extra.iter().any(|(n, _)| n == &format!("feat_{d}")))
            .count();
    }
    if dim == 0 || dim == usize::MAX {
        return Err(SelectionError::File {
            file: "source".into(),
            message: "no `features` file and no feat_* properties".into(),
        });
    }
    let mut out = Vec::with_capacity(flat.len() * dim);
    for &(s, i) in flat {
        let c = &sources[s].cloud;
        for d in 0..dim {
            let col = c.extra.iter().find(|(n, _)| n == &format!("feat_{d}"));
            out.push(col.map_or(0.0, |(_, v)| v[i]));
        }
    }
    Ok((out, dim))
}

fn object(
    ctx: &Ctx,
    base: &Path,
    i: usize,
    o: &ObjectToml,
    sources: &mut [Placed],
    seed: u64,
    default_physics_spacing_m: Option<f32>,
) -> Result<SceneObject, SceneError> {
    let key = format!("object[{i}]");
    ctx.check(
        !o.name.is_empty(),
        format!("{key}.name"),
        "must not be empty",
    )?;
    if let Some(h) = o.physics_spacing_m {
        let k = format!("{key}.physics_spacing_m");
        ctx.check(h.is_finite() && h > 0.0, &k, "must be > 0")?;
        ctx.check(
            o.kind != ObjectKind::Static,
            &k,
            "static objects are not simulated (every Gaussian stays a collider particle)",
        )?;
    }
    if let Some(dx) = o.grid_dx_m {
        ctx.check(
            dx.is_finite() && dx > 0.0,
            format!("{key}.grid_dx_m"),
            "must be > 0",
        )?;
    }
    // Static objects never take the simulation-level default.
    let physics_spacing_m = match o.kind {
        ObjectKind::Static => None,
        _ => o.physics_spacing_m.or(default_physics_spacing_m),
    };
    let mat = match &o.material {
        Some(m) => material(ctx, m, &format!("{key}.material"))?,
        None => default_material(),
    };
    let restitution = o.restitution.unwrap_or(0.5);
    ctx.check(
        (0.0..=1.0).contains(&restitution),
        format!("{key}.restitution"),
        "must be in [0, 1]",
    )?;
    let friction = o.friction.unwrap_or(0.3);
    ctx.check(
        friction.is_finite() && friction >= 0.0,
        format!("{key}.friction"),
        "must be >= 0",
    )?;
    let rolling_resistance_m = o.rolling_resistance_m.unwrap_or(0.0);
    ctx.check(
        (0.0..=MAX_ROLLING_RESISTANCE_M).contains(&rolling_resistance_m),
        format!("{key}.rolling_resistance_m"),
        format!("must be in [0, {MAX_ROLLING_RESISTANCE_M}] m"),
    )?;
    ctx.finite3(o.velocity_m_s, format!("{key}.velocity_m_s"))?;
    let gaussians = match (&o.select, &o.shape) {
        (Some(_), Some(_)) => {
            return Err(ctx.invalid(&key, "give either `select` or `shape`, not both"));
        }
        (None, None) => return Err(ctx.invalid(&key, "needs `select` or `shape`")),
        (Some(sel), None) => {
            ctx.check(
                o.spacing_m.is_none() && o.color.is_none(),
                &key,
                "`spacing_m` and `color` only apply to `shape`",
            )?;
            let picked = select(ctx, base, &key, sel, sources, seed)?;
            let mut cloud = GaussianCloud::default();
            for (s, idx) in &picked {
                for &g in idx {
                    sources[*s].claimed[g] = true;
                }
                cloud = concat(&cloud, &subset(&sources[*s].cloud, idx));
            }
            cloud
        }
        (None, Some(shape)) => {
            let spacing = o.spacing_m.unwrap_or(0.01);
            let color = o.color.unwrap_or([0.7, 0.7, 0.7]);
            ctx.check(
                color.iter().all(|c| (0.0..=1.0).contains(c)),
                format!("{key}.color"),
                "each channel in [0, 1]",
            )?;
            let mut cloud = shape_gaussians(shape, spacing, color, seed).map_err(|source| {
                SceneError::Procedural {
                    file: ctx.file.to_path_buf(),
                    key_path: format!("{key}.shape"),
                    source,
                }
            })?;
            if let Some(r) = o.rotation_deg {
                ctx.finite3(r, format!("{key}.rotation_deg"))?;
                // p' = c + R (p - c): about the shape's centre.
                let q = euler_xyz_deg(r);
                let c = shape.center();
                apply_similarity(&mut cloud, 1.0, q, c - q * c);
            }
            cloud
        }
    };
    ctx.check(
        o.rotation_deg.is_none() || o.shape.is_some(),
        format!("{key}.rotation_deg"),
        "only turns a procedural `shape` (a selection keeps its source's rotation_deg)",
    )?;
    ctx.check(!gaussians.is_empty(), &key, "selects no Gaussians")?;
    let mut visible = vec![true; gaussians.len()];
    let mut gaussians = gaussians;
    if let Some(fill) = &o.fill {
        let params = crate::fill::FillParams {
            spacing_m: fill.spacing_m,
            density_threshold: fill
                .density_threshold
                .unwrap_or(crate::fill::FillParams::default().density_threshold),
            max_particles: fill
                .max_particles
                .unwrap_or(crate::fill::FillParams::default().max_particles),
            max_seal_cells: fill
                .max_seal_cells
                .unwrap_or(crate::fill::FillParams::default().max_seal_cells),
            ..crate::fill::FillParams::default()
        };
        ctx.check(
            params.spacing_m.is_finite() && params.spacing_m > 0.0,
            format!("{key}.fill.spacing_m"),
            "must be > 0",
        )?;
        ctx.check(
            params.max_seal_cells <= crate::fill::MAX_SEAL_CELLS,
            format!("{key}.fill.max_seal_cells"),
            format!("must be at most {}", crate::fill::MAX_SEAL_CELLS),
        )?;
        let added = crate::fill::fill_interior(&gaussians, &params);
        let n_add = added.len();
        gaussians = concat(
            &gaussians,
            &crate::procedural::isotropic_gaussians(added, 0.5 * params.spacing_m, [0.5; 3]),
        );
        visible.extend(std::iter::repeat_n(false, n_add));
    }
    Ok(SceneObject {
        name: o.name.clone(),
        kind: o.kind,
        material: mat,
        restitution,
        friction,
        rolling_resistance_m,
        velocity_m_s: o.velocity_m_s,
        gaussians,
        visible,
        physics_spacing_m,
        grid_dx_m: o.grid_dx_m,
        shape: o.shape,
        shape_rotation: o.rotation_deg.map_or(glam::Quat::IDENTITY, euler_xyz_deg),
        surface: o.surface.unwrap_or(super::model::Surface::Separate),
    })
}

/// Largest rolling resistance an object may have (m): a lever arm longer than any object.
pub const MAX_ROLLING_RESISTANCE_M: f32 = 1.0;

/// Most Gaussians the automatic support plane is fitted to (an even stride over the rest).
const AUTO_PLANE_SAMPLE: usize = 50_000;

/// The support plane of the placed sources (RANSAC, as automatic selection finds it), over their
/// Gaussians at least half opaque, as (point on it, normal to the side objects stand on).
fn auto_plane(sources: &[Placed], seed: u64) -> Option<([f32; 3], [f32; 3])> {
    let points: Vec<[f32; 3]> = sources
        .iter()
        .flat_map(|p| {
            (0..p.cloud.len())
                .filter(|&g| p.cloud.opacity(g) >= 0.5)
                .map(|g| p.cloud.positions[g])
        })
        .collect();
    let stride = points.len().div_ceil(AUTO_PLANE_SAMPLE).max(1);
    let sample: Vec<[f32; 3]> = points.into_iter().step_by(stride).collect();
    let params = crate::selection::auto::AutoParams {
        seed,
        ..Default::default()
    };
    let fit = crate::selection::auto::ransac_plane(
        &sample,
        params.ransac_iterations,
        params.plane_tolerance_m,
        params.seed,
    )?;
    let n = Vec3::from(fit.normal);
    Some(((n * fit.offset_m).to_array(), fit.normal))
}

fn colliders(
    ctx: &Ctx,
    f: &SceneFile,
    sources: &[Placed],
    seed: u64,
) -> Result<Vec<ColliderSpec>, SceneError> {
    let mut out = Vec::new();
    for (i, c) in f.collider.iter().enumerate() {
        let key = format!("collider[{i}]");
        let shape = match (&c.plane, &c.box_) {
            (Some(PlaneChoice::Keyword(k)), None) => {
                ctx.check(
                    k == "auto",
                    format!("{key}.plane"),
                    format!("a plane is a table {{ point_m, normal }} or \"auto\", not {k:?}"),
                )?;
                let (point_m, normal) = auto_plane(sources, seed).ok_or_else(|| {
                    ctx.invalid(
                        format!("{key}.plane"),
                        "\"auto\" found no support plane in the sources (none, or too few opaque Gaussians)",
                    )
                })?;
                ColliderShape::Plane { point_m, normal }
            }
            (Some(PlaneChoice::Given(p)), None) => {
                ctx.finite3(p.point_m, format!("{key}.plane.point_m"))?;
                let n = Vec3::from(p.normal);
                ctx.check(
                    n.is_finite() && n.length() > 1e-6,
                    format!("{key}.plane.normal"),
                    "must be a non-zero vector",
                )?;
                ColliderShape::Plane {
                    point_m: p.point_m,
                    normal: n.normalize().to_array(),
                }
            }
            (None, Some(b)) => {
                ctx.check(
                    (0..3).all(|k| b.min_m[k] < b.max_m[k]),
                    format!("{key}.box"),
                    "min_m must be below max_m on every axis",
                )?;
                ColliderShape::Box {
                    min_m: b.min_m,
                    max_m: b.max_m,
                }
            }
            _ => return Err(ctx.invalid(&key, "give exactly one of `plane` or `box`")),
        };
        ctx.check(
            c.friction.is_finite() && c.friction >= 0.0,
            format!("{key}.friction"),
            "must be >= 0",
        )?;
        ctx.finite3(c.velocity_m_s, format!("{key}.velocity_m_s"))?;
        if let Some([a, b]) = c.active_s {
            ctx.check(
                a <= b,
                format!("{key}.active_s"),
                "start must not be after end",
            )?;
        }
        out.push(ColliderSpec {
            name: c.name.clone(),
            shape,
            surface: c.surface,
            friction: c.friction,
            velocity_m_s: c.velocity_m_s,
            active_s: c.active_s,
        });
    }
    Ok(out)
}

/// Builds the scene parsed from `file`; relative paths resolve against `base_dir`.
///
/// # Errors
/// Any [`SceneError`] naming the key path.
pub fn build_scene(file: &Path, base_dir: &Path, f: &SceneFile) -> Result<Scene, SceneError> {
    let ctx = Ctx { file };
    let simulation = settings(&ctx, f)?;
    let mut warnings = Vec::new();
    let mut sources = place_sources(&ctx, base_dir, f, &mut warnings)?;
    let mut objects: Vec<SceneObject> = Vec::new();
    for (i, o) in f.object.iter().enumerate() {
        ctx.check(
            !objects.iter().any(|p| p.name == o.name),
            format!("object[{i}].name"),
            format!("duplicate object name {:?}", o.name),
        )?;
        let seed = simulation.seed.wrapping_add(i as u64);
        objects.push(object(
            &ctx,
            base_dir,
            i,
            o,
            &mut sources,
            seed,
            simulation.physics_spacing_m,
        )?);
        if let Some(dx) = o.grid_dx_m {
            ctx.check(
                simulation.method == super::model::Method::Com || dx == simulation.grid_dx_m,
                format!("object[{i}].grid_dx_m"),
                format!(
                    "method {:?} steps every object on one grid of simulation.grid_dx_m = {}; \
                     a grid per object needs method \"com\"",
                    simulation.method.name(),
                    simulation.grid_dx_m
                ),
            )?;
        }
    }
    let mut background = GaussianCloud::default();
    for p in &sources {
        let rest: Vec<usize> = (0..p.cloud.len()).filter(|&i| !p.claimed[i]).collect();
        background = concat(&background, &subset(&p.cloud, &rest));
    }
    let colliders = colliders(&ctx, f, &sources, simulation.seed)?;
    let events = super::events::events(&ctx, f, &objects, &mut warnings)?;
    for (i, c) in f.camera.iter().enumerate() {
        let key = format!("camera[{i}]");
        ctx.finite3(c.position_m, format!("{key}.position_m"))?;
        ctx.finite3(c.look_at_m, format!("{key}.look_at_m"))?;
        ctx.check(
            c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0,
            format!("{key}.fov_y_deg"),
            "must be in (0, 180)",
        )?;
        ctx.check(
            c.width_px > 0 && c.height_px > 0,
            format!("{key}.width_px"),
            "image size must be > 0",
        )?;
    }
    Ok(Scene {
        simulation,
        objects,
        background,
        colliders,
        events,
        warnings,
        cameras: f.camera.clone(),
    })
}
