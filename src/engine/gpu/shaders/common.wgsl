// Shared by every kernel: the records of layout.rs, the uniform parameters and the periodic
// minimum image. The generated prelude before this file defines WG, MAX_SLOTS, MAX_WALLS, EMPTY,
// WALL_KEY and the ST_* status words. Arithmetic is written in the CPU engine's order
// (contact/hertz_mindlin.rs, grid.rs, cpu/) so that f32 results agree to rounding.

// The run's effects, fixed when the pipelines are built (pipelines.rs, `Specialization`): the
// shader compiler drops every branch a run does not need, as the CPU engine skips those kernels.
override ROTATION: bool = true;
// Spherocylinders: orientations, segment contacts, the free rotor (rods.wgsl, rotate.wgsl).
override ORIENTED: bool = true;
override HISTORY: bool = true;
override ANY_HERTZ: bool = true;
override ANY_LINEAR: bool = true;
override WALLS: bool = true;
override PERIODIC_X: bool = true;
override PERIODIC_Y: bool = true;
override SINK: bool = true;
// The contact-record kernel only: gather as compute_forces does, change nothing, and append each
// contact once to `records` (contacts.wgsl).
override RECORD: bool = false;

struct Law {
    hertz: u32,
    tangential: u32,
    kn: f32,
    kt: f32,
    damp_n: f32,
    damp_t: f32,
    mu: f32,
    pad: f32,
}

struct Params {
    n: u32,
    slots: u32,
    stride: u32,
    n_walls: u32,
    nx: u32,
    ny: u32,
    nz: u32,
    ncell: u32,
    periodic_x: u32,
    periodic_y: u32,
    rotation: u32,
    has_sink: u32,
    scan_chunk: u32,
    n_chunks: u32,
    reorder: u32,
    hist_split: u32,
    lo_x: f32,
    lo_y: f32,
    lo_z: f32,
    sink_z: f32,
    width_x: f32,
    width_y: f32,
    width_z: f32,
    skin: f32,
    box_lo_x: f32,
    box_lo_y: f32,
    box_len_x: f32,
    box_len_y: f32,
    gravity_x: f32,
    gravity_y: f32,
    gravity_z: f32,
    dt: f32,
    half_dt: f32,
    half_skin2: f32,
    overlap_limit: f32,
    half_skin: f32,
    law_pp: Law,
    law_pw: Law,
    // Batches (engine.rs): this job's index, the slots of every job's block, where its cells
    // start in the batch's grid, and whether it still runs.
    job: u32,
    n_job: u32,
    cell_offset: u32,
    running: u32,
    nbr_split: u32,
    pad2: u32,
    pad3: u32,
    pad4: u32,
}

struct Wall {
    a: vec4<f32>,
    b: vec4<f32>,
    rot: vec4<f32>,
    kind: u32,
    r: f32,
    z0: f32,
    z1: f32,
}

// MAX_WALLS per job, job after job.
struct Walls {
    w: array<Wall, MAX_WALLS_ALL>,
}

struct Info {
    id: u32,
    alive: u32,
    mass: f32,
    inv_inertia: f32,
}

struct Load {
    force: vec4<f32>,
    torque: vec4<f32>,
}

struct Slot {
    spring: vec3<f32>,
    key: u32,
}

// The rotational state of an oriented particle (layout.rs RodGpu).
struct Rod {
    // Orientation quaternion (x, y, z, w), body → lab.
    q: vec4<f32>,
    // Lab-frame angular momentum; w unused.
    ang_mom: vec4<f32>,
    // Inverse principal moments (body frame), zero when fixed; w = l/2.
    inv_inertia_h: vec4<f32>,
}

// One record per job of the batch; the global fields (n, stride, slots, the scan's) are the same
// in every record.
@group(0) @binding(0) var<uniform> jobs: array<Params, MAX_JOBS>;

// The record of the job this invocation works for: every entry point sets it first, with
// `enter` (a particle's job) or `enter_global` (kernels over cells).
var<private> params: Params;

