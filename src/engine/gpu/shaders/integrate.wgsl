// Velocity Verlet with the fused kick of cpu/rods.rs: `kick_drift` kicks by dt/2 at a chunk's first
// step and by two dt/2 after (the previous step's closing half kick and this step's opening one),
// drifts, wraps, flags sink deaths and list staleness (step.wgsl), and for oriented runs turns the
// particle (rotate.wgsl) in the same invocation; `close_kick` is the chunk's closing half kick;
// `finish` checks finiteness, counts contacts and sums the kinetic energy per workgroup.

// Step k's kick and drift of every particle, then (oriented runs) its rotation; the step index
// advances here for `compute_forces`. Void when an earlier step left the lists stale.
@compute @workgroup_size(WG)
fn kick_drift(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n) { return; }
    let k = atomicLoad(&status[ST_STEP]);
    if (atomicLoad(&status[ST_STALE]) < k) { return; }
    if (i == 0u) {
        atomicStore(&status[ST_STEP_NEXT], k + 1u);
    }
    enter(i);
    if (params.running == 0u) { return; }
    translate(i, k);
    if (ORIENTED) {
        kick_rotate(i, k);
    }
}

@compute @workgroup_size(WG)
fn close_kick(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n || atomicLoad(&status[ST_STALE]) != 0xffffffffu) { return; }
    enter(i);
    if (params.running == 0u) { return; }
    let half = params.half_dt;
    let vi = vel_im[i];
    let im = vi.w;
    if (im != 0.0 && live(info[i].alive)) {
        let dv = half_kick_dv(i, im);
        let v = kick_split(vi.xyz, vel_im[rest_at(i)].xyz, dv);
        vel_im[i] = vec4<f32>(v.s, im);
        vel_im[rest_at(i)] = vec4<f32>(v.e, 0.0);
    }
    if (ROTATION && !ORIENTED) {
        let dw = load[i].torque.xyz * (info[i].inv_inertia * half);
        let w = kick_split(omega[i].xyz, omega[rest_at(i)].xyz, dw);
        omega[i] = vec4<f32>(w.s, 0.0);
        omega[rest_at(i)] = vec4<f32>(w.e, 0.0);
    }
    if (ORIENTED) {
        // oriented::close_kick: L gets the half kick, ω is refreshed from it (every particle,
        // as on the CPU; fixed ones have zero inverse inertia and stay put).
        let r = rod[i];
        let inv = r.inv_inertia_h.xyz;
        if (inv.x != 0.0) {
            let l = kick_split(r.ang_mom.xyz, omega[rest_at(i)].xyz, load[i].torque.xyz * half);
            rod[i].ang_mom = vec4<f32>(l.s, 0.0);
            omega[rest_at(i)] = vec4<f32>(l.e, 0.0);
            omega[i] = vec4<f32>(angular_velocity(r.q, inv, l.s), 0.0);
        }
    }
}

fn is_finite3(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

// Each slot's kinetic energy as f32 bits (`finish`), then two words (low, high) per workgroup:
// the fixed-point sum of `energy_sum`.
@group(0) @binding(17) var<storage, read_write> energy: array<u32>;

// Finiteness and the contact count of live particle i; returns its kinetic energy (translational
// and rotational, as State::kinetic_energy; zero when fixed).
fn check_particle(i: u32) -> f32 {
    if (!live(info[i].alive)) { return 0.0; }
    atomicAdd(&status[sw(ST_CONTACTS)], u32(load[i].force.w));
    var kind = 4u;
    if (!is_finite3(pos_r[i].xyz)) {
        kind = 0u;
    } else if (!is_finite3(vel_im[i].xyz)) {
        kind = 1u;
    } else if (ROTATION && !is_finite3(omega[i].xyz)) {
        kind = 2u;
    } else if (ORIENTED && !is_finite3(vec3<f32>(quat_norm2(rod[i].q)))) {
        kind = 3u;
    }
    if (kind < 4u) {
        atomicMin(&status[sw(ST_NONFINITE)], info[i].id * 4u + kind);
    }
    if (vel_im[i].w == 0.0) { return 0.0; }
    let v = vel_im[i].xyz;
    var e = 0.5 * info[i].mass * dot3(v, v);
    if (ORIENTED) {
        e += 0.5 * dot3(omega[i].xyz, rod[i].ang_mom.xyz);
    } else if (ROTATION && info[i].inv_inertia > 0.0) {
        let w = omega[i].xyz;
        e += 0.5 / info[i].inv_inertia * dot3(w, w);
    }
    return e;
}

// The chunk's closing checks: each live particle's kinetic energy is left in energy[i] and the
// job's largest in its status block (the scale of `energy_sum`).
@compute @workgroup_size(WG)
fn finish(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n) { return; }
    var e = 0.0;
    if (atomicLoad(&status[ST_STALE]) == 0xffffffffu) {
        enter(i);
        if (params.running != 0u) {
            // +0 for anything not positive (−0 and NaN would order above every energy as bits).
            e = check_particle(i);
            e = select(0.0, e, e > 0.0);
            atomicMax(&status[sw(ST_KE_MAX)], bitcast<u32>(e));
            // A death marked by a one-dispatch step (2 + its step) becomes 0, as the
            // two-dispatch step writes it: chunk-local steps never meet an old mark.
            if (info[i].alive > 1u) {
                info[i].alive = 0u;
            }
        }
    }
    energy[i] = bitcast<u32>(e);
}

