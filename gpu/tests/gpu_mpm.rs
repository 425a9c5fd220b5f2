//! The GPU path against closed forms and against the CPU solver on the same problem.
//!
//! Needs a wgpu adapter: a GPU, or Mesa's lavapipe (software Vulkan, `apt install
//! mesa-vulkan-drivers`), which CI installs. Without one every test here prints why and passes,
//! unless `SPLATPHYS_REQUIRE_GPU` is set (CI sets it): then a missing adapter fails.

use glam::Vec3A;
use splatphys_core::collider::{BoxShape, Collider, Plane, Shape, Surface};
use splatphys_core::material::{ConstitutiveModel, Material, MaterialModel, MaterialSpec};
use splatphys_core::mpm::{MpmSystem, Particles, TimeStepPolicy};
use splatphys_gpu::mpm::check_supported;
use splatphys_gpu::{GpuContext, GpuError, GpuMpm};

/// The device every test shares, or `None` (with a message) where there is none and none is
/// required. One device for the whole run: lavapipe keeps well over a gigabyte per device it
/// opened until the process ends, and a device per test ran the tests out of memory.
fn context() -> Option<GpuContext> {
    static SHARED: std::sync::OnceLock<Result<GpuContext, String>> = std::sync::OnceLock::new();
    match SHARED.get_or_init(|| GpuContext::new().map_err(|e| e.to_string())) {
        Ok(ctx) => {
            eprintln!("GPU tests on {}", ctx.name());
            Some(ctx.clone())
        }
        Err(e) => {
            assert!(
                std::env::var_os("SPLATPHYS_REQUIRE_GPU").is_none(),
                "SPLATPHYS_REQUIRE_GPU is set and there is no adapter: {e}"
            );
            eprintln!("skipped: {e}");
            None
        }
    }
}

/// The fixed substep of these tests (s): about a third of the CFL bound (C = 1) on a 1/32 m grid
/// of the fastest material here (snow at its hardening cap, ~44 m/s), twice `splatphys bench
/// mpm`'s, so that the software Vulkan device the tests run on covers a landing in half the
/// substeps.
const DT_S: f32 = 2e-4;

/// An elastic cube of n³ particles filling (0.35, 0.35, 0.3)..(0.65, 0.65, 0.6) m at `v0` m/s,
/// jelly E = 1e5 Pa, ν = 0.3, 1000 kg/m³, in a 1 m domain bound 3 cells in, fixed dt
/// [`DT_S`]: the standard problem of `splatphys bench mpm` at twice its substep.
fn cube(n: u32, dx_m: f32, v0: Vec3A, gravity: Vec3A, material: Material) -> MpmSystem {
    let mut p = Particles::lattice_box(
        Vec3A::new(0.35, 0.35, 0.3),
        Vec3A::new(0.65, 0.65, 0.6),
        0.3 / n as f32,
        1000.0,
        0,
        0,
    );
    p.v.iter_mut().for_each(|v| *v = v0);
    let mut sys = MpmSystem::new(p, vec![material], dx_m);
    sys.gravity_m_s2 = gravity;
    sys.policy = TimeStepPolicy::Fixed {
        dt_s: DT_S,
        force: false,
    };
    let bound = BoxShape::new(Vec3A::splat(3.0 * dx_m), Vec3A::splat(1.0 - 3.0 * dx_m)).unwrap();
    sys.colliders.push(Collider::fixed(
        Shape::DomainBound(bound),
        Surface::Separate,
        0.0,
    ));
    sys
}

fn jelly() -> Material {
    Material::jelly(1e5, 0.3, 1000.0).unwrap()
}

fn model(model: MaterialModel, e_pa: f64, nu: f64, density: f64) -> Material {
    Material::from_spec(&MaterialSpec::new(model, e_pa, nu, density)).unwrap()
}

fn com(p: &Particles) -> Vec3A {
    let m: f32 = p.mass_kg.iter().sum();
    p.x.iter()
        .zip(&p.mass_kg)
        .fold(Vec3A::ZERO, |s, (x, &w)| s + *x * w)
        / m
}

/// The fixed substep of `sys` (s).
fn fixed_dt_s(sys: &MpmSystem) -> f32 {
    match sys.policy {
        TimeStepPolicy::Fixed { dt_s, .. } => dt_s,
        _ => panic!("these tests run fixed substeps"),
    }
}

