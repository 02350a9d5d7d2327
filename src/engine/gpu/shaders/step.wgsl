// One step's kick and drift of one particle, shared by the two-dispatch step (`kick_drift`,
// integrate.wgsl) and the one-dispatch step (`fused_step`, fused.wgsl). It reads the particle's
// state where the step starts (`pos_r`, `vel_im`, `omega`) and writes the new state through the
// `put_*` functions: in place for `kick_drift` (inplace.wgsl), into the other copy of the state
// for `fused_step`, whose neighbours still read the old one.

// Marks the lists stale from step k on (the first such step wins).
fn flag_stale(k: u32) {
    if (atomicLoad(&status[ST_STALE]) > k) {
        atomicMin(&status[ST_STALE], k);
    }
}

// The translational kick and drift of particle i at step k, the sink and (spheres) the skin.
// A chunk's first step kicks by dt/2; every other step by the previous step's closing dt/2 and
// then its own opening dt/2, two `kick_split`s, as a chunk's close_kick and the next chunk's
// first step do.
fn translate(i: u32, k: u32) {
    let half = params.half_dt;
    if (ROTATION && !ORIENTED) {
        // NOTE: like the CPU engine, every particle's ω is kicked (fixed ones have 1/I = 0).
        let dw = load[i].torque.xyz * (info[i].inv_inertia * half);
        var w = kick_split(omega[i].xyz, omega[rest_at(i)].xyz, dw);
        if (k > 0u) {
            w = kick_split(w.s, w.e, dw);
        }
        put_omega(i, vec4<f32>(w.s, 0.0));
        put_omega(rest_at(i), vec4<f32>(w.e, 0.0));
    }
    let vi = vel_im[i];
    let im = vi.w;
    if (im == 0.0 || !live(info[i].alive)) { return; }
    let dv = half_kick_dv(i, im);
    var vs = kick_split(vi.xyz, vel_im[rest_at(i)].xyz, dv);
    if (k > 0u) {
        vs = kick_split(vs.s, vs.e, dv);
    }
    let v = vs.s;
    // The split drift (position::drift), then the wrap's shift added the same way. The product
    // is rounded on its own (`opaque`): the fused step drifts in another kernel than a chunk's
    // first step, and an FMA in one of them only would part the two.
    let moved = two_sum(pos_r[i].xyz, opaque(v * params.dt) + pos_r[lo_at(i)].xyz);
    var x = moved.s;
    var lo = moved.e;
    let shift = wrap_shift(x);
    if (any(shift != vec3<f32>(0.0))) {
        let w = two_sum(x, shift);
        let back = two_sum(w.s, w.e + lo);
        x = back.s;
        lo = back.e;
    }
    lo = f64_rest(x, lo);
    put_vel(rest_at(i), vec4<f32>(vs.e, 0.0));
    put_vel(i, vec4<f32>(v, im));
    put_pos(i, vec4<f32>(x, pos_r[i].w));
    put_pos(lo_at(i), vec4<f32>(lo, 0.0));
    if (SINK && x.z < params.sink_z) {
        mark_dead(i, k);
        let e = atomicAdd(&status[sw(ST_DEATHS)], 1u);
        events[params.job * params.n_job + e] = vec2<u32>(info[i].id, k);
    }
    // Oriented particles test their ends after turning, in kick_rotate.
    if (ORIENTED) { return; }
    let d = min_image(ref_pos[i].xyz, x);
    if (dot3(d, d) > params.half_skin2) {
        flag_stale(k);
    }
}

// Particle i's velocity change in a half kick, (F/m + g) dt/2. kick_drift and close_kick must
// round it alike, or where a chunk ends would change bits; but naga's SPIR-V carries no
// NoContraction, and a driver may fuse F·(1/m) + g into one FMA in one kernel and not in the
// other. `opaque` makes the product a value of its own, so neither can fuse it.
fn half_kick_dv(i: u32, im: f32) -> vec3<f32> {
    return (opaque(load[i].force.xyz * im) + gravity()) * params.half_dt;
}

