//! Scripted events: the `[[event]]` tables of a scene file, checked and turned into
//! [`EventSpec`]s whose commands are the one command vocabulary ([`Command`]).

use serde::Deserialize;
use splatphys_types::{CommandToml, MaterialEdit};

use super::SceneError;
use super::context::Ctx;
use super::model::{Command, EventSpec, MaterialSpec, ObjectKind, SceneObject};
use super::schema::{ImpulseToml, SceneFile, SetMaterialToml, SetVelocityToml};

/// The `[[event]]` tables: `at_s` plus a [`CommandToml`] (the keys control timelines use). The
/// form before it (`impulse = {..}`, `set_velocity = {..}`, `set_material = {..}`) is still
/// read, with a warning in `warnings`. Only object commands can be scripted; events come back
/// sorted by time (stable).
pub(super) fn events(
    ctx: &Ctx,
    f: &SceneFile,
    objects: &[SceneObject],
    warnings: &mut Vec<String>,
) -> Result<Vec<EventSpec>, SceneError> {
    let mut out = Vec::new();
    for (i, table) in f.event.iter().enumerate() {
        let key = format!("event[{i}]");
        let mut table = table.clone();
        let at_s = match table.remove("at_s") {
            Some(toml::Value::Float(t)) => t,
            Some(toml::Value::Integer(t)) => t as f64,
            Some(_) => {
                return Err(ctx.invalid(format!("{key}.at_s"), "must be a number of seconds"));
            }
            None => return Err(ctx.invalid(format!("{key}.at_s"), "missing")),
        };
        ctx.check(
            at_s.is_finite() && at_s >= 0.0,
            format!("{key}.at_s"),
            "must be >= 0",
        )?;
        let command = if let Some(old) = deprecated_event(ctx, &key, &table)? {
            warnings.push(format!(
                "{}: {key}: `impulse = {{..}}`, `set_velocity = {{..}}` and `set_material = {{..}}` are deprecated; write `command = \"{}\"` and its keys (docs/reference/scene-format.md)",
                ctx.file.display(),
                old.name()
            ));
            old
        } else {
            CommandToml::<String>::deserialize(toml::Value::Table(table))
                .map_err(|e| ctx.invalid(&key, e.to_string()))?
                .into_command()
                .map_err(|e| ctx.invalid(&key, e))?
        };
        check_event(ctx, &key, &command, objects)?;
        out.push(EventSpec { at_s, command });
    }
    out.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    Ok(out)
}

/// An event in the form before `command = ...`, if `table` is one.
fn deprecated_event(
    ctx: &Ctx,
    key: &str,
    table: &toml::Table,
) -> Result<Option<Command<String>>, SceneError> {
    let old = ["impulse", "set_velocity", "set_material"];
    let given: Vec<&str> = old.into_iter().filter(|k| table.contains_key(*k)).collect();
    if given.is_empty() {
        return Ok(None);
    }
    if given.len() > 1 || table.len() > 1 {
        return Err(ctx.invalid(
            key,
            "give `at_s` and exactly one of `impulse`, `set_velocity`, `set_material` (or, better, `command = ...` and its keys)",
        ));
    }
    let name = given[0];
    let value = table[name].clone();
    let at = |e: toml::de::Error| ctx.invalid(format!("{key}.{name}"), e.message().to_string());
    Ok(Some(match name {
        "impulse" => {
            let a = ImpulseToml::deserialize(value).map_err(at)?;
            Command::Impulse {
                object: a.object,
                impulse_n_s: a.vector_n_s,
                point_m: a.point_m,
            }
        }
        "set_velocity" => {
            let v = SetVelocityToml::deserialize(value).map_err(at)?;
            Command::SetVelocity {
                object: v.object,
                velocity_m_s: v.velocity_m_s,
                angular_velocity_rad_s: None,
            }
        }
        _ => {
            let m = SetMaterialToml::deserialize(value).map_err(at)?;
            let mut edit = MaterialEdit {
                restitution: m.restitution,
                friction: m.friction,
                ..MaterialEdit::default()
            };
            if let Some(mt) = m.material {
                let model_parameters = MaterialSpec::new(
                    mt.model,
                    mt.youngs_modulus_pa,
                    mt.poisson_ratio,
                    mt.density_kg_m3,
                );
                ctx.check(
                    mt == model_parameters,
                    format!("{key}.set_material.material"),
                    "model parameters (hardening, yield stress, ...) cannot be changed by an event; give them in the object's material",
                )?;
                edit.model = Some(mt.model);
                edit.youngs_modulus_pa = Some(mt.youngs_modulus_pa);
                edit.poisson_ratio = Some(mt.poisson_ratio);
                edit.density_kg_m3 = Some(mt.density_kg_m3);
            }
            Command::EditMaterial {
                object: m.object,
                edit,
            }
        }
    }))
}

