//! A signed distance field sampled on a regular grid: the collision surface of a captured object
//! or of the captured background, built from points (particles or opaque Gaussians).
//!
//! Solid cells (cell size h): the cells holding a point, closed by one cell so that gaps between
//! surface Gaussians do not leak (dilate by one cell, flood the outside from the grid border,
//! erode by one cell; the cells holding points always stay solid). An open shell, such as a
//! patch of captured ground, stays a slab one or two cells thick.
//!
//! Distance: at every grid node (cell corner), the exact distance to the nearest boundary face
//! (a face between a solid and an empty cell), found among the nearest face centres on a k-d
//! tree; negative at nodes whose 8 cells are all solid. Queries interpolate trilinearly, so the
//! surface lies on the solid cells' outer faces, to within h/2 of the true one for a captured
//! surface (Osher and Fedkiw, "Level Set Methods and Dynamic Implicit Surfaces", 2003, ch. 7 for
//! the representation; the closing is standard solid voxelisation).

use std::collections::VecDeque;

use glam::{IVec3, Vec3A};
use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;

/// Face centres examined per node for the exact point-to-face distance.
const NEAREST_FACES: usize = 6;

/// A signed distance field on a grid of nodes (m; negative inside).
#[derive(Debug, Clone, PartialEq)]
pub struct LevelSet {
    /// Position of node (0, 0, 0) (m).
    origin_m: Vec3A,
    /// Node spacing h (m).
    h_m: f32,
    /// Nodes per axis.
    dims: [usize; 3],
    /// `[dims.x * dims.y * dims.z]` signed distances (m), x fastest.
    phi_m: Vec<f32>,
    /// Boundary face centres (m), one per solid cell face that borders an empty cell.
    faces: Vec<Vec3A>,
    /// `[faces]` the axis each face is normal to (0, 1, 2).
    axes: Vec<u8>,
    /// The face centres for range queries ([`Self::faces_near`]); `None` without faces.
    tree: Option<Box<ImmutableKdTree<f32, u32, 3, 32>>>,
}

/// Solid cells of a point set on a cell grid: `dims` cells from `origin_m`, spacing `h_m`.
struct Cells {
    origin_m: Vec3A,
    h_m: f32,
    dims: [usize; 3],
    solid: Vec<bool>,
}

const FACES: [IVec3; 6] = [
    IVec3::X,
    IVec3::NEG_X,
    IVec3::Y,
    IVec3::NEG_Y,
    IVec3::Z,
    IVec3::NEG_Z,
];

impl Cells {
    fn index(&self, c: IVec3) -> Option<usize> {
        let [nx, ny, nz] = self.dims.map(|d| d as i32);
        (c.x >= 0 && c.y >= 0 && c.z >= 0 && c.x < nx && c.y < ny && c.z < nz)
            .then(|| (c.x + nx * (c.y + ny * c.z)) as usize)
    }

    fn coords(&self, i: usize) -> IVec3 {
        let [nx, ny, _] = self.dims;
        IVec3::new(
            (i % nx) as i32,
            ((i / nx) % ny) as i32,
            (i / (nx * ny)) as i32,
        )
    }

    fn is_solid(&self, c: IVec3) -> bool {
        self.index(c).is_some_and(|i| self.solid[i])
    }

    /// Points binned into cells with a margin of `margin` cells on every side; the spacing grows
    /// (doubling) until the grid has at most `max_cells` cells.
    fn from_points(points: &[Vec3A], h_m: f32, margin: usize, max_cells: usize) -> Option<Self> {
        let mut lo = Vec3A::splat(f32::INFINITY);
        let mut hi = Vec3A::splat(f32::NEG_INFINITY);
        for p in points.iter().filter(|p| p.is_finite()) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if !(lo.cmple(hi).all() && h_m.is_finite() && h_m > 0.0) {
            return None;
        }
        let mut h = h_m;
        let dims = |h: f32| {
            let n = ((hi - lo) / h).floor();
            [n.x, n.y, n.z].map(|v| v as usize + 2 + 2 * margin)
        };
        while dims(h).iter().map(|&d| d as f64).product::<f64>() > max_cells as f64 {
            h *= 2.0;
        }
        let dims = dims(h);
        // Cells anchored at the world origin: a point set's surface does not move with its
        // bounds.
        let origin_m = (lo / h).floor() * h - Vec3A::splat(margin as f32 * h);
        let mut cells = Cells {
            origin_m,
            h_m: h,
            dims,
            solid: vec![false; dims.iter().product()],
        };
        for p in points.iter().filter(|p| p.is_finite()) {
            let c = ((*p - origin_m) / h).floor().as_ivec3();
            if let Some(i) = cells.index(c) {
                cells.solid[i] = true;
            }
        }
        Some(cells)
    }

