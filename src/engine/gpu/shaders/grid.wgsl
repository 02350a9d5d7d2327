// Neighbour search: a uniform cell grid filled by a counting sort (atomic histogram, chunked
// prefix sum, scatter of particle indices), then a full Verlet list per particle with cutoff
// r_i + r_j + skin (r the reach: the radius, plus l/2 for a spherocylinder), ordered by partner
// id so that force sums depend neither on the order the atomics happened to run in, nor on when
// the lists were built, nor on where the particles sit in the buffers. The host records these passes only at steps it chose (engine.rs);
// each returns at once when an earlier step left the lists stale (the submission is void past
// that step and the host redoes it).

@group(0) @binding(2) var<storage, read> pos_r: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> info: array<Info>;
@group(0) @binding(8) var<storage, read_write> nbr: array<u32>;
@group(0) @binding(9) var<storage, read_write> ref_pos: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> cell_rank: array<vec2<u32>>;
@group(0) @binding(13) var<storage, read_write> cell_count: array<atomic<u32>>;
@group(0) @binding(14) var<storage, read_write> cell_start: array<u32>;
@group(0) @binding(15) var<storage, read_write> chunk_sums: array<u32>;
@group(0) @binding(16) var<storage, read_write> sorted: array<u32>;
@group(0) @binding(3) var<storage, read> vel_im: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> omega: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> load: array<Load>;
@group(0) @binding(7) var<storage, read> hist: array<Slot>;
@group(0) @binding(21) var<storage, read> hist_hi: array<Slot>;
@group(0) @binding(22) var<storage, read_write> nbr_hi: array<u32>;

// History slot x and list word x, wherever the binding split put them (layout.rs `HIST_HI`).
fn hist_get(x: u32) -> Slot {
    if (x < params.hist_split) { return hist[x]; }
    return hist_hi[x - params.hist_split];
}

fn nbr_set(x: u32, v: u32) {
    if (x < params.nbr_split) {
        nbr[x] = v;
    } else {
        nbr_hi[x - params.nbr_split] = v;
    }
}
@group(0) @binding(18) var<storage, read> rod: array<Rod>;
@group(0) @binding(20) var<storage, read_write> scratch: array<vec4<u32>>;

// Whether a step before this one found the lists stale (this build is then void).
fn void_build() -> bool {
    return atomicLoad(&status[ST_STALE]) < atomicLoad(&status[ST_STEP]);
}

fn axis_cell(x: f32, lo: f32, w: f32, n: u32, periodic: bool) -> u32 {
    let c = i32(clamp(floor((x - lo) / w), -1.0e9, 1.0e9));
    let ni = i32(n);
    if (periodic) {
        return u32(((c % ni) + ni) % ni);
    }
    return u32(clamp(c, 0, ni - 1));
}

fn cell_of(p: vec3<f32>) -> vec3<u32> {
    return vec3<u32>(
        axis_cell(p.x, params.lo_x, params.width_x, params.nx, PERIODIC_X),
        axis_cell(p.y, params.lo_y, params.width_y, params.ny, PERIODIC_Y),
        axis_cell(p.z, params.lo_z, params.width_z, params.nz, false),
    );
}

@compute @workgroup_size(WG)
fn histogram(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n || void_build()) { return; }
    enter(i);
    if (!live(info[i].alive) || params.running == 0u) { return; }
    let c3 = cell_of(pos_r[i].xyz);
    let c = params.cell_offset + (c3.z * params.ny + c3.y) * params.nx + c3.x;
    cell_rank[i] = vec2<u32>(c, atomicAdd(&cell_count[c], 1u));
}

// The cell starts: a work-efficient exclusive scan of the counts in three passes. Each
// workgroup scans a block of WG × SCAN_ITEMS cells (block-relative starts, the block's total),
// one workgroup scans the block totals, and each workgroup adds its block's offset. Integer
// sums, so the order of the additions cannot change a bit.

var<workgroup> wg_sum: array<u32, WG>;
var<workgroup> wg_flag: u32;

// Whether this build is void, as a value every invocation of the workgroup agrees on (the
// passes below synchronise, so they may only return together).
fn uniform_void(t: u32) -> bool {
    if (t == 0u) {
        wg_flag = select(0u, 1u, void_build());
    }
    return workgroupUniformLoad(&wg_flag) != 0u;
}

// The exclusive prefix of v over the workgroup's invocations (x) and their total (y).
fn workgroup_exclusive(t: u32, v: u32) -> vec2<u32> {
    wg_sum[t] = v;
    workgroupBarrier();
    for (var o = 1u; o < WG; o = o * 2u) {
        var add = 0u;
        if (t >= o) {
            add = wg_sum[t - o];
        }
        workgroupBarrier();
        wg_sum[t] = wg_sum[t] + add;
        workgroupBarrier();
    }
    let out = vec2<u32>(wg_sum[t] - v, wg_sum[WG - 1u]);
    workgroupBarrier();
    return out;
}

