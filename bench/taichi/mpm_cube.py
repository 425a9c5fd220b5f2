#!/usr/bin/env python3
"""Taichi reference of `splatphys bench mpm`: the same MLS-MPM problem, written the way Taichi
users write it (the mpm88/mpm99/mpm3d examples: a dense grid of (1/dx)^3 nodes cleared every
substep, atomic scatter, `ti.svd` for the polar decomposition), on the CPU backend.

Problem (the standard Taichi MLS-MPM CPU benchmark): an elastic cube of n^3 particles (side 0.3 m, corner (0.35, 0.35, 0.3) m) at
1 m/s towards the floor (-z) of a 1 m cube domain, dx = 1/grid m, E = 1e5 Pa, nu = 0.3,
1000 kg/m^3, fixed dt = 1e-4 s, gravity 9.8 m/s^2 (-z); `--warmup` substeps (kernel compilation
happens there) then `--steps` timed substeps, `ti.sync()` before the clock stops.

Same discretisation as splatphys (sim-core/src/mpm): particles at the cell centres of a lattice of
spacing 0.3/n (`Particles::lattice_box`), volume spacing^3, mass 1000 * volume; quadratic
B-splines, APIC, fixed-corotated ("jelly") Kirchhoff stress 2 mu (F - R) F^T + lambda J (J - 1) I;
grid v = p/m + dt g, then a "separate" boundary 3 cells from every wall (only the approaching
normal velocity is removed); G2P with F <- (I + dt C) F.

Prints ONE JSON line on stdout (Taichi's own log lines go to stderr):
  {"bench": "mpm", "impl": "taichi", "particles", "steps", "threads", "grid", "domain_scale",
   "grid_nodes", "seconds", "particle_substeps_per_s", "taichi_version", "com_z_m",
   "momentum_z_kg_m_s"}
com_z_m / momentum_z_kg_m_s: centre-of-mass height and total z momentum after warm-up + steps.

Run by `splatphys bench mpm --vs-taichi`; alone:
  python3 bench/taichi/mpm_cube.py --particles-per-axis 40 --grid 64 --steps 200 --threads 2
"""

