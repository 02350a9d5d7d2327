// The particles sorted by cell at a list build (`GpuOptions::reorder_by_cell`): `scatter`
// (grid.wgsl) packed each live particle's record at its new slot of `scratch`; `settle` unpacks
// every slot of each running job's block, the live particles first and then empty slots. The
// order within a cell comes from atomics and varies from run to run; no bit depends on it: lists
// are ordered by partner id, histories keyed by id, sink events and failures name ids, the
// kinetic energy is summed in fixed point and downloads are sorted by id.

@group(0) @binding(2) var<storage, read_write> pos_r: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> vel_im: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> omega: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> info: array<Info>;
@group(0) @binding(6) var<storage, read_write> load: array<Load>;
@group(0) @binding(7) var<storage, read_write> hist: array<Slot>;
@group(0) @binding(21) var<storage, read_write> hist_hi: array<Slot>;

// History slot x, wherever the binding split put it (layout.rs `HIST_HI`).
fn hist_set(x: u32, v: Slot) {
    if (x < params.hist_split) {
        hist[x] = v;
    } else {
        hist_hi[x - params.hist_split] = v;
    }
}
@group(0) @binding(10) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(14) var<storage, read> cell_start: array<u32>;
@group(0) @binding(18) var<storage, read_write> rod: array<Rod>;
@group(0) @binding(20) var<storage, read> scratch: array<vec4<u32>>;

fn f4(t: u32, q: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(scratch[packed_at(t, q)]);
}

@compute @workgroup_size(WG)
fn settle(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let t = flat(gid, nwg);
    if (t >= jobs[0].n || atomicLoad(&status[ST_STALE]) < atomicLoad(&status[ST_STEP])) {
        return;
    }
    enter(t);
    if (params.running == 0u) { return; }
    let first = cell_start[params.cell_offset];
    let live = cell_start[params.cell_offset + params.nx * params.ny * params.nz] - first;
    let local = t - params.job * params.n_job;
    if (local >= live) {
        // An empty slot: nothing reads more than that it is not alive and has no history.
        info[t] = Info(EMPTY, 0u, 0.0, 0.0);
        vel_im[t] = vec4<f32>(0.0);
        load[t] = Load(vec4<f32>(0.0), vec4<f32>(0.0));
        for (var q = 0u; q < params.slots; q++) {
            hist_set(slot_at(t, q), Slot(vec3<f32>(0.0), EMPTY));
        }
        return;
    }
    pos_r[t] = f4(t, 0u);
    pos_r[lo_at(t)] = f4(t, 1u);
    vel_im[t] = f4(t, 2u);
    omega[t] = f4(t, 3u);
    let m = scratch[packed_at(t, 4u)];
    info[t] = Info(m.x, m.y, bitcast<f32>(m.z), bitcast<f32>(m.w));
    load[t] = Load(f4(t, 5u), f4(t, 6u));
    vel_im[rest_at(t)] = f4(t, 7u);
    omega[rest_at(t)] = f4(t, 8u);
    if (ORIENTED) {
        pos_r[shape_at(t)] = f4(t, 9u);
        rod[t] = Rod(f4(t, 10u), f4(t, 11u), f4(t, 12u));
    }
    let h0 = select(PACKED_SPHERE, PACKED_ROD, ORIENTED);
    var open = true;
    for (var q = 0u; q < params.slots; q++) {
        var h = Slot(vec3<f32>(0.0), EMPTY);
        if (open) {
            let w = scratch[packed_at(t, h0 + q)];
            h = Slot(bitcast<vec3<f32>>(w.xyz), w.w);
            open = w.w != EMPTY;
        }
        hist_set(slot_at(t, q), h);
    }
}