    /// Closing by one cell with the enclosed space filled (module docs).
    fn close(&mut self) {
        let n = self.solid.len();
        let mut dilated = self.solid.clone();
        for i in (0..n).filter(|&i| self.solid[i]) {
            let c = self.coords(i);
            for d in neighbours26() {
                if let Some(j) = self.index(c + d) {
                    dilated[j] = true;
                }
            }
        }
        // Flood the outside from every border cell that is not solid.
        let mut outside = vec![false; n];
        let mut queue = VecDeque::new();
        for i in 0..n {
            let c = self.coords(i);
            let border = (0..3).any(|a| c[a] == 0 || c[a] == self.dims[a] as i32 - 1);
            if border && !dilated[i] {
                outside[i] = true;
                queue.push_back(i);
            }
        }
        while let Some(i) = queue.pop_front() {
            let c = self.coords(i);
            for f in FACES {
                if let Some(j) = self.index(c + f)
                    && !dilated[j]
                    && !outside[j]
                {
                    outside[j] = true;
                    queue.push_back(j);
                }
            }
        }
        // Erode the filled set by one cell: a cell stays when no neighbour is outside.
        let filled: Vec<bool> = (0..n)
            .map(|i| {
                self.solid[i]
                    || (!outside[i]
                        && neighbours26()
                            .all(|d| self.index(self.coords(i) + d).is_some_and(|j| !outside[j])))
            })
            .collect();
        self.solid = filled;
    }
}

fn neighbours26() -> impl Iterator<Item = IVec3> {
    (-1..=1).flat_map(|z| {
        (-1..=1).flat_map(move |y| {
            (-1..=1)
                .map(move |x| IVec3::new(x, y, z))
                .filter(|d| *d != IVec3::ZERO)
        })
    })
}

/// Distance from `p` to the axis-aligned square face of side `h` centred at `c` whose normal is
/// the axis where `c` sits on a cell boundary (`axis`).
fn face_distance(p: Vec3A, c: Vec3A, axis: usize, h: f32) -> f32 {
    let d = p - c;
    let mut q = d.abs() - Vec3A::splat(0.5 * h);
    q[axis] = d[axis].abs();
    q.max(Vec3A::ZERO).length()
}

impl LevelSet {
    /// The level set of the solid that the points `[N]` (m) occupy, cells of size `h_m` (m,
    /// doubled until the grid has at most `max_cells` cells). `None` for no finite point or a
    /// bad spacing.
    pub fn from_points(points: &[Vec3A], h_m: f32, max_cells: usize) -> Option<Self> {
        let mut cells = Cells::from_points(points, h_m, 3, max_cells)?;
        cells.close();
        Some(Self::from_cells(&cells))
    }

