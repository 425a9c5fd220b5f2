//! Criterion benchmarks of the MPM kernels: one full substep (binning, P2G, grid update, G2P) of
//! an elastic cube, and the 3×3 SVD. `cargo bench -p splatphys-core --bench kernels`.
#![allow(missing_docs)] // criterion_group! generates an undocumented function.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Mat3A, Vec3A};
use splatphys_core::material::Material;
use splatphys_core::math::svd3;
use splatphys_core::mpm::{MpmSystem, Particles, TimeStepPolicy};

fn substep(c: &mut Criterion) {
    let jelly = Material::jelly(1e5, 0.3, 1000.0).expect("valid material");
    let mut p = Particles::lattice_box(
        Vec3A::splat(0.35),
        Vec3A::splat(0.65),
        0.3 / 24.0,
        1000.0,
        0,
        0,
    );
    p.v.iter_mut().for_each(|v| *v = Vec3A::new(0.0, 0.0, -1.0));
    let mut sys = MpmSystem::new(p, vec![jelly], 1.0 / 64.0);
    sys.policy = TimeStepPolicy::Fixed {
        dt_s: 1e-4,
        force: false,
    };
    c.bench_function("mpm substep, 13824 particles", |b| {
        b.iter(|| sys.substep(1.0).expect("stable"))
    });
}

fn svd(c: &mut Criterion) {
    let m = Mat3A::from_cols_array(&[1.1, 0.05, -0.02, 0.03, 0.95, 0.01, -0.04, 0.02, 1.02]);
    c.bench_function("svd3 near identity", |b| {
        b.iter(|| svd3(std::hint::black_box(m)))
    });
}

criterion_group!(benches, substep, svd);
criterion_main!(benches);