/// Runs `sys` on the GPU for `substeps` of its fixed dt; returns its particles.
fn on_gpu(ctx: GpuContext, sys: &MpmSystem, substeps: u32) -> Particles {
    let mut gpu = GpuMpm::new(ctx, sys).expect("supported");
    gpu.substeps(substeps, fixed_dt_s(sys));
    gpu.check().expect("no failed substep");
    let mut out = sys.particles.clone();
    gpu.read_particles(&mut out).unwrap();
    out
}

/// The same run on the GPU and on the CPU solver (`cpu` is advanced `substeps` of its dt, and
/// `each` sees it after every one).
struct Compared {
    /// COM (m) on the CPU and on the GPU.
    com_cpu: Vec3A,
    com_gpu: Vec3A,
    /// The largest distance between a particle on the CPU and on the GPU (m).
    worst_m: f32,
}

fn against_cpu(
    ctx: GpuContext,
    cpu: &mut MpmSystem,
    substeps: u32,
    mut each: impl FnMut(&MpmSystem),
) -> Compared {
    let gpu = on_gpu(ctx, cpu, substeps);
    for _ in 0..substeps {
        cpu.substep(1.0).unwrap();
        each(cpu);
    }
    let worst_m = cpu
        .particles
        .x
        .iter()
        .zip(&gpu.x)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0f32, f32::max);
    Compared {
        com_cpu: com(&cpu.particles),
        com_gpu: com(&gpu),
        worst_m,
    }
}

impl Compared {
    /// Prints the comparison and asserts the COMs within 1 mm and every particle within a
    /// tenth of a cell (`dx_m`).
    fn assert_close(&self, what: &str, dx_m: f32) {
        let Self {
            com_cpu,
            com_gpu,
            worst_m,
        } = self;
        println!(
            "{what}: COM CPU {com_cpu:?} GPU {com_gpu:?}; worst particle apart {worst_m:.2e} m (a cell is {dx_m:.3} m)"
        );
        assert!(
            (*com_cpu - *com_gpu).length() < 1e-3,
            "{what}: {com_cpu:?} vs {com_gpu:?}"
        );
        assert!(
            *worst_m < 0.1 * dx_m,
            "{what}: worst particle {worst_m} m apart"
        );
    }
}

#[test]
fn a_falling_cube_follows_the_closed_form() {
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.81);
    let v0 = Vec3A::new(0.3, 0.0, 1.0);
    let sys = cube(8, 1.0 / 32.0, v0, g, jelly());
    let before = com(&sys.particles);
    // 0.15 s: the cube rises and falls back without reaching a wall.
    let n = 750;
    let after = on_gpu(ctx, &sys, n);
    // Symplectic Euler (gravity into the grid velocity, then x += dt v) after N substeps of dt:
    // x0 + v0 t + g t² / 2 + g dt t / 2.
    let dt = DT_S;
    let t = n as f32 * dt;
    let want = before + v0 * t + g * (0.5 * t * t + 0.5 * dt * t);
    let got = com(&after);
    println!("COM after {t} s: {got:?}, closed form {want:?}");
    // Within the rounding of f32 positions near 0.5 m (half an ulp, 3e-8 m, per substep, at
    // worst).
    let rounding_m = 3e-8 * n as f32;
    assert!((got - want).length() < rounding_m, "{got:?} vs {want:?}");
    // A free translation stays a translation: every particle moved by the same amount, to that
    // rounding.
    let moved = after.x[0] - sys.particles.x[0];
    let spread = after
        .x
        .iter()
        .zip(&sys.particles.x)
        .map(|(a, b)| (*a - *b - moved).length())
        .fold(0.0f32, f32::max);
    println!("largest difference between two particles' displacements: {spread:.1e} m");
    assert!(spread < 2.0 * rounding_m, "{spread}");
}

/// The COM in f64 (m): f32 sums of thousands of positions near 0.4 m round by 1e-7 m.
fn com_f64(p: &Particles) -> glam::DVec3 {
    let m: f64 = p.mass_kg.iter().map(|&m| f64::from(m)).sum();
    p.x.iter()
        .zip(&p.mass_kg)
        .fold(glam::DVec3::ZERO, |s, (x, &w)| {
            s + x.as_dvec3() * f64::from(w)
        })
        / m
}

