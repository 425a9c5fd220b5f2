//! The scenes of `bench contact`, described once as plain geometry ([`ContactScene`]) and
//! turned into a splatphys [`Scene`] (rigid procedural objects through the scene builder) or, in
//! `contact/rapier.rs` and `contact/mujoco.rs`, into rapier or MuJoCo bodies of the same sizes
//! and start poses.
//!
//! - **stack**: 10 boxes of 10 cm on the ground, box k's bottom at k·(0.1 + 0.002) m: each drops
//!   2 mm onto the one below;
//! - **pyramid**: 15 boxes of 10 cm in the x-z plane, rows of 5, 4, 3, 2 and 1 from the bottom,
//!   2 mm apart horizontally, row r's bottom at r·(0.1 + 0.002) m;
//! - **pile**: boxes (each edge 5 to 8 cm) and balls (5 to 8 cm across), one or the other at
//!   random, on a 5 × 5 lattice of 10 cm pitch in layers 10 cm apart, each moved up to ±5 mm
//!   from its lattice point (ChaCha8 seeded by `--seed`), dropped into an open box: the ground
//!   plane and four walls 5 cm thick around a 50 cm × 50 cm floor.
//! - **cubes**: 125 cubes of 5 cm, each turned by its own uniformly random rotation (ChaCha8
//!   seeded by `--seed`, Shoemake's method), centred on a 5 × 5 × 5 lattice of 9 cm pitch (their
//!   bounding spheres, 8.66 cm across, start at least 3.4 mm apart) whose even layers are moved
//!   by +2.25 cm in x and y and odd layers by −2.25 cm, the lowest bounding sphere 5 mm above
//!   the floor, dropped into an open box of 50 cm × 50 cm inside (walls as the pile's).
//! - **cubes1000**: the same with 1,000 cubes on a 10 × 10 × 10 lattice in an open box of
//!   1 m × 1 m inside.
//!
//! The staggered layers put every cube over the gap between four cubes of the layer below: on a
//! plain lattice each lands centred on the one below and the 125 cubes end as columns up to
//! five cubes tall (tallest COM 22 cm) in splatphys and rapier alike; staggered they end two or
//! three cubes deep (measured, seed 0, 3 s: tallest COM 13 to 15 cm, median 7.5 cm, in all
//! three engines; splatphys and rapier on a 60 or 70 cm floor: tallest 13 to 15 cm, median 4
//! to 6.5 cm). A wider box hardly changes that (friction holds the pile, the walls barely touch
//! it), so each box is about as small as lets its lattice start inside (the lattices span
//! 49.2 cm and 94.2 cm across their bounding spheres).
//!
//! Every object but the cubes starts axis-aligned; every object starts at rest; every surface
//! (objects, ground, walls) has the same friction and restitution, so no engine's combine rule
//! changes them.

use clap::ValueEnum;
use glam::{DQuat, EulerRot};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatphys_core::contact::ContactSolver;
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
/// Wall thickness of the open boxes of the pile and the cube scenes (m).
pub const WALL_THICKNESS_M: f32 = 0.05;
/// Edge of the cubes of `cubes` and `cubes1000` (m).
pub const CUBE_EDGE_M: f32 = 0.05;
/// Lattice pitch of the cube scenes, horizontally and between layers (m): more than a cube's
/// bounding-sphere diameter (√3 · 5 cm = 8.66 cm), so no two turned cubes start touching.
pub const CUBE_PITCH_M: f32 = 0.09;
/// Gap between the floor and the bounding spheres of the lowest lattice layer (m).
pub const CUBE_CLEARANCE_M: f32 = 0.005;
/// How far even lattice layers of the cube scenes are moved along +x and +y, odd ones along −x
/// and −y (m): a quarter pitch, so each cube starts over the gap between four below it.
pub const CUBE_STAGGER_M: f32 = CUBE_PITCH_M / 4.0;
/// Cubes per lattice side of `cubes` (125 cubes).
pub const CUBES_SIDE: usize = 5;
/// Inner half-width of the open box of `cubes` (m).
pub const CUBES_HALF_WIDTH_M: f32 = 0.25;
/// Cubes per lattice side of `cubes1000` (1,000 cubes).
pub const CUBES1000_SIDE: usize = 10;
/// Inner half-width of the open box of `cubes1000` (m).
pub const CUBES1000_HALF_WIDTH_M: f32 = 0.5;