import argparse
import contextlib
import json
import sys
import time


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--particles-per-axis", type=int, default=40)
    ap.add_argument("--grid", type=int, default=64, help="cells per metre (dx = 1/grid m)")
    ap.add_argument("--steps", type=int, default=200, help="timed substeps")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--warmup", type=int, default=5, help="untimed substeps (compile here)")
    ap.add_argument("--domain-scale", type=float, default=1.0, help="domain edge (m)")
    ap.add_argument("--arch", choices=["cpu", "cuda", "vulkan"], default="cpu",
                    help="Taichi backend (cuda: the GPU comparison of `bench mpm --device gpu`)")
    a = ap.parse_args()
    if a.particles_per_axis < 1 or a.grid < 8 or a.steps < 0 or a.threads < 1 or a.warmup < 1:
        ap.error("need --particles-per-axis >= 1, --grid >= 8, --steps >= 0, --threads >= 1, --warmup >= 1")

    # Taichi prints its banner and init lines on stdout: keep stdout for the one JSON line.
    with contextlib.redirect_stdout(sys.stderr):
        import numpy as np
        import taichi as ti

        ti.init(arch=getattr(ti, a.arch), cpu_max_num_threads=a.threads, default_fp=ti.f32, random_seed=0)

    n = a.particles_per_axis
    dx = 1.0 / a.grid
    inv_dx = float(a.grid)
    n_grid = int(round(a.domain_scale * a.grid))
    bound = 3
    dt = 1e-4
    spacing = np.float32(0.3) / np.float32(n)
    p_vol = float(spacing**3)
    p_rho = 1000.0
    p_mass = p_vol * p_rho
    E, nu = 1e5, 0.3
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    n_particles = n**3
    if n_grid - bound <= int(0.65 * a.grid) + 2:
        ap.error("--domain-scale too small for the cube and its 3-cell bound")

    x = ti.Vector.field(3, dtype=ti.f32, shape=n_particles)
    v = ti.Vector.field(3, dtype=ti.f32, shape=n_particles)
    C = ti.Matrix.field(3, 3, dtype=ti.f32, shape=n_particles)
    F = ti.Matrix.field(3, 3, dtype=ti.f32, shape=n_particles)
    grid_v = ti.Vector.field(3, dtype=ti.f32, shape=(n_grid, n_grid, n_grid))
    grid_m = ti.field(dtype=ti.f32, shape=(n_grid, n_grid, n_grid))
    gravity = ti.Vector([0.0, 0.0, -9.8])

    @ti.kernel
    def substep():
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.Vector.zero(ti.f32, 3)
            grid_m[I] = 0.0
        ti.loop_config(block_dim=64)
        for p in x:
            Xp = x[p] * inv_dx
            base = ti.cast(Xp - 0.5, ti.i32)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            U, sig, V = ti.svd(F[p])
            R = U @ V.transpose()
            J = F[p].determinant()
            tau = 2.0 * mu * (F[p] - R) @ F[p].transpose() + ti.Matrix.identity(ti.f32, 3) * (lam * J * (J - 1.0))
            stress = (-dt * p_vol * 4.0 * inv_dx * inv_dx) * tau
            affine = stress + p_mass * C[p]
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                offset = ti.Vector([i, j, k])
                dpos = (offset - fx) * dx
                weight = w[i][0] * w[j][1] * w[k][2]
                grid_v[base + offset] += weight * (p_mass * v[p] + affine @ dpos)
                grid_m[base + offset] += weight * p_mass
        for I in ti.grouped(grid_m):
            if grid_m[I] > 0:
                vi = grid_v[I] / grid_m[I] + dt * gravity
                for d in ti.static(range(3)):
                    if I[d] < bound and vi[d] < 0:
                        vi[d] = 0.0
                    if I[d] > n_grid - bound and vi[d] > 0:
                        vi[d] = 0.0
                grid_v[I] = vi
        ti.loop_config(block_dim=64)
        for p in x:
            Xp = x[p] * inv_dx
            base = ti.cast(Xp - 0.5, ti.i32)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(ti.f32, 3)
            new_C = ti.Matrix.zero(ti.f32, 3, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                offset = ti.Vector([i, j, k])
                dpos = offset - fx
                g_v = grid_v[base + offset]
                weight = w[i][0] * w[j][1] * w[k][2]
                new_v += weight * g_v
                new_C += 4.0 * inv_dx * weight * g_v.outer_product(dpos)
            v[p] = new_v
            C[p] = new_C
            F[p] = (ti.Matrix.identity(ti.f32, 3) + dt * new_C) @ F[p]
            x[p] += dt * new_v

    # The lattice of `Particles::lattice_box`: cell centres min + (i + 0.5) * spacing, in f32.
    idx = np.arange(n, dtype=np.float32)
    coord = (idx + np.float32(0.5)) * spacing
    gx, gy, gz = np.meshgrid(coord, coord, coord, indexing="ij")
    lattice = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1).astype(np.float32)
    lattice += np.array([0.35, 0.35, 0.3], dtype=np.float32)
    x.from_numpy(lattice)
    v.from_numpy(np.tile(np.array([0.0, 0.0, -1.0], dtype=np.float32), (n_particles, 1)))
    C.fill(0.0)
    F.from_numpy(np.tile(np.eye(3, dtype=np.float32), (n_particles, 1, 1)))

    with contextlib.redirect_stdout(sys.stderr):
        for _ in range(a.warmup):
            substep()
        ti.sync()
        t = time.perf_counter()
        for _ in range(a.steps):
            substep()
        ti.sync()
        seconds = time.perf_counter() - t

    xs = x.to_numpy().astype(np.float64)
    vs = v.to_numpy().astype(np.float64)
    if not (np.isfinite(xs).all() and np.isfinite(vs).all()):
        print("taichi run became non-finite", file=sys.stderr)
        return 1
    com_z = float(xs[:, 2].mean())
    momentum_z = float(vs[:, 2].sum() * p_mass)
    rate = n_particles * a.steps / seconds if seconds > 0 else 0.0
    print(
        json.dumps(
            {
                "bench": "mpm",
                "impl": "taichi",
                "taichi_version": ".".join(str(p) for p in ti.__version__),
                "arch": a.arch,
                "particles": n_particles,
                "steps": a.steps,
                "threads": a.threads,
                "grid": a.grid,
                "domain_scale": a.domain_scale,
                "grid_nodes": n_grid**3,
                "seconds": seconds,
                "particle_substeps_per_s": rate,
                "com_z_m": com_z,
                "momentum_z_kg_m_s": momentum_z,
            }
        ),
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
