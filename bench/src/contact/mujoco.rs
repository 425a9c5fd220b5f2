//! The MuJoCo side of `bench contact`: the same [`ContactScene`] in MuJoCo (pip package
//! `mujoco`, 4.x), run as a Python child process, `bench/mujoco/contact.py`.
//!
//! The scene goes to the script as one JSON document on stdin ([`input_json`]): each body its
//! shape (box or ball of the scene's size), geometric centre and start orientation, and the mass,
//! centre of mass and inertia tensor the splatphys world computed from its particles
//! ([`MassProps`]), as for rapier; the statics are the ground (the plane z = 0, normal +z) and
//! the walls (fixed axis-aligned boxes); every surface gets the scene's friction, gravity is the
//! world's (as for rapier). The script builds an MJCF model of free-joint bodies (explicit
//! `<inertial>`, sleeping disabled), steps it with `mj_step` and answers one JSON document on
//! stdout: the steps, the fixed step, the wall time of the `mj_step` calls, and per body the COM,
//! the rotation from the start pose, the COM velocity and the angular velocity (world frame),
//! plus the deepest contact it saw ([`MujocoRun`]).
//!
//! Everything else is MuJoCo's default: a 0.002 s step unless `dt_s` is given, the Euler
//! integrator, the Newton solver, the pyramidal friction cone, 100 iterations, soft contacts
//! (solref 0.02 1): MuJoCo has no restitution coefficient, so the scene's restitution is not
//! passed (a line on stderr says so when it is not 0).
//!
//! A missing script is an error (a broken checkout, [`find_script`]); a missing `python3` or a
//! Python without `mujoco` (the script exits with [`EXIT_NO_MUJOCO`]) is a skip: one line on
//! stderr and `Ok(None)`.

use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail, ensure};
use glam::{DQuat, DVec3};
use serde::Deserialize;
use serde_json::{Value, json};

use super::scenes::{BodyShape, ContactScene, ContactSettings};
use super::{EngineRun, FinalBody, MassProps};

/// The script of `bench contact` under `bench/mujoco/`.
pub const SCRIPT: &str = "contact.py";

/// The exit status of the script when `import mujoco` fails.
pub const EXIT_NO_MUJOCO: i32 = 3;

/// The message when MuJoCo cannot be run.
pub const NOT_INSTALLED: &str = "mujoco is not installed: pip install mujoco";

/// Gravity of the contact scenes (m/s²): [`ContactScene::to_scene`] keeps the scene builder's
/// default; `bench contact` passes the world's own value, the tests this one.
pub const GRAVITY_M_S2: DVec3 = DVec3::new(0.0, 0.0, -9.81);

/// One MuJoCo run of one scene: the [`EngineRun`] and what only MuJoCo reports.
#[derive(Debug, Clone, PartialEq)]
pub struct MujocoRun {
    /// "mujoco" and its version, e.g. "mujoco 4.0.0".
    pub engine: String,
    /// Deepest contact over the run, sampled every 10 steps: the largest −dist of MuJoCo's
    /// contacts (m; 0 when none penetrated).
    pub deepest_contact_m: f64,
    /// MuJoCo warnings that fired, with their counts (`mjWARN_BADQACC` means MuJoCo reset the
    /// state: the run is void); empty on a clean run.
    pub warnings: Vec<(String, u64)>,
    /// Steps, times and bodies at the end, in scene order.
    pub run: EngineRun,
}

