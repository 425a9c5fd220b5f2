//! A `World` whose deformable objects run on the GPU where nothing but grid colliders can reach
//! them, against the same world on the CPU: the trajectory, the restitution law (with its
//! friction bound on an oblique impact), a command, and the hand-over to the CPU when a solid
//! object comes near.
//!
//! Needs a wgpu adapter (a GPU, or Mesa's lavapipe); without one every test prints why and
//! passes, unless `SPLATPHYS_REQUIRE_GPU` is set (CI sets it).

use std::sync::Arc;

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{
    ColliderSpec, Command, Device, ObjectKind, Scene, SceneObject, Surface,
};
use splatphys_core::world::World;
use splatphys_gpu::GpuBackend;

/// The GPU backend every test shares (one device per process: lavapipe keeps over a gigabyte per
/// device until the process ends), or `None` with a message where there is none.
fn backend() -> Option<Arc<GpuBackend>> {
    static SHARED: std::sync::OnceLock<Result<Arc<GpuBackend>, String>> =
        std::sync::OnceLock::new();
    match SHARED.get_or_init(|| GpuBackend::open().map(Arc::new).map_err(|e| e.to_string())) {
        Ok(b) => Some(b.clone()),
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

/// A jelly ball (R 4 cm, E 2e5 Pa, e = 0.5, μ 0.3) dropped from 6 cm above a sticky plane on a
/// 1 cm grid, thrown sideways at 0.3 m/s, and, when `slab`, a static slab 0.3 m along x that the
/// ball reaches after its bounce.
fn scene(slab: bool) -> Scene {
    let mut s = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.5)
        .frame_rate_hz(30.0)
        .sleep(false)
        .device(Device::Gpu)
        .collider(ColliderSpec::plane(
            "floor",
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
        ))
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.1], 0.04)
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .restitution(0.5)
                .friction(0.3)
                .velocity([0.3, 0.0, 0.0]),
        );
    if slab {
        s = s.object(
            SceneObject::cuboid("slab", [0.1, -0.1, 0.0], [0.2, 0.1, 0.05])
                .kind(ObjectKind::Static)
                .friction(0.3),
        );
    }
    s.build().expect("scene")
}

/// The ball's COM (m) and velocity (m/s) after every frame of `w`, with `command` applied after
/// frame 6.
fn run(mut w: World, command: Option<&Command>) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, World) {
    let (mut com, mut vel) = (Vec::new(), Vec::new());
    while !w.is_finished() {
        w.advance_frame().expect("frame");
        let o = &w.objects()[0];
        com.push(o.com_m);
        vel.push(o.velocity_m_s);
        if w.frame() == 6
            && let Some(c) = command
        {
            w.apply(c).expect("command");
        }
    }
    (com, vel, w)
}