/// P2G's fixed-point sums take each term to a unit (2^-20 of the heaviest particle's mass for
/// these 4,096 particles), rounded up or down at random with the odds of its fraction. On a
/// lattice many nodes get the same terms, so rounding to the nearest unit pushes the whole cube
/// one way every substep: 6.3e-6 m from the CPU in 500 substeps here (measured on lavapipe).
/// Dithered, the cube follows the CPU's f32 sums (3.0e-7 m).
#[test]
fn the_fixed_point_sums_move_a_lattice_cube_as_the_cpus_float_sums_do() {
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let mut cpu = cube(16, 1.0 / 32.0, Vec3A::new(0.3, 0.2, -1.0), g, jelly());
    cpu.policy = TimeStepPolicy::Fixed {
        dt_s: 1e-4,
        force: false,
    };
    let start = com_f64(&cpu.particles);
    let gpu = on_gpu(ctx, &cpu, 500);
    for _ in 0..500 {
        cpu.substep(1.0).unwrap();
    }
    let (a, b) = (com_f64(&cpu.particles), com_f64(&gpu));
    println!(
        "COM moved {:.4} m; CPU and GPU apart {:.2e} m",
        (a - start).length(),
        (a - b).length()
    );
    assert!((a - b).length() < 1e-6, "CPU {a:?} GPU {b:?}");
}

#[test]
fn the_standard_cube_matches_the_cpu_solver_through_its_landing() {
    for material in [jelly(), model(MaterialModel::NeoHookean, 1e5, 0.3, 1000.0)] {
        let Some(ctx) = context() else { return };
        let g = Vec3A::new(0.0, 0.0, -9.8);
        let mut cpu = cube(10, 1.0 / 32.0, Vec3A::new(0.0, 0.0, -1.0), g, material);
        let compared = against_cpu(ctx, &mut cpu, 1500, |_| {});
        // 0.3 s: the cube has hit the floor (about 0.2 s) and is on its way back up.
        let rising = cpu.particles.v.iter().map(|v| v.z).sum::<f32>() > 0.0;
        assert!(rising, "the cube should be on its way back up");
        compared.assert_close(cpu.materials[0].name(), 1.0 / 32.0);
    }
}

#[test]
fn a_cube_thrown_onto_a_plane_with_friction_matches_the_cpu_solver() {
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let dx = 1.0 / 32.0;
    // A floor that lets material leave (its nodes take the rule only where material reaches
    // them: the gap check) with Coulomb friction: a plane 0.4 of a cell above a node layer, one
    // a tenth of a cell below the next (where the nodes half a cell outside it take its rule
    // too), a box with its top there, and a plate 1 mm thick 0.6 of a cell below a node layer
    // (no node inside it or within half a cell above: the nodes behind it hold the material).
    let top = 6.9 * dx;
    let plate = 6.4 * dx;
    let floors = [
        (
            "plane",
            0.2,
            Shape::Plane(Plane::new(Vec3A::new(0.0, 0.0, 0.2), Vec3A::Z).unwrap()),
        ),
        (
            "plane below a node layer",
            top,
            Shape::Plane(Plane::new(Vec3A::new(0.0, 0.0, top), Vec3A::Z).unwrap()),
        ),
        (
            "box below a node layer",
            top,
            Shape::Box(
                BoxShape::new(Vec3A::new(0.05, 0.05, 0.1), Vec3A::new(0.95, 0.95, top)).unwrap(),
            ),
        ),
        (
            "1 mm plate",
            plate,
            Shape::Box(
                BoxShape::new(
                    Vec3A::new(0.05, 0.05, plate - 0.001),
                    Vec3A::new(0.95, 0.95, plate),
                )
                .unwrap(),
            ),
        ),
    ];
    for (what, height, shape) in floors {
        let mut cpu = cube(10, dx, Vec3A::new(0.8, 0.0, -1.0), g, jelly());
        cpu.colliders
            .push(Collider::fixed(shape, Surface::Separate, 0.3));
        let mut lowest = f32::MAX;
        let compared = against_cpu(ctx.clone(), &mut cpu, 1500, |cpu| {
            lowest = cpu.particles.x.iter().map(|x| x.z).fold(lowest, f32::min);
        });
        println!(
            "on a {what}: lowest particle ever {:.4} m above it",
            lowest - height
        );
        // It landed on the floor (reached it: particles 3 cm apart rest with their centres
        // about half that above it; never passed it) and friction slowed it.
        assert!(
            lowest > height - 0.005 && lowest < height + 0.02,
            "{what}: {lowest}"
        );
        let vx = cpu.particles.v.iter().map(|v| v.x).sum::<f32>() / cpu.particles.len() as f32;
        assert!(vx < 0.75, "{what}: friction should have slowed it: {vx}");
        compared.assert_close(what, dx);
    }
}