/// Which scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SceneKind {
    /// 10 boxes stacked in a column.
    Stack,
    /// 15 boxes in rows of 5, 4, 3, 2, 1.
    Pyramid,
    /// Boxes and balls dropped into an open box.
    Pile,
    /// 125 randomly turned 5 cm cubes dropped into an open box.
    Cubes,
    /// 1,000 randomly turned 5 cm cubes dropped into a larger open box (slow).
    Cubes1000,
}

impl SceneKind {
    /// The name in tables and file rows.
    pub fn name(self) -> &'static str {
        match self {
            Self::Stack => "stack",
            Self::Pyramid => "pyramid",
            Self::Pile => "pile",
            Self::Cubes => "cubes",
            Self::Cubes1000 => "cubes1000",
        }
    }

    /// Whether it is one of the cube scenes (their duration is `--cubes-duration-s`).
    pub fn is_cubes(self) -> bool {
        matches!(self, Self::Cubes | Self::Cubes1000)
    }
}

/// The shape of a body, centred on its geometric centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BodyShape {
    /// A box, along the axes of its body frame (turned by [`BodySpec::orientation_wxyz`] at
    /// the start).
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
    /// Half extents of the box (m), along its body axes; a ball's radius thrice.
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
    /// Orientation at the start (w, x, y, z; unit): how the shape is turned about its centre
    /// from its body axes to the world. [`IDENTITY_WXYZ`] but in the cube scenes.
    pub orientation_wxyz: [f32; 4],
    /// How far the body sinks from its start to its ideal rest pose, closing the gaps below it
    /// (m, along −z); `None` where no rest pose is known (the pile).
    pub settle_drop_m: Option<f32>,
}

/// The start orientation of an axis-aligned body (w, x, y, z).
pub const IDENTITY_WXYZ: [f32; 4] = [1.0, 0.0, 0.0, 0.0];

impl BodySpec {
    /// The start orientation as a unit quaternion.
    pub fn orientation(&self) -> DQuat {
        let [w, x, y, z] = self.orientation_wxyz.map(f64::from);
        DQuat::from_xyzw(x, y, z, w).normalize()
    }

    /// Whether it starts turned (its orientation is not the identity).
    pub fn is_turned(&self) -> bool {
        self.orientation_wxyz != IDENTITY_WXYZ
    }
}

/// Euler angles x, y, z (degrees) of `q` in the scene builder's convention,
/// R = Rz(z) · Ry(y) · Rx(x) (`splatphys_core::scene::transform::euler_xyz_deg`).
pub fn euler_xyz_deg(q: DQuat) -> [f32; 3] {
    // glam's intrinsic ZYX: q = Rz(a) · Ry(b) · Rx(c).
    let (z, y, x) = q.to_euler(EulerRot::ZYX);
    [x, y, z].map(|a| a.to_degrees() as f32)
}

/// A uniformly random rotation (Shoemake's method, w, x, y, z).
fn random_orientation_wxyz(rng: &mut impl Rng) -> [f32; 4] {
    let tau = std::f64::consts::TAU;
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = DQuat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    )
    .normalize();
    [q.w, q.x, q.y, q.z].map(|v| v as f32)
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

/// Surface and material settings shared by every engine (MuJoCo takes no restitution).
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
    /// How the splatphys world solves its contacts.
    pub contact_solver: ContactSolver,
}

impl ContactSettings {
    /// The bench's defaults (friction 0.5, no restitution, 1000 kg/m³, dx 1 cm, seed 0), for
    /// tests.
    #[cfg(test)]
    pub(crate) fn for_tests() -> Self {
        Self {
            friction: 0.5,
            restitution: 0.0,
            density_kg_m3: 1000.0,
            dx_m: 0.01,
            contact_solver: ContactSolver::default(),
            seed: 0,
        }
    }
}

impl ContactScene {
    /// The scene `kind`; `pile_count` objects for the pile.
    pub fn new(kind: SceneKind, pile_count: usize, seed: u64) -> Self {
        match kind {
            SceneKind::Stack => stack(),
            SceneKind::Pyramid => pyramid(),
            SceneKind::Pile => pile(pile_count, seed),
            SceneKind::Cubes => cubes(kind, CUBES_SIDE, CUBES_HALF_WIDTH_M, seed),
            SceneKind::Cubes1000 => cubes(kind, CUBES1000_SIDE, CUBES1000_HALF_WIDTH_M, seed),
        }
    }

