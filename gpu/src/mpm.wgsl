// MLS-MPM substep on the GPU (Hu et al. 2018, "A moving least squares material point method
// with displacement discontinuity and two-way rigid body coupling", eqs. 17 and 29): the same
// P2G, grid update and G2P as splatphys-core's CPU solver (src/mpm/p2g.rs, grid_update.rs,
// g2p.rs), on a dense grid, with the return mappings of the plastic models (plastic.wgsl, which
// is appended to this file when the module is built).
//
// P2G scatters into fixed-point sums of three u32 words each (the terms' bits 0-15, 16-31 and
// 32-63, add_magnitude), so a node's sum is exact and does not depend on the order in which particles
// add to it: results are deterministic for a given device.

struct Params {
    grid_dims: vec3<i32>,
    n_particles: u32,
    grid_origin: vec3<f32>,
    dx: f32,
    gravity: vec3<f32>,
    dt: f32,
    inv_dx: f32,
    n_colliders: u32,
    scale_m: f32,
    scale_p: f32,
    inv_scale_m: f32,
    inv_scale_p: f32,
    n_gated: u32,
    // Time at the start of the batch of substeps (s); substep k of it starts at t0 + k dt.
    t0: f32,
    // The point moments are taken about and the rigid field turns about (m), and the number of
    // workgroups of a pass over the particles (sums.wgsl).
    reference: vec3<f32>,
    n_groups: u32,
    // The rigid field's uniform velocity (m/s) and angular velocity (rad/s) (sums.wgsl).
    field_dv: vec3<f32>,
    field_dw: vec3<f32>,
    // When a run of substeps halts (run.wgsl).
    speed_limit: f32,
    plastic_floor: f32,
    opens_at: f32,
    open_mask: u32,
    run_flags: u32,
};

// Material: Lamé mu, lambda (Pa), Kelvin–Voigt viscosity eta (Pa s), model (MODEL_*), and the
// model's parameters p0..p3 (plastic.wgsl says which each uses).
struct Material {
    mu: f32,
    lambda: f32,
    eta: f32,
    model: u32,
    p0: f32,
    p1: f32,
    p2: f32,
    p3: f32,
};

// Fixed-corotated ("jelly"), neo-Hookean, snow (fixed-corotated with hardening), sand and von
// Mises (metal, plasticine, foam; both on Hencky strain).
const MODEL_JELLY: u32 = 0u;
const MODEL_NEO_HOOKEAN: u32 = 1u;
const MODEL_SNOW: u32 = 2u;
const MODEL_SAND: u32 = 3u;
const MODEL_VON_MISES: u32 = 4u;

// Collider: kind (0 plane: a = point, b = outward normal; 1 box: a = min, b = max; 2 domain
// bound: a = min, b = max), surface (0 sticky, 1 slip, 2 separate, 3 clamp), Coulomb friction
// (a sticky collider's already raised to STICKY_FRICTION), and what the node gaps are read
// for (`gated`): 1 where its nodes take the rule only where material reaches the surface
// (mpm/reach.rs), 2 for a box that holds every node inside it (sticky, clamp) but is thin
// enough for the grid to read which side of it the material lies on (Collider::takes_sides),
// 0 for neither. Both kinds share one gap per node: a node near a gated collider and a thin
// sticky box at once reads the smaller gap of the two (the CPU keeps two maps).
// A moving collider (w of `velocity` = 1) acts within [window.x, window.y) s and is displaced
// by velocity × (t − window.x) (collider/mod.rs).
struct Collider {
    kind: u32,
    surface: u32,
    friction: f32,
    gated: u32,
    a: vec4<f32>,
    b: vec4<f32>,
    velocity: vec4<f32>,
    window: vec4<f32>,
};

