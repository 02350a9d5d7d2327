// The one-dispatch step (GpuOptions::fused_step): `fused_step` computes the forces of step k and
// then the kick and drift of step k (+ the rotation), one dispatch where the two-dispatch step
// takes `compute_forces` and `kick_drift`. The forces read the neighbours' positions, velocities
// and spins while their own invocations move them, so the state has two copies: the step reads
// one (`pos_r`, `vel_im`, `omega`, bound as contacts.wgsl declares them) and writes the other
// (`pos_w`, `vel_w`, `omega_w`); the host swaps the two bind groups from one fused dispatch to
// the next and, after a chunk that ends on the second copy, `adopt`s it back. Rods' orientation
// records (`rod`) are read only by their own particle and stay in place. Deaths are marked
// 2 + k (common.wgsl `live_at_forces`). The step index comes from the host (an immediate), and
// the status words are written for the list builds and the closing forces that follow.
@group(0) @binding(9) var<storage, read> ref_pos: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> events: array<vec2<u32>>;
@group(0) @binding(18) var<storage, read_write> rod: array<Rod>;
@group(0) @binding(23) var<storage, read_write> pos_w: array<vec4<f32>>;
@group(0) @binding(24) var<storage, read_write> vel_w: array<vec4<f32>>;
@group(0) @binding(25) var<storage, read_write> omega_w: array<vec4<f32>>;

// The chunk-local step this dispatch computes (the forces after k steps, then step k's drift).
var<immediate> step_k: u32;

fn put_pos(x: u32, v: vec4<f32>) {
    pos_w[x] = v;
}

fn put_vel(x: u32, v: vec4<f32>) {
    vel_w[x] = v;
}

fn put_omega(x: u32, v: vec4<f32>) {
    omega_w[x] = v;
}

fn moved_pos(i: u32) -> vec4<f32> {
    return pos_w[i];
}

fn mark_dead(i: u32, k: u32) {
    info[i].alive = 2u + k;
}

// Slot i's records, every block of them, copied to the other copy: what the step does not change
// (fixed, dead and stopped particles, the radius, the rests it leaves) must be there too.
fn carry_over(i: u32) {
    let n = jobs[0].n;
    pos_w[i] = pos_r[i];
    pos_w[n + i] = pos_r[n + i];
    if (ORIENTED) {
        pos_w[2u * n + i] = pos_r[2u * n + i];
    }
    vel_w[i] = vel_im[i];
    vel_w[n + i] = vel_im[n + i];
    omega_w[i] = omega[i];
    omega_w[n + i] = omega[n + i];
}

@compute @workgroup_size(WG)
fn fused_step(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n) { return; }
    let k = step_k;
    // As `compute_forces` and `kick_drift` leave them, before the void test: a list build after
    // a void step must find itself void too.
    if (i == 0u) {
        atomicStore(&status[ST_STEP], k);
        atomicStore(&status[ST_STEP_NEXT], k + 1u);
    }
    if (atomicLoad(&status[ST_STALE]) < k) { return; }
    carry_over(i);
    enter(i);
    if (params.running == 0u) { return; }
    forces(i, k);
    translate(i, k);
    if (ORIENTED) {
        kick_rotate(i, k);
    }
}

// The second copy written back to the first at a chunk's end (bound with the copies swapped:
// `pos_r` is the second, `pos_w` the first), so that read-backs, uploads and the next chunk see
// one layout. Void, like every closing pass, while a stale step waits to be redone.
@compute @workgroup_size(WG)
fn adopt(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n || atomicLoad(&status[ST_STALE]) != 0xffffffffu) { return; }
    carry_over(i);
}
