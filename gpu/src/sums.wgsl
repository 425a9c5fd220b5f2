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

// One set of moments as seven vec4s in the order above: the sums s0..s4 ([0..20)), lo (the three
// minima and the first maximum) and hi (the other four maxima). Plain fields, not an array of 28
// floats: with arrays (summed in workgroup memory, or passed by value) this pass took 2.6-5.7x
// as long on lavapipe.
struct Moments {
    s0: vec4<f32>, // sum m, sum m y
    s1: vec4<f32>, // sum m v, (sum m y x v).x
    s2: vec4<f32>, // (sum m y x v).yz, spin.xy
    s3: vec4<f32>, // spin.z, sum m (y_x^2, y_y^2, y_z^2)
    s4: vec4<f32>, // sum m (y_x y_y, y_x y_z, y_y y_z), sum m |v|^2
    lo: vec4<f32>, // min y, max y_x
    hi: vec4<f32>, // max y_y, max y_z, max |v|, max of minus the plastic scalar
}

var<workgroup> partial: array<Moments, 64>;

// Empty moments: zero sums and speed, bounds that any value replaces.
fn empty_moments() -> Moments {
    let z = vec4<f32>(0.0);
    return Moments(
        z, z, z, z, z,
        vec4<f32>(3.0e38, 3.0e38, 3.0e38, -3.0e38),
        vec4<f32>(-3.0e38, -3.0e38, 0.0, -3.0e38),
    );
}

// Particle p's moments.
fn particle_moments(p: u32) -> Moments {
    let xm = xv[2u * p];
    let v = xv[2u * p + 1u].xyz;
    let m = xm.w;
    let y = xm.xyz - params.reference;
    let c = mat3x3<f32>(cf[6u * p].xyz, cf[6u * p + 1u].xyz, cf[6u * p + 2u].xyz);
    let l = cross(y, v) * m;
    let spin = vec3<f32>(c[1].z - c[2].y, c[2].x - c[0].z, c[0].y - c[1].x) * m;
    let my = m * y;
    return Moments(
        vec4<f32>(m, my),
        vec4<f32>(m * v, l.x),
        vec4<f32>(l.y, l.z, spin.x, spin.y),
        vec4<f32>(spin.z, my * y),
        vec4<f32>(my.x * y.y, my.x * y.z, my.y * y.z, m * dot(v, v)),
        vec4<f32>(y, y.x),
        vec4<f32>(y.y, y.z, length(v), -plastic[3u * p].w),
    );
}

// Moments `a` with `b` folded in.
fn combined(a: Moments, b: Moments) -> Moments {
    return Moments(
        a.s0 + b.s0,
        a.s1 + b.s1,
        a.s2 + b.s2,
        a.s3 + b.s3,
        a.s4 + b.s4,
        vec4<f32>(min(a.lo.xyz, b.lo.xyz), max(a.lo.w, b.lo.w)),
        max(a.hi, b.hi),
    );
}

// The tree over the workgroup's 64 threads, each starting from `own`; thread 0 ends with the
// total in partial[0].
fn reduce_workgroup(t: u32, own: Moments) {
    partial[t] = own;
    for (var stride = 32u; stride > 0u; stride = stride / 2u) {
        workgroupBarrier();
        if t < stride {
            partial[t] = combined(partial[t], partial[t + stride]);
        }
    }
    workgroupBarrier();
}

// Writes `m` to moments[at..at + MOMENTS).
fn store_moments(at: u32, m: Moments) {
    let v = array<vec4<f32>, 7>(m.s0, m.s1, m.s2, m.s3, m.s4, m.lo, m.hi);
    for (var k = 0u; k < 7u; k++) {
        for (var j = 0u; j < 4u; j++) {
            moments[at + 4u * k + j] = v[k][j];
        }
    }
}

// moments[at..at + 4) as a vec4.
fn four(at: u32) -> vec4<f32> {
    return vec4<f32>(moments[at], moments[at + 1u], moments[at + 2u], moments[at + 3u]);
}

// The moments at moments[at..at + MOMENTS).
fn load_moments(at: u32) -> Moments {
    return Moments(
        four(at), four(at + 4u), four(at + 8u), four(at + 12u), four(at + 16u), four(at + 20u),
        four(at + 24u),
    );
}

// Pass 1: workgroup g of params.n_groups (a one-row dispatch) takes particles g * 64 + t, then
// every params.n_groups * 64 after, in order (summed in the thread's registers), then the tree;
// its moments into moments[MOMENTS * (1 + g)].
@compute @workgroup_size(64)
fn moments_per_group(
    @builtin(local_invocation_index) t: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    var own = empty_moments();
    let stride = params.n_groups * 64u;
    for (var p = wid.x * 64u + t; p < params.n_particles; p += stride) {
        own = combined(own, particle_moments(p));
    }
    reduce_workgroup(t, own);
    if t == 0u {
        store_moments(MOMENTS * (1u + wid.x), partial[0]);
    }
}

// Pass 2, one workgroup: the groups' moments, thread t taking groups t, t + 64, ... in order,
// then the tree; the total into moments[0..MOMENTS).
@compute @workgroup_size(64)
fn moments_total(@builtin(local_invocation_index) t: u32) {
    var own = empty_moments();
    for (var g = t; g < params.n_groups; g += 64u) {
        own = combined(own, load_moments(MOMENTS * (1u + g)));
    }
    reduce_workgroup(t, own);
    if t == 0u {
        store_moments(0u, partial[0]);
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
