//! Islands: objects that cannot touch before the next synchronisation step separately, each
//! island at its own CFL substep.
//!
//! A deformable object's CFL bound dt = C dx / (c_p + |v|max) depends on its own material and
//! grid, so a world stepped as one whole takes every object at the substep of its stiffest one.
//! Under method `com`, at the start of each frame (and at each scene event inside it) the
//! movable objects are grouped into islands. Over the interval T to the next synchronisation an
//! object stays inside its bounding box swept by
//!
//!   reach = 2 (s + |g| T) T + 2 dx + the collision cell,
//!
//! where s is its fastest speed now (a deformable object's fastest particle; a rigid or kinematic
//! object's |v| + |ω| r, r the distance of its farthest point from its COM; a kinematic object on
//! its way to a pose sweeps the whole way there). The factor 2 covers what gravity, elasticity and the
//! contacts inside its island can add to the speed over T; the two cells cover the reach of the
//! grid boundaries and contact margins. Two objects whose swept boxes overlap share an island,
//! and so do the objects chained through them (union-find, as Box2D builds its islands; Catto,
//! "Iterative Dynamics with Temporal Coherence", GDC 2005). Static objects, grid colliders and the
//! captured background never move: every island sees them and none is joined through them.
//!
//! Each island then steps on its own from the synchronisation time to the next (the frame's end
//! or the next event), with the smallest CFL substep of its members, and the islands meet again
//! there. Objects of different islands cannot reach each other in between, so stepping them
//! apart changes nothing but how many substeps each takes: a stiff object no longer forces its
//! substeps on a soft one out of its reach. While an island steps, the others' contact caches
//! and resting pairs are set aside, and `World::stepping` hides their objects from every part
//! of the substep. Each island's substeps are counted in [`crate::world::WorldStats::substeps`]
//! and per object in [`crate::world::Body::substeps_taken`].
//!
//! After each interval every object is checked against its swept box; an object found outside
//! it (a blast the factor did not cover) is counted in
//! [`crate::world::WorldStats::island_escapes`], and the next frame is planned from where it is.

use glam::Vec3A;

use super::body::Body;
use super::contact::{ContactCache, Other, PairKey};
use super::deformable_pair::RestingPatch;
use super::kinematic::Drive;
use super::{World, WorldError};
use crate::scene::{Method, ObjectKind};

/// An object's axis-aligned box (m) grown by how far it may move over the interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Swept {
    /// Lower corner (m).
    pub min_m: Vec3A,
    /// Upper corner (m).
    pub max_m: Vec3A,
}

impl Swept {
    fn contains(&self, lo: Vec3A, hi: Vec3A) -> bool {
        self.min_m.cmple(lo).all() && hi.cmple(self.max_m).all()
    }
}

/// Groups `boxes` (`None`: the object joins no island and is left out) into islands: the
/// connected sets of overlapping boxes, each sorted, ordered by their first object.
pub fn group(boxes: &[Option<Swept>]) -> Vec<Vec<usize>> {
    let n = boxes.len();
    let mut parent: Vec<usize> = (0..n).collect();
    let bounds: Vec<Option<(Vec3A, Vec3A)>> = boxes
        .iter()
        .map(|b| b.map(|b| (b.min_m, b.max_m)))
        .collect();
    // Components do not depend on the order the overlapping pairs are joined in.
    for (i, j) in super::contact::broad_phase(&bounds, 0.0) {
        let (ri, rj) = (
            super::sleep::root(&mut parent, i),
            super::sleep::root(&mut parent, j),
        );
        parent[ri.max(rj)] = ri.min(rj);
    }
    let mut islands: Vec<Vec<usize>> = Vec::new();
    let mut slot: Vec<Option<usize>> = vec![None; n];
    for k in (0..n).filter(|&k| boxes[k].is_some()) {
        let r = super::sleep::root(&mut parent, k);
        match slot[r] {
            Some(s) => islands[s].push(k),
            None => {
                slot[r] = Some(islands.len());
                islands.push(vec![k]);
            }
        }
    }
    islands
}