// One block: block-relative starts into cell_start, the total into chunk_sums; the counts are
// zeroed for the next build.
@compute @workgroup_size(WG)
fn scan_blocks(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    enter_global();
    let t = lid.x;
    if (uniform_void(t)) { return; }
    let base = (wid.x * WG + t) * SCAN_ITEMS;
    var own: array<u32, SCAN_ITEMS>;
    var run = 0u;
    for (var k = 0u; k < SCAN_ITEMS; k++) {
        let c = base + k;
        own[k] = run;
        if (c < params.ncell) {
            run += atomicLoad(&cell_count[c]);
            atomicStore(&cell_count[c], 0u);
        }
    }
    let p = workgroup_exclusive(t, run);
    for (var k = 0u; k < SCAN_ITEMS; k++) {
        let c = base + k;
        if (c < params.ncell) {
            cell_start[c] = p.x + own[k];
        }
    }
    if (t == 0u) {
        chunk_sums[wid.x] = p.y;
    }
}

// The block totals, scanned by one workgroup (each invocation a run of them); it also writes the
// end sentinel, counts the build and clears the staleness it answers (alone on the device).
@compute @workgroup_size(WG)
fn scan_totals(@builtin(local_invocation_id) lid: vec3<u32>) {
    enter_global();
    let t = lid.x;
    if (uniform_void(t)) { return; }
    if (t == 0u) {
        atomicStore(&status[ST_STALE], 0xffffffffu);
        atomicAdd(&status[ST_BUILDS], 1u);
    }
    let blocks = params.n_chunks;
    let per = (blocks + WG - 1u) / WG;
    let a = min(t * per, blocks);
    let b = min(a + per, blocks);
    var s = 0u;
    for (var k = a; k < b; k++) {
        s += chunk_sums[k];
    }
    let p = workgroup_exclusive(t, s);
    var run = p.x;
    for (var k = a; k < b; k++) {
        let x = chunk_sums[k];
        chunk_sums[k] = run;
        run += x;
    }
    if (t == WG - 1u) {
        cell_start[params.ncell] = p.y;
    }
}

// Each block's offset added to its starts.
@compute @workgroup_size(WG)
fn scan_apply(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    enter_global();
    if (void_build()) { return; }
    let off = chunk_sums[wid.x];
    let base = (wid.x * WG + lid.x) * SCAN_ITEMS;
    for (var k = 0u; k < SCAN_ITEMS; k++) {
        let c = base + k;
        if (c < params.ncell) {
            cell_start[c] += off;
        }
    }
}

// Each live particle's place in its cell's run of `sorted`. With `reorder`, that place is also
// its slot from now on: the job's live particles fill the start of its block in cell order
// (within a cell, in the atomics' order: nothing depends on it, reorder.wgsl), so `sorted` holds
// the new slots and the particle's record goes to `scratch` for `settle` to unpack.
@compute @workgroup_size(WG)
fn scatter(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n || void_build()) { return; }
    enter(i);
    if (!live(info[i].alive) || params.running == 0u) { return; }
    let cr = cell_rank[i];
    let s = cell_start[cr.x] + cr.y;
    if (params.reorder == 0u) {
        sorted[s] = i;
        return;
    }
    let t = params.job * params.n_job + (s - cell_start[params.cell_offset]);
    sorted[s] = t;
    pack(i, t);
}

// Particle i's record, written at slot t of `scratch`: the layout `settle` reads.
fn pack(i: u32, t: u32) {
    scratch[packed_at(t, 0u)] = bitcast<vec4<u32>>(pos_r[i]);
    scratch[packed_at(t, 1u)] = bitcast<vec4<u32>>(pos_r[lo_at(i)]);
    scratch[packed_at(t, 2u)] = bitcast<vec4<u32>>(vel_im[i]);
    scratch[packed_at(t, 3u)] = bitcast<vec4<u32>>(omega[i]);
    let m = info[i];
    scratch[packed_at(t, 4u)] =
        vec4<u32>(m.id, m.alive, bitcast<u32>(m.mass), bitcast<u32>(m.inv_inertia));
    scratch[packed_at(t, 5u)] = bitcast<vec4<u32>>(load[i].force);
    scratch[packed_at(t, 6u)] = bitcast<vec4<u32>>(load[i].torque);
    scratch[packed_at(t, 7u)] = bitcast<vec4<u32>>(vel_im[rest_at(i)]);
    scratch[packed_at(t, 8u)] = bitcast<vec4<u32>>(omega[rest_at(i)]);
    if (ORIENTED) {
        scratch[packed_at(t, 9u)] = bitcast<vec4<u32>>(pos_r[shape_at(i)]);
        let r = rod[i];
        scratch[packed_at(t, 10u)] = bitcast<vec4<u32>>(r.q);
        scratch[packed_at(t, 11u)] = bitcast<vec4<u32>>(r.ang_mom);
        scratch[packed_at(t, 12u)] = bitcast<vec4<u32>>(r.inv_inertia_h);
    }
    let h0 = select(PACKED_SPHERE, PACKED_ROD, ORIENTED);
    for (var q = 0u; q < params.slots; q++) {
        let h = hist_get(slot_at(i, q));
        scratch[packed_at(t, h0 + q)] = vec4<u32>(bitcast<vec3<u32>>(h.spring), h.key);
        if (h.key == EMPTY) { break; }
    }
}

