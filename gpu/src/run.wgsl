
// A run of substeps in one submission (mpm/run.rs): after each substep, `run_check` logs it
// and decides whether the run halts there; every kernel of the substeps after a halt returns
// at once (`halted`), so the host reads the state after the substep it has to see.
//
// The log, from status word RUN_HEADER, one entry a substep: the largest particle speed at its
// end (f32 bits), then each collider's COLLIDER_WORDS words of grid_sum (its normal and
// friction impulses and nodes in the substep).

const RUN_HEADER: u32 = 8u;
// run_flags: halt after any substep that touches a collider.
const RUN_HALT_ON_TOUCH: u32 = 1u;

fn halted() -> bool {
    return atomicLoad(&status[4]) != 0u;
}

@compute @workgroup_size(1)
fn run_check() {
    if halted() {
        return;
    }
    // G2P (or `tick`) counted the substep just done.
    let done = atomicLoad(&status[3]);
    let entry = RUN_HEADER + (done - 1u) * (1u + COLLIDER_WORDS * params.n_colliders);
    let speed = atomicExchange(&status[1], 0u);
    atomicStore(&status[entry], speed);
    var halt = bitcast<f32>(speed) > params.speed_limit || atomicLoad(&status[5]) != 0u
        || atomicLoad(&status[0]) != 0u;
    let d = params.grid_dims;
    let sums = u32(d.x * d.y * d.z) * NODE_WORDS;
    for (var c = 0u; c < params.n_colliders; c++) {
        let at = sums + COLLIDER_WORDS * c;
        var touched = false;
        var w: array<u32, 13>;
        for (var k = 0u; k < COLLIDER_WORDS; k++) {
            w[k] = atomicLoad(&grid_sum[at + k]);
            atomicStore(&status[entry + 1u + COLLIDER_WORDS * c + k], w[k]);
            touched = touched || w[k] != 0u;
        }
        let j = vec3<f32>(fixed_to_f32(w[0], w[1]), fixed_to_f32(w[2], w[3]), fixed_to_f32(w[4], w[5]));
        if ((params.open_mask >> c) & 1u) != 0u {
            // The impact there ends when nothing touches it: the restitution law acts.
            halt = halt || !touched;
        } else {
            // An impact opens: the host records the object's velocity then.
            halt = halt || length(j) > params.opens_at;
        }
        halt = halt || (touched && (params.run_flags & RUN_HALT_ON_TOUCH) != 0u);
    }
    if halt {
        atomicStore(&status[4], 1u);
    }
}