    fn from_cells(cells: &Cells) -> Self {
        let h = cells.h_m;
        // Boundary faces: (centre, axis).
        let mut faces = Vec::new();
        let mut axes = Vec::new();
        for i in (0..cells.solid.len()).filter(|&i| cells.solid[i]) {
            let c = cells.coords(i);
            let centre = cells.origin_m + (c.as_vec3a() + 0.5) * h;
            for (k, f) in FACES.iter().enumerate() {
                if !cells.is_solid(c + *f) {
                    faces.push(centre + f.as_vec3a() * (0.5 * h));
                    axes.push(k / 2);
                }
            }
        }
        let dims = cells.dims.map(|d| d + 1);
        let [nx, ny, nz] = dims;
        let mut phi_m = vec![f32::INFINITY; nx * ny * nz];
        let mut kept_tree = None;
        if !faces.is_empty() {
            let points: Vec<[f32; 3]> = faces.iter().map(|f| f.to_array()).collect();
            let tree: ImmutableKdTree<f32, u32, 3, 32> = ImmutableKdTree::new_from_slice(&points);
            let k = std::num::NonZero::new(NEAREST_FACES.min(faces.len()))
                .unwrap_or(std::num::NonZero::<usize>::MIN);
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        let node = IVec3::new(x as i32, y as i32, z as i32);
                        let p = cells.origin_m + node.as_vec3a() * h;
                        let mut best = f32::INFINITY;
                        for nn in tree.nearest_n::<SquaredEuclidean>(&p.to_array(), k) {
                            let j = nn.item as usize;
                            best = best.min(face_distance(p, faces[j], axes[j], h));
                        }
                        let inside = (0..8).all(|corner| {
                            let d = IVec3::new(corner & 1, (corner >> 1) & 1, corner >> 2);
                            cells.is_solid(node - IVec3::ONE + d)
                        });
                        phi_m[x + nx * (y + ny * z)] = if inside { -best } else { best };
                    }
                }
            }
            kept_tree = Some(Box::new(tree));
        }
        Self {
            origin_m: cells.origin_m,
            h_m: h,
            dims,
            phi_m,
            faces,
            axes: axes.into_iter().map(|a| a as u8).collect(),
            tree: kept_tree,
        }
    }

    /// The boundary faces within `reach_m` of `x` (m), each as its index into
    /// [`Self::surface_points`], the point of the face (a square of side h) closest to `x`, and
    /// whether that point is `x`'s projection onto the face's plane (not clipped to its edges).
    /// The union of the faces is the surface the level set's distance is measured to, so the
    /// nearest of these points is the surface point nearest `x` (in no particular order).
    pub fn faces_near(&self, x: Vec3A, reach_m: f32) -> Vec<(u32, Vec3A, bool)> {
        let Some(tree) = &self.tree else {
            return Vec::new();
        };
        // A face's points lie within h/√2 of its centre.
        let r = reach_m + self.h_m * std::f32::consts::FRAC_1_SQRT_2;
        let half = Vec3A::splat(0.5 * self.h_m);
        tree.within_unsorted::<SquaredEuclidean>(&x.to_array(), r * r)
            .into_iter()
            .filter_map(|nn| {
                let f = nn.item as usize;
                let (c, axis) = (self.faces[f], self.axes[f] as usize);
                let mut offset = x - c;
                offset[axis] = 0.0;
                let projected = offset.abs().cmple(half).all();
                let q = c + offset.clamp(-half, half);
                ((x - q).length() <= reach_m).then_some((nn.item, q, projected))
            })
            .collect()
    }

    /// Node spacing h (m).
    pub fn spacing_m(&self) -> f32 {
        self.h_m
    }

    /// Bounds of the grid (m): outside them [`Self::sample`] is at least the distance to the box.
    pub fn bounds_m(&self) -> (Vec3A, Vec3A) {
        let [nx, ny, nz] = self.dims;
        let extent = Vec3A::new(nx as f32 - 1.0, ny as f32 - 1.0, nz as f32 - 1.0) * self.h_m;
        (self.origin_m, self.origin_m + extent)
    }

    /// The boundary face centres (m): points on the surface, about one per h² of area.
    pub fn surface_points(&self) -> &[Vec3A] {
        &self.faces
    }

    fn node(&self, i: usize, j: usize, k: usize) -> f32 {
        self.phi_m[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// Signed distance at `x` (m) and its gradient (unnormalised; zero where flat), trilinear.
    /// Outside the grid: the value at the nearest grid point plus the distance to it.
    pub fn sample(&self, x: Vec3A) -> (f32, Vec3A) {
        let (lo, hi) = self.bounds_m();
        let clamped = x.clamp(lo, hi);
        let outside = (x - clamped).length();
        let g = (clamped - self.origin_m) / self.h_m;
        let max = Vec3A::new(
            self.dims[0] as f32 - 2.0,
            self.dims[1] as f32 - 2.0,
            self.dims[2] as f32 - 2.0,
        );
        let base = g.floor().clamp(Vec3A::ZERO, max.max(Vec3A::ZERO));
        let f = (g - base).clamp(Vec3A::ZERO, Vec3A::ONE);
        let (i, j, k) = (base.x as usize, base.y as usize, base.z as usize);
        let c = |a: usize, b: usize, d: usize| self.node(i + a, j + b, k + d);
        let (c000, c100, c010, c110) = (c(0, 0, 0), c(1, 0, 0), c(0, 1, 0), c(1, 1, 0));
        let (c001, c101, c011, c111) = (c(0, 0, 1), c(1, 0, 1), c(0, 1, 1), c(1, 1, 1));
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = lerp(c000, c100, f.x);
        let x10 = lerp(c010, c110, f.x);
        let x01 = lerp(c001, c101, f.x);
        let x11 = lerp(c011, c111, f.x);
        let y0 = lerp(x00, x10, f.y);
        let y1 = lerp(x01, x11, f.y);
        let phi = lerp(y0, y1, f.z);
        let dx = lerp(
            lerp(c100 - c000, c110 - c010, f.y),
            lerp(c101 - c001, c111 - c011, f.y),
            f.z,
        );
        let dy = lerp(x10 - x00, x11 - x01, f.z);
        let dz = y1 - y0;
        let grad = Vec3A::new(dx, dy, dz) / self.h_m;
        if outside > 0.0 {
            let out = (x - clamped) / outside;
            (phi.max(0.0) + outside, out)
        } else {
            (phi, grad)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a jittered-free lattice filling the box [lo, hi) at spacing s.
    fn box_points(lo: Vec3A, hi: Vec3A, s: f32) -> Vec<Vec3A> {
        let n = ((hi - lo) / s).round().as_ivec3();
        let mut out = Vec::new();
        for z in 0..n.z {
            for y in 0..n.y {
                for x in 0..n.x {
                    out.push(lo + (IVec3::new(x, y, z).as_vec3a() + 0.5) * s);
                }
            }
        }
        out
    }

    #[test]
    fn a_box_of_points_has_its_faces_on_the_cell_faces() {
        // 10 cm cube filled at 5 mm, cells of 1 cm aligned with it: the surface is the cube's.
        let ls = LevelSet::from_points(
            &box_points(Vec3A::ZERO, Vec3A::splat(0.1), 0.005),
            0.01,
            1 << 20,
        )
        .unwrap();
        let (phi, grad) = ls.sample(Vec3A::new(0.05, 0.05, 0.13));
        assert!((phi - 0.03).abs() < 1e-5, "{phi}");
        assert!((grad.normalize() - Vec3A::Z).length() < 1e-4);
        let (phi, _) = ls.sample(Vec3A::new(0.05, 0.05, 0.05));
        assert!((phi + 0.05).abs() < 1e-5, "centre {phi}");
        let (phi, grad) = ls.sample(Vec3A::new(0.05, -0.004, 0.05));
        assert!((phi - 0.004).abs() < 1e-5, "{phi}");
        assert!((grad.normalize() + Vec3A::Y).length() < 1e-4);
        // Corner region: distance to the corner.
        let (phi, _) = ls.sample(Vec3A::new(0.13, 0.14, 0.1));
        assert!((phi - 0.05).abs() < 1e-3, "{phi}");
    }

    #[test]
    fn a_hollow_shell_is_filled_and_an_open_sheet_stays_thin() {
        // The surface of a 10 cm cube only (points 2 mm apart on its faces, cells of 1 cm).
        let mut shell = Vec::new();
        for p in box_points(Vec3A::ZERO, Vec3A::splat(0.1), 0.002) {
            if p.min_element() < 0.002 || p.max_element() > 0.098 {
                shell.push(p);
            }
        }
        let ls = LevelSet::from_points(&shell, 0.01, 1 << 20).unwrap();
        assert!(ls.sample(Vec3A::splat(0.05)).0 < -0.03);
        // A 1 mm thick sheet: one cell thick, inside only within it.
        let sheet = box_points(Vec3A::ZERO, Vec3A::new(0.2, 0.2, 0.002), 0.002);
        let ls = LevelSet::from_points(&sheet, 0.01, 1 << 22).unwrap();
        assert!(ls.sample(Vec3A::new(0.1, 0.1, 0.005)).0 < 1e-4);
        let (above, g) = ls.sample(Vec3A::new(0.1, 0.1, 0.03));
        assert!((above - 0.02).abs() < 1e-4, "{above}");
        assert!(g.normalize().z > 0.99);
        assert!(ls.sample(Vec3A::new(0.1, 0.1, -0.03)).0 > 0.0);
    }

    #[test]
    fn queries_outside_the_grid_grow_with_distance() {
        let ls = LevelSet::from_points(
            &box_points(Vec3A::ZERO, Vec3A::splat(0.1), 0.01),
            0.01,
            1 << 20,
        )
        .unwrap();
        let (near, _) = ls.sample(Vec3A::new(0.05, 0.05, 0.2));
        let (far, g) = ls.sample(Vec3A::new(0.05, 0.05, 1.0));
        assert!(far > near + 0.7, "{near} {far}");
        assert!(g.z > 0.99);
    }
}
