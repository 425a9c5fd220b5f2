//! The three scenes of `bench contact`, described once as plain geometry ([`ContactScene`]) and
//! turned into a splatphys [`Scene`] (rigid procedural objects through the scene builder) or, in
//! `contact/rapier.rs`, into rapier bodies and colliders of the same sizes.
//!
//! - **stack**: 10 boxes of 10 cm on the ground, box k's bottom at k·(0.1 + 0.002) m: each drops
//!   2 mm onto the one below;
//! - **pyramid**: 15 boxes of 10 cm in the x-z plane, rows of 5, 4, 3, 2 and 1 from the bottom,
//!   2 mm apart horizontally, row r's bottom at r·(0.1 + 0.002) m;
//! - **pile**: boxes (each edge 5 to 8 cm) and balls (5 to 8 cm across), one or the other at
//!   random, on a 5 × 5 lattice of 10 cm pitch in layers 10 cm apart, each moved up to ±5 mm
//!   from its lattice point (ChaCha8 seeded by `--seed`), dropped into an open box: the ground
//!   plane and four walls 5 cm thick around a 50 cm × 50 cm floor.
//!
//! Every object starts axis-aligned and at rest; every surface (objects, ground, walls) has the
//! same friction and restitution, so no engine's combine rule changes them.

use clap::ValueEnum;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatphys_core::mpm::timestep::MAX_DT_S;
use splatphys_core::scene::{
    ColliderSpec, MaterialSpec, Method, ObjectKind, Scene, SceneError, SceneObject, Surface,
};

/// Box edge of the stack and the pyramid (m).
pub const BOX_EDGE_M: f32 = 0.1;
/// Gap between neighbouring boxes at the start of the stack and the pyramid (m).
pub const GAP_M: f32 = 0.002;
/// Boxes in the stack.
pub const STACK_BOXES: usize = 10;
/// Boxes in the bottom row of the pyramid (rows shrink by one up to a single box).
pub const PYRAMID_BASE: usize = 5;
/// Lattice pitch of the pile, horizontally and between layers (m).
pub const PILE_PITCH_M: f32 = 0.1;
/// Pile objects per layer side (a layer holds this squared).
pub const PILE_SIDE: usize = 5;
/// Size range of pile objects: box edges and ball diameters (m).
pub const PILE_SIZE_M: (f32, f32) = (0.05, 0.08);
/// Largest random offset of a pile object from its lattice point, per axis (m).
pub const PILE_JITTER_M: f32 = 0.005;
/// Inner half-width of the pile's open box (m).
pub const PILE_HALF_WIDTH_M: f32 = 0.25;
/// Wall thickness of the pile's open box (m).
pub const WALL_THICKNESS_M: f32 = 0.05;

/// Which scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SceneKind {
    /// 10 boxes stacked in a column.
    Stack,
    /// 15 boxes in rows of 5, 4, 3, 2, 1.
    Pyramid,
    /// Boxes and balls dropped into an open box.
    Pile,
}

impl SceneKind {
    /// The name in tables and file rows.
    pub fn name(self) -> &'static str {
        match self {
            Self::Stack => "stack",
            Self::Pyramid => "pyramid",
            Self::Pile => "pile",
        }
    }
}

/// The shape of a body, centred on its geometric centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BodyShape {
    /// An axis-aligned box at the start.
    Cuboid {
        /// Half edge lengths (m).
        half_extents_m: [f32; 3],
    },
    /// A ball.
    Ball {
        /// Radius (m).
        radius_m: f32,
    },
}

impl BodyShape {
    /// Half extents of the axis-aligned bounding box at the start (m).
    pub fn half_extents_m(self) -> [f32; 3] {
        match self {
            Self::Cuboid { half_extents_m } => half_extents_m,
            Self::Ball { radius_m } => [radius_m; 3],
        }
    }

    /// Radius of the bounding sphere (m).
    pub fn bounding_radius_m(self) -> f32 {
        let [x, y, z] = self.half_extents_m();
        match self {
            Self::Cuboid { .. } => (x * x + y * y + z * z).sqrt(),
            Self::Ball { radius_m } => radius_m,
        }
    }

    /// "box" or "ball".
    pub fn name(self) -> &'static str {
        match self {
            Self::Cuboid { .. } => "box",
            Self::Ball { .. } => "ball",
        }
    }
}

/// One rigid body of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct BodySpec {
    /// Unique name.
    pub name: String,
    /// Its shape.
    pub shape: BodyShape,
    /// Geometric centre at the start (m).
    pub center_m: [f32; 3],
    /// How far the body sinks from its start to its ideal rest pose, closing the gaps below it
    /// (m, along −z); `None` where no rest pose is known (the pile).
    pub settle_drop_m: Option<f32>,
}

/// A scene as geometry: rigid bodies over the ground plane z = 0, and fixed walls.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactScene {
    /// Which scene.
    pub kind: SceneKind,
    /// Bodies, in object order.
    pub bodies: Vec<BodySpec>,
    /// Fixed boxes `[min, max]` (m).
    pub walls: Vec<[[f32; 3]; 2]>,
}