// A read-only storage buffer, not a uniform one: Mesa's lavapipe (22.x) compiles a shader
// again, with the values inlined, every time a pipeline is bound whose branches depend on
// uniform values only (P2G's `n_gated`): 8 ms a dispatch on two cores, and memory that grows
// until the pipeline is destroyed. (Not measured on a GPU, where both are cached reads.)
@group(0) @binding(0) var<storage, read> params: Params;
// Per particle: (x, mass), (v, volume0).
@group(0) @binding(1) var<storage, read_write> xv: array<vec4<f32>>;
// Per particle: C columns 0..2, then F columns 0..2 (w unused).
@group(0) @binding(2) var<storage, read_write> cf: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> particle_material: array<u32>;
@group(0) @binding(4) var<storage, read> materials: array<Material>;
@group(0) @binding(5) var<storage, read> colliders: array<Collider>;
// Per node 15 words: the mass as an unsigned fixed-point sum of two words (add_magnitude);
// px, py, pz each as two such sums, of the positive terms and of the negative terms' magnitudes
// (read as their difference); then the node's gap to the colliders that read gaps (`gated`; the
// bitwise NOT of an order-preserving u32 form of the f32, so that 0 is "no particle's column
// reaches it" and atomicMax takes the smallest gap, with the code of the normal there in its
// low bits: encode_gap).
// After the nodes, per collider 13 words: the normal impulse it gave the grid in the substep,
// n n·Δp summed over its nodes (grid_update.rs's collider impulses), as three 64-bit sums at
// the momentum scale, its friction impulse (Δp − n n·Δp) as three more, then the count of
// nodes with mass inside it (whether or not they took its rule).
@group(0) @binding(6) var<storage, read_write> grid_sum: array<atomic<u32>>;
// Per node: velocity (m/s), mass (kg).
@group(0) @binding(7) var<storage, read_write> grid_v: array<vec4<f32>>;
// [0] particles or nodes that failed (left the grid, not finite), [1] largest speed (f32 bits),
// [2] first failed particle + 1, [3] substeps done in this batch, [4] whether a run of substeps
// halted (the substeps after do nothing), [5] whether snow's Jp fell below the run's floor;
// from word 8, a run's log (run.wgsl).
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
// Per particle: F_p columns 0..2 (the plastic deformation its Gaussians follow), with the model's
// plastic scalar (snow's Jp, the others' accumulated plastic strain) in the first column's w.
@group(0) @binding(9) var<storage, read_write> plastic: array<vec4<f32>>;
// An object's moments: the total, then each workgroup's (sums.wgsl).
@group(0) @binding(10) var<storage, read_write> moments: array<f32>;

// The first word of a node's sum takes each term's part below this (2^16) (add_magnitude).
const LOW_UNIT: f32 = 65536.0;

const TWO_32: f32 = 4294967296.0;
// Per node: the mass (2 words), each momentum component as positive and negative sums (4 words
// each), the gap (1 word).
const NODE_WORDS: u32 = 15u;
const NODE_GAP: u32 = 14u;
const COLLIDER_WORDS: u32 = 13u;
// The word of a collider's sums that counts its nodes.
const COLLIDER_NODES: u32 = 12u;
// A node counts as reached when the gap is within this fraction of the particle's size
// (mpm/reach.rs REACH_TOLERANCE).
const REACH_TOLERANCE: f32 = 0.25;
// A gated collider's rule also acts at nodes up to OUTSIDE cells outside it, but not within
// ON_SURFACE cells of it, and only where the node's normal is within 60° of the gap's; a node
// whose normal is more than 120° from the gap's, inside or up to BEHIND cells outside, lies
// behind a thin box and takes the near face's normal (mpm/reach.rs OUTSIDE, ON_SURFACE,
// BEHIND, NodeGaps::rule_normal).
const OUTSIDE: f32 = 0.5;
const ON_SURFACE: f32 = 1.0e-3;
const BEHIND: f32 = 1.5;
// Low bits of a node's gap word that hold its normal's code (encode_gap).
const GAP_NORMAL_MASK: u32 = 0x3FFu;
// Workgroups per row of a dispatch (the limit per dimension); work items are numbered row by
// row, 64 per workgroup.
const ROW: u32 = 65535u;

fn flat_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * ROW * 64u;
}

// Adds the 64-bit word pair (lo, hi) to the sum at `slot`: one atomic unless hi or the carry
// out of the low word is non-zero.
fn add_words(slot: u32, lo: u32, hi: u32) {
    let old = atomicAdd(&grid_sum[slot], lo);
    let carry = select(0u, 1u, old + lo < old);
    if hi + carry != 0u {
        atomicAdd(&grid_sum[slot + 1u], hi + carry);
    }
}

// Adds `value` (already scaled; |value| < 2^62) to the 64-bit two's-complement fixed-point sum
// at `slot` (a collider's impulse).
fn add_fixed(slot: u32, value: f32) {
    let a = abs(value);
    let hi_f = floor(a / TWO_32);
    var hi = u32(hi_f);
    var lo = u32(round(a - hi_f * TWO_32));
    if value < 0.0 {
        lo = ~lo + 1u;
        hi = ~hi + select(0u, 1u, lo == 0u);
    }
    add_words(slot, lo, hi);
}