fn enter(i: u32) {
    params = jobs[min(i / jobs[0].n_job, MAX_JOBS - 1u)];
}

// The slot of an invocation. A dispatch of more workgroups than one dimension holds (65 535)
// runs as rows of nwg.x workgroups (`kernels::dispatch_size`); the last row's invocations
// past the slots return at their kernel's bounds check.
fn flat(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * WG;
}

// Liveness. `info.alive` is 1 for a live particle and 0 for a dead one, except during a chunk of
// one-dispatch steps (fused.wgsl): there a particle that crossed the sink in the drift of step k
// holds 2 + k until `finish`, so that the forces of step k, computed in the same dispatch as its
// death, read it alive whether or not its own invocation has run yet.
fn live(alive: u32) -> bool {
    return alive == 1u;
}

// The step whose forces this invocation computes (`forces`); the largest u32 elsewhere.
var<private> force_step: u32 = 0xffffffffu;

// Whether a neighbour with this `alive` word takes part in the forces of `force_step`.
fn live_at_forces(alive: u32) -> bool {
    return alive == 1u || (alive > 1u && alive - 2u >= force_step);
}

fn enter_global() {
    params = jobs[0];
}

// A status word of this invocation's job (the global words, ST_STALE, ST_BUILDS, ST_STEP and
// ST_STEP_NEXT, live in job 0's block).
fn sw(w: u32) -> u32 {
    return params.job * STATUS_WORDS + w;
}

// a · b summed left to right, as V3::dot.
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// a × b, as V3::cross.
fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// Minimum-image separation b − a (Periodic::delta).
fn min_image(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return fold(b - a);
}

// The separation b − a of two split positions (hi, lo), folded to the minimum image
// (position::separation).
fn separation(a: vec3<f32>, a_lo: vec3<f32>, b: vec3<f32>, b_lo: vec3<f32>) -> vec3<f32> {
    return fold((b - a) + (b_lo - a_lo));
}

// a + b = s + e exactly (position::two_sum); returned as (s, e) in one struct.
struct TwoSum {
    s: vec3<f32>,
    e: vec3<f32>,
}

fn two_sum(a: vec3<f32>, b: vec3<f32>) -> TwoSum {
    var r: TwoSum;
    r.s = opaque(a + b);
    let bb = opaque(r.s - a);
    r.e = (a - (r.s - bb)) + (b - bb);
    return r;
}

// The rest `lo` of hi + lo, cut toward zero to a multiple of 2^(E − 52) where 2^E ≤ |hi| < 2^(E+1):
// then hi + lo is exact in f64, so a download (hi + lo in f64) and an upload (position::split)
// give back the same pair, and a job resumed from a checkpoint, compacted or moved into a batch
// goes on with the same bits. It drops less than 2⁻⁵² of |hi|. Integer masking, not ldexp,
// whose 2^e would overflow f32 for small rests. A zero rest is +0 (what an upload makes of it).
fn f64_rest1(hi: f32, lo: f32) -> f32 {
    let eh = i32((bitcast<u32>(hi) >> 23u) & 0xffu);
    let b = bitcast<u32>(lo);
    // lo's lowest bit is 2^(el − 150) (subnormals: el = 1), f64's lowest beside hi 2^(eh − 179).
    let el = max(i32((b >> 23u) & 0xffu), 1);
    let drop = eh - el - 29;
    if (lo == 0.0 || drop >= 24) { return 0.0; }
    if (drop <= 0) { return lo; }
    return bitcast<f32>(b & ~((1u << u32(drop)) - 1u));
}

fn f64_rest(hi: vec3<f32>, lo: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(f64_rest1(hi.x, lo.x), f64_rest1(hi.y, lo.y), f64_rest1(hi.z, lo.z));
}