/// Surface and material settings shared by both engines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactSettings {
    /// Coulomb friction of every surface.
    pub friction: f32,
    /// Restitution of every surface.
    pub restitution: f32,
    /// Density of every body (kg/m³).
    pub density_kg_m3: f64,
    /// Grid cell size of the world, also the lattice spacing of the particles (m).
    pub dx_m: f64,
    /// Seed of the pile layout and of the lattice jitter.
    pub seed: u64,
}

impl ContactScene {
    /// The scene `kind`; `pile_count` objects for the pile.
    pub fn new(kind: SceneKind, pile_count: usize, seed: u64) -> Self {
        match kind {
            SceneKind::Stack => stack(),
            SceneKind::Pyramid => pyramid(),
            SceneKind::Pile => pile(pile_count, seed),
        }
    }

    /// The splatphys scene: every body a rigid procedural object of the given density on a
    /// lattice of spacing dx, the ground and the walls as slip colliders with the same friction,
    /// simulated for `duration_s` with the COM method, gravity (0, 0, −9.81) m/s², sleeping
    /// off. Frames are
    /// one largest substep long ([`MAX_DT_S`]), so frame boundaries never shorten a substep
    /// while the bodies are slow.
    ///
    /// # Errors
    /// When the scene builder refuses a value.
    pub fn to_scene(&self, s: &ContactSettings, duration_s: f64) -> Result<Scene, SceneError> {
        let mu = s.friction;
        let mut b = Scene::builder()
            .method(Method::Com)
            .duration_s(duration_s)
            .frame_rate_hz(1.0 / f64::from(MAX_DT_S))
            .grid_dx_m(s.dx_m)
            .seed(s.seed)
            // Resting must come from contact, not from zeroed velocities.
            .sleep(false)
            .collider(
                ColliderSpec::ground("ground")
                    .surface(Surface::Slip)
                    .friction(mu),
            );
        for (i, [lo, hi]) in self.walls.iter().enumerate() {
            b = b.collider(
                ColliderSpec::cuboid(format!("wall{i}"), *lo, *hi)
                    .surface(Surface::Slip)
                    .friction(mu),
            );
        }
        for body in &self.bodies {
            let c = body.center_m;
            let object = match body.shape {
                BodyShape::Cuboid { half_extents_m: h } => SceneObject::cuboid(
                    body.name.clone(),
                    [c[0] - h[0], c[1] - h[1], c[2] - h[2]],
                    [c[0] + h[0], c[1] + h[1], c[2] + h[2]],
                ),
                BodyShape::Ball { radius_m } => SceneObject::sphere(body.name.clone(), c, radius_m),
            };
            b = b.object(
                object
                    .kind(ObjectKind::Rigid)
                    // Rigid: only the density matters.
                    .material(MaterialSpec::jelly(1e6, 0.3, s.density_kg_m3))
                    .friction(mu)
                    .restitution(s.restitution)
                    .spacing_m(s.dx_m as f32),
            );
        }
        b.build()
    }
}

/// A box of edge [`BOX_EDGE_M`] whose bottom face is centred on (x, y, bottom).
fn edge_box(name: String, x: f32, y: f32, bottom_m: f32, settle_drop_m: f32) -> BodySpec {
    let h = BOX_EDGE_M / 2.0;
    BodySpec {
        name,
        shape: BodyShape::Cuboid {
            half_extents_m: [h; 3],
        },
        center_m: [x, y, bottom_m + h],
        settle_drop_m: Some(settle_drop_m),
    }
}

fn stack() -> ContactScene {
    let pitch = BOX_EDGE_M + GAP_M;
    let bodies = (0..STACK_BOXES)
        .map(|k| {
            edge_box(
                format!("box{k}"),
                0.0,
                0.0,
                k as f32 * pitch,
                k as f32 * GAP_M,
            )
        })
        .collect();
    ContactScene {
        kind: SceneKind::Stack,
        bodies,
        walls: Vec::new(),
    }
}

fn pyramid() -> ContactScene {
    let pitch = BOX_EDGE_M + GAP_M;
    let mut bodies = Vec::new();
    for row in 0..PYRAMID_BASE {
        let n = PYRAMID_BASE - row;
        for i in 0..n {
            let x = (i as f32 - (n - 1) as f32 / 2.0) * pitch;
            let name = format!("row{row}_box{i}");
            let z = row as f32 * pitch;
            bodies.push(edge_box(name, x, 0.0, z, row as f32 * GAP_M));
        }
    }
    ContactScene {
        kind: SceneKind::Pyramid,
        bodies,
        walls: Vec::new(),
    }
}