// Adds `a` >= 0 (already scaled) to the unsigned fixed-point sum at `slot`, two words that each
// sum one part of every term: its part below 2^16, rounded up or down by the dither `d` in
// [0, 1), and the rest. Neither carries while a node takes fewer than 2^16 terms in a substep
// and its sum stays below 2^48, so no atomic's result is waited for, and a term below 2^16 (the
// host's scales make most so) is one atomic. Against one 64-bit sum whose carry is propagated
// (the atomic's old value read back), P2G took 684 instead of 1,543 µs a substep for a million
// particles on an H200.
fn add_magnitude(slot: u32, a: f32, d: f32) {
    let hi = floor(a / LOW_UNIT);
    let lo = u32(floor(a - hi * LOW_UNIT + d));
    if lo != 0u {
        atomicAdd(&grid_sum[slot], lo);
    }
    if hi > 0.0 {
        atomicAdd(&grid_sum[slot + 1u], u32(hi));
    }
}

// Four dithers in [0, 1) for particle p's terms at node `node` (PCG's output permutation of a
// hash of both and the substep): each term is rounded up with the probability of its fraction,
// so rounding adds no bias even where a lattice of particles gives many nodes the same terms,
// and the same inputs give the same bits.
fn dithers(p: u32, node: u32, seed: u32) -> vec4<f32> {
    var h = p * 747796405u + node * 2891336453u + seed;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    let bytes = vec4<u32>(h & 255u, (h >> 8u) & 255u, (h >> 16u) & 255u, h >> 24u);
    return (vec4<f32>(bytes) + vec4<f32>(0.5)) / 256.0;
}

// Adds `value` (already scaled) to the signed sum kept as two unsigned ones at `slot` (the
// positive terms) and `slot + 2` (the magnitudes of the negative ones): a negative term costs
// one atomic as a positive one does, where a two's-complement sum would take two.
fn add_split(slot: u32, value: f32, d: f32) {
    add_magnitude(slot + select(0u, 2u, value < 0.0), abs(value), d);
}

// A 64-bit two's-complement value (lo, hi) as f32.
fn fixed_to_f32(lo: u32, hi: u32) -> f32 {
    let negative = (hi & 0x80000000u) != 0u;
    var l = lo;
    var h = hi;
    if negative {
        l = ~lo + 1u;
        h = ~hi + select(0u, 1u, l == 0u);
    }
    let magnitude = f32(h) * TWO_32 + f32(l);
    return select(magnitude, -magnitude, negative);
}

// The unsigned sum at `slot` (add_magnitude) as a 64-bit (lo, hi) pair: the first word plus the
// second times 2^16.
fn read_magnitude(slot: u32) -> vec2<u32> {
    let w0 = atomicLoad(&grid_sum[slot]);
    let w1 = atomicLoad(&grid_sum[slot + 1u]);
    let lo = w0 + (w1 << 16u);
    return vec2<u32>(lo, (w1 >> 16u) + select(0u, 1u, lo < w0));
}

// The unsigned sum at `slot` (add_magnitude) as f32 (still scaled).
fn read_unsigned(slot: u32) -> f32 {
    let m = read_magnitude(slot);
    return f32(m.y) * TWO_32 + f32(m.x);
}

// The split sum at `slot` ([`add_split`]) as f32 (still scaled): positive minus negative, exact
// in 64 bits before the one rounding.
fn read_split(slot: u32) -> f32 {
    let pos = read_magnitude(slot);
    let neg = read_magnitude(slot + 2u);
    let lo = pos.x - neg.x;
    let hi = pos.y - neg.y - select(0u, 1u, pos.x < neg.x);
    return fixed_to_f32(lo, hi);
}

// Time at the start of the current substep (s).
fn substep_time() -> f32 {
    return params.t0 + f32(atomicLoad(&status[3])) * params.dt;
}

fn collider_active(c: Collider, t: f32) -> bool {
    return c.velocity.w == 0.0 || (t >= c.window.x && t < c.window.y);
}

// Displacement of a moving collider at time t (m).
fn collider_offset(c: Collider, t: f32) -> vec3<f32> {
    if c.velocity.w == 0.0 {
        return vec3<f32>(0.0);
    }
    return c.velocity.xyz * max(t - c.window.x, 0.0);
}

// Velocity of the collider at time t (m/s): zero when static or inactive.
fn collider_velocity(c: Collider, t: f32) -> vec3<f32> {
    if c.velocity.w != 0.0 && collider_active(c, t) {
        return c.velocity.xyz;
    }
    return vec3<f32>(0.0);
}

