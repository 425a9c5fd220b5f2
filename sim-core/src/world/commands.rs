//! Commands on objects: impulses, velocities, poses, material and kind edits. Each wakes the
//! object; static objects refuse to move, kinematic objects refuse impulses (`set-pose` is in
//! [`super::kinematic`]). Used by scene events and the server's command service.

use glam::{DVec3, Vec3A};
use splatphys_types::{Command, MaterialEdit};

use super::{World, WorldError, coherence, measure};
use crate::material::{ConstitutiveModel, Material};
use crate::scene::ObjectKind;

impl World {
    /// Applies `command` (scene events and the server's command service both end here).
    /// `Reset` resets the world; `Pause`, `Resume`, `Step` and `Shutdown` are the server's and
    /// do nothing here. Values are narrowed to the solver's f32.
    ///
    /// # Errors
    /// As the command's method: unknown or static object, a refused material.
    pub fn apply(&mut self, command: &Command) -> Result<(), WorldError> {
        let v = |a: [f64; 3]| DVec3::from(a).as_vec3a();
        match *command {
            Command::Impulse {
                object,
                impulse_n_s,
                point_m,
            } => self.apply_impulse(object as usize, v(impulse_n_s), point_m.map(v)),
            Command::SetVelocity {
                object,
                velocity_m_s,
                angular_velocity_rad_s,
            } => self.set_velocity(
                object as usize,
                v(velocity_m_s),
                angular_velocity_rad_s.map(v),
            ),
            Command::SetPose {
                object,
                position_m,
                orientation_wxyz,
                at_step,
            } => self.set_pose(object as usize, position_m, orientation_wxyz, at_step),
            Command::EditMaterial { object, edit } => self.edit_material(object as usize, &edit),
            Command::SetKind { object, kind } => self.set_kind(object as usize, kind),
            Command::Reset => {
                self.reset();
                Ok(())
            }
            Command::Pause | Command::Resume | Command::Step { .. } | Command::Shutdown => Ok(()),
        }
    }

    /// Edits object `id`'s material: only the fields `edit` names change, starting from the
    /// object's own spec (a snow object keeps its θc, θs and ξ when only E is edited).
    ///
    /// # Errors
    /// Unknown object or a refused material.
    pub fn edit_material(&mut self, id: usize, edit: &MaterialEdit) -> Result<(), WorldError> {
        let b = self
            .bodies
            .get(id)
            .ok_or_else(|| WorldError::UnknownObject(format!("#{id}")))?;
        let spec = edit
            .changes_material()
            .then(|| b.materials[0].spec().edited(edit));
        self.set_material(
            id,
            spec.as_ref(),
            edit.restitution.map(|e| e as f32),
            edit.friction.map(|mu| mu as f32),
        )
    }

    fn movable(&self, id: usize) -> Result<(), WorldError> {
        let b = self
            .bodies
            .get(id)
            .ok_or_else(|| WorldError::UnknownObject(format!("#{id}")))?;
        if b.kind == ObjectKind::Static {
            return Err(WorldError::Refused {
                object: b.name.clone(),
                reason: "static objects do not move".into(),
            });
        }
        Ok(())
    }

    /// Applies impulse `j_n_s` (N s) to object `id` at `point_m` (default: its COM).
    ///
    /// # Errors
    /// Unknown or static object, or a non-finite value.
    pub fn apply_impulse(
        &mut self,
        id: usize,
        j_n_s: Vec3A,
        point_m: Option<Vec3A>,
    ) -> Result<(), WorldError> {
        // It reads and edits the particles on the host (`device.rs`).
        self.sync_devices(true)?;
        self.movable(id)?;
        if self.bodies[id].kind == ObjectKind::Kinematic {
            return Err(WorldError::Refused {
                object: self.bodies[id].name.clone(),
                reason: "kinematic objects move only as commanded (set-pose, set-velocity)".into(),
            });
        }
        if !j_n_s.is_finite() || point_m.is_some_and(|p| !p.is_finite()) {
            return Err(WorldError::Refused {
                object: self.bodies[id].name.clone(),
                reason: "non-finite impulse".into(),
            });
        }
        self.check_impulse(id, j_n_s.as_dvec3(), point_m.map(|p| p.as_dvec3()))?;
        self.wake(id);
        self.forget_impacts(id);
        let b = &mut self.bodies[id];
        let dx = b.dx_m();
        let com_m = match b.kind {
            ObjectKind::Rigid => b.rigid.com_m,
            _ => measure(&b.particles, dx).com_m,
        };
        let point = point_m.map(|p| p.as_dvec3()).unwrap_or(com_m);
        match b.kind {
            ObjectKind::Rigid => {
                b.apply_rigid_impulse(j_n_s.as_dvec3(), point);
                b.max_speed_m_s = b.rigid_speed_m_s();
            }
            _ => {
                // The zone: particles within 3 cells of the point (all of them for the COM).
                let r2 = (3.0 * dx as f64).powi(2);
                let zone: Vec<u32> = if point_m.is_some() {
                    (0..b.particles.len())
                        .filter(|&i| (b.particles.x[i].as_dvec3() - point).length_squared() <= r2)
                        .map(|i| i as u32)
                        .collect()
                } else {
                    Vec::new()
                };
                coherence::apply_impulse(b, j_n_s.as_dvec3(), DVec3::ZERO, point, &zone);
            }
        }
        Ok(())
    }

