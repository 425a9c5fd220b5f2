//! The restitution law where a deformable object meets a solid on its grid.
//!
//! Boundary nodes stop a deformable object's approach, and its rebound is then its own
//! elasticity: an MPM jelly is nearly lossless, so without more it would bounce off a static
//! table for ever whatever e says. The law is applied at the object level, as the paper does for
//! object pairs: when a deformable object starts touching a solid, its approach speed a along the
//! contact normal n (the direction of the grid's impulse on it) is recorded; when the contact
//! ends, a separation speed s above e·a (e = max(e_object, e_solid), the background's e is 0;
//! above the normal velocity at first touch when the object was already separating then, so a
//! grazing second touch does not take a rebound away) is removed by a uniform velocity change
//! −(s − e a) n, which leaves its deformation and angular momentum alone and only ever removes
//! energy; a rigid solid takes the opposite momentum (a kinematic or static one counts it in its
//! contact force). A resting object never ends its contact and is not touched.

use glam::DVec3;

use super::World;
use super::body::measure_bounds;
use crate::contact::mix_restitution;
use crate::scene::ObjectKind;

/// A solid a deformable object touched: an object index, or `None` for the background.
pub(super) type SolidOf = Option<usize>;

/// A contact between a deformable object and a solid, from its first substep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Contact normal, pointing from the solid into the deformable object.
    pub normal: DVec3,
    /// Approach speed along the normal at first touch (m/s, >= 0).
    pub approach_m_s: f64,
    /// Relative normal velocity at first touch (m/s, positive when already separating).
    pub touch_m_s: f64,
}

impl World {
    fn solid_velocity(&self, solid: SolidOf) -> DVec3 {
        match solid {
            Some(k) if self.bodies[k].moves_rigidly() => self.bodies[k].rigid.velocity_m_s,
            _ => DVec3::ZERO,
        }
    }

    /// Opens and closes impacts from this substep's `touches` (deformable, solid, impulse the
    /// grid gave the deformable in N s) and applies the law to the closed ones (module docs).
    pub(super) fn boundary_restitution(&mut self, touches: &[(usize, SolidOf, DVec3)]) {
        let dx = self.dx_m();
        for &(k, solid, j) in touches {
            let Some(n) = j.try_normalize() else { continue };
            if self.impacts.contains_key(&(k, solid)) {
                continue;
            }
            let v = measure_bounds(&self.bodies[k].particles, dx).velocity_m_s;
            let touch = (v - self.solid_velocity(solid)).dot(n);
            self.impacts.insert(
                (k, solid),
                Impact {
                    normal: n,
                    approach_m_s: (-touch).max(0.0),
                    touch_m_s: touch,
                },
            );
        }
        let mut ended: Vec<((usize, SolidOf), Impact)> = self
            .impacts
            .iter()
            .filter(|(key, _)| !touches.iter().any(|(k, s, _)| (*k, *s) == **key))
            .map(|(key, imp)| (*key, *imp))
            .collect();
        ended.sort_by_key(|((k, s), _)| (*k, s.map_or(usize::MAX, |s| s)));
        for ((k, solid), imp) in ended {
            self.impacts.remove(&(k, solid));
            let b = &self.bodies[k];
            if b.kind != ObjectKind::Deformable || b.sleeping {
                continue;
            }
            let s = measure_bounds(&b.particles, dx);
            let separation = (s.velocity_m_s - self.solid_velocity(solid)).dot(imp.normal);
            let e_solid = solid.map_or(0.0, |o| self.bodies[o].restitution);
            let e = mix_restitution(b.restitution, e_solid) as f64;
            // A touch while already separating (the far side of a ringing object grazing the
            // boundary again) keeps the speed it came with: the law caps what a contact adds.
            let excess = separation - (e * imp.approach_m_s).max(imp.touch_m_s);
            if excess <= 0.0 || !excess.is_finite() {
                continue;
            }
            let dv = (imp.normal * -excess).as_vec3a();
            let b = &mut self.bodies[k];
            b.particles.v.iter_mut().for_each(|v| *v += dv);
            b.max_speed_m_s = b.particles.v.iter().map(|v| v.length()).fold(0.0, f32::max);
            if let Some(o) = solid {
                let p = imp.normal * (excess * s.mass_kg);
                let com = self.bodies[o].rigid.com_m;
                self.bodies[o].record_contact(p, com);
                if self.bodies[o].kind == ObjectKind::Rigid && !self.bodies[o].sleeping {
                    self.bodies[o].apply_rigid_impulse(p, com);
                }
            }
        }
    }
}