/// A body's axis-aligned box now (m) and its fastest speed (m/s); `None` when it has no
/// particles. A solid's come from its pose (its collision surface's box turned into place and
/// its rigid velocities), with no pass over its particles.
fn bounds_and_speed(b: &Body) -> Option<(Vec3A, Vec3A, f64)> {
    if b.kind != ObjectKind::Deformable {
        let (lo, hi) = b.state().aabb_m;
        return Some((lo.as_vec3a(), hi.as_vec3a(), f64::from(b.rigid_speed_m_s())));
    }
    let p = &b.particles;
    if p.is_empty() {
        return None;
    }
    let mut lo = Vec3A::splat(f32::INFINITY);
    let mut hi = Vec3A::splat(f32::NEG_INFINITY);
    let mut v2 = 0.0f32;
    for (x, v) in p.x.iter().zip(&p.v) {
        lo = lo.min(*x);
        hi = hi.max(*x);
        v2 = v2.max(v.length_squared());
    }
    Some((lo, hi, f64::from(v2.sqrt())))
}

impl World {
    /// Object `k`'s box swept over `interval_s` (module docs); `None` for a static object.
    fn swept(&self, k: usize, interval_s: f64) -> Option<Swept> {
        let b = &self.bodies[k];
        if b.kind == ObjectKind::Static {
            return None;
        }
        let (lo, hi, speed) = bounds_and_speed(b).unwrap_or_else(|| {
            let c = b.rigid.com_m.as_vec3a();
            (c, c, 0.0)
        });
        let g = f64::from(self.gravity_m_s2.length());
        let mut reach = 2.0 * (speed + g * interval_s) * interval_s
            + 2.0 * f64::from(self.dx_m().max(b.solver.dx_m))
            + f64::from(b.collision_cell_m);
        if let Drive::Pose { com_m, .. } = b.drive
            && b.kind == ObjectKind::Kinematic
        {
            // Its whole way to the pose, and a half-turn at its farthest point.
            reach += (com_m - b.rigid.com_m).length() + std::f64::consts::PI * b.arm_m();
        }
        let r = Vec3A::splat(reach as f32);
        Some(Swept {
            min_m: lo - r,
            max_m: hi + r,
        })
    }

    /// The islands that would step from now until `end_s` (s), as object indices: every object
    /// in one unless the method is `com`, islands are on (`[simulation] islands`) and more than
    /// one island forms (module docs); static objects are then in none.
    pub fn plan_islands(&self, end_s: f64) -> Vec<Vec<usize>> {
        let all = || vec![(0..self.bodies.len()).collect::<Vec<_>>()];
        let movable = self.bodies.iter().filter(|b| b.kind != ObjectKind::Static);
        if self.settings.method != Method::Com || !self.settings.islands || movable.count() < 2 {
            return all();
        }
        let interval = end_s - self.time_s;
        let boxes: Vec<Option<Swept>> = (0..self.bodies.len())
            .map(|k| self.swept(k, interval))
            .collect();
        let islands = group(&boxes);
        if islands.len() > 1 { islands } else { all() }
    }