/// Runs `scene` in MuJoCo for `duration_s` with the masses of `mass` and gravity `gravity_m_s2`
/// (m/s²), at MuJoCo's default step (0.002 s) or `dt_s` (s), through `python script` (see
/// [`find_script`]); warnings MuJoCo raised go to stderr, one line.
///
/// `Ok(None)` when `python` cannot be started or has no `mujoco` (after one line on stderr).
///
/// # Errors
/// When `mass` does not hold one entry per body, a duration, step or mass is not positive and
/// finite, or the script fails or answers something else than its result (naming the script,
/// with its stderr).
#[allow(clippy::too_many_arguments)]
pub fn run(
    scene: &ContactScene,
    mass: &[MassProps],
    settings: &ContactSettings,
    gravity_m_s2: DVec3,
    duration_s: f64,
    dt_s: Option<f64>,
    python: &str,
    script: &Path,
) -> Result<Option<MujocoRun>> {
    let input = input_json(scene, mass, settings, gravity_m_s2, duration_s, dt_s)?;
    if settings.restitution != 0.0 {
        eprintln!(
            "mujoco: restitution {} not passed: MuJoCo has no restitution coefficient and runs \
             its default soft contact",
            settings.restitution
        );
    }
    let Some(r) = run_input(&input, scene.bodies.len(), python, script)? else {
        return Ok(None);
    };
    if !r.warnings.is_empty() {
        eprintln!(
            "mujoco: {}: MuJoCo warned {}",
            scene.kind.name(),
            r.warnings
                .iter()
                .map(|(w, n)| format!("{w} × {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(Some(r))
}

/// The script's input document for `scene` (the format is in `bench/mujoco/contact.py`): bodies
/// in scene order with their start orientations ([`super::scenes::BodySpec::orientation_wxyz`])
/// and the masses of `mass`, the ground and the walls as statics, every surface of friction
/// `settings.friction`, gravity `gravity_m_s2` (m/s²), `duration_s` simulated at `dt_s` (s;
/// `None`: MuJoCo's default).
///
/// # Errors
/// When `mass` does not hold one entry per body, or a duration, step or mass is not positive and
/// finite.
pub fn input_json(
    scene: &ContactScene,
    mass: &[MassProps],
    settings: &ContactSettings,
    gravity_m_s2: DVec3,
    duration_s: f64,
    dt_s: Option<f64>,
) -> Result<Value> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    ensure!(
        mass.len() == scene.bodies.len(),
        "{} mass properties for {} bodies",
        mass.len(),
        scene.bodies.len()
    );
    ensure!(
        positive(duration_s),
        "MuJoCo duration must be positive, got {duration_s} s"
    );
    if let Some(dt) = dt_s {
        ensure!(positive(dt), "MuJoCo step must be positive, got {dt} s");
    }
    ensure!(
        gravity_m_s2.is_finite(),
        "gravity {gravity_m_s2} is not finite"
    );
    let v3 = |v: [f32; 3]| v.map(f64::from);
    let mut bodies = Vec::with_capacity(scene.bodies.len());
    for (b, m) in scene.bodies.iter().zip(mass) {
        ensure!(
            positive(m.mass_kg) && m.com_m.is_finite() && m.inertia_kg_m2.is_finite(),
            "body {}: mass {} kg, COM {} m, inertia {} kg m²: not a rigid body MuJoCo can take",
            b.name,
            m.mass_kg,
            m.com_m,
            m.inertia_kg_m2
        );
        let i = m.inertia_kg_m2;
        let mut body = match b.shape {
            BodyShape::Cuboid { half_extents_m } => {
                json!({"shape": "box", "half_extents_m": v3(half_extents_m)})
            }
            BodyShape::Ball { radius_m } => {
                json!({"shape": "ball", "radius_m": f64::from(radius_m)})
            }
        };
        body["center_m"] = json!(v3(b.center_m));
        let q = b.orientation();
        body["orientation_wxyz"] = json!([q.w, q.x, q.y, q.z]);
        body["mass_kg"] = json!(m.mass_kg);
        body["com_m"] = json!(m.com_m.to_array());
        body["inertia_kg_m2"] = json!([
            i.row(0).to_array(),
            i.row(1).to_array(),
            i.row(2).to_array()
        ]);
        bodies.push(body);
    }
    let mut statics = vec![json!({
        "shape": "plane",
        "point_m": [0.0, 0.0, 0.0],
        "normal": [0.0, 0.0, 1.0],
    })];
    for [lo, hi] in &scene.walls {
        let (lo, hi) = (DVec3::from_array(v3(*lo)), DVec3::from_array(v3(*hi)));
        statics.push(json!({
            "shape": "box",
            "center_m": ((lo + hi) / 2.0).to_array(),
            "half_extents_m": ((hi - lo) / 2.0).to_array(),
        }));
    }
    Ok(json!({
        "scene": scene.kind.name(),
        "duration_s": duration_s,
        "dt_s": dt_s,
        "gravity_m_s2": gravity_m_s2.to_array(),
        "friction": f64::from(settings.friction),
        "bodies": bodies,
        "statics": statics,
    }))
}

/// The script's answer (the format is in `bench/mujoco/contact.py`).
#[derive(Debug, Deserialize)]
struct Output {
    engine: String,
    steps: u64,
    dt_s: f64,
    wall_s: f64,
    simulated_s: f64,
    bodies: Vec<OutputBody>,
    deepest_contact_m: f64,
    #[serde(default)]
    warnings: std::collections::BTreeMap<String, u64>,
}

/// One body of the script's answer.
#[derive(Debug, Deserialize)]
struct OutputBody {
    com_m: [f64; 3],
    orientation_wxyz: [f64; 4],
    velocity_m_s: [f64; 3],
    omega_rad_s: [f64; 3],
}

/// Runs `python script` on `input` ([`input_json`]) and reads its answer for `bodies` bodies.
///
/// `Ok(None)` when `python` cannot be found or the script exits with [`EXIT_NO_MUJOCO`] (after
/// one line on stderr).
///
/// # Errors
/// When the child cannot be started, exits with another non-zero status, or answers no result
/// document for `bodies` bodies; naming the script, with its stderr.
pub fn run_input(
    input: &Value,
    bodies: usize,
    python: &str,
    script: &Path,
) -> Result<Option<MujocoRun>> {
    let text = serde_json::to_string(input).context("writing the MuJoCo input")?;
    let who = format!("{python} {}", script.display());
    let child = Command::new(python)
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Err(e) if e.kind() == ErrorKind::NotFound => {
            eprintln!("{NOT_INSTALLED} ({python}: {e}); MuJoCo skipped");
            return Ok(None);
        }
        other => other.with_context(|| format!("starting {who}"))?,
    };
    let mut stdin = child
        .stdin
        .take()
        .with_context(|| format!("{who}: no stdin pipe"))?;
    // Write from a second thread, so neither side waits on a full pipe.
    let (written, out) = std::thread::scope(|s| {
        let writer = s.spawn(move || stdin.write_all(text.as_bytes()));
        let out = child.wait_with_output();
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(std::io::Error::other("the stdin writer panicked")));
        (written, out)
    });
    let out = out.with_context(|| format!("waiting for {who}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(EXIT_NO_MUJOCO) {
        eprintln!("{NOT_INSTALLED} ({}); MuJoCo skipped", last_line(&stderr));
        return Ok(None);
    }
    if !out.status.success() {
        bail!(
            "{who} failed ({}); its stderr ends with:\n{}",
            out.status,
            tail(&stderr, 20)
        );
    }
    written.with_context(|| format!("writing the scene to {who}"))?;
    let o: Output = serde_json::from_str(stdout.trim()).with_context(|| {
        format!(
            "{who} answered no result document; its stderr ends with:\n{}",
            tail(&stderr, 20)
        )
    })?;
    ensure!(
        o.bodies.len() == bodies,
        "{who} answered {} bodies for {bodies}",
        o.bodies.len()
    );
    ensure!(
        o.dt_s.is_finite() && o.dt_s > 0.0,
        "{who} answered the step {} s",
        o.dt_s
    );
    let bodies = o
        .bodies
        .iter()
        .map(|b| {
            let [w, x, y, z] = b.orientation_wxyz;
            FinalBody {
                com_m: DVec3::from_array(b.com_m),
                orientation: DQuat::from_xyzw(x, y, z, w).normalize(),
                velocity_m_s: DVec3::from_array(b.velocity_m_s),
                omega_rad_s: DVec3::from_array(b.omega_rad_s),
                asleep: false,
            }
        })
        .collect();
    Ok(Some(MujocoRun {
        engine: o.engine,
        deepest_contact_m: o.deepest_contact_m,
        warnings: o.warnings.into_iter().collect(),
        run: EngineRun {
            steps: o.steps,
            simulated_s: o.simulated_s,
            dt_range_s: [o.dt_s, o.dt_s],
            wall_s: o.wall_s,
            cpu_s: None,
            particles: None,
            bodies,
        },
    }))
}

/// The script `name` (e.g. [`SCRIPT`]): `explicit` when given, else `bench/mujoco/<name>` under
/// the current directory, the repository two levels above the executable (`target/release/`)
/// or the source tree this binary was built from.
///
/// # Errors
/// When the script is not a file, naming the places tried.
pub fn find_script(name: &str, explicit: Option<&Path>) -> Result<PathBuf> {
    crate::script::find("mujoco", name, explicit, "--mujoco-script", "MuJoCo")
}

fn last_line(s: &str) -> &str {
    s.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("")
}

fn tail(s: &str, lines: usize) -> String {
    let all: Vec<&str> = s.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::scenes::{BodySpec, IDENTITY_WXYZ, SceneKind};
    use glam::DMat3;

    fn settings() -> ContactSettings {
        ContactSettings::for_tests()
    }

    /// Exact mass properties of `scene`'s bodies at 1000 kg/m³.
    fn exact_mass(scene: &ContactScene) -> Vec<MassProps> {
        scene
            .bodies
            .iter()
            .map(|b| {
                let c = DVec3::from_array(b.center_m.map(f64::from));
                let (m, i) = match b.shape {
                    BodyShape::Cuboid { half_extents_m } => {
                        let [x, y, z] = half_extents_m.map(|h| 2.0 * f64::from(h));
                        let m = 1000.0 * x * y * z;
                        let d = DVec3::new(y * y + z * z, x * x + z * z, x * x + y * y);
                        (m, d * m / 12.0)
                    }
                    BodyShape::Ball { radius_m } => {
                        let r = f64::from(radius_m);
                        let m = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
                        (m, DVec3::splat(0.4 * m * r * r))
                    }
                };
                MassProps {
                    mass_kg: m,
                    com_m: c,
                    inertia_kg_m2: DMat3::from_diagonal(i),
                }
            })
            .collect()
    }

    #[test]
    fn input_carries_the_start_orientations() {
        let scene = ContactScene::new(SceneKind::Cubes, 0, 4);
        let mass = exact_mass(&scene);
        let v = input_json(&scene, &mass, &settings(), GRAVITY_M_S2, 1.0, Some(0.001)).unwrap();
        assert_eq!(v["bodies"].as_array().map(Vec::len), Some(125));
        assert_eq!(v["dt_s"], json!(0.001));
        for (b, spec) in v["bodies"].as_array().unwrap().iter().zip(&scene.bodies) {
            let q: Vec<f64> = b["orientation_wxyz"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            let want = spec.orientation_wxyz.map(f64::from);
            let err = q
                .iter()
                .zip(want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-6, "{}: {q:?} vs {want:?}", spec.name);
        }
    }

    #[test]
    fn input_has_the_bodies_ground_and_walls() {
        let scene = ContactScene::new(SceneKind::Pile, 30, 0);
        let mass = exact_mass(&scene);
        let v = input_json(&scene, &mass, &settings(), GRAVITY_M_S2, 1.0, None).unwrap();
        assert_eq!(v["bodies"].as_array().map(Vec::len), Some(30));
        assert_eq!(
            v["statics"].as_array().map(Vec::len),
            Some(1 + scene.walls.len())
        );
        assert_eq!(v["statics"][0]["shape"], "plane");
        assert_eq!(v["statics"][1]["shape"], "box");
        assert!(v["dt_s"].is_null());
        for (b, spec) in v["bodies"].as_array().unwrap().iter().zip(&scene.bodies) {
            let shape = b["shape"].as_str().unwrap();
            assert_eq!(shape, spec.shape.name());
            assert_eq!(b["half_extents_m"].is_array(), shape == "box");
            assert_eq!(b["radius_m"].is_number(), shape == "ball");
            assert_eq!(b["orientation_wxyz"], json!([1.0, 0.0, 0.0, 0.0]));
            assert_eq!(b["inertia_kg_m2"].as_array().map(Vec::len), Some(3));
        }
        let err = input_json(&scene, &mass[1..], &settings(), GRAVITY_M_S2, 1.0, None);
        assert!(err.is_err());
        let err = input_json(&scene, &mass, &settings(), GRAVITY_M_S2, 1.0, Some(0.0));
        assert!(err.is_err());
    }

    #[test]
    fn a_missing_python_is_a_skip() {
        let scene = ContactScene::new(SceneKind::Stack, 0, 0);
        let mass = exact_mass(&scene);
        let script = Path::new("bench/mujoco/contact.py");
        let r = run(
            &scene,
            &mass,
            &settings(),
            GRAVITY_M_S2,
            0.1,
            None,
            "/nonexistent/python3",
            script,
        );
        assert!(matches!(r, Ok(None)), "{r:?}");
    }

    #[test]
    fn mujoco_holds_a_box_at_rest_on_the_ground() {
        // A 10 cm box of 1 kg standing on the ground: after 1 s at MuJoCo's default step its COM
        // has moved less than 1 mm (MuJoCo's soft contact sags by a fraction of that). Skipped
        // (passes) where python3 or mujoco is missing.
        let h = 0.05_f32;
        let scene = ContactScene {
            kind: SceneKind::Stack,
            bodies: vec![BodySpec {
                name: "box".into(),
                shape: BodyShape::Cuboid {
                    half_extents_m: [h; 3],
                },
                center_m: [0.0, 0.0, h],
                orientation_wxyz: IDENTITY_WXYZ,
                settle_drop_m: Some(0.0),
            }],
            walls: Vec::new(),
        };
        let mass = exact_mass(&scene);
        let script = find_script(SCRIPT, None).unwrap();
        let g = GRAVITY_M_S2;
        let Some(m) = run(&scene, &mass, &settings(), g, 1.0, None, "python3", &script).unwrap()
        else {
            return;
        };
        assert!(m.engine.starts_with("mujoco "), "{}", m.engine);
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        // It stands on the ground from the start: soft contact sinks it, by well under 1 mm.
        assert!((0.0..1e-3).contains(&m.deepest_contact_m));
        let r = m.run;
        assert_eq!(r.steps, 500);
        assert_eq!(r.dt_range_s, [0.002, 0.002]);
        assert!(r.wall_s > 0.0);
        let drift_m = (r.bodies[0].com_m - mass[0].com_m).length();
        assert!(drift_m < 1e-3, "drifted {drift_m} m");
        assert!(!r.bodies[0].asleep);
    }
}