// The o-th (0, 1, 2) neighbour of cell c on an axis of n cells, or −1. On a periodic axis with
// fewer than 3 cells the offsets −1 and +1 meet the same cells and are visited once (grid.rs).
fn around(c: u32, o: u32, n: u32, periodic: bool) -> i32 {
    let ni = i32(n);
    if (periodic) {
        if (o >= n) { return -1; }
        let d = select(select(-1, 1, o == 1u), 0, o == 0u);
        return (i32(c) + d + ni) % ni;
    }
    let x = i32(c) + i32(o) - 1;
    if (x < 0 || x >= ni) { return -1; }
    return x;
}

// How far particle j (radius r) reaches from its centre: r, plus l/2 when oriented.
fn reach(j: u32, r: f32) -> f32 {
    if (ORIENTED) {
        return r + pos_r[shape_at(j)].w;
    }
    return r;
}

// The row being built, in the order found: partner ids and their slots.
var<private> found_id: array<u32, MAX_LIST>;
var<private> found_slot: array<u32, MAX_LIST>;

// Appends the particles of sorted[a..b) within the cutoff of i to the row; returns the count.
fn scan_range(i: u32, p: vec3<f32>, ri: f32, a: u32, b: u32, k0: u32) -> u32 {
    var k = k0;
    for (var s = a; s < b; s++) {
        let j = sorted[s];
        if (j == i) { continue; }
        let pj = pos_r[j];
        let d = min_image(p, pj.xyz);
        let cut = ri + reach(j, pj.w) + params.skin;
        if (dot3(d, d) < cut * cut) {
            if (k < params.stride) {
                found_id[k] = info[j].id;
                found_slot[k] = j;
            }
            k++;
        }
    }
    return k;
}

@compute @workgroup_size(WG)
fn build_list(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = flat(gid, nwg);
    if (i >= jobs[0].n || void_build()) { return; }
    enter(i);
    let p4 = pos_r[i];
    ref_pos[i] = p4;
    if (ORIENTED) {
        // The axis the rotational skin criterion measures turns from.
        ref_pos[shape_at(i)] = pos_r[shape_at(i)];
    }
    if (!live(info[i].alive) || params.running == 0u) {
        nbr_set(nbr_at(i, 0u), 0u);
        return;
    }
    let p = p4.xyz;
    let ri = reach(i, p4.w);
    let c = cell_of(p);
    let px = PERIODIC_X;
    // Three x-adjacent cells are one contiguous run of `sorted` unless the run wraps.
    let contiguous = !px || (params.nx >= 3u && c.x >= 1u && c.x + 2u <= params.nx);
    let x_lo = select(c.x, c.x - 1u, c.x >= 1u);
    let x_hi = min(c.x + 1u, params.nx - 1u);
    var k = 0u;
    for (var oz = 0u; oz < 3u; oz++) {
        let z = around(c.z, oz, params.nz, false);
        if (z < 0) { continue; }
        for (var oy = 0u; oy < 3u; oy++) {
            let y = around(c.y, oy, params.ny, PERIODIC_Y);
            if (y < 0) { continue; }
            let base = params.cell_offset + (u32(z) * params.ny + u32(y)) * params.nx;
            if (contiguous) {
                k = scan_range(i, p, ri, cell_start[base + x_lo], cell_start[base + x_hi + 1u], k);
            } else {
                for (var ox = 0u; ox < 3u; ox++) {
                    let x = around(c.x, ox, params.nx, px);
                    if (x < 0) { continue; }
                    let cc = base + u32(x);
                    k = scan_range(i, p, ri, cell_start[cc], cell_start[cc + 1u], k);
                }
            }
        }
    }
    let m = min(k, params.stride);
    // Each partner goes to its rank by id (ids are distinct): the same summation order whatever
    // the slots, with a fixed amount of work per pair and one write per entry.
    for (var a = 0u; a < m; a++) {
        let key = found_id[a];
        var rank = 0u;
        for (var b = 0u; b < m; b++) {
            rank += select(0u, 1u, found_id[b] < key);
        }
        nbr_set(nbr_at(i, 1u + rank), found_slot[a]);
    }
    nbr_set(nbr_at(i, 0u), m);
    if (k > params.stride) {
        atomicMax(&status[sw(ST_LIST_OVERFLOW)], k);
    }
}
