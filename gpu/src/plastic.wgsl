// The plastic models of splatphys-core on the GPU: the 3x3 SVD they need (math/svd.rs), Hencky
// stress (material/hencky.rs), the return mappings of snow (material/snow.rs, Stomakhin et al.
// 2013 with the closest-point return in the energy norm), sand (material/sand.rs, Drucker-Prager,
// Klár et al. 2016 eqs. 27-28) and von Mises on Hencky strain (metal, plasticine, foam), and the
// plastic deformation F_p a particle's Gaussians follow (mpm/plastic_flow.rs). Each function
// follows its CPU twin line by line, so a run differs from the CPU's only by f32 rounding and the
// device's exp/log.

// Snow (material/snow.rs): smallest Jp kept and the hardening factor's bounds.
const MIN_JP: f32 = 1.0e-6;
const HARDENING_MIN: f32 = 0.1;
const HARDENING_MAX: f32 = 5.0;
// Smallest singular value a log is taken of (material/hencky.rs MIN_SIGMA).
const MIN_SIGMA: f32 = 1.0e-4;
// sqrt(2/3): a uniaxial yield stress as the norm of the deviatoric stress.
const UNIAXIAL_TO_DEVIATORIC_NORM: f32 = 0.8164966;
// F_p's stretches stay within these (mpm/particles.rs).
const PLASTIC_STRETCH_MIN: f32 = 0.25;
const PLASTIC_STRETCH_MAX: f32 = 4.0;

struct Svd {
    u: mat3x3<f32>,
    sigma: vec3<f32>,
    v: mat3x3<f32>,
};

// Any unit vector orthogonal to unit `u` (glam's any_orthonormal_vector: Duff et al. 2017).
fn any_orthogonal(u: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, u.z >= 0.0);
    let a = -1.0 / (s + u.z);
    let b = u.x * u.y * a;
    return vec3<f32>(b, s + u.y * u.y * a, -u.y);
}

// Sign-fixed SVD by one-sided Jacobi (math/svd.rs svd3): A = U diag(sigma) V^T, U and V proper
// rotations, sigma sorted by decreasing magnitude with the sign of det A on the last.
fn svd3(a: mat3x3<f32>) -> Svd {
    var b = array<vec3<f32>, 3>(a[0], a[1], a[2]);
    var v = array<vec3<f32>, 3>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    for (var sweep = 0; sweep < 10; sweep++) {
        var rotated = false;
        // Pairs (0, 1), (0, 2), (1, 2).
        for (var k = 0u; k < 3u; k++) {
            let p = select(0u, 1u, k == 2u);
            let q = select(2u, 1u, k == 0u);
            let alpha = dot(b[p], b[p]);
            let beta = dot(b[q], b[q]);
            let gamma = dot(b[p], b[q]);
            if gamma == 0.0 || abs(gamma) <= 1.0e-6 * sqrt(alpha * beta) {
                continue;
            }
            rotated = true;
            let zeta = (beta - alpha) / (2.0 * gamma);
            let t = select(-1.0, 1.0, zeta >= 0.0) / (abs(zeta) + sqrt(1.0 + zeta * zeta));
            let c = 1.0 / sqrt(1.0 + t * t);
            let s = c * t;
            let bp = b[p];
            let bq = b[q];
            b[p] = bp * c - bq * s;
            b[q] = bp * s + bq * c;
            let vp = v[p];
            let vq = v[q];
            v[p] = vp * c - vq * s;
            v[q] = vp * s + vq * c;
        }
        if !rotated {
            break;
        }
    }
    // Sort by decreasing column norm; each swap negates one column so det V stays +1.
    for (var k = 0u; k < 3u; k++) {
        let p = select(0u, 1u, k == 2u);
        let q = select(2u, 1u, k == 0u);
        if dot(b[p], b[p]) < dot(b[q], b[q]) {
            let tb = b[p];
            b[p] = b[q];
            b[q] = -tb;
            let tv = v[p];
            v[p] = v[q];
            v[q] = -tv;
        }
    }
    // U by Gram-Schmidt with completion: a proper rotation even for rank-deficient A.
    let s0 = length(b[0]);
    var u0 = vec3<f32>(1.0, 0.0, 0.0);
    if s0 > 1.17549435e-38 {
        u0 = b[0] / s0;
    }
    let r1 = b[1] - u0 * dot(u0, b[1]);
    let n1 = length(r1);
    var u1: vec3<f32>;
    if n1 > 1.0e-30 && n1 > 1.0e-6 * s0 {
        u1 = r1 / n1;
    } else {
        u1 = any_orthogonal(u0);
    }
    if dot(u1, b[1]) < 0.0 {
        u1 = -u1;
    }
    let u2 = cross(u0, u1);
    var out: Svd;
    out.u = mat3x3<f32>(u0, u1, u2);
    out.sigma = vec3<f32>(s0, dot(u1, b[1]), dot(u2, b[2]));
    out.v = mat3x3<f32>(v[0], v[1], v[2]);
    return out;
}