fn pile(count: usize, seed: u64) -> ContactScene {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let per_layer = PILE_SIDE * PILE_SIDE;
    let (lo, hi) = PILE_SIZE_M;
    let j = PILE_JITTER_M;
    let mut bodies = Vec::with_capacity(count);
    for k in 0..count {
        let (layer, cell) = (k / per_layer, k % per_layer);
        let offset = |i: usize| (i as f32 - (PILE_SIDE - 1) as f32 / 2.0) * PILE_PITCH_M;
        let center_m = [
            offset(cell % PILE_SIDE) + rng.random_range(-j..=j),
            offset(cell / PILE_SIDE) + rng.random_range(-j..=j),
            // The lowest layer clears the floor by at least a jitter.
            hi / 2.0 + 2.0 * j + layer as f32 * PILE_PITCH_M + rng.random_range(-j..=j),
        ];
        let shape = if rng.random_bool(0.5) {
            BodyShape::Cuboid {
                half_extents_m: [0; 3].map(|_| rng.random_range(lo..=hi) / 2.0),
            }
        } else {
            BodyShape::Ball {
                radius_m: rng.random_range(lo..=hi) / 2.0,
            }
        };
        bodies.push(BodySpec {
            name: format!("{}{k}", shape.name()),
            shape,
            center_m,
            settle_drop_m: None,
        });
    }
    let top = bodies
        .iter()
        .map(|b| b.center_m[2] + b.shape.half_extents_m()[2])
        .fold(0.0f32, f32::max);
    let (w, t, height) = (PILE_HALF_WIDTH_M, WALL_THICKNESS_M, top + PILE_PITCH_M);
    let walls = vec![
        [[w, -w - t, 0.0], [w + t, w + t, height]],
        [[-w - t, -w - t, 0.0], [-w, w + t, height]],
        [[-w, w, 0.0], [w, w + t, height]],
        [[-w, -w - t, 0.0], [w, -w, height]],
    ];
    ContactScene {
        kind: SceneKind::Pile,
        bodies,
        walls,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Smallest gap between the start boxes of `a` and `b` along the axis that separates them
    /// most (m); negative when they overlap.
    fn gap(a: [f32; 3], ha: [f32; 3], b: [f32; 3], hb: [f32; 3]) -> f32 {
        (0..3)
            .map(|i| (a[i] - b[i]).abs() - ha[i] - hb[i])
            .fold(f32::NEG_INFINITY, f32::max)
    }

    #[test]
    fn scenes_have_their_body_counts_and_start_apart() {
        for (kind, count, walls) in [
            (SceneKind::Stack, STACK_BOXES, 0),
            (SceneKind::Pyramid, 15, 0),
            (SceneKind::Pile, 100, 4),
        ] {
            let s = ContactScene::new(kind, 100, 7);
            assert_eq!(s.bodies.len(), count, "{kind:?}");
            assert_eq!(s.walls.len(), walls, "{kind:?}");
            for (i, a) in s.bodies.iter().enumerate() {
                let ha = a.shape.half_extents_m();
                // Box 0 of the stack and row 0 of the pyramid stand on the ground: 0 within
                // f32 rounding of centre minus half edge.
                assert!(a.center_m[2] - ha[2] > -1e-6, "{} below the ground", a.name);
                for b in &s.bodies[i + 1..] {
                    let g = gap(a.center_m, ha, b.center_m, b.shape.half_extents_m());
                    // The closest start gap of any scene is the 2 mm of the stack and pyramid
                    // (f32 rounding of 1 m coordinates is below 1e-6 m).
                    assert!(g > GAP_M - 1e-5, "{} and {} {g} m apart", a.name, b.name);
                }
                for [lo, hi] in &s.walls {
                    let c = [0, 1, 2].map(|k| (lo[k] + hi[k]) / 2.0);
                    let h = [0, 1, 2].map(|k| (hi[k] - lo[k]) / 2.0);
                    assert!(gap(a.center_m, ha, c, h) > 0.0, "{} in a wall", a.name);
                }
            }
        }
    }

    #[test]
    fn stack_rests_at_whole_box_heights() {
        // Closing the gaps puts box k's centre at k·0.1 + 0.05 m.
        for (k, b) in ContactScene::new(SceneKind::Stack, 0, 0)
            .bodies
            .iter()
            .enumerate()
        {
            let rest = b.center_m[2] - b.settle_drop_m.unwrap_or(f32::NAN);
            assert!(
                (rest - (k as f32 * 0.1 + 0.05)).abs() < 1e-6,
                "box {k}: {rest}"
            );
        }
    }

    #[test]
    fn every_scene_builds_as_rigid_objects() {
        let settings = ContactSettings {
            friction: 0.5,
            restitution: 0.0,
            density_kg_m3: 1000.0,
            dx_m: 0.01,
            seed: 0,
        };
        for kind in [SceneKind::Stack, SceneKind::Pyramid, SceneKind::Pile] {
            let c = ContactScene::new(kind, 30, 0);
            let scene = c.to_scene(&settings, 0.1).expect("builds");
            assert_eq!(scene.objects.len(), c.bodies.len());
            assert!(scene.objects.iter().all(|o| o.kind == ObjectKind::Rigid));
            assert!(!scene.simulation.sleep, "sleeping must not hold a stack up");
            assert_eq!(scene.colliders.len(), 1 + c.walls.len());
        }
    }
}
