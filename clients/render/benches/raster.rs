//! Rasterizer throughput: 100k random Gaussians at 640×480 (target: >= 30 frames/s on
//! 2 cores). Not a test; it never gates CI.
//!
//! Scene: centres uniform in a 1.6 m cube 3 m in front of the camera (50° vertical field of
//! view, so the cube fills most of the frame), standard deviations log-uniform in 2-20 mm per
//! axis, random orientation, opacities uniform in [0.05, 1], SH degree 0.

use criterion::{Criterion, criterion_main};
use glam::{Mat3, Quat, Vec3};
use splatphys_render::{Camera, RenderSettings, Splats, render};

/// splitmix64: a tiny deterministic generator, enough for a benchmark scene.
struct SplitMix(u64);

impl SplitMix {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn random_scene(n: usize) -> Splats {
    let mut rng = SplitMix(7);
    let mut s = Splats::default();
    for _ in 0..n {
        let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.6 - 0.8;
        s.positions.push(p.to_array());
        let scale = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
            .map(|u| (2e-3f32.ln() + u * (20e-3f32 / 2e-3).ln()).exp());
        let q = Quat::from_xyzw(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
        )
        .normalize();
        let rs = Mat3::from_quat(q) * Mat3::from_diagonal(scale);
        let c = rs * rs.transpose();
        s.covariances.push([
            c.x_axis.x, c.y_axis.x, c.z_axis.x, c.y_axis.y, c.z_axis.y, c.z_axis.z,
        ]);
        s.opacities.push(0.05 + 0.95 * rng.next_f32());
        s.sh.push([
            rng.next_f32() * 2.0 - 1.0,
            rng.next_f32() * 2.0 - 1.0,
            rng.next_f32() * 2.0 - 1.0,
        ]);
    }
    s
}

fn bench_raster(c: &mut Criterion) {
    let splats = random_scene(100_000);
    let view = splats.view().expect("consistent arrays");
    let camera = Camera::new(
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::ZERO,
        Vec3::Z,
        50.0,
        640,
        480,
    )
    .expect("valid camera");
    let settings = RenderSettings::default();
    c.bench_function("raster_100k_640x480", |b| {
        b.iter(|| render(&view, &camera, &settings).expect("render"))
    });
}

// criterion's macro defines an undocumented `pub fn benches`.
#[allow(missing_docs)]
mod group {
    use super::bench_raster;
    criterion::criterion_group!(benches, bench_raster);
}
criterion_main!(group::benches);