fn diag(d: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(d.x, 0.0, 0.0), vec3<f32>(0.0, d.y, 0.0), vec3<f32>(0.0, 0.0, d.z));
}

// Principal Hencky strain ln(max(sigma, MIN_SIGMA)).
fn log_strain(sigma: vec3<f32>) -> vec3<f32> {
    return log(max(sigma, vec3<f32>(MIN_SIGMA)));
}

// Kirchhoff stress of St. Venant-Kirchhoff elasticity on the Hencky strain of f.
fn hencky_stress(f: mat3x3<f32>, mu: f32, lambda: f32) -> mat3x3<f32> {
    let s = svd3(f);
    let eps = log_strain(s.sigma);
    let tau = eps * (2.0 * mu) + vec3<f32>(lambda * (eps.x + eps.y + eps.z));
    return s.u * diag(tau) * transpose(s.u);
}

// Snow's hardening factor e^{xi (1 - Jp)}, bounded.
fn hardening_factor(xi: f32, jp: f32) -> f32 {
    return clamp(exp(xi * (1.0 - jp)), HARDENING_MIN, HARDENING_MAX);
}

// Whether every singular value of f is surely in [lo, hi], without an SVD (snow.rs inside_box).
fn inside_box(f: mat3x3<f32>, lo: f32, hi: f32) -> bool {
    if det3(f) <= 0.0 {
        return false;
    }
    let c = transpose(f) * f;
    let margin = 1.0e-5;
    let lo2 = lo * lo + margin;
    let hi2 = hi * hi - margin;
    let centre = vec3<f32>(c[0].x, c[1].y, c[2].z);
    let radius = vec3<f32>(abs(c[1].x) + abs(c[2].x), abs(c[0].y) + abs(c[2].y), abs(c[0].z) + abs(c[1].z));
    return all(centre - radius >= vec3<f32>(lo2)) && all(centre + radius <= vec3<f32>(hi2));
}

// The closest point of the box [lo, hi]^3 to sigma in the norm |d|^2 + r (sum d)^2 (snow.rs
// return_to_box): the best feasible stationary point of the 27 faces, edges, corners and interior.
fn return_to_box(sigma: vec3<f32>, lo: f32, hi: f32, r: f32) -> vec3<f32> {
    if all(sigma >= vec3<f32>(lo)) && all(sigma <= vec3<f32>(hi)) {
        return sigma;
    }
    var best = clamp(sigma, vec3<f32>(lo), vec3<f32>(hi));
    var best_norm = 3.0e38;
    for (var code = 0u; code < 27u; code++) {
        let state = vec3<u32>(code % 3u, (code / 3u) % 3u, code / 9u);
        var fixed_sum = 0.0;
        var free = 0.0;
        for (var i = 0u; i < 3u; i++) {
            if state[i] == 1u {
                fixed_sum += lo - sigma[i];
            } else if state[i] == 2u {
                fixed_sum += hi - sigma[i];
            } else {
                free += 1.0;
            }
        }
        let c = -r * fixed_sum / (1.0 + r * free);
        var y = vec3<f32>(0.0);
        var feasible = true;
        for (var i = 0u; i < 3u; i++) {
            if state[i] == 1u {
                y[i] = lo;
            } else if state[i] == 2u {
                y[i] = hi;
            } else {
                y[i] = sigma[i] + c;
            }
            feasible = feasible && y[i] >= lo && y[i] <= hi;
        }
        if !feasible {
            continue;
        }
        let d = y - sigma;
        let sum = d.x + d.y + d.z;
        let norm = dot(d, d) + r * sum * sum;
        if norm < best_norm {
            best_norm = norm;
            best = y;
        }
    }
    return best;
}

// A return mapping's result: the elastic F, the plastic scalar, and whether F changed.
struct Returned {
    f: mat3x3<f32>,
    plastic: f32,
    changed: bool,
};

fn unchanged(f: mat3x3<f32>, plastic: f32) -> Returned {
    return Returned(f, plastic, false);
}

// Snow (snow.rs project): p0 hardening xi, p1 critical compression, p2 critical stretch.
fn project_snow(m: Material, f: mat3x3<f32>, jp: f32) -> Returned {
    let lo = 1.0 - m.p1;
    let hi = 1.0 + m.p2;
    if inside_box(f, lo, hi) {
        return unchanged(f, jp);
    }
    let s = svd3(f);
    let clamped = return_to_box(s.sigma, lo, hi, m.lambda / (2.0 * m.mu));
    let old_j = abs(s.sigma.x * s.sigma.y * s.sigma.z);
    let new_j = clamped.x * clamped.y * clamped.z;
    return Returned(s.u * diag(clamped) * transpose(s.v), max(jp * old_j / new_j, MIN_JP), true);
}