#[test]
fn a_cube_dropped_onto_a_1_mm_sticky_plate_lands_as_on_a_sticky_plane() {
    // A sticky box holds every node inside it; one thinner than a cell may hold none. The
    // nodes behind it, in the stencil of the particles on its near side, hold the material
    // there along the near face's normal, on the GPU as on the CPU, so the cube lands on a
    // 1 mm plate 0.6 of a cell below a node layer about as on a sticky plane at the plate's
    // top (without them the GPU's cube passed the plate and fell to the domain's floor). Not
    // exactly: the plane holds every node inside it, the ring of nodes just beyond the cube's
    // edge too (121 against the plate's 81 in the first substeps of the landing), which brakes
    // the landing more: measured 2.2 mm higher COM on the plane, 7 % of a cell.
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let dx = 1.0 / 32.0;
    let top = 6.4 * dx;
    let floors = [
        (
            "sticky plane",
            Shape::Plane(Plane::new(Vec3A::new(0.0, 0.0, top), Vec3A::Z).unwrap()),
        ),
        (
            "sticky 1 mm plate",
            Shape::Box(
                BoxShape::new(
                    Vec3A::new(0.05, 0.05, top - 0.001),
                    Vec3A::new(0.95, 0.95, top),
                )
                .unwrap(),
            ),
        ),
    ];
    let mut landed = Vec::new();
    for (what, shape) in floors {
        let mut cpu = cube(10, dx, Vec3A::new(0.0, 0.0, -1.0), g, jelly());
        cpu.colliders
            .push(Collider::fixed(shape, Surface::Sticky, 0.0));
        let mut lowest = f32::MAX;
        let compared = against_cpu(ctx.clone(), &mut cpu, 1000, |cpu| {
            lowest = cpu.particles.x.iter().map(|x| x.z).fold(lowest, f32::min);
        });
        println!(
            "on a {what}: lowest particle ever {:.4} m above it",
            lowest - top
        );
        assert!(lowest > top - 0.005, "{what}: passed it, {lowest}");
        compared.assert_close(what, dx);
        landed.push(compared.com_gpu.z);
    }
    assert!(
        (landed[0] - landed[1]).abs() < 0.1 * dx,
        "the cube's COM on the plane {} m, on the plate {} m",
        landed[0],
        landed[1]
    );
}

#[test]
fn the_impulse_a_plane_gives_a_cube_resting_on_it_is_the_cpus() {
    // A jelly cube dropped 1 cm onto a sticky plane, 0.2 s on (resting on it, still ringing):
    // the GPU's sum of the plane's normal impulse in the last substep is the CPU's, and it holds
    // the cube up (of the order of its weight times dt; measured 1.75× at DT_S, the ringing).
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let mut cpu = cube(8, 1.0 / 32.0, Vec3A::ZERO, g, jelly());
    let plane = Plane::new(Vec3A::new(0.0, 0.0, 0.29), Vec3A::Z).unwrap();
    cpu.colliders
        .push(Collider::fixed(Shape::Plane(plane), Surface::Sticky, 0.3));
    let mut gpu = GpuMpm::new(ctx, &cpu).expect("supported");
    gpu.substeps(1000, DT_S);
    let on_gpu = gpu.collider_impulses_n_s().unwrap();
    for _ in 0..1000 {
        cpu.substep(1.0).unwrap();
    }
    let on_cpu = cpu.solver.collider_impulses_n_s().to_vec();
    let weight_dt = cpu.particles.mass_kg.iter().sum::<f32>() as f64 * 9.8 * f64::from(DT_S);
    println!(
        "plane's impulse in the last substep: GPU {:?}, CPU {:?} N s; weight x dt {weight_dt:.3e}",
        on_gpu[1], on_cpu[1]
    );
    assert_eq!(on_gpu.len(), 2);
    // The domain bound is far from the cube and gave nothing.
    assert_eq!(on_gpu[0], glam::DVec3::ZERO);
    assert!((on_gpu[1] - on_cpu[1]).length() < 1e-3 * on_cpu[1].length());
    assert!(
        on_cpu[1].z > 0.5 * weight_dt && on_cpu[1].z < 3.0 * weight_dt,
        "{on_cpu:?}"
    );
}