/// What a scripted command must satisfy: an object command on an object of the scene, finite
/// vectors, material values in range.
fn check_event(
    ctx: &Ctx,
    key: &str,
    command: &Command<String>,
    objects: &[SceneObject],
) -> Result<(), SceneError> {
    let Some(object) = command.object() else {
        return Err(ctx.invalid(
            format!("{key}.command"),
            format!(
                "`{}` is a server command and cannot be scripted in a scene (impulse, set-velocity, set-pose, edit-material, set-kind can)",
                command.name()
            ),
        ));
    };
    ctx.check(
        objects.iter().any(|o| &o.name == object),
        format!("{key}.object"),
        format!("no object named {object:?}"),
    )?;
    let finite = |v: &[f64], k: &str| {
        ctx.check(
            v.iter().all(|x| x.is_finite()),
            format!("{key}.{k}"),
            "must be finite",
        )
    };
    match command {
        Command::Impulse {
            impulse_n_s,
            point_m,
            ..
        } => {
            finite(impulse_n_s, "impulse_n_s")?;
            finite(point_m.as_ref().map_or(&[], |p| &p[..]), "point_m")
        }
        Command::SetVelocity {
            velocity_m_s,
            angular_velocity_rad_s,
            ..
        } => {
            finite(velocity_m_s, "velocity_m_s")?;
            finite(
                angular_velocity_rad_s.as_ref().map_or(&[], |w| &w[..]),
                "angular_velocity_rad_s",
            )
        }
        Command::SetPose {
            position_m,
            orientation_wxyz,
            ..
        } => {
            ctx.check(
                objects
                    .iter()
                    .any(|o| &o.name == object && o.kind == ObjectKind::Kinematic),
                format!("{key}.object"),
                format!("{object:?} is not kinematic; set-pose drives kinematic objects"),
            )?;
            finite(position_m, "position_m")?;
            finite(orientation_wxyz, "orientation_wxyz")?;
            ctx.check(
                orientation_wxyz.iter().map(|x| x * x).sum::<f64>() > 1e-12,
                format!("{key}.orientation_wxyz"),
                "must be a rotation (not zero)",
            )
        }
        Command::EditMaterial { edit, .. } => {
            let range = |v: Option<f64>, k: &str, ok: fn(f64) -> bool, what: &str| {
                ctx.check(v.is_none_or(ok), format!("{key}.{k}"), what)
            };
            range(
                edit.youngs_modulus_pa,
                "youngs_modulus_pa",
                |v| v.is_finite() && v > 0.0,
                "must be > 0",
            )?;
            range(
                edit.poisson_ratio,
                "poisson_ratio",
                |v| v > -1.0 && v < 0.5,
                "must be in (-1, 0.5)",
            )?;
            range(
                edit.density_kg_m3,
                "density_kg_m3",
                |v| v.is_finite() && v > 0.0,
                "must be > 0",
            )?;
            range(
                edit.restitution,
                "restitution",
                |v| (0.0..=1.0).contains(&v),
                "must be in [0, 1]",
            )?;
            range(
                edit.friction,
                "friction",
                |v| v.is_finite() && v >= 0.0,
                "must be finite and >= 0",
            )
        }
        _ => Ok(()),
    }
}