// Sand (sand.rs project): p0 the cone coefficient alpha.
fn project_sand(m: Material, f: mat3x3<f32>, plastic: f32) -> Returned {
    let s = svd3(f);
    let eps = log_strain(s.sigma);
    let tr = eps.x + eps.y + eps.z;
    var new_eps = vec3<f32>(0.0);
    var p = plastic;
    if tr >= 0.0 {
        p += length(eps);
    } else {
        let dev = eps - vec3<f32>(tr / 3.0);
        let norm = length(dev);
        let dgamma = norm + (3.0 * m.lambda + 2.0 * m.mu) / (2.0 * m.mu) * tr * m.p0;
        if dgamma <= 0.0 || norm <= 0.0 {
            return unchanged(f, plastic);
        }
        p += dgamma;
        new_eps = eps - dev * (dgamma / norm);
    }
    return Returned(s.u * diag(exp(new_eps)) * transpose(s.v), p, true);
}

// Von Mises on Hencky strain (hencky.rs von_mises_project): p0 the uniaxial yield stress (Pa),
// p1 its softening per unit plastic strain (plasticine), p2 the viscosity (Pa s) that makes the
// flow a fraction dt / (dt + eta / mu) of the excess (foam); metal has neither.
fn project_von_mises(m: Material, f: mat3x3<f32>, plastic: f32, dt: f32) -> Returned {
    let yield_now = m.p0 * max(1.0 - m.p1 * plastic, 0.1);
    var fraction = 1.0;
    if m.p2 > 0.0 {
        fraction = dt / (dt + m.p2 / m.mu);
    }
    let s = svd3(f);
    let eps = log_strain(s.sigma);
    let mean = (eps.x + eps.y + eps.z) / 3.0;
    let dev = eps - vec3<f32>(mean);
    let norm = length(dev);
    let excess = norm - UNIAXIAL_TO_DEVIATORIC_NORM * yield_now / (2.0 * m.mu);
    if excess <= 0.0 || norm <= 0.0 {
        return unchanged(f, plastic);
    }
    let dgamma = excess * fraction;
    let eps_new = eps - dev * (dgamma / norm);
    return Returned(s.u * diag(exp(eps_new)) * transpose(s.v), plastic + dgamma, true);
}

// The particle's model's return mapping of trial F (ConstitutiveModel::project).
fn project(m: Material, f: mat3x3<f32>, plastic: f32, dt: f32) -> Returned {
    if m.model == MODEL_SNOW {
        return project_snow(m, f, plastic);
    } else if m.model == MODEL_SAND {
        return project_sand(m, f, plastic);
    } else if m.model == MODEL_VON_MISES {
        return project_von_mises(m, f, plastic, dt);
    }
    return unchanged(f, plastic);
}

fn inverse3(m: mat3x3<f32>, det: f32) -> mat3x3<f32> {
    let r0 = cross(m[1], m[2]);
    let r1 = cross(m[2], m[0]);
    let r2 = cross(m[0], m[1]);
    return transpose(mat3x3<f32>(r0, r1, r2)) * (1.0 / det);
}

// F_p after a return mapping took `trial` to `elastic` (plastic_flow.rs after_return_mapping):
// F_p' = F'^-1 F* F_p with its stretches kept within [PLASTIC_STRETCH_MIN, PLASTIC_STRETCH_MAX].
fn after_return_mapping(trial: mat3x3<f32>, elastic: mat3x3<f32>, fp: mat3x3<f32>) -> mat3x3<f32> {
    let det = det3(elastic);
    if !(abs(det) > 1.0e-12) {
        return fp;
    }
    let next = inverse3(elastic, det) * trial * fp;
    let big = vec3<f32>(3.0e38);
    if !(all(abs(next[0]) < big) && all(abs(next[1]) < big) && all(abs(next[2]) < big)) {
        return fp;
    }
    let norm2 = dot(next[0], next[0]) + dot(next[1], next[1]) + dot(next[2], next[2]);
    if norm2 <= PLASTIC_STRETCH_MAX * PLASTIC_STRETCH_MAX && det3(next) >= PLASTIC_STRETCH_MIN * norm2 {
        return next;
    }
    let s = svd3(next);
    let sigma = clamp(s.sigma, vec3<f32>(PLASTIC_STRETCH_MIN), vec3<f32>(PLASTIC_STRETCH_MAX));
    return s.u * diag(sigma) * transpose(s.v);
}