#[test]
fn the_friction_a_plane_gives_a_sliding_cube_is_the_cpus() {
    // A jelly cube thrown along a plane at 0.5 m/s from 1 cm above it (μ = 0.3), 0.1 s on
    // (landed, sliding): the GPU's sum of the plane's friction impulse in the last substep is the
    // CPU's, and it brakes the slide (along −x, of the order of μ times the normal impulse).
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let mut cpu = cube(8, 1.0 / 32.0, Vec3A::new(0.5, 0.0, 0.0), g, jelly());
    let plane = Plane::new(Vec3A::new(0.0, 0.0, 0.29), Vec3A::Z).unwrap();
    cpu.colliders
        .push(Collider::fixed(Shape::Plane(plane), Surface::Separate, 0.3));
    let mut gpu = GpuMpm::new(ctx, &cpu).expect("supported");
    gpu.substeps(500, DT_S);
    let on_gpu = gpu.collider_contacts().unwrap();
    for _ in 0..500 {
        cpu.substep(1.0).unwrap();
    }
    let (normal, friction) = (
        cpu.solver.collider_impulses_n_s()[1],
        cpu.solver.collider_friction_n_s()[1],
    );
    println!(
        "plane's friction in the last substep: GPU {:?}, CPU {friction:?} N s; normal {normal:?}",
        on_gpu.friction_n_s[1]
    );
    assert_eq!(on_gpu.friction_n_s.len(), 2);
    assert_eq!(on_gpu.friction_n_s[0], glam::DVec3::ZERO);
    assert!((on_gpu.friction_n_s[1] - friction).length() < 1e-3 * friction.length());
    assert!(
        friction.x < -0.1 * 0.3 * normal.z && friction.x > -1.01 * 0.3 * normal.z,
        "friction {friction:?}, normal {normal:?}"
    );
}

#[test]
fn a_moving_plane_lifts_and_drags_a_cube_as_on_the_cpu() {
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let mut cpu = cube(10, 1.0 / 32.0, Vec3A::ZERO, g, jelly());
    // A floor rising at 0.3 m/s and sliding at 0.4 m/s from 0.02 s on, with friction: it meets
    // the falling cube, then carries it up and along.
    let plane = Plane::new(Vec3A::new(0.0, 0.0, 0.15), Vec3A::Z).unwrap();
    let mut moving = Collider::fixed(Shape::Plane(plane), Surface::Separate, 0.4);
    moving.velocity_m_s = Vec3A::new(0.4, 0.0, 0.3);
    moving.active_s = Some((0.02, 10.0));
    cpu.colliders.push(moving);
    let compared = against_cpu(ctx, &mut cpu, 1500, |_| {});
    let vx = cpu.particles.v.iter().map(|v| v.x).sum::<f32>() / cpu.particles.len() as f32;
    println!("moving plane: v_x {vx:.3} m/s");
    // The plane carried it: dragged along x by friction.
    let c = compared.com_cpu;
    assert!(vx > 0.05 && c.x > 0.505, "v_x {vx}, COM {c:?}");
    compared.assert_close("moving plane", 1.0 / 32.0);
}