var<workgroup> ke_lo: array<u32, WG>;
var<workgroup> ke_hi: array<u32, WG>;

// The exponent x of 2^x > every particle energy of the job, from the largest one's f32 bits.
fn ke_exponent(max_bits: u32) -> i32 {
    return i32((max_bits >> 23u) & 0xffu) - 126;
}

// An energy summed so that no order of the particles (in the buffers or in time) can change a
// bit: each particle's energy[i] is rounded to a multiple of 2^(ke_exponent − KE_BITS), the
// exponent from the job's largest (its f32 bits in status word `max_word`), and the integers are
// added exactly (two words with carry) into the two words of workgroup g from energy[at + 2 g];
// the host adds the workgroups' sums in u128 and scales back. Workgroups past the slots (the
// last row of a 2-D dispatch) write nothing.
fn fixed_sum(i: u32, t: u32, max_word: u32, g: u32, at: u32) {
    var lo = 0u;
    var hi = 0u;
    if (i < jobs[0].n && atomicLoad(&status[ST_STALE]) == 0xffffffffu) {
        enter(i);
        let e = bitcast<f32>(energy[i]);
        if (params.running != 0u && e > 0.0) {
            let scale = KE_BITS - ke_exponent(atomicLoad(&status[sw(max_word)]));
            let x = round(ldexp(e, scale));
            let h = floor(ldexp(x, -32));
            hi = u32(h);
            lo = u32(x - ldexp(h, 32));
        }
    }
    ke_lo[t] = lo;
    ke_hi[t] = hi;
    workgroupBarrier();
    for (var s = WG / 2u; s > 0u; s = s / 2u) {
        if (t < s) {
            let a = ke_lo[t];
            let l = a + ke_lo[t + s];
            ke_lo[t] = l;
            ke_hi[t] = ke_hi[t] + ke_hi[t + s] + select(0u, 1u, l < a);
        }
        workgroupBarrier();
    }
    if (t == 0u && g < groups_of_slots()) {
        energy[at + 2u * g] = ke_lo[0];
        energy[at + 2u * g + 1u] = ke_hi[0];
    }
}

// Workgroups that cover the slots.
fn groups_of_slots() -> u32 {
    return (jobs[0].n + WG - 1u) / WG;
}

// The kinetic energy `finish` left per slot, summed per workgroup.
@compute @workgroup_size(WG)
fn energy_sum(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    fixed_sum(flat(gid, nwg), lid.x, ST_KE_MAX, wid.x + wid.y * nwg.x, jobs[0].n);
}

// The elastic energy `contact_energy` left per slot, summed per workgroup after the kinetic
// sums (the energy watchdog's U₀ at a chunk's start).
@compute @workgroup_size(WG)
fn elastic_sum(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let g = wid.x + wid.y * nwg.x;
    fixed_sum(flat(gid, nwg), lid.x, ST_U_MAX, g, jobs[0].n + 2u * groups_of_slots());
}