    /// Sets object `id`'s COM velocity (m/s) and, when `omega_rad_s` is given, its angular
    /// velocity about the COM (rad/s), keeping its internal motion (a deformable object gets the
    /// angular momentum I ω). A kinematic object keeps these velocities until its next command.
    ///
    /// # Errors
    /// Unknown or static object, a non-finite value, or a speed above the command limit.
    pub fn set_velocity(
        &mut self,
        id: usize,
        v_m_s: Vec3A,
        omega_rad_s: Option<Vec3A>,
    ) -> Result<(), WorldError> {
        // It reads and edits the particles on the host (`device.rs`).
        self.sync_devices(true)?;
        self.movable(id)?;
        if !v_m_s.is_finite() || omega_rad_s.is_some_and(|w| !w.is_finite()) {
            return Err(WorldError::Refused {
                object: self.bodies[id].name.clone(),
                reason: "non-finite velocity".into(),
            });
        }
        let omega = omega_rad_s.map(|w| w.as_dvec3());
        self.check_velocity(id, v_m_s.as_dvec3(), omega)?;
        self.wake(id);
        self.forget_impacts(id);
        let b = &mut self.bodies[id];
        let dx = b.dx_m();
        match b.kind {
            ObjectKind::Rigid | ObjectKind::Kinematic => {
                b.rigid.velocity_m_s = v_m_s.as_dvec3();
                if let Some(w) = omega {
                    b.rigid.omega_rad_s = w;
                }
                b.drive = super::kinematic::Drive::Velocity;
                b.max_speed_m_s = b.rigid_speed_m_s();
            }
            _ => {
                let s = measure(&b.particles, dx);
                let l = omega.map_or(s.angular_momentum, |w| s.inertia * w);
                coherence::enforce(b, v_m_s.as_dvec3() * s.mass_kg, l, s.com_m);
                b.max_speed_m_s = b.particles.v.iter().map(|v| v.length()).fold(0.0, f32::max);
            }
        }
        Ok(())
    }

    /// Replaces object `id`'s material and/or contact coefficients. Masses follow a new density.
    ///
    /// # Errors
    /// Unknown object or a refused material.
    pub fn set_material(
        &mut self,
        id: usize,
        spec: Option<&crate::material::MaterialSpec>,
        restitution: Option<f32>,
        friction: Option<f32>,
    ) -> Result<(), WorldError> {
        // It reads and edits the particles on the host (`device.rs`).
        self.sync_devices(true)?;
        let name = &self
            .bodies
            .get(id)
            .ok_or_else(|| WorldError::UnknownObject(format!("#{id}")))?
            .name;
        let checked = match spec {
            Some(spec) => {
                let m = Material::from_spec(spec).map_err(|source| WorldError::Material {
                    object: name.clone(),
                    source,
                })?;
                self.check_material(id, spec, &m)?;
                Some(m)
            }
            None => None,
        };
        if let Some(e) = restitution
            && !(0.0..=1.0).contains(&e)
        {
            return Err(WorldError::Refused {
                object: name.clone(),
                reason: format!("restitution {e} is outside [0, 1]"),
            });
        }
        if let Some(mu) = friction
            && !(mu.is_finite() && mu >= 0.0)
        {
            return Err(WorldError::Refused {
                object: name.clone(),
                reason: format!("friction {mu} must be finite and >= 0"),
            });
        }
        let b = &mut self.bodies[id];
        if let Some(m) = checked {
            let rho = m.density_kg_m3();
            let ratio = (rho / b.materials[0].density_kg_m3()) as f64;
            let p0 = m.initial_plastic_state();
            let new_model = m.name() != b.materials[0].name();
            // A solid's particles wait in its template; a deformable object's are live.
            for p in [&mut b.particles, &mut b.template] {
                for (mass, vol) in p.mass_kg.iter_mut().zip(&p.volume0_m3) {
                    *mass = rho * vol;
                }
                if new_model {
                    p.plastic.iter_mut().for_each(|p| *p = p0);
                }
            }
            b.materials[0] = m;
            // One density throughout: mass and inertia scale, the pose and surface stay.
            b.rigid.mass_kg *= ratio;
            b.rigid.inertia_rest *= ratio;
        }
        if let Some(e) = restitution {
            b.restitution = e.clamp(0.0, 1.0);
        }
        if let Some(mu) = friction {
            b.friction = mu.max(0.0);
        }
        self.wake(id);
        Ok(())
    }

    /// Changes object `id`'s kind. Becoming a solid (rigid, static, kinematic) freezes the
    /// current shape as the rest shape; a kinematic object starts still.
    ///
    /// # Errors
    /// Unknown object.
    pub fn set_kind(&mut self, id: usize, kind: ObjectKind) -> Result<(), WorldError> {
        // It reads and edits the particles on the host (`device.rs`).
        self.sync_devices(true)?;
        let b = self
            .bodies
            .get_mut(id)
            .ok_or_else(|| WorldError::UnknownObject(format!("#{id}")))?;
        let solid = |k: ObjectKind| k != ObjectKind::Deformable;
        if solid(kind) && !solid(b.kind) {
            // The current shape, as it is, becomes the rest shape and the collision surface;
            // the particles wait in the body-frame template.
            b.capture_rigid_pose();
            b.build_collision(None, glam::Quat::IDENTITY);
            b.freeze();
        }
        if matches!(kind, ObjectKind::Static | ObjectKind::Kinematic) {
            b.rigid.velocity_m_s = glam::DVec3::ZERO;
            b.rigid.omega_rad_s = glam::DVec3::ZERO;
            b.drive = super::kinematic::Drive::Velocity;
            b.max_speed_m_s = 0.0;
        }
        if !solid(kind) && solid(b.kind) {
            // The template placed by the pose, moving as the body did.
            b.collision = None;
            b.thaw();
        }
        let frozen = solid(kind) && !solid(b.kind);
        b.kind = kind;
        // Where it leaned as another kind is not where it leans now.
        b.supports.clear();
        if frozen {
            self.contacts.made_solid.push(id);
        }
        self.wake(id);
        Ok(())
    }
}