fn fail(p: u32) {
    atomicAdd(&status[0], 1u);
    atomicMax(&status[2], p + 1u);
}

fn node_index(node: vec3<i32>) -> i32 {
    let d = params.grid_dims;
    if any(node < vec3<i32>(0)) || any(node >= d) {
        return -1;
    }
    return node.x + d.x * (node.y + d.y * node.z);
}

// Quadratic B-spline weights per axis for offsets 0, 1, 2 (bspline.rs).
struct Stencil {
    base: vec3<i32>,
    fx: vec3<f32>,
    w0: vec3<f32>,
    w1: vec3<f32>,
    w2: vec3<f32>,
};

fn stencil(x: vec3<f32>) -> Stencil {
    let xp = (x - params.grid_origin) * params.inv_dx;
    let base_f = floor(xp - vec3<f32>(0.5));
    let fx = xp - base_f;
    var s: Stencil;
    s.base = vec3<i32>(base_f);
    s.fx = fx;
    s.w0 = 0.5 * (vec3<f32>(1.5) - fx) * (vec3<f32>(1.5) - fx);
    s.w1 = vec3<f32>(0.75) - (fx - vec3<f32>(1.0)) * (fx - vec3<f32>(1.0));
    s.w2 = 0.5 * (fx - vec3<f32>(0.5)) * (fx - vec3<f32>(0.5));
    return s;
}

fn weight(s: Stencil, axis: u32, i: u32) -> f32 {
    if i == 0u {
        return s.w0[axis];
    } else if i == 1u {
        return s.w1[axis];
    }
    return s.w2[axis];
}

fn det3(m: mat3x3<f32>) -> f32 {
    return dot(m[0], cross(m[1], m[2]));
}

// R of F = R S by Newton's iteration X <- (X + X^-T) / 2 (Higham 1986), as
// splatphys-core's math/newton_polar.rs; an inverted or singular F keeps the identity.
fn polar_rotation(a: mat3x3<f32>) -> mat3x3<f32> {
    var x = a;
    for (var step = 0; step < 12; step++) {
        let k0 = cross(x[1], x[2]);
        let k1 = cross(x[2], x[0]);
        let k2 = cross(x[0], x[1]);
        let det = dot(x[0], k0);
        if !(det > 1.0e-30) {
            return mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
        }
        let h = 0.5 / det;
        let next = mat3x3<f32>(x[0] * 0.5 + k0 * h, x[1] * 0.5 + k1 * h, x[2] * 0.5 + k2 * h);
        let d = max(max(abs(next[0] - x[0]), abs(next[1] - x[1])), abs(next[2] - x[2]));
        x = next;
        if max(max(d.x, d.y), d.z) <= 3.0e-4 {
            break;
        }
    }
    return x;
}

const IDENTITY: mat3x3<f32> = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));

// Kirchhoff stress of the particle's model at plastic state `jp` plus its Kelvin–Voigt damping
// J eta (C + C^T).
fn kirchhoff(m: Material, f: mat3x3<f32>, c: mat3x3<f32>, jp: f32) -> mat3x3<f32> {
    let j = det3(f);
    var tau: mat3x3<f32>;
    if m.model == MODEL_JELLY || m.model == MODEL_SNOW {
        // Fixed-corotated: 2 mu (F - R) F^T + lambda (J - 1) J I; snow's moduli hardened.
        var h = 1.0;
        if m.model == MODEL_SNOW {
            h = hardening_factor(m.p0, jp);
        }
        let r = polar_rotation(f);
        tau = (f - r) * transpose(f) * (2.0 * m.mu * h) + IDENTITY * (m.lambda * h * (j - 1.0) * j);
    } else if m.model == MODEL_NEO_HOOKEAN {
        // Compressible neo-Hookean: mu (F F^T - I) + lambda ln J I.
        tau = (f * transpose(f) - IDENTITY) * m.mu + IDENTITY * (m.lambda * log(max(j, 1.0e-4)));
    } else {
        tau = hencky_stress(f, m.mu, m.lambda);
    }
    if m.eta > 0.0 {
        tau = tau + (c + transpose(c)) * (m.eta * j);
    }
    return tau;
}