// A kick of a split quantity (velocity, ω of spheres, L of oriented particles: value in one
// record, rest at `rest_at`): hi + lo + d, with the rest kept exactly (TwoSum) and cut by
// `f64_rest`. A step's two half kicks are two of these, and so are a chunk's closing half kick
// and the next chunk's opening one: where a chunk ends changes no bit. In plain f32 the slow
// part of a speed (g dt/2 is ~40 ulps of 2 m/s at dt = 10⁻⁶ s) was rounded away at every step.
// `d` is a product at every call (… · dt/2): `opaque` rounds it before the rest is added, so no
// kernel can fuse d + lo into an FMA and two kernels' kicks cannot part by a rounding.
fn kick_split(hi: vec3<f32>, lo: vec3<f32>, d: vec3<f32>) -> TwoSum {
    var r = two_sum(hi, opaque(d) + lo);
    r.e = f64_rest(r.s, r.e);
    return r;
}

// x, hidden from the shader compiler's algebra: WGSL cannot mark arithmetic exact, and a
// compiler free to use x − (x − a) = a would fold TwoSum's error term to zero. The condition
// is false whenever a kernel runs (it has particles), but the compiler cannot know it.
fn opaque(x: vec3<f32>) -> vec3<f32> {
    return select(x, vec3<f32>(0.0), params.n == 0u);
}

// The minimum image of a separation d.
fn fold(d0: vec3<f32>) -> vec3<f32> {
    var d = d0;
    if (PERIODIC_X) {
        let l = params.box_len_x;
        d.x = d.x - l * floor(d.x / l + 0.5);
    }
    if (PERIODIC_Y) {
        let l = params.box_len_y;
        d.y = d.y - l * floor(d.y / l + 0.5);
    }
    return d;
}

// A position wrapped into the periodic box (Periodic::wrap).
fn wrap(p: vec3<f32>) -> vec3<f32> {
    return p + wrap_shift(p);
}

// What the wrap adds to p: a whole number of box lengths along each periodic axis.
fn wrap_shift(p: vec3<f32>) -> vec3<f32> {
    var q = vec3<f32>(0.0);
    if (PERIODIC_X) {
        let l = params.box_len_x;
        q.x = -l * floor((p.x - params.box_lo_x) / l);
    }
    if (PERIODIC_Y) {
        let l = params.box_len_y;
        q.y = -l * floor((p.y - params.box_lo_y) / l);
    }
    return q;
}

// Neighbour lists and history slots are stored slot-major (word k of particle i at k n + i), so
// that neighbouring invocations read neighbouring words (coalesced on a GPU, one cache line per
// SIMD group on lavapipe). List word 0 is the count, words 1.. the neighbours.
fn nbr_at(i: u32, k: u32) -> u32 {
    return k * params.n + i;
}

fn slot_at(i: u32, s: u32) -> u32 {
    return s * params.n + i;
}

// Entry q of slot t's packed record in the cell-order scratch (grid.wgsl `pack`, reorder.wgsl).
fn packed_at(t: u32, q: u32) -> u32 {
    return q * params.n + t;
}

// Oriented runs keep a second block of n records after the positions in pos_r (the unit axis
// and l/2 of particle i, derived from its orientation) and after the reference positions in
// ref_pos (the axis at the last list build): the contact kernel binds no more buffers than the
// sphere kernel.
fn shape_at(i: u32) -> u32 {
    return params.n + i;
}

// Velocities (vel_im) and the spin buffer (omega) keep, after their n records, n records with
// the rest of each value (`kick_split`; for oriented particles the rest of L, whose value is in
// the rod record; the fourth place zero).
fn rest_at(i: u32) -> u32 {
    return params.n + i;
}

// Every run keeps, after those blocks, a block of n records with the rest of each position
// below f32's spacing at it (position.rs; the fourth place zero).
fn lo_at(i: u32) -> u32 {
    return select(1u, 2u, ORIENTED) * params.n + i;
}

// Real::max and Real::min of the CPU engine (real.rs): the comparison decides, so a NaN argument
// gives the other one, whatever the GPU's max/min do with NaN.
fn rmax(a: f32, b: f32) -> f32 {
    return select(b, a, a > b);
}

fn rmin(a: f32, b: f32) -> f32 {
    return select(b, a, a < b);
}

fn gravity() -> vec3<f32> {
    return vec3<f32>(params.gravity_x, params.gravity_y, params.gravity_z);
}