    /// Steps each of `islands` on its own from now to `sync_s` (s), calling `keep_going` after
    /// every substep; returns the substeps taken by all islands. Static objects step with none
    /// (they never move) and see every island.
    ///
    /// # Errors
    /// As [`World::substep`], [`WorldError::Unstable`] and [`WorldError::Interrupted`]; the
    /// islands after the failing one have not stepped.
    pub(super) fn advance_islands(
        &mut self,
        islands: &[Vec<usize>],
        sync_s: f64,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<u64, WorldError> {
        let start_s = self.time_s;
        let swept: Vec<Option<Swept>> = (0..self.bodies.len())
            .map(|k| self.swept(k, sync_s - start_s))
            .collect();
        let mut substeps = 0;
        let mut contacts = Vec::new();
        for island in islands {
            self.time_s = start_s;
            let aside = self.enter_island(island);
            let r = self.step_island(sync_s, keep_going, &mut substeps);
            contacts.append(&mut self.contacts.last);
            self.leave_island(aside);
            r?;
        }
        self.time_s = sync_s;
        self.contacts.last = contacts;
        for (k, s) in swept.iter().enumerate() {
            let inside = s.is_none_or(|s| {
                bounds_and_speed(&self.bodies[k]).is_none_or(|(lo, hi, _)| s.contains(lo, hi))
            });
            if !inside {
                self.stats.island_escapes += 1;
            }
        }
        Ok(substeps)
    }

    fn step_island(
        &mut self,
        sync_s: f64,
        keep_going: &mut dyn FnMut() -> bool,
        substeps: &mut u64,
    ) -> Result<(), WorldError> {
        while sync_s - self.time_s > 1e-9 {
            self.substep_on_pool(sync_s - self.time_s)?;
            *substeps += 1;
            self.check_stable()?;
            if !keep_going() {
                return Err(WorldError::Interrupted { frame: self.frame });
            }
        }
        Ok(())
    }

    /// Hides every object outside `island` and sets aside the contact cache and resting pairs
    /// of the other islands.
    fn enter_island(&mut self, island: &[usize]) -> Aside {
        let mut mask = vec![false; self.bodies.len()];
        for &k in island {
            mask[k] = true;
        }
        let mine = |k: u32| mask.get(k as usize).copied().unwrap_or(false);
        let contacts = self.contacts.cache.split_off(|(a, other): PairKey| {
            mine(a) || matches!(other, Other::Object(b) if mine(b))
        });
        let (resting, others): (Vec<RestingPatch>, Vec<RestingPatch>) =
            std::mem::take(&mut self.contacts.resting_patches)
                .into_iter()
                .partition(|p| mine(p.a as u32) || mine(p.b as u32));
        self.contacts.resting_patches = resting;
        self.island = Some(mask);
        Aside {
            contacts,
            resting: others,
        }
    }

    /// Shows every object again and takes back what [`World::enter_island`] set aside.
    fn leave_island(&mut self, aside: Aside) {
        self.island = None;
        self.contacts.cache.absorb(aside.contacts);
        self.contacts.resting_patches.extend(aside.resting);
    }
}

/// What one island's stepping sets aside of the others'.
struct Aside {
    contacts: ContactCache,
    resting: Vec<RestingPatch>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxed(lo: f32, hi: f32) -> Option<Swept> {
        Some(Swept {
            min_m: Vec3A::new(lo, 0.0, 0.0),
            max_m: Vec3A::new(hi, 1.0, 1.0),
        })
    }

    #[test]
    fn overlapping_boxes_chain_into_one_island_and_static_ones_join_none() {
        // 0 and 2 overlap through 1; 3 is apart; 4 is static (None) and overlaps everything.
        let boxes = [
            boxed(0.0, 1.0),
            boxed(0.9, 2.0),
            boxed(1.9, 3.0),
            boxed(5.0, 6.0),
            None,
        ];
        assert_eq!(group(&boxes), vec![vec![0, 1, 2], vec![3]]);
        // Touching faces count as overlap.
        assert_eq!(group(&[boxed(0.0, 1.0), boxed(1.0, 2.0)]), vec![vec![0, 1]]);
        assert_eq!(group(&[None, None]), Vec::<Vec<usize>>::new());
    }

    #[test]
    fn islands_are_ordered_by_their_first_object() {
        let boxes = [boxed(5.0, 6.0), boxed(0.0, 1.0), boxed(5.5, 7.0)];
        assert_eq!(group(&boxes), vec![vec![0, 2], vec![1]]);
    }
}
