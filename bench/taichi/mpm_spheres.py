#!/usr/bin/env python3
"""Taichi reference of the `mpm` baseline of `splatphys bench compare`: two elastic spheres meeting
head-on on ONE shared grid (contact happens through the grid, no contact model), CPU backend.

Scene (bench/src/compare.rs `sphere_pair`): spheres of radius 4 cm centred at
x = -/+0.08 m moving at +/-1 m/s along x, jelly (fixed-corotated) E = 2e5 Pa, nu = 0.3,
1000 kg/m^3, no gravity, 0.3 s simulated in 100 Hz frames, CFL 0.5 substeps
dt = 0.5 dx / (c_p + |v|max) landing on every frame end (sim-core/src/mpm/timestep.rs).
Particles as sim-core/src/procedural.rs `fill_points`: cell centres of a lattice of spacing dx/2
centred on the sphere's bounding box, each jittered uniformly by +/-0.25 spacing, kept inside the
sphere; volume = dx^3 split evenly among the particles of each grid cell (world/mod.rs
`particle_volumes`), mass = 1000 * volume. The jitter comes from numpy, not ChaCha8, so particle
counts and positions differ from splatphys' by the jitter noise.

Same MLS-MPM as mpm_cube.py on a dense grid around the pair (no walls: the run fails if a particle
gets near the grid edge). Prints ONE JSON line: throughput (particle substeps per second over the
whole 0.3 s, kernel compilation excluded) and the rebound: v1_m_s, v2_m_s (each sphere's
centre-of-mass x velocity at the end) and rebound_ratio = (v2 - v1) / 2, the relative speed after
over before.

  python3 bench/taichi/mpm_spheres.py --dx-m 0.02 --threads 2
"""

import argparse
import contextlib
import json
import math
import sys
import time


