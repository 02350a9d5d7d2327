// Contact forces, gathered per particle (each particle computes the forces on itself from its
// full list: no float atomics), with the contact law of contact/hertz_mindlin.rs and the history rows of
// history.rs: the old rows are read into private memory, looked up by partner key, and rewritten
// packed with only the contacts that exist this step (particles in list order, then walls).
// Oriented runs gather with segment geometry (rods.wgsl).

@group(0) @binding(2) var<storage, read> pos_r: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> vel_im: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> omega: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> info: array<Info>;
@group(0) @binding(6) var<storage, read_write> load: array<Load>;
@group(0) @binding(7) var<storage, read_write> hist: array<Slot>;
@group(0) @binding(8) var<storage, read> nbr: array<u32>;
@group(0) @binding(10) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(19) var<storage, read_write> records: array<Rec>;
@group(0) @binding(21) var<storage, read_write> hist_hi: array<Slot>;
@group(0) @binding(22) var<storage, read> nbr_hi: array<u32>;

// History slot x and list word x, wherever the binding split put them (layout.rs `HIST_HI`).
fn hist_get(x: u32) -> Slot {
    if (x < params.hist_split) { return hist[x]; }
    return hist_hi[x - params.hist_split];
}

fn hist_set(x: u32, v: Slot) {
    if (x < params.hist_split) {
        hist[x] = v;
    } else {
        hist_hi[x - params.hist_split] = v;
    }
}

fn nbr_get(x: u32) -> u32 {
    if (x < params.nbr_split) { return nbr[x]; }
    return nbr_hi[x - params.nbr_split];
}

// One contact as `record_contacts` leaves it: (slot of i, id of i, slot of j or the wall's index,
// flags: 1 wall, 2 j fixed), (position of i, id of j as bits), branch c_i − c_j or c_i − contact
// point, force on i.
struct Rec {
    who: vec4<u32>,
    pos: vec4<f32>,
    branch: vec4<f32>,
    force: vec4<f32>,
}

// `u` is the contact's elastic energy (branch.w of the record). While `contact_energy` tallies,
// the contact only adds `u` to the tally.
fn emit(i: u32, me: Info, key: u32, id_j: u32, flags: u32, p: vec3<f32>, branch: vec3<f32>, f: vec3<f32>,
        u: f32) {
    if (tallying) {
        tally += u;
        return;
    }
    let k = atomicAdd(&status[ST_RECORDS], 1u);
    if (k < arrayLength(&records)) {
        records[k] = Rec(vec4<u32>(i, me.id, key, flags), vec4<f32>(p, bitcast<f32>(id_j)),
                         vec4<f32>(branch, u), vec4<f32>(f, 0.0));
    }
}

// The elastic-energy pass (`contact_energy`, compiled with RECORD): each contact's energy summed
// per particle, each contact once, as the records list them.
var<private> tallying: bool;
var<private> tally: f32;
@group(0) @binding(17) var<storage, read_write> energy: array<u32>;

var<private> old_key: array<u32, MAX_SLOTS>;
var<private> old_spring: array<vec3<f32>, MAX_SLOTS>;
var<private> old_len: u32;
var<private> new_len: u32;
var<private> full: bool;

fn rows_open(i: u32) {
    old_len = 0u;
    new_len = 0u;
    full = false;
    loop {
        if (old_len >= params.slots) { break; }
        let s = hist_get(slot_at(i, old_len));
        if (s.key == EMPTY) { break; }
        old_key[old_len] = s.key;
        old_spring[old_len] = s.spring;
        old_len++;
    }
}

fn rows_get(key: u32) -> vec3<f32> {
    for (var s = 0u; s < old_len; s++) {
        if (old_key[s] == key) { return old_spring[s]; }
    }
    return vec3<f32>(0.0);
}

fn rows_put(i: u32, key: u32, spring: vec3<f32>) {
    if (RECORD) { return; }
    if (new_len >= params.slots) {
        full = true;
        return;
    }
    hist_set(slot_at(i, new_len), Slot(spring, key));
    new_len++;
}

fn rows_close(i: u32) {
    if (RECORD) { return; }
    for (var s = new_len; s < max(old_len, new_len); s++) {
        hist_set(slot_at(i, s), Slot(vec3<f32>(0.0), EMPTY));
    }
}