#[test]
fn a_report_read_by_polling_is_the_one_read_by_blocking() {
    // A `World` reads a report after every substep; polling the device for it (what a hardware
    // adapter does) and blocking (a software one) must give the same report and particles.
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    let mut sys = cube(6, 1.0 / 32.0, Vec3A::new(0.0, 0.0, -1.0), g, jelly());
    let plane = Plane::new(Vec3A::new(0.0, 0.0, 0.29), Vec3A::Z).unwrap();
    sys.colliders
        .push(Collider::fixed(Shape::Plane(plane), Surface::Separate, 0.3));
    let run = |spin_ms: u64| {
        let mut gpu = GpuMpm::new(context().expect("the same device"), &sys).expect("supported");
        gpu.set_spin_wait(std::time::Duration::from_millis(spin_ms));
        let reports: Vec<_> = (0..60)
            .map(|_| {
                gpu.substep(DT_S);
                gpu.report(Vec3A::new(0.5, 0.5, 0.45)).expect("report")
            })
            .collect();
        let mut p = sys.particles.clone();
        gpu.read_particles(&mut p).expect("read back");
        (reports, p)
    };
    drop(ctx);
    let (polled, a) = run(50);
    let (blocked, b) = run(0);
    // The cube reached the plane: its impulse is in the reports.
    assert!(polled.iter().any(|r| r.impulses_n_s[1].z > 0.0));
    assert_eq!(polled, blocked);
    assert_eq!(a.x, b.x);
}

#[test]
fn a_grid_laid_out_anew_gives_what_a_new_upload_gives() {
    // A cube thrown sideways at 2 m/s on a grid laid out just around it: after 20 substeps the
    // grid is laid out anew over a wider box, the particles staying on the GPU, and the run
    // goes on bit for bit as a new upload of the particles read back at that point does. On
    // the first grid the cube would have left it.
    let Some(ctx) = context() else { return };
    let mut sys = cube(
        8,
        1.0 / 32.0,
        Vec3A::new(2.0, 0.0, 0.0),
        Vec3A::new(0.0, 0.0, -9.8),
        jelly(),
    );
    sys.colliders.clear();
    let (lo, hi) = (Vec3A::new(0.35, 0.35, 0.3), Vec3A::new(0.65, 0.65, 0.6));
    let wide = (lo - Vec3A::splat(0.2), hi + Vec3A::splat(0.2));
    let mut a = GpuMpm::new_over(ctx.clone(), &sys, Some((lo, hi))).expect("supported");
    a.substeps(20, DT_S);
    a.check().expect("inside the first grid");
    let mut at = sys.clone();
    a.read_particles(&mut at.particles).expect("read back");
    at.time_s = a.time_s;
    let mut b = GpuMpm::new_over(ctx.clone(), &at, Some(wide)).expect("supported");
    let mut stays = GpuMpm::new_over(ctx, &at, Some((lo, hi))).expect("supported");
    assert!(a.regrid(wide));
    for gpu in [&mut a, &mut b, &mut stays] {
        gpu.substeps(300, DT_S);
    }
    a.check().expect("inside the new grid");
    b.check().expect("inside the uploaded grid");
    assert!(stays.check().is_err(), "the cube stayed on its first grid");
    let (mut pa, mut pb) = (at.particles.clone(), at.particles.clone());
    a.read_particles(&mut pa).expect("read back");
    b.read_particles(&mut pb).expect("read back");
    assert!(com(&pa).x > 0.6, "it moved 10 cm on: {:?}", com(&pa));
    assert_eq!(pa.x, pb.x);
    assert_eq!(pa.v, pb.v);
    assert_eq!(pa.f, pb.f);
}

#[test]
fn a_run_gives_the_same_bits_every_time() {
    let Some(ctx) = context() else { return };
    let sys = cube(
        8,
        1.0 / 32.0,
        Vec3A::new(0.2, -0.1, -1.0),
        Vec3A::new(0.0, 0.0, -9.8),
        jelly(),
    );
    // 0.2 s: through the landing, where most nodes take terms from several workgroups.
    let a = on_gpu(ctx, &sys, 1000);
    let b = on_gpu(context().expect("the same device"), &sys, 1000);
    assert_eq!(a.x, b.x);
    assert_eq!(a.f, b.f);
}