    /// The splatphys scene: every body a rigid procedural object of the given density on a
    /// lattice of spacing dx, turned about its centre to its start orientation (the builder's
    /// `rotation_deg`, which turns the particles and the contact shape alike), the ground and
    /// the walls as slip colliders with the same friction, simulated for `duration_s` with the
    /// COM method, gravity (0, 0, −9.81) m/s², sleeping off. Frames are one largest substep
    /// long ([`MAX_DT_S`]), so frame boundaries never shorten a substep while the bodies are
    /// slow.
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
            .contact_solver(s.contact_solver)
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
            let object = if body.is_turned() {
                object.rotation_deg(euler_xyz_deg(body.orientation()))
            } else {
                object
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
        orientation_wxyz: IDENTITY_WXYZ,
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
            orientation_wxyz: IDENTITY_WXYZ,
            settle_drop_m: None,
        });
    }
    let top = bodies
        .iter()
        .map(|b| b.center_m[2] + b.shape.half_extents_m()[2])
        .fold(0.0f32, f32::max);
    ContactScene {
        kind: SceneKind::Pile,
        bodies,
        walls: open_box(PILE_HALF_WIDTH_M, top + PILE_PITCH_M),
    }
}

/// Four walls [`WALL_THICKNESS_M`] thick around the floor |x|, |y| <= `half_width_m`, from the
/// ground to `height_m` (m).
fn open_box(half_width_m: f32, height_m: f32) -> Vec<[[f32; 3]; 2]> {
    let (w, t, h) = (half_width_m, WALL_THICKNESS_M, height_m);
    vec![
        [[w, -w - t, 0.0], [w + t, w + t, h]],
        [[-w - t, -w - t, 0.0], [-w, w + t, h]],
        [[-w, w, 0.0], [w, w + t, h]],
        [[-w, -w - t, 0.0], [w, -w, h]],
    ]
}