// The step the forces advance the springs by: records give the force of the last step, the
// stored spring not advanced (dt = 0), as the CPU's contact_records.
fn spring_dt() -> f32 {
    return select(params.dt, 0.0, RECORD);
}

// What one particle's gather returns: force, torque, largest overlap ratio, contact count.
struct Gathered {
    f: vec3<f32>,
    t: vec3<f32>,
    max_ov: f32,
    nc: u32,
}

// The sphere path: each pair from i's side (pair_pass.rs).
fn gather_spheres(i: u32, me: Info) -> Gathered {
    var f = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    var max_ov = 0.0;
    var nc = 0u;
    let use_rows = HISTORY;
    let p4 = pos_r[i];
    let pi = p4.xyz;
    let lo_i = pos_r[lo_at(i)].xyz;
    let ri = p4.w;
    let mi = me.mass;
    let v4 = vel_im[i];
    let vi = v4.xyz;
    let rotation = ROTATION;
    var wi = vec3<f32>(0.0);
    if (rotation) {
        wi = omega[i].xyz;
    }
    let fixed_i = v4.w == 0.0;
    let cnt = nbr_get(nbr_at(i, 0u));
    for (var q = 0u; q < cnt; q++) {
        let j = nbr_get(nbr_at(i, 1u + q));
        let other = info[j];
        if (!live_at_forces(other.alive)) { continue; }
        let vj4 = vel_im[j];
        // Fixed particles feel no force: skip pairs of two fixed ones entirely.
        let fixed_j = vj4.w == 0.0;
        if (fixed_i && fixed_j) { continue; }
        let pj4 = pos_r[j];
        let d = separation(pj4.xyz, pos_r[lo_at(j)].xyz, pi, lo_i); // from j to i
        let rj = pj4.w;
        let dist2 = dot3(d, d);
        let sum = ri + rj;
        if (dist2 >= sum * sum) { continue; }
        let dist = sqrt(dist2);
        let n = d * (1.0 / dist);
        let overlap = sum - dist;
        let half_ov = overlap * 0.5;
        let bi = -(n * (ri - half_ov));
        let bj = n * (rj - half_ov);
        var wj = vec3<f32>(0.0);
        if (rotation) {
            wj = omega[j].xyz;
        }
        let v_rel = (vi + cross3(wi, bi)) - (vj4.xyz + cross3(wj, bj));
        let mj = other.mass;
        // A fixed partner acts as infinitely heavy.
        var m_eff = mi * mj / (mi + mj);
        if (fixed_j) {
            m_eff = mi;
        } else if (fixed_i) {
            m_eff = mj;
        }
        var spring = vec3<f32>(0.0);
        if (use_rows) {
            spring = rows_get(other.id);
        }
        let stored = spring;
        let fc = contact_force(params.law_pp, overlap, n, v_rel, ri * rj / sum, m_eff, spring_dt(),
                               &spring);
        if (use_rows) {
            rows_put(i, other.id, spring);
        }
        f = f + fc;
        t = t + cross3(bi, fc);
        max_ov = max(max_ov, overlap / (min(ri, rj) * 2.0));
        nc++;
        if (RECORD && !fixed_i && (fixed_j || me.id < other.id)) {
            emit(i, me, j, other.id, select(0u, 2u, fixed_j), pi, d, fc,
                 elastic_energy(params.law_pp, overlap, ri * rj / sum, stored));
        }
    }
    if (WALLS && !fixed_i) {
        for (var w = 0u; w < params.n_walls; w++) {
            let wc = wall_touch_split(walls.w[params.job * MAX_WALLS + w], pi, lo_i, ri);
            if (!wc.hit) { continue; }
            let n = wc.normal;
            let bi = -(n * (ri - wc.overlap * 0.5));
            let v_rel = vi + cross3(wi, bi) - wc.wall_velocity;
            let key = WALL_KEY | w;
            var spring = vec3<f32>(0.0);
            if (use_rows) {
                spring = rows_get(key);
            }
            let stored = spring;
            let fc = contact_force(params.law_pw, wc.overlap, n, v_rel, ri, mi, spring_dt(), &spring);
            if (use_rows) {
                rows_put(i, key, spring);
            }
            f = f + fc;
            t = t + cross3(bi, fc);
            max_ov = max(max_ov, wc.overlap / (ri * 2.0));
            nc++;
            if (RECORD) {
                emit(i, me, w, 0u, 3u, pi, -bi, fc,
                     elastic_energy(params.law_pw, wc.overlap, ri, stored));
            }
        }
    }
    return Gathered(f, t, max_ov, nc);
}