#[test]
fn the_plastic_models_match_the_cpu_solver_through_a_crushing_landing() {
    // Each model's cube thrown at 2.5 m/s onto the domain's floor: it yields (the plastic state
    // moves on every particle that flowed) and its F_p follows. Compared over 0.12 s, through the
    // landing (at about 0.08 s).
    let cases = [
        (MaterialModel::Snow, 1.4e5, 0.2, 400.0),
        (MaterialModel::Sand, 3.5e5, 0.3, 1600.0),
        (MaterialModel::Metal, 2e5, 0.3, 1000.0),
        (MaterialModel::Plasticine, 1e5, 0.3, 1000.0),
        (MaterialModel::Foam, 1e5, 0.3, 300.0),
    ];
    for (kind, e_pa, nu, density) in cases {
        let Some(ctx) = context() else { return };
        let g = Vec3A::new(0.0, 0.0, -9.8);
        let material = model(kind, e_pa, nu, density);
        let name = material.name();
        let mut cpu = cube(8, 1.0 / 32.0, Vec3A::new(0.3, 0.0, -2.5), g, material);
        let initial = cpu.particles.plastic.clone();
        let gpu = on_gpu(ctx, &cpu, 600);
        for _ in 0..600 {
            cpu.substep(1.0).unwrap();
        }
        let flowed = |p: &Particles| {
            p.plastic
                .iter()
                .zip(&initial)
                .filter(|(a, b)| (*a - *b).abs() > 1e-6)
                .count()
        };
        let (flowed_cpu, flowed_gpu) = (flowed(&cpu.particles), flowed(&gpu));
        let apart = |a: &[Vec3A], b: &[Vec3A]| {
            a.iter()
                .zip(b)
                .map(|(a, b)| (*a - *b).length())
                .fold(0.0f32, f32::max)
        };
        let worst_m = apart(&cpu.particles.x, &gpu.x);
        let fp_apart = cpu
            .particles
            .f_plastic
            .iter()
            .zip(&gpu.f_plastic)
            .map(|(a, b)| {
                (*a - *b)
                    .abs()
                    .to_cols_array()
                    .into_iter()
                    .fold(0.0f32, f32::max)
            })
            .fold(0.0f32, f32::max);
        let n = cpu.particles.len();
        println!(
            "{name}: flowed on {flowed_cpu}/{n} particles (GPU {flowed_gpu}); worst particle \
             {worst_m:.2e} m apart, worst F_p entry {fp_apart:.2e} apart"
        );
        assert!(flowed_cpu > n / 10, "{name} should have yielded");
        assert!(
            flowed_gpu.abs_diff(flowed_cpu) <= n / 50,
            "{name}: {flowed_gpu} vs {flowed_cpu}"
        );
        assert!(worst_m < 0.1 / 32.0, "{name}: {worst_m} m apart");
        assert!(fp_apart < 0.05, "{name}: F_p {fp_apart} apart");
        let (c_cpu, c_gpu) = (com(&cpu.particles), com(&gpu));
        assert!(
            (c_cpu - c_gpu).length() < 1e-3,
            "{name}: {c_cpu:?} vs {c_gpu:?}"
        );
    }
}