/// `side`³ randomly turned cubes of edge [`CUBE_EDGE_M`] on a lattice of [`CUBE_PITCH_M`] pitch
/// with layers staggered by ±[`CUBE_STAGGER_M`], in an open box of inner half-width
/// `half_width_m` (m).
fn cubes(kind: SceneKind, side: usize, half_width_m: f32, seed: u64) -> ContactScene {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let shape = BodyShape::Cuboid {
        half_extents_m: [CUBE_EDGE_M / 2.0; 3],
    };
    let r = shape.bounding_radius_m();
    let offset = |i: usize| (i as f32 - (side - 1) as f32 / 2.0) * CUBE_PITCH_M;
    let mut bodies = Vec::with_capacity(side * side * side);
    for layer in 0..side {
        let stagger = if layer % 2 == 0 {
            CUBE_STAGGER_M
        } else {
            -CUBE_STAGGER_M
        };
        for j in 0..side {
            for i in 0..side {
                let k = bodies.len();
                bodies.push(BodySpec {
                    name: format!("cube{k}"),
                    shape,
                    center_m: [
                        offset(i) + stagger,
                        offset(j) + stagger,
                        r + CUBE_CLEARANCE_M + layer as f32 * CUBE_PITCH_M,
                    ],
                    orientation_wxyz: random_orientation_wxyz(&mut rng),
                    settle_drop_m: None,
                });
            }
        }
    }
    let top = r + CUBE_CLEARANCE_M + (side - 1) as f32 * CUBE_PITCH_M + r;
    ContactScene {
        kind,
        bodies,
        walls: open_box(half_width_m, top + CUBE_PITCH_M),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec3, Vec3};

    /// Smallest gap between the start boxes of `a` and `b` along the axis that separates them
    /// most (m); negative when they overlap.
    fn gap(a: [f32; 3], ha: [f32; 3], b: [f32; 3], hb: [f32; 3]) -> f32 {
        (0..3)
            .map(|i| (a[i] - b[i]).abs() - ha[i] - hb[i])
            .fold(f32::NEG_INFINITY, f32::max)
    }

    /// Smallest gap between the start shapes of `a` and `b` (m), a lower bound: their boxes when
    /// both are axis-aligned, else their bounding spheres.
    fn body_gap(a: &BodySpec, b: &BodySpec) -> f32 {
        if a.is_turned() || b.is_turned() {
            let d = DVec3::from(a.center_m.map(f64::from)) - DVec3::from(b.center_m.map(f64::from));
            d.length() as f32 - a.shape.bounding_radius_m() - b.shape.bounding_radius_m()
        } else {
            gap(
                a.center_m,
                a.shape.half_extents_m(),
                b.center_m,
                b.shape.half_extents_m(),
            )
        }
    }

    /// Smallest gap between the start shape of `a` and the wall box `[lo, hi]` (m), a lower
    /// bound as [`body_gap`].
    fn wall_gap(a: &BodySpec, lo: [f32; 3], hi: [f32; 3]) -> f32 {
        let c = [0, 1, 2].map(|k| (lo[k] + hi[k]) / 2.0);
        let h = [0, 1, 2].map(|k| (hi[k] - lo[k]) / 2.0);
        if a.is_turned() {
            let p = Vec3::from(a.center_m);
            let nearest = p.clamp(Vec3::from(lo), Vec3::from(hi));
            p.distance(nearest) - a.shape.bounding_radius_m()
        } else {
            gap(a.center_m, a.shape.half_extents_m(), c, h)
        }
    }

    #[test]
    fn scenes_have_their_body_counts_and_start_apart() {
        for (kind, count, walls) in [
            (SceneKind::Stack, STACK_BOXES, 0),
            (SceneKind::Pyramid, 15, 0),
            (SceneKind::Pile, 100, 4),
            (SceneKind::Cubes, 125, 4),
            (SceneKind::Cubes1000, 1000, 4),
        ] {
            let s = ContactScene::new(kind, 100, 7);
            assert_eq!(s.kind, kind);
            assert_eq!(s.bodies.len(), count, "{kind:?}");
            assert_eq!(s.walls.len(), walls, "{kind:?}");
            // Only the cubes start turned, and all of them do.
            assert!(s.bodies.iter().all(|b| b.is_turned() == kind.is_cubes()));
            for (i, a) in s.bodies.iter().enumerate() {
                // Box 0 of the stack and row 0 of the pyramid stand on the ground: 0 within
                // f32 rounding of centre minus half edge.
                let bottom = if a.is_turned() {
                    a.center_m[2] - a.shape.bounding_radius_m()
                } else {
                    a.center_m[2] - a.shape.half_extents_m()[2]
                };
                assert!(bottom > -1e-6, "{} below the ground", a.name);
                for b in &s.bodies[i + 1..] {
                    let g = body_gap(a, b);
                    // The closest start gap of any scene is the 2 mm of the stack and pyramid
                    // (f32 rounding of 1 m coordinates is below 1e-6 m); the cubes' bounding
                    // spheres start 3.4 mm apart.
                    assert!(g > GAP_M - 1e-5, "{} and {} {g} m apart", a.name, b.name);
                }
                for [lo, hi] in &s.walls {
                    assert!(wall_gap(a, *lo, *hi) > 0.0, "{} in a wall", a.name);
                }
            }
        }
    }

    #[test]
    fn cube_scenes_start_inside_their_box_and_below_its_rim() {
        for (kind, side, half_width) in [
            (SceneKind::Cubes, CUBES_SIDE, CUBES_HALF_WIDTH_M),
            (SceneKind::Cubes1000, CUBES1000_SIDE, CUBES1000_HALF_WIDTH_M),
        ] {
            let s = ContactScene::new(kind, 0, 3);
            let rim = s
                .walls
                .iter()
                .map(|w| w[1][2])
                .fold(f32::INFINITY, f32::min);
            for b in &s.bodies {
                let r = b.shape.bounding_radius_m();
                let [x, y, z] = b.center_m;
                assert!(
                    x.abs() + r < half_width && y.abs() + r < half_width,
                    "{}",
                    b.name
                );
                assert!(z + r < rim, "{} above the walls", b.name);
                assert_eq!(b.shape.half_extents_m(), [CUBE_EDGE_M / 2.0; 3]);
            }
            // Neighbouring layers are staggered by half a pitch along x and y: cube 0 and the
            // first cube of the next layer.
            let next = s.bodies.len() / side;
            let [dx, dy, dz] =
                [0, 1, 2].map(|k| s.bodies[0].center_m[k] - s.bodies[next].center_m[k]);
            assert!(
                (dx - CUBE_PITCH_M / 2.0).abs() < 1e-6 && (dy - dx).abs() < 1e-6,
                "{dx} {dy}"
            );
            assert!((dz + CUBE_PITCH_M).abs() < 1e-6, "{dz}");
            // The walls close the floor |x|, |y| <= half width on all four sides.
            for [lo, hi] in &s.walls {
                let inner = (0..2).any(|k| lo[k] == half_width || hi[k] == -half_width);
                assert!(inner, "{lo:?} {hi:?}");
            }
        }
    }

    #[test]
    fn cube_orientations_are_uniform_seeded_unit_rotations() {
        let s = ContactScene::new(SceneKind::Cubes1000, 0, 11);
        let q: Vec<DQuat> = s.bodies.iter().map(BodySpec::orientation).collect();
        for (b, q) in s.bodies.iter().zip(&q) {
            let n: f32 = b.orientation_wxyz.iter().map(|v| v * v).sum();
            assert!((n - 1.0).abs() < 1e-5, "{}: |q|² = {n}", b.name);
            assert!(q.is_normalized());
        }
        // A uniform rotation sends z to a uniform direction: mean 0, mean z² of 1/3 (1,000
        // samples: standard errors 0.018 and 0.009).
        let up: Vec<DVec3> = q.iter().map(|q| *q * DVec3::Z).collect();
        let mean = up.iter().sum::<DVec3>() / up.len() as f64;
        let z2 = up.iter().map(|u| u.z * u.z).sum::<f64>() / up.len() as f64;
        assert!(mean.length() < 0.1, "mean axis {mean}");
        assert!((z2 - 1.0 / 3.0).abs() < 0.04, "mean z² {z2}");
        // The seed picks them: the same seed again, another seed not.
        assert_eq!(ContactScene::new(SceneKind::Cubes1000, 0, 11), s);
        let other = ContactScene::new(SceneKind::Cubes1000, 0, 12);
        assert_ne!(
            other.bodies[0].orientation_wxyz,
            s.bodies[0].orientation_wxyz
        );
        // The small scene draws its own 125 from the same stream.
        let small = ContactScene::new(SceneKind::Cubes, 0, 11);
        assert_eq!(
            small.bodies[0].orientation_wxyz,
            s.bodies[0].orientation_wxyz
        );
    }

    #[test]
    fn euler_angles_give_back_the_orientation() {
        let s = ContactScene::new(SceneKind::Cubes, 0, 5);
        for b in s.bodies.iter().take(50) {
            let q = b.orientation().as_quat();
            let back = splatphys_core::scene::transform::euler_xyz_deg(euler_xyz_deg(q.as_dquat()));
            assert!(q.dot(back).abs() > 1.0 - 1e-6, "{}: {q} vs {back}", b.name);
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

    fn settings() -> ContactSettings {
        ContactSettings::for_tests()
    }

    #[test]
    fn every_scene_builds_as_rigid_objects() {
        for kind in [
            SceneKind::Stack,
            SceneKind::Pyramid,
            SceneKind::Pile,
            SceneKind::Cubes,
        ] {
            let c = ContactScene::new(kind, 30, 0);
            let scene = c.to_scene(&settings(), 0.1).expect("builds");
            assert_eq!(scene.objects.len(), c.bodies.len());
            assert!(scene.objects.iter().all(|o| o.kind == ObjectKind::Rigid));
            assert!(!scene.simulation.sleep, "sleeping must not hold a stack up");
            assert_eq!(scene.colliders.len(), 1 + c.walls.len());
        }
    }

    #[test]
    fn turned_cubes_are_built_turned() {
        let c = ContactScene::new(SceneKind::Cubes, 0, 9);
        let scene = c.to_scene(&settings(), 0.1).expect("builds");
        let h = CUBE_EDGE_M / 2.0;
        for (b, o) in c.bodies.iter().zip(&scene.objects).take(20) {
            let q = b.orientation().as_quat();
            // The contact shape is turned as the body ...
            assert!(o.shape_rotation.dot(q).abs() > 1.0 - 1e-6, "{}", b.name);
            // ... and so are its particles: inside the cube along its turned axes (lattice
            // points lie inside the shape), and reaching beyond the unturned cube.
            let c = Vec3::from(b.center_m);
            let mut beyond_unturned = false;
            for p in &o.gaussians.positions {
                let d = Vec3::from(*p) - c;
                let local = q.inverse() * d;
                assert!(local.abs().max_element() <= h + 1e-5, "{}: {local}", b.name);
                beyond_unturned |= d.abs().max_element() > h + 1e-3;
            }
            assert!(beyond_unturned, "{} is not turned", b.name);
        }
    }
}
