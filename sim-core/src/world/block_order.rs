//! Particles stored in block order. P2G and G2P walk an object's particles block by block
//! ([`crate::mpm::binning::Binning`]: by stencil base block of 4³ cells, then by index), so
//! when index order is block order they read and write the particle arrays front to back
//! instead of at scattered addresses. Captured Gaussians arrive in the order training densified
//! them, which is close to random in space: `splatphys bench mpm --shuffle` measures what that
//! costs.
//!
//! An object's particles are therefore sorted once, when it is built, by (stencil base block,
//! stencil base node inside the block, Gaussian order). Particles move little against their
//! neighbours, so the order stays close to block order as the object moves; the per-substep
//! binning keeps the walk exact whatever the order. Gaussians keep the scene's order everywhere
//! outside the object (published frames, the scene service, recordings): a carried object's
//! neighbour lists name the sorted particles, and an object without a carry keeps, per Gaussian,
//! the particle that is that Gaussian ([`super::Body::gaussian_pose`]).

use glam::Vec3A;

use crate::mpm::binning::{BLOCK, block_key, pack};

/// The block order of particles at `x` (m) on a grid of cell `dx_m` (m): `order[k]` is the
/// index in `x` of the particle stored k-th. Sorted by stencil base block (the order of
/// [`crate::mpm::binning::Binning`]), then the base node inside that block (x fastest), then
/// index; a position outside the addressable grid (or not finite) sorts last, by index.
pub fn block_order(x: &[Vec3A], dx_m: f32) -> Vec<u32> {
    let inv_dx = 1.0 / dx_m;
    let key = |p: Vec3A| -> (u64, u32) {
        match block_key(p, inv_dx) {
            Some(k) => {
                let node = (p * inv_dx - Vec3A::splat(0.5)).floor().as_ivec3() - k * BLOCK;
                let local = (node.x + BLOCK * (node.y + BLOCK * node.z)) as u32;
                (pack(k), local)
            }
            None => (u64::MAX, u32::MAX),
        }
    };
    let mut keyed: Vec<(u64, u32, u32)> = x
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (block, local) = key(*p);
            (block, local, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, _, i)| i).collect()
}

/// The inverse of permutation `order`: `inverse[order[k]] = k`.
pub fn inverse(order: &[u32]) -> Vec<u32> {
    let mut inv = vec![0u32; order.len()];
    for (k, &i) in order.iter().enumerate() {
        inv[i as usize] = k as u32;
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::binning::Binning;

    /// Positions scattered pseudo-randomly over several blocks (cell 0.1 m).
    fn cloud(n: u32) -> Vec<Vec3A> {
        (0..n)
            .map(|i| {
                let h = i.wrapping_mul(2_654_435_761);
                Vec3A::new(
                    (h % 97) as f32,
                    (h / 97 % 89) as f32,
                    (h / 8633 % 83) as f32,
                ) * 0.031
                    - Vec3A::splat(1.2)
            })
            .collect()
    }

    #[test]
    fn stored_in_block_order_the_binning_walks_particles_front_to_back() {
        let x = cloud(5000);
        let order = block_order(&x, 0.1);
        let sorted: Vec<Vec3A> = order.iter().map(|&i| x[i as usize]).collect();
        let mut bins = Binning::default();
        bins.rebuild(&sorted, 10.0).expect("finite positions");
        let walk: Vec<u32> = (0..sorted.len() as u32).collect();
        assert_eq!(bins.order, walk, "the binning's walk is index order");
        // Shuffled, it is not (the test would pass vacuously on a cloud in block order).
        bins.rebuild(&x, 10.0).expect("finite positions");
        assert_ne!(bins.order, walk);
    }

    #[test]
    fn order_is_a_permutation_and_inverse_undoes_it() {
        let x = cloud(777);
        let order = block_order(&x, 0.05);
        let inv = inverse(&order);
        for (k, &i) in order.iter().enumerate() {
            assert_eq!(inv[i as usize], k as u32);
        }
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..777).collect::<Vec<u32>>());
    }

    #[test]
    fn a_position_off_the_grid_sorts_last() {
        let mut x = cloud(10);
        x[3] = Vec3A::splat(f32::NAN);
        let order = block_order(&x, 0.1);
        assert_eq!(*order.last().expect("ten"), 3);
    }
}