// The NOT of an order-preserving u32 form of `gap` (module docs of the grid buffer) whose low
// GAP_NORMAL_BITS hold the octahedral code of the solid's normal at the particle (mpm/reach.rs
// keeps it for the test of nodes outside the surface): the smallest gap wins, to 2^-13 of
// itself, and among equal gaps the smallest code.
fn encode_gap(gap: f32, n: vec3<f32>) -> u32 {
    let bits = bitcast<u32>(gap);
    let ordered = select(~bits, bits ^ 0x80000000u, gap >= 0.0);
    return ~((ordered & ~GAP_NORMAL_MASK) | encode_normal(n));
}

// The octahedral code of unit vector n (Meyer et al. 2010, "On floating-point normal
// vectors"), 31 levels per coordinate so that the axes are exact: 5 bits each.
fn encode_normal(n: vec3<f32>) -> u32 {
    var p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if n.z < 0.0 {
        p = (vec2<f32>(1.0) - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    }
    let k = vec2<u32>(round(clamp(p, vec2<f32>(-1.0), vec2<f32>(1.0)) * 15.0 + 15.0));
    return k.x | (k.y << 5u);
}

fn decode_normal(code: u32) -> vec3<f32> {
    let p = vec2<f32>(f32(code & 31u), f32((code >> 5u) & 31u)) / 15.0 - vec2<f32>(1.0);
    var n = vec3<f32>(p, 1.0 - abs(p.x) - abs(p.y));
    if n.z < 0.0 {
        n = vec3<f32>((vec2<f32>(1.0) - abs(n.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), n.xy >= vec2<f32>(0.0)), n.z);
    }
    return normalize(n);
}

// The smallest gap of a node (m), or a huge value where no column reached it.
fn node_gap(slot: u32) -> f32 {
    let stored = atomicLoad(&grid_sum[slot + NODE_GAP]);
    if stored == 0u {
        return 3.0e38;
    }
    let ordered = ~stored & ~GAP_NORMAL_MASK;
    let bits = select(~ordered, ordered ^ 0x80000000u, (ordered & 0x80000000u) != 0u);
    return bitcast<f32>(bits);
}

// The solid's normal at the particle that gave a node its gap (zero where none did).
fn node_gap_normal(slot: u32) -> vec3<f32> {
    let stored = atomicLoad(&grid_sum[slot + NODE_GAP]);
    if stored == 0u {
        return vec3<f32>(0.0);
    }
    return decode_normal(~stored & GAP_NORMAL_MASK);
}

// Signed distance (m, negative inside) of x from a plane or box collider and its outward
// normal (collider/boxes.rs signed_distance), as (normal, distance).
fn collider_distance(c: Collider, x: vec3<f32>) -> vec4<f32> {
    if c.kind == 0u {
        return vec4<f32>(c.b.xyz, dot(x - c.a.xyz, c.b.xyz));
    }
    let centre = (c.a.xyz + c.b.xyz) * 0.5;
    let d = x - centre;
    let q = abs(d) - (c.b.xyz - c.a.xyz) * 0.5;
    let outside = max(q, vec3<f32>(0.0));
    let len = length(outside);
    if len > 0.0 {
        return vec4<f32>(outside * sign(d) / len, len);
    }
    var axis = 2u;
    if q.x >= q.y && q.x >= q.z {
        axis = 0u;
    } else if q.y >= q.z {
        axis = 1u;
    }
    var n = vec3<f32>(0.0);
    n[axis] = select(-1.0, 1.0, d[axis] >= 0.0);
    return vec4<f32>(n, q[axis]);
}

// The node gaps of one particle against the nearest collider that reads them (`gated` 1 or 2;
// mpm/reach.rs): each node of its 3x3x3 stencil in its column along the surface normal, about
// inside the solid, gets the particle's gap phi - (1/2 + REACH_TOLERANCE) size.
fn scatter_gaps(x: vec3<f32>, volume0: f32, s: Stencil) {
    var best = vec4<f32>(0.0, 0.0, 1.0, 3.0e38);
    let t = substep_time();
    for (var k = 0u; k < params.n_colliders; k++) {
        let c = colliders[k];
        if c.gated == 0u || !collider_active(c, t) {
            continue;
        }
        let sd = collider_distance(c, x - collider_offset(c, t));
        if sd.w < best.w {
            best = sd;
        }
    }
    let dx = params.dx;
    let phi = best.w;
    let n = best.xyz;
    if !(phi < 3.0 * dx) {
        return;
    }
    let size = pow(volume0, 1.0 / 3.0);
    let gap = phi - (0.5 + REACH_TOLERANCE) * size;
    if !(gap < 2.0 * dx) {
        return;
    }
    // A particle already inside holds every node of its stencil there (mpm/reach.rs).
    let r = max(0.5 * dx, 0.75 * size);
    let radius2 = select(r * r, 3.0e38, phi < 0.0);
    let encoded = encode_gap(gap, n);
    for (var kk = 0; kk < 3; kk++) {
        for (var jj = 0; jj < 3; jj++) {
            for (var ii = 0; ii < 3; ii++) {
                let node = s.base + vec3<i32>(ii, jj, kk);
                let d = params.grid_origin + vec3<f32>(node) * dx - x;
                let along = dot(d, n);
                let across = d - n * along;
                if phi + along > 0.5 * dx || dot(across, across) > radius2 {
                    continue;
                }
                let index = node_index(node);
                if index >= 0 {
                    atomicMax(&grid_sum[u32(index) * NODE_WORDS + NODE_GAP], encoded);
                }
            }
        }
    }
}

// Particle p's affine momentum matrix times dx (kg m/s): (m C - dt V0 D^-1 tau) dx, with the
// Kirchhoff stress tau of its material (Hu et al. 2018, eq. 29; p2g.rs).
fn particle_affine_dx(p: u32) -> mat3x3<f32> {
    let mass = xv[2u * p].w;
    let volume0 = xv[2u * p + 1u].w;
    let c = mat3x3<f32>(cf[6u * p].xyz, cf[6u * p + 1u].xyz, cf[6u * p + 2u].xyz);
    let f = mat3x3<f32>(cf[6u * p + 3u].xyz, cf[6u * p + 4u].xyz, cf[6u * p + 5u].xyz);
    let tau = kirchhoff(materials[particle_material[p]], f, c, plastic[3u * p].w);
    let d_inv = 4.0 * params.inv_dx * params.inv_dx;
    return (tau * (-params.dt * volume0 * d_inv) + c * mass) * params.dx;
}

// Adds particle p's mass and momentum, with its affine matrix `a` (times dx), to the nodes of
// its stencil (and its gap to the gated colliders).
fn scatter_particle(p: u32, a: mat3x3<f32>) {
    let xm = xv[2u * p];
    let vv = xv[2u * p + 1u];
    let mass = xm.w;
    let s = stencil(xm.xyz);
    if params.n_gated > 0u {
        scatter_gaps(xm.xyz, vv.w, s);
    }
    // Momentum at offset o (cells): w (m v + affine (o - fx) dx) = w (q + A o), A = affine dx.
    let q = vv.xyz * mass - a * s.fx;
    let seed = (atomicLoad(&status[3]) * 2654435769u) ^ bitcast<u32>(params.t0);
    for (var k = 0u; k < 3u; k++) {
        for (var j = 0u; j < 3u; j++) {
            for (var i = 0u; i < 3u; i++) {
                let w = weight(s, 0u, i) * weight(s, 1u, j) * weight(s, 2u, k);
                let node = node_index(s.base + vec3<i32>(i32(i), i32(j), i32(k)));
                if node < 0 {
                    fail(p);
                    continue;
                }
                let mom = (q + a * vec3<f32>(f32(i), f32(j), f32(k))) * w;
                let slot = u32(node) * NODE_WORDS;
                let d = dithers(p, u32(node), seed);
                add_magnitude(slot, mass * w * params.scale_m, d.x);
                add_split(slot + 2u, mom.x * params.scale_p, d.y);
                add_split(slot + 6u, mom.y * params.scale_p, d.z);
                add_split(slot + 10u, mom.z * params.scale_p, d.w);
            }
        }
    }
}

@compute @workgroup_size(64)
fn p2g(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = flat_index(gid);
    if p >= params.n_particles || halted() {
        return;
    }
    scatter_particle(p, particle_affine_dx(p));
}

// Coulomb friction on tangential velocity vt for an approaching normal speed `pressed` >= 0.
fn friction(vt: vec3<f32>, pressed: f32, mu: f32) -> vec3<f32> {
    if mu <= 0.0 || pressed <= 0.0 {
        return vt;
    }
    let speed = length(vt);
    if speed <= mu * pressed {
        return vec3<f32>(0.0);
    }
    return vt * (1.0 - mu * pressed / speed);
}

// collider/surface.rs: clamp, slip, or separate and sticky (separate with the larger friction
// it was given) with friction, at outward normal n.
fn apply_surface(v: vec3<f32>, n: vec3<f32>, surface: u32, mu: f32) -> vec3<f32> {
    let vn = dot(v, n);
    if surface == 3u {
        return vec3<f32>(0.0);
    } else if surface == 1u {
        return friction(v - vn * n, max(-vn, 0.0), mu);
    }
    if vn < 0.0 {
        return friction(v - vn * n, -vn, mu);
    }
    return v;
}

// The collider's outward normal at node position x if x is inside it, else zero (collider/).
fn contact_normal(c: Collider, x: vec3<f32>) -> vec3<f32> {
    if c.kind == 0u {
        if dot(x - c.a.xyz, c.b.xyz) <= 0.0 {
            return c.b.xyz;
        }
        return vec3<f32>(0.0);
    }
    let lo = c.a.xyz;
    let hi = c.b.xyz;
    if c.kind == 1u {
        if any(x < lo) || any(x > hi) {
            return vec3<f32>(0.0);
        }
        let below = x - lo;
        let above = hi - x;
        var best = 3.0e38;
        var n = vec3<f32>(0.0, 0.0, 1.0);
        for (var axis = 0u; axis < 3u; axis++) {
            var e = vec3<f32>(0.0);
            e[axis] = 1.0;
            if below[axis] < best {
                best = below[axis];
                n = -e;
            }
            if above[axis] < best {
                best = above[axis];
                n = e;
            }
        }
        return n;
    }
    // Domain bound: the inward normal outside the box.
    let n = select(vec3<f32>(0.0), vec3<f32>(1.0), x < lo) - select(vec3<f32>(0.0), vec3<f32>(1.0), x > hi);
    let len = length(n);
    if len > 0.0 {
        return n / len;
    }
    return vec3<f32>(0.0);
}

@compute @workgroup_size(64)
fn grid_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    let d = params.grid_dims;
    let n_nodes = u32(d.x * d.y * d.z);
    let i = flat_index(gid);
    if i >= n_nodes || halted() {
        return;
    }
    let slot = i * NODE_WORDS;
    let m = read_unsigned(slot) * params.inv_scale_m;
    if m <= 0.0 {
        grid_v[i] = vec4<f32>(0.0);
        return;
    }
    let p = vec3<f32>(read_split(slot + 2u), read_split(slot + 6u), read_split(slot + 10u)) * params.inv_scale_p;
    var v = p / m + params.gravity * params.dt;
    let node = vec3<i32>(i32(i) % d.x, (i32(i) / d.x) % d.y, i32(i) / (d.x * d.y));
    let x = params.grid_origin + vec3<f32>(node) * params.dx;
    let t = substep_time();
    for (var k = 0u; k < params.n_colliders; k++) {
        let c = colliders[k];
        if !collider_active(c, t) {
            continue;
        }
        let sums = n_nodes * NODE_WORDS + COLLIDER_WORDS * k;
        var n = contact_normal(c, x - collider_offset(c, t));
        let inside = dot(n, n) > 0.0;
        if inside {
            atomicAdd(&grid_sum[sums + COLLIDER_NODES], 1u);
            // Past the middle of a thin box, as seen from the material that reaches it.
            if c.gated != 0u && dot(node_gap_normal(slot), n) < -0.5 {
                n = -n;
            }
        } else if c.gated != 0u {
            let sd = collider_distance(c, x - collider_offset(c, t));
            let facing = dot(node_gap_normal(slot), sd.xyz);
            if facing < -0.5 && sd.w <= BEHIND * params.dx {
                n = -sd.xyz;
            } else if c.gated == 1u && sd.w >= ON_SURFACE * params.dx
                && sd.w <= OUTSIDE * params.dx && facing > 0.5 {
                n = sd.xyz;
            }
        }
        if dot(n, n) > 0.0 {
            let vc = collider_velocity(c, t);
            // A gated collider's rule only where material meets its surface within the substep.
            if c.gated == 1u && !(node_gap(slot) <= max(-dot(v - vc, n), 0.0) * params.dt) {
                continue;
            }
            if !inside {
                // It holds material at the surface: a contact, as a node inside is.
                atomicAdd(&grid_sum[sums + COLLIDER_NODES], 1u);
            }
            let before = v;
            v = apply_surface(v - vc, n, c.surface, c.friction) + vc;
            let dp = n * (dot(v - before, n) * m * params.scale_p);
            let friction = (v - before) * (m * params.scale_p) - dp;
            if any(dp != vec3<f32>(0.0)) {
                add_fixed(sums, dp.x);
                add_fixed(sums + 2u, dp.y);
                add_fixed(sums + 4u, dp.z);
            }
            if any(friction != vec3<f32>(0.0)) {
                add_fixed(sums + 6u, friction.x);
                add_fixed(sums + 8u, friction.y);
                add_fixed(sums + 10u, friction.z);
            }
        }
    }
    if !(all(abs(v) < vec3<f32>(3.0e38))) {
        atomicAdd(&status[0], 1u);
    }
    grid_v[i] = vec4<f32>(v, m);
}