@compute @workgroup_size(WG)
fn compute_forces(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n) { return; }
    // Steps done after this one (1-based step index); the next kick_drift reads it.
    let k = atomicLoad(&status[ST_STEP_NEXT]);
    if (i == 0u) {
        atomicStore(&status[ST_STEP], k);
    }
    // Void when the lists went stale at this step or before (the host redoes it).
    if (atomicLoad(&status[ST_STALE]) < k) { return; }
    enter(i);
    if (params.running == 0u) { return; }
    forces(i, k);
}

// The force and torque on particle i after k steps of the chunk, into load[i] (also the contact
// count and the largest overlap), and the job's overlap and full-history words.
fn forces(i: u32, k: u32) {
    force_step = k;
    let use_rows = HISTORY;
    if (use_rows) {
        rows_open(i);
    }
    let me = info[i];
    if (!live(me.alive)) {
        if (use_rows) {
            rows_close(i);
        }
        load[i] = Load(vec4<f32>(0.0), vec4<f32>(0.0));
        return;
    }
    var g: Gathered;
    if (ORIENTED) {
        g = gather_oriented(i, me);
    } else {
        g = gather_spheres(i, me);
    }
    var f = g.f;
    var t = g.t;
    let max_ov = g.max_ov;
    if (vel_im[i].w == 0.0) {
        f = vec3<f32>(0.0);
        t = vec3<f32>(0.0);
    }
    if (use_rows) {
        rows_close(i);
    }
    load[i] = Load(vec4<f32>(f, f32(g.nc)), vec4<f32>(t, max_ov));
    if (full) {
        atomicMin(&status[sw(ST_FULL_STEP)], k);
        atomicMin(&status[sw(ST_FULL_INDEX)], me.id);
    }
    if (max_ov > bitcast<f32>(atomicLoad(&status[sw(ST_MAX_OVERLAP)]))) {
        atomicMax(&status[sw(ST_MAX_OVERLAP)], bitcast<u32>(max_ov));
    }
    if (max_ov > params.overlap_limit) {
        atomicMin(&status[sw(ST_OVERLAP_STEP)], k);
    }
}

// Every contact of the current state, each once (pairs from the side of the lower id, or of the
// mobile particle), with the force a step would compute now: for stress observers
// (`GpuEngine::contact_records_job`). Writes nothing else.
@compute @workgroup_size(WG)
fn record_contacts(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n) { return; }
    enter(i);
    if (params.running == 0u) { return; }
    let me = info[i];
    if (!live(me.alive)) { return; }
    if (HISTORY) {
        rows_open(i);
    }
    if (ORIENTED) {
        gather_oriented(i, me);
    } else {
        gather_spheres(i, me);
    }
}

// Each live particle's share of the elastic energy stored in the contacts (each contact counted
// once, from the side `record_contacts` takes it) into energy[i], and the job's largest share in
// its status block (the scale of `elastic_sum`): the energy watchdog's U₀, at a chunk's start
// right after its list build. Compiled with RECORD: springs are read, nothing else is written.
@compute @workgroup_size(WG)
fn contact_energy(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n) { return; }
    enter(i);
    var u = 0.0;
    let me = info[i];
    if (params.running != 0u && live(me.alive)) {
        tallying = true;
        tally = 0.0;
        if (HISTORY) {
            rows_open(i);
        }
        if (ORIENTED) {
            gather_oriented(i, me);
        } else {
            gather_spheres(i, me);
        }
        // +0 for anything not positive (−0 and NaN would order above every energy as bits).
        u = select(0.0, tally, tally > 0.0);
        atomicMax(&status[sw(ST_U_MAX)], bitcast<u32>(u));
    }
    energy[i] = bitcast<u32>(u);
}