def fill_sphere(np, center, radius, spacing, rng):
    """Jittered lattice inside a sphere, as procedural.rs fill_points (f32 like it)."""
    f32 = np.float32
    c = np.array(center, dtype=f32)
    r, h = f32(radius), f32(spacing)
    lo, hi = c - r, c + r
    cells = np.maximum(np.ceil((hi - lo) / h), f32(1.0)).astype(np.int64)
    start = (lo + hi) * f32(0.5) - (cells - 1).astype(f32) * f32(0.5) * h
    nx, ny, nz = (int(n) for n in cells)
    j = f32(0.25) * h
    # Loop order k (z), j (y), i (x) with x fastest, one jitter triple per lattice site.
    kk, jj, ii = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    site = np.stack([ii.ravel(), jj.ravel(), kk.ravel()], axis=1).astype(f32)
    jitter = rng.uniform(-j, j, size=site.shape).astype(f32)
    p = start + site * h + jitter
    keep = ((p - c) ** 2).sum(axis=1) <= r * r
    return p[keep]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dx-m", type=float, default=0.02, help="grid cell (m); particle spacing dx/2")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--duration-s", type=float, default=0.3)
    ap.add_argument("--seed", type=int, default=0, help="numpy seed of the particle jitter")
    a = ap.parse_args()
    if not (0.002 <= a.dx_m <= 0.05) or a.threads < 1 or not (a.duration_s > 0):
        ap.error("need --dx-m in [0.002, 0.05], --threads >= 1, --duration-s > 0")

    with contextlib.redirect_stdout(sys.stderr):
        import numpy as np
        import taichi as ti

        ti.init(arch=ti.cpu, cpu_max_num_threads=a.threads, default_fp=ti.f32, random_seed=0)

    dx = a.dx_m
    inv_dx = 1.0 / dx
    E, nu, rho = 2e5, 0.3, 1000.0
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    c_p = math.sqrt((lam + 2 * mu) / rho)
    rng = np.random.default_rng(a.seed)
    left = fill_sphere(np, [-0.08, 0.0, 0.0], 0.04, dx / 2, rng)
    right = fill_sphere(np, [0.08, 0.0, 0.0], 0.04, dx / 2, rng)
    pos = np.concatenate([left, right]).astype(np.float32)
    vel = np.zeros_like(pos)
    vel[: len(left), 0] = 1.0
    vel[len(left) :, 0] = -1.0
    obj = np.concatenate([np.zeros(len(left), np.int32), np.ones(len(right), np.int32)])
    cells = np.floor(pos / np.float32(dx)).astype(np.int64)
    _, inverse, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
    vol = (np.float32(dx) ** 3 / counts[inverse.ravel()]).astype(np.float32)
    mass = (rho * vol).astype(np.float32)
    n_particles = len(pos)

    # Dense grid around the pair; the origin is a whole number of cells so stencils match.
    half = np.array([0.6, 0.15, 0.15])
    lo_cells = np.ceil(half / dx).astype(np.int64)
    shape = tuple(int(n) for n in 2 * lo_cells + 1)
    origin = (-lo_cells * dx).astype(np.float32)

    x = ti.Vector.field(3, dtype=ti.f32, shape=n_particles)
    v = ti.Vector.field(3, dtype=ti.f32, shape=n_particles)
    C = ti.Matrix.field(3, 3, dtype=ti.f32, shape=n_particles)
    F = ti.Matrix.field(3, 3, dtype=ti.f32, shape=n_particles)
    p_mass = ti.field(dtype=ti.f32, shape=n_particles)
    p_vol = ti.field(dtype=ti.f32, shape=n_particles)
    grid_v = ti.Vector.field(3, dtype=ti.f32, shape=shape)
    grid_m = ti.field(dtype=ti.f32, shape=shape)
    vmax = ti.field(dtype=ti.f32, shape=())

    @ti.kernel
    def substep(dt: ti.f32):
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.Vector.zero(ti.f32, 3)
            grid_m[I] = 0.0
        for p in x:
            Xp = x[p] * inv_dx
            base = ti.cast(Xp - 0.5, ti.i32)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            U, sig, V = ti.svd(F[p])
            R = U @ V.transpose()
            J = F[p].determinant()
            tau = 2.0 * mu * (F[p] - R) @ F[p].transpose() + ti.Matrix.identity(ti.f32, 3) * (lam * J * (J - 1.0))
            affine = (-dt * p_vol[p] * 4.0 * inv_dx * inv_dx) * tau + p_mass[p] * C[p]
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                offset = ti.Vector([i, j, k])
                dpos = (offset - fx) * dx
                weight = w[i][0] * w[j][1] * w[k][2]
                grid_v[base + offset] += weight * (p_mass[p] * v[p] + affine @ dpos)
                grid_m[base + offset] += weight * p_mass[p]
        for I in ti.grouped(grid_m):
            if grid_m[I] > 0:
                grid_v[I] = grid_v[I] / grid_m[I]
        vmax[None] = 0.0
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
            ti.atomic_max(vmax[None], new_v.norm())

    def reset():
        x.from_numpy(pos - origin)
        v.from_numpy(vel)
        C.fill(0.0)
        F.from_numpy(np.tile(np.eye(3, dtype=np.float32), (n_particles, 1, 1)))
        p_mass.from_numpy(mass)
        p_vol.from_numpy(vol)

    with contextlib.redirect_stdout(sys.stderr):
        reset()
        substep(1e-5)  # compiles the kernel; the state is reset below
        ti.sync()
        reset()
        frames = round(a.duration_s * 100.0)
        t_s, speed, substeps = 0.0, 1.0, 0
        start = time.perf_counter()
        for frame in range(frames):
            end = (frame + 1) / 100.0
            while end - t_s > 1e-9:
                dt = float(np.float32(min(0.5 * dx / (c_p + speed), 1e-2)))
                remaining = float(np.float32(end - t_s))
                if remaining <= dt * 1.0001:
                    dt = remaining
                substep(dt)
                speed = float(vmax[None])  # reads back: a sync per substep, as any CFL loop
                t_s += dt
                substeps += 1
            t_s = end
        ti.sync()
        seconds = time.perf_counter() - start

    xs = x.to_numpy().astype(np.float64) + origin
    vs = v.to_numpy().astype(np.float64)
    margin = 3 * dx
    inside = ((xs - origin) > margin).all() and ((xs - origin) < np.array(shape) * dx - margin).all()
    if not (np.isfinite(xs).all() and np.isfinite(vs).all() and inside):
        print("taichi spheres run became non-finite or left its grid", file=sys.stderr)
        return 1
    m = mass.astype(np.float64)
    v_obj = [float((vs[obj == k, 0] * m[obj == k]).sum() / m[obj == k].sum()) for k in (0, 1)]
    print(
        json.dumps(
            {
                "bench": "spheres",
                "impl": "taichi",
                "taichi_version": ".".join(str(p) for p in ti.__version__),
                "method": "mpm",
                "dx_m": dx,
                "seed": a.seed,
                "particles": n_particles,
                "threads": a.threads,
                "substeps": substeps,
                "wall_s": seconds,
                "particle_substeps_per_s": n_particles * substeps / seconds,
                "v1_m_s": v_obj[0],
                "v2_m_s": v_obj[1],
                "rebound_ratio": (v_obj[1] - v_obj[0]) / 2.0,
            }
        ),
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
