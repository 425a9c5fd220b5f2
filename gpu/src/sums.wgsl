// What the COM layer needs of an object whose particles stay on the GPU: its moments, summed on
// the GPU so that one small buffer crosses the bus (world/measure.rs computes the same on the
// CPU), and the rigid velocity field the COM layer's laws add to it (world/coherence.rs
// rigid_field). Appended to mpm.wgsl when the module is built.
//
// Moments are taken about a reference point r0 (params.reference: the object's last COM keeps
// the f32 sums accurate), y = x - r0, in a fixed order (per workgroup of 64, then over the
// workgroups in index order), so they are deterministic for a given device:
//   [0] sum m, [1..4) sum m y, [4..7) sum m v, [7..10) sum m y x v,
//   [10..13) sum m (C_zy - C_yz, C_xz - C_zx, C_yx - C_xy) (the APIC spin),
//   [13..16) sum m (y_x^2, y_y^2, y_z^2), [16..19) sum m (y_x y_y, y_x y_z, y_y y_z),
//   [19] sum m |v|^2, [20..23) min y, [23..26) max y, [26] max |v|, [27] max of minus the
//   plastic scalar (its minimum, negated: snow's smallest Jp sets its CFL wave speed).

const MOMENTS: u32 = 28u;
const SUMS: u32 = 20u;

var<workgroup> partial: array<f32, 1792>; // 64 threads x MOMENTS

// Empty moments at `base`: zero sums and speed, bounds that any value replaces.
fn reset(base: u32) {
    for (var k = 0u; k < MOMENTS; k++) {
        partial[base + k] = 0.0;
    }
    for (var k = 20u; k < 23u; k++) {
        partial[base + k] = 3.0e38;
    }
    for (var k = 23u; k < 26u; k++) {
        partial[base + k] = -3.0e38;
    }
    partial[base + 27u] = -3.0e38;
}

// Particle p's moments.
fn particle_moments(p: u32) -> array<f32, 28> {
    let xm = xv[2u * p];
    let v = xv[2u * p + 1u].xyz;
    let m = xm.w;
    let y = xm.xyz - params.reference;
    let c = mat3x3<f32>(cf[6u * p].xyz, cf[6u * p + 1u].xyz, cf[6u * p + 2u].xyz);
    let l = cross(y, v) * m;
    let spin = vec3<f32>(c[1].z - c[2].y, c[2].x - c[0].z, c[0].y - c[1].x) * m;
    return array<f32, 28>(
        m, m * y.x, m * y.y, m * y.z, m * v.x, m * v.y, m * v.z, l.x, l.y, l.z,
        spin.x, spin.y, spin.z, m * y.x * y.x, m * y.y * y.y, m * y.z * y.z,
        m * y.x * y.y, m * y.x * y.z, m * y.y * y.z, m * dot(v, v),
        y.x, y.y, y.z, y.x, y.y, y.z, length(v), -plastic[3u * p].w,
    );
}

// Folds moments `values` into those at `base`.
fn accumulate(base: u32, values: array<f32, 28>) {
    for (var k = 0u; k < SUMS; k++) {
        partial[base + k] += values[k];
    }
    for (var k = 20u; k < 23u; k++) {
        partial[base + k] = min(partial[base + k], values[k]);
    }
    for (var k = 23u; k < 28u; k++) {
        partial[base + k] = max(partial[base + k], values[k]);
    }
}

// The moments at `base` (in `partial`) as an array.
fn moments_at(base: u32) -> array<f32, 28> {
    var out: array<f32, 28>;
    for (var k = 0u; k < MOMENTS; k++) {
        out[k] = partial[base + k];
    }
    return out;
}

// Folds thread `t + stride`'s moments into thread t's.
fn fold(t: u32, stride: u32) {
    accumulate(t * MOMENTS, moments_at((t + stride) * MOMENTS));
}

// The tree over the workgroup's 64 threads; thread 0 ends with the total.
fn reduce_workgroup(t: u32) {
    for (var stride = 32u; stride > 0u; stride = stride / 2u) {
        workgroupBarrier();
        if t < stride {
            fold(t, stride);
        }
    }
    workgroupBarrier();
}

// Pass 1: workgroup g of params.n_groups (a one-row dispatch) takes particles g * 64 + t, then
// every params.n_groups * 64 after, in order; its moments into moments[MOMENTS * (1 + g)].
@compute @workgroup_size(64)
fn moments_per_group(
    @builtin(local_invocation_index) t: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let base = t * MOMENTS;
    reset(base);
    let stride = params.n_groups * 64u;
    for (var p = wid.x * 64u + t; p < params.n_particles; p += stride) {
        accumulate(base, particle_moments(p));
    }
    reduce_workgroup(t);
    if t == 0u {
        for (var k = 0u; k < MOMENTS; k++) {
            moments[MOMENTS * (1u + wid.x) + k] = partial[k];
        }
    }
}

// Pass 2, one workgroup: the groups' moments, thread t taking groups t, t + 64, ... in order,
// then the tree; the total into moments[0..MOMENTS).
@compute @workgroup_size(64)
fn moments_total(@builtin(local_invocation_index) t: u32) {
    let base = t * MOMENTS;
    reset(base);
    for (var g = t; g < params.n_groups; g += 64u) {
        var values: array<f32, 28>;
        for (var k = 0u; k < MOMENTS; k++) {
            values[k] = moments[MOMENTS * (1u + g) + k];
        }
        accumulate(base, values);
    }
    reduce_workgroup(t);
    if t == 0u {
        for (var k = 0u; k < MOMENTS; k++) {
            moments[k] = partial[k];
        }
    }
}

// v += dv + dw x (x - about), C += [dw]x on every particle (world/coherence.rs rigid_field), with
// (dv, dw, about) in params.field_dv, field_dw and reference.
@compute @workgroup_size(64)
fn rigid_field(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = flat_index(gid);
    if p >= params.n_particles {
        return;
    }
    let dw = params.field_dw;
    let x = xv[2u * p].xyz;
    let vv = xv[2u * p + 1u];
    xv[2u * p + 1u] = vec4<f32>(vv.xyz + params.field_dv + cross(dw, x - params.reference), vv.w);
    cf[6u * p] = vec4<f32>(cf[6u * p].xyz + vec3<f32>(0.0, dw.z, -dw.y), 0.0);
    cf[6u * p + 1u] = vec4<f32>(cf[6u * p + 1u].xyz + vec3<f32>(-dw.z, 0.0, dw.x), 0.0);
    cf[6u * p + 2u] = vec4<f32>(cf[6u * p + 2u].xyz + vec3<f32>(dw.y, -dw.x, 0.0), 0.0);
}