#[test]
fn a_device_with_too_few_storage_buffers_per_stage_is_refused_with_the_limit() {
    if context().is_none() {
        return;
    }
    // wgpu's default limit, 8, below the kernels' 11.
    let ctx = GpuContext::with_limits(|l| wgpu::Limits {
        max_storage_buffers_per_shader_stage: 8,
        ..l
    })
    .expect("a device with lower limits");
    let sys = cube(4, 1.0 / 16.0, Vec3A::ZERO, Vec3A::ZERO, jelly());
    match GpuMpm::new(ctx, &sys) {
        Err(GpuError::Unsupported { what }) => {
            assert!(
                what.contains("11 storage buffers") && what.contains("allows 8"),
                "{what}"
            );
        }
        other => panic!("expected Unsupported, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn what_the_gpu_does_not_run_is_refused_with_its_name() {
    let mut sys = cube(4, 1.0 / 32.0, Vec3A::ZERO, Vec3A::ZERO, jelly());
    sys.colliders.clear();
    let e = check_supported(&sys).unwrap_err();
    assert!(matches!(e, GpuError::Unsupported { .. }));
    assert!(e.to_string().contains("domain bound"), "{e}");
    assert!(check_supported(&cube(4, 1.0 / 32.0, Vec3A::ZERO, Vec3A::ZERO, jelly())).is_ok());
    let snow = model(MaterialModel::Snow, 1.4e5, 0.2, 400.0);
    assert!(check_supported(&cube(4, 1.0 / 32.0, Vec3A::ZERO, Vec3A::ZERO, snow)).is_ok());
}

#[test]
fn the_moments_summed_on_the_gpu_are_the_cpus_and_a_rigid_field_adds_as_on_the_cpu() {
    let Some(ctx) = context() else { return };
    let g = Vec3A::new(0.0, 0.0, -9.8);
    // A tumbling cube (C carries a spin) after its landing: every moment is non-trivial.
    let mut sys = cube(10, 1.0 / 32.0, Vec3A::new(0.4, -0.2, -1.5), g, jelly());
    for (x, v) in sys.particles.x.iter().zip(sys.particles.v.iter_mut()) {
        *v += Vec3A::new(0.0, 0.0, 3.0).cross(*x - Vec3A::splat(0.5));
    }
    let mut gpu = GpuMpm::new(ctx, &sys).expect("supported");
    gpu.substeps(750, DT_S);
    let mut p = sys.particles.clone();
    gpu.read_particles(&mut p).unwrap();
    let dx = 1.0 / 32.0;
    let want = splatphys_core::world::measure(&p, dx);
    let (got, max_speed) = gpu
        .moments(want.com_m.as_vec3a() + Vec3A::splat(0.01))
        .unwrap();
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-12);
    let rel3 = |a: glam::DVec3, b: glam::DVec3| (a - b).length() / b.length().max(1e-12);
    let rel_m = |a: glam::DMat3, b: glam::DMat3| {
        (a - b)
            .to_cols_array()
            .iter()
            .map(|d| d.abs())
            .fold(0.0, f64::max)
            / b.to_cols_array()
                .iter()
                .map(|d| d.abs())
                .fold(0.0, f64::max)
    };
    let fastest = p.v.iter().map(|v| v.length()).fold(0.0f32, f32::max);
    println!(
        "moments on the GPU against the CPU: mass {:.1e}, COM {:.1e} m, velocity {:.1e}, L {:.1e}, \
         inertia {:.1e} (relative); max speed {max_speed} vs {fastest} m/s",
        rel(got.mass_kg, want.mass_kg),
        (got.com_m - want.com_m).length(),
        rel3(got.velocity_m_s, want.velocity_m_s),
        rel3(got.angular_momentum, want.angular_momentum),
        rel_m(got.inertia, want.inertia),
    );
    // f32 sums over 1,000 particles against the CPU's f64 (measured: 2e-8 to 1e-7).
    assert!(rel(got.mass_kg, want.mass_kg) < 1e-6);
    assert!((got.com_m - want.com_m).length() < 1e-7);
    assert!(rel3(got.velocity_m_s, want.velocity_m_s) < 1e-6);
    assert!(rel3(got.angular_momentum, want.angular_momentum) < 1e-6);
    assert!(rel_m(got.inertia, want.inertia) < 1e-6);
    assert!((max_speed - fastest).abs() <= 1e-6 * fastest);
    assert!(got.radius_m >= want.radius_m - 1e-6);
    for k in 0..3 {
        assert!((got.aabb_m.0[k] - want.aabb_m.0[k]).abs() < 1e-6);
        assert!((got.aabb_m.1[k] - want.aabb_m.1[k]).abs() < 1e-6);
    }
    // The rigid field on the GPU adds what the CPU's formula adds.
    let (dv, dw, about) = (
        Vec3A::new(0.1, -0.2, 0.05),
        Vec3A::new(1.0, 2.0, -0.5),
        want.com_m.as_vec3a(),
    );
    gpu.rigid_field(dv, dw, about);
    let mut after = p.clone();
    gpu.read_particles(&mut after).unwrap();
    let skew = glam::Mat3A::from_cols(
        Vec3A::new(0.0, dw.z, -dw.y),
        Vec3A::new(-dw.z, 0.0, dw.x),
        Vec3A::new(dw.y, -dw.x, 0.0),
    );
    for i in 0..p.len() {
        let v = p.v[i] + dv + dw.cross(p.x[i] - about);
        assert!((after.v[i] - v).length() < 1e-6, "particle {i}");
        let c = p.c[i] + skew;
        let dc = (after.c[i] - c).to_cols_array();
        assert!(dc.iter().all(|d| d.abs() < 1e-5), "particle {i}");
    }
}