@compute @workgroup_size(64)
fn g2p(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = flat_index(gid);
    if p >= params.n_particles || halted() {
        return;
    }
    // Ends the substep (as `tick` does without particles): nothing in G2P reads the time.
    if p == 0u {
        atomicAdd(&status[3], 1u);
    }
    let xm = xv[2u * p];
    let vv = xv[2u * p + 1u];
    let v_old = vv.xyz;
    let s = stencil(xm.xyz);
    // With u = vi - v_old and d = (i, j, k) - fx (cells): v = v_old + sum w u and
    // C = (4 / dx) sum w u d^T (g2p.rs).
    var sum_u = vec3<f32>(0.0);
    var col0 = vec3<f32>(0.0);
    var col1 = vec3<f32>(0.0);
    var col2 = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        for (var j = 0u; j < 3u; j++) {
            for (var i = 0u; i < 3u; i++) {
                let w = weight(s, 0u, i) * weight(s, 1u, j) * weight(s, 2u, k);
                let node = node_index(s.base + vec3<i32>(i32(i), i32(j), i32(k)));
                if node < 0 {
                    continue;
                }
                let u = (grid_v[u32(node)].xyz - v_old) * w;
                let dcell = vec3<f32>(f32(i), f32(j), f32(k)) - s.fx;
                sum_u += u;
                col0 += u * dcell.x;
                col1 += u * dcell.y;
                col2 += u * dcell.z;
            }
        }
    }
    let new_v = v_old + sum_u;
    let new_c = mat3x3<f32>(col0, col1, col2) * (4.0 * params.inv_dx);
    let f = mat3x3<f32>(cf[6u * p + 3u].xyz, cf[6u * p + 4u].xyz, cf[6u * p + 5u].xyz);
    let trial_f = (IDENTITY + new_c * params.dt) * f;
    let fp0 = plastic[3u * p];
    let returned = project(materials[particle_material[p]], trial_f, fp0.w, params.dt);
    let new_f = returned.f;
    let new_x = xm.xyz + new_v * params.dt;
    let big = vec3<f32>(3.0e38);
    let finite = all(abs(new_x) < big) && all(abs(new_v) < big) && all(abs(new_c[0]) < big)
        && all(abs(new_c[1]) < big) && all(abs(new_c[2]) < big) && all(abs(new_f[0]) < big)
        && all(abs(new_f[1]) < big) && all(abs(new_f[2]) < big) && abs(returned.plastic) < 3.0e38;
    if !finite {
        fail(p);
        return;
    }
    if returned.changed {
        // Snow's wave speed grows as Jp falls: below the floor a run's dt was chosen for, the
        // run halts (run.wgsl).
        if materials[particle_material[p]].model == MODEL_SNOW
            && returned.plastic < params.plastic_floor {
            atomicStore(&status[5], 1u);
        }
        let fp = mat3x3<f32>(fp0.xyz, plastic[3u * p + 1u].xyz, plastic[3u * p + 2u].xyz);
        let new_fp = after_return_mapping(trial_f, new_f, fp);
        plastic[3u * p] = vec4<f32>(new_fp[0], returned.plastic);
        plastic[3u * p + 1u] = vec4<f32>(new_fp[1], 0.0);
        plastic[3u * p + 2u] = vec4<f32>(new_fp[2], 0.0);
    }
    xv[2u * p] = vec4<f32>(new_x, xm.w);
    xv[2u * p + 1u] = vec4<f32>(new_v, vv.w);
    cf[6u * p] = vec4<f32>(new_c[0], 0.0);
    cf[6u * p + 1u] = vec4<f32>(new_c[1], 0.0);
    cf[6u * p + 2u] = vec4<f32>(new_c[2], 0.0);
    cf[6u * p + 3u] = vec4<f32>(new_f[0], 0.0);
    cf[6u * p + 4u] = vec4<f32>(new_f[1], 0.0);
    cf[6u * p + 5u] = vec4<f32>(new_f[2], 0.0);
    atomicMax(&status[1], bitcast<u32>(length(new_v)));
}

// Ends a substep without particles (G2P does it otherwise): the next one starts dt later.
@compute @workgroup_size(1)
fn tick() {
    if halted() {
        return;
    }
    atomicAdd(&status[3], 1u);
}