/// A sideways push on the ball (0.05 N s on about 0.27 kg).
fn push() -> Command {
    Command::Impulse {
        object: 0,
        impulse_n_s: [0.0, 0.05, 0.0],
        point_m: None,
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// The CPU world and the GPU world of `scene`.
fn pair(scene: &Scene, gpu: Arc<GpuBackend>) -> (World, World) {
    let cpu = World::from_scene(scene).expect("world");
    let mut on_gpu = cpu.clone();
    on_gpu.set_device(Some(gpu));
    (cpu, on_gpu)
}

#[test]
fn a_ball_bouncing_on_a_plane_follows_the_cpu_world_and_takes_a_command() {
    let Some(gpu) = backend() else {
        return;
    };
    let push = push();
    let (cpu, on_gpu) = pair(&scene(false), gpu);
    let (com_c, vel_c, _) = run(cpu, Some(&push));
    let (com_g, vel_g, w) = run(on_gpu, Some(&push));
    let b = &w.bodies()[0];
    let substeps = b.stats().substeps_taken;
    eprintln!(
        "{} of {substeps} substeps, {} upload(s), on {}",
        b.device_substeps(),
        b.device_uploads(),
        w.device().map(|d| d.name()).unwrap_or_default()
    );
    assert_eq!(b.device_refused(), None);
    assert_eq!(b.device_substeps(), substeps, "every substep on the GPU");
    // It travels 15 cm, past its grid's margin, and the command brings its particles back to
    // the host: the grid moves and the particles are written back, with no new upload.
    assert_eq!(b.device_uploads(), 1);
    for (f, (c, g)) in com_c.iter().zip(&com_g).enumerate() {
        let d = distance(*c, *g);
        eprintln!(
            "frame {f:2}: z {:.4}/{:.4} m, v_z {:+.3}/{:+.3} m/s, v_y {:+.3}/{:+.3}, COM apart {d:.2e} m",
            c[2], g[2], vel_c[f][2], vel_g[f][2], vel_c[f][1], vel_g[f][1]
        );
        // Free fall (the first 3 frames) to float round-off; bounces within a tenth of a cell
        // (measured on lavapipe: 1e-7 m over every frame).
        let tolerance = if f < 3 { 1e-6 } else { 1e-3 };
        assert!(
            d < tolerance,
            "frame {f}: COM {c:?} on the CPU, {g:?} on the GPU"
        );
    }
    // The restitution law ran on the GPU: the ball left the plane at the CPU's speed.
    let top = |v: &[[f64; 3]]| v.iter().map(|v| v[2]).fold(f64::MIN, f64::max);
    assert!(top(&vel_c) > 0.1, "no rebound on the CPU: {vel_c:?}");
    assert!((top(&vel_c) - top(&vel_g)).abs() < 0.02);
    // The command's impulse (0.05 N s on about 0.27 kg) reached the particles on the GPU.
    assert!(vel_g[7][1] > 0.1, "{:?}", vel_g[7]);
    assert!((vel_c[7][1] - vel_g[7][1]).abs() < 1e-3);
}

#[test]
fn a_ball_reaching_a_static_slab_steps_on_the_cpu_there_and_matches_the_cpu_world() {
    let Some(gpu) = backend() else {
        return;
    };
    let (cpu, on_gpu) = pair(&scene(true), gpu);
    let (com_c, _, _) = run(cpu, None);
    let (com_g, _, w) = run(on_gpu, None);
    let b = &w.bodies()[0];
    let (on, all) = (b.device_substeps(), b.stats().substeps_taken);
    eprintln!("{on} of {all} substeps on the GPU");
    assert!(on > 0 && on < all, "{on} of {all} on the GPU");
    for (f, (c, g)) in com_c.iter().zip(&com_g).enumerate() {
        let d = distance(*c, *g);
        eprintln!(
            "frame {f:2}: x {:.4}/{:.4} m, COM apart {d:.2e} m",
            c[0], g[0]
        );
        assert!(
            d < 1e-3,
            "frame {f}: COM {c:?} on the CPU, {g:?} on the GPU"
        );
    }
    // The slab stopped the ball on both.
    assert!(com_g.last().unwrap()[0] < 0.1);
}

#[test]
fn runs_of_substeps_in_one_wait_follow_one_substep_at_a_time() {
    let Some(gpu) = backend() else {
        return;
    };
    let push = push();
    let (_, in_runs) = pair(&scene(false), gpu);
    let mut alone = in_runs.clone();
    alone.set_device_run(1);
    let (com_a, vel_a, wa) = run(alone, Some(&push));
    let (com_r, vel_r, wr) = run(in_runs, Some(&push));
    let (a, r) = (&wa.bodies()[0], &wr.bodies()[0]);
    let (substeps_a, substeps_r) = (a.stats().substeps_taken, r.stats().substeps_taken);
    eprintln!(
        "one at a time: {substeps_a} substeps, {} runs; in runs: {substeps_r} substeps in {} runs",
        a.device_runs(),
        r.device_runs()
    );
    assert_eq!(a.device_runs(), 0);
    assert_eq!(r.device_substeps(), substeps_r, "every substep on the GPU");
    // Free flight and resting take long runs; each bounce's contact opening and closing ends
    // one (measured on lavapipe: 1,735 substeps in 80 runs, the frames' last substeps alone).
    assert!(
        r.device_runs() > 0 && r.device_runs() * 5 < substeps_r,
        "{} runs for {substeps_r} substeps",
        r.device_runs()
    );
    // A run's dt is the CFL bound of a speed a little above the present one: a few more
    // substeps (measured: 1,735 against 1,723).
    assert!(substeps_r.abs_diff(substeps_a) * 50 <= substeps_a);
    for (f, (c, g)) in com_a.iter().zip(&com_r).enumerate() {
        let d = distance(*c, *g);
        eprintln!(
            "frame {f:2}: z {:.4}/{:.4} m, v_z {:+.3}/{:+.3} m/s, COM apart {d:.2e} m",
            c[2], g[2], vel_a[f][2], vel_r[f][2]
        );
        assert!(d < 1e-3, "frame {f}: COM {c:?} alone, {g:?} in runs");
    }
    // The restitution law acted at the same rebounds: each bounce's top speed.
    let top = |v: &[[f64; 3]]| v.iter().map(|v| v[2]).fold(f64::MIN, f64::max);
    assert!((top(&vel_a) - top(&vel_r)).abs() < 0.02);
    assert!((vel_a[7][1] - vel_r[7][1]).abs() < 1e-3);
}

#[test]
fn an_oblique_jelly_keeps_coulombs_sliding_speed_on_the_gpu_as_on_the_cpu() {
    // No gravity: a 10 cm jelly cube at (1, 0, −1) m/s onto a "separate" plane with μ = 0.3,
    // e = 0. The restitution law holds the impact's friction to μ times the normal impulse it
    // keeps, from the friction impulse the device sums: it leaves sliding at 1 − μ = 0.7 m/s
    // along the plane, as on the CPU.
    let Some(gpu) = backend() else {
        return;
    };
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.3)
        .frame_rate_hz(100.0)
        .gravity_m_s2([0.0; 3])
        .sleep(false)
        .device(Device::Gpu)
        .collider(
            ColliderSpec::plane("table", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.3),
        )
        .object(
            SceneObject::cuboid("jelly", [-0.05, -0.05, 0.01], [0.05, 0.05, 0.11])
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .restitution(0.0)
                .friction(0.3)
                .velocity([1.0, 0.0, -1.0]),
        )
        .build()
        .expect("scene");
    let (cpu, on_gpu) = pair(&scene, gpu);
    let (_, vel_c, _) = run(cpu, None);
    let (_, vel_g, w) = run(on_gpu, None);
    let b = &w.bodies()[0];
    assert_eq!(b.device_substeps(), b.stats().substeps_taken);
    let (c, g) = (vel_c.last().unwrap(), vel_g.last().unwrap());
    eprintln!("leaves at {c:.4?} m/s on the CPU, {g:.4?} on the GPU");
    assert!((g[0] - 0.7).abs() < 0.01 && g[2].abs() < 0.01, "{g:?}");
    assert!(distance(*c, *g) < 0.01, "CPU {c:?}, GPU {g:?}");
}
