//! The records the host and the shaders share: Pod structs mirrored field for field in
//! `shaders/common.wgsl`, the binding numbers, and the constants injected into every shader as a
//! generated prelude (so the workgroup size and the status words are one constant on both sides).
//! It owns no device object.

use bytemuck::{Pod, Zeroable};

use crate::engine::contact::LawKernel;
use crate::engine::history::{EMPTY, MAX_SLOTS};
use crate::engine::walls::{Wall, WallShape};

/// Invocations per workgroup of every per-particle and per-chunk kernel. 64 suits lavapipe (256-bit
/// lanes, 8 wide) and is a safe multiple of the warp/wavefront size of real GPUs.
pub const WORKGROUP_SIZE: u32 = 64;

/// Cells each invocation of the cell-start scan takes: a block is WORKGROUP_SIZE × SCAN_ITEMS.
pub const SCAN_ITEMS: u32 = 4;

/// Most neighbours a list row holds (`grid::list_capacity` stays within it).
pub const MAX_LIST: u32 = 256;

/// Bits below a job's largest particle energy kept by the fixed-point kinetic-energy sum: each
/// particle's energy is rounded to 2^(e_max − KE_BITS), where 2^e_max bounds the largest, so a
/// workgroup's sum of 64 stays below 2^51 and the host's sum of them is exact in u64.
pub const KE_BITS: i32 = 44;

/// Entries (16 bytes each) of a particle's packed record before its history rows, for spheres
/// and for oriented particles (`scatter` and `settle`).
pub const PACKED_SPHERE: u32 = 9;
pub const PACKED_ROD: u32 = 13;

/// Bytes of the scratch that holds every slot's packed record when lists builds sort by cell.
pub fn scratch_bytes(slots_total: usize, oriented: bool, history_slots: usize) -> u64 {
    let head = if oriented { PACKED_ROD } else { PACKED_SPHERE };
    slots_total as u64 * (head as u64 + history_slots as u64) * 16
}

/// Most walls a run may have (they live in one uniform array).
pub const MAX_WALLS: usize = 16;

/// Most jobs one batch advances together (their records and walls live in uniform arrays).
pub const MAX_JOBS: usize = 32;

/// Words of the status block (flags, counters and errors written by the kernels).
pub const STATUS_WORDS: usize = 16;
/// The first step (0-based in the chunk) after whose drift some particle had moved more than
/// skin/2 since the last list build, u32::MAX when none is pending. Every kernel of a later step
/// returns at once: the host finds the step in the submission's status, rebuilds, and goes on
/// from it (engine.rs). A list build clears it.
pub const ST_STALE: usize = 0;
/// Neighbour-list builds in this chunk.
pub const ST_BUILDS: usize = 1;
/// Particles that fell through the sink in this chunk (entries of the event buffer).
pub const ST_DEATHS: usize = 2;
/// Largest overlap ratio of the chunk, as f32 bits (non-negative floats order like u32).
pub const ST_MAX_OVERLAP: usize = 3;
/// First step (1-based in the chunk) whose overlap exceeded the watchdog limit.
pub const ST_OVERLAP_STEP: usize = 4;
/// First step (1-based in the chunk) at which a history table overflowed.
pub const ST_FULL_STEP: usize = 5;
/// Smallest id of a particle whose history table overflowed.
pub const ST_FULL_INDEX: usize = 6;
/// Largest neighbour count that did not fit in a list row (0: none).
pub const ST_LIST_OVERFLOW: usize = 7;
/// The step being taken (0-based in the chunk): read by `kick_drift` and the rebuild passes,
/// set to `ST_STEP_NEXT` by `compute_forces` (whose other invocations do not read it).
pub const ST_STEP: usize = 8;
/// Sum of the contact counts at the chunk's end.
pub const ST_CONTACTS: usize = 9;
/// Smallest 4 id + kind of a non-finite particle (kind 0 position, 1 velocity, 2 angular velocity,
/// 3 orientation).
pub const ST_NONFINITE: usize = 10;
/// The step after the one being taken: written by `kick_drift`, read by `compute_forces` (so the
/// step index advances without a dispatch of its own).
pub const ST_STEP_NEXT: usize = 11;
/// Contacts `record_contacts` appended (all jobs'; it may exceed the record buffer's length).
pub const ST_RECORDS: usize = 12;
/// Largest kinetic energy of one particle at the chunk's end, as f32 bits: the scale of the
/// fixed-point energy sum (`energy_sum`).
pub const ST_KE_MAX: usize = 13;
/// Largest elastic energy stored in one particle's contacts at the chunk's start, as f32 bits:
/// the scale of the fixed-point elastic sum (`contact_energy`, `elastic_sum`).
pub const ST_U_MAX: usize = 14;

/// Status words at the start of a chunk: no step taken, nothing stale, minima at u32::MAX.
pub fn status_initial() -> [u32; STATUS_WORDS] {
    let mut s = [0u32; STATUS_WORDS];
    s[ST_STALE] = u32::MAX;
    s[ST_OVERLAP_STEP] = u32::MAX;
    s[ST_FULL_STEP] = u32::MAX;
    s[ST_FULL_INDEX] = u32::MAX;
    s[ST_NONFINITE] = u32::MAX;
    s
}

/// Binding numbers: one number per buffer in every shader (each kernel binds a subset).
pub mod binding {
    pub const PARAMS: u32 = 0;
    pub const WALLS: u32 = 1;
    pub const POS_R: u32 = 2;
    pub const VEL_IM: u32 = 3;
    pub const OMEGA: u32 = 4;
    pub const INFO: u32 = 5;
    pub const LOAD: u32 = 6;
    pub const HIST: u32 = 7;
    pub const NBR: u32 = 8;
    pub const REF_POS: u32 = 9;
    pub const STATUS: u32 = 10;
    pub const EVENTS: u32 = 11;
    pub const CELL_RANK: u32 = 12;
    pub const CELL_COUNT: u32 = 13;
    pub const CELL_START: u32 = 14;
    pub const CHUNK_SUMS: u32 = 15;
    pub const SORTED: u32 = 16;
    /// An energy per slot (kinetic from `finish`, elastic from `contact_energy`), then two
    /// fixed-point sums per workgroup of particles: the kinetic (`energy_sum`) and the elastic
    /// (`elastic_sum`).
    pub const ENERGY: u32 = 17;
    /// Contact records (`record_contacts`), `RecordGpu`.
    pub const RECORDS: u32 = 19;
    /// Orientation, angular momentum and body inertia of oriented particles (`RodGpu`).
    pub const ROD: u32 = 18;
    /// Every particle's record packed at its slot of the next order (`scatter` writes it,
    /// `settle` unpacks it): `reorder.wgsl`.
    pub const SCRATCH: u32 = 20;
    /// The history and list words past what one binding holds (the same buffers, bound from
    /// `hist_split` and `nbr_split` on; a spare record when everything fits in the first).
    pub const HIST_HI: u32 = 21;
    pub const NBR_HI: u32 = 22;
    /// The second copy of the positions, velocities and spins, which a one-dispatch step writes
    /// while its forces read the first (`fused.wgsl`); bind groups of the other parity swap them.
    pub const POS_W: u32 = 23;
    pub const VEL_W: u32 = 24;
    pub const OMEGA_W: u32 = 25;
}

/// WGSL constants generated from this file, prepended to `common.wgsl`.
pub fn prelude() -> String {
    let mut s = format!(
        "const WG: u32 = {WORKGROUP_SIZE}u;\nconst MAX_SLOTS: u32 = {MAX_SLOTS}u;\n\
         const MAX_WALLS: u32 = {MAX_WALLS}u;\nconst EMPTY: u32 = {EMPTY}u;\n\
         const WALL_KEY: u32 = {}u;\nconst MAX_JOBS: u32 = {MAX_JOBS}u;\n\
         const MAX_WALLS_ALL: u32 = {}u;\nconst STATUS_WORDS: u32 = {STATUS_WORDS}u;\n\
         const SCAN_ITEMS: u32 = {SCAN_ITEMS}u;\nconst MAX_LIST: u32 = {MAX_LIST}u;\n\
         const KE_BITS: i32 = {KE_BITS};\nconst PACKED_SPHERE: u32 = {PACKED_SPHERE}u;\n\
         const PACKED_ROD: u32 = {PACKED_ROD}u;\n",
        crate::engine::history::wall_key(0),
        MAX_WALLS * MAX_JOBS
    );
    // The segment geometry's thresholds (shape/segment.rs), as the exact f32 the CPU engine's
    // f32 kernels use (`R::from_f64`), written as hexadecimal literals so that no decimal
    // rounding can differ from Rust's.
    let sin = crate::engine::shape::PARALLEL_SIN;
    for (name, v) in [
        ("PARALLEL_SIN", sin as f32),
        ("PARALLEL_SIN2", (sin * sin) as f32),
        ("POINT_LEN2", crate::engine::shape::POINT_LEN2 as f32),
        ("TOUCH_TINY", 1e-24f32),
    ] {
        s += &format!("const {name}: f32 = {};\n", hex_f32(v));
    }
    for (name, v) in [
        ("ST_STALE", ST_STALE),
        ("ST_BUILDS", ST_BUILDS),
        ("ST_DEATHS", ST_DEATHS),
        ("ST_MAX_OVERLAP", ST_MAX_OVERLAP),
        ("ST_OVERLAP_STEP", ST_OVERLAP_STEP),
        ("ST_FULL_STEP", ST_FULL_STEP),
        ("ST_FULL_INDEX", ST_FULL_INDEX),
        ("ST_LIST_OVERFLOW", ST_LIST_OVERFLOW),
        ("ST_STEP", ST_STEP),
        ("ST_CONTACTS", ST_CONTACTS),
        ("ST_NONFINITE", ST_NONFINITE),
        ("ST_STEP_NEXT", ST_STEP_NEXT),
        ("ST_RECORDS", ST_RECORDS),
        ("ST_KE_MAX", ST_KE_MAX),
        ("ST_U_MAX", ST_U_MAX),
    ] {
        s += &format!("const {name}: u32 = {v}u;\n");
    }
    s
}

/// A positive normal f32 as an exact WGSL hexadecimal literal, 0x1.mmmmmmpEf.
fn hex_f32(v: f32) -> String {
    let bits = v.to_bits();
    debug_assert!(v.is_normal() && v > 0.0);
    let exp = ((bits >> 23) & 0xff) as i32 - 127;
    format!("0x1.{:06x}p{exp}f", (bits & 0x7f_ffff) << 1)
}

/// A contact law as the shaders read it (`LawKernel<f32>`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct LawGpu {
    pub hertz: u32,
    pub tangential: u32,
    pub kn: f32,
    pub kt: f32,
    pub damp_n: f32,
    pub damp_t: f32,
    pub mu: f32,
    pub pad: f32,
}

impl From<LawKernel<f32>> for LawGpu {
    fn from(l: LawKernel<f32>) -> Self {
        Self {
            hertz: l.hertz as u32,
            tangential: l.tangential as u32,
            kn: l.kn_coef,
            kt: l.kt_coef,
            damp_n: l.damp_n,
            damp_t: l.damp_t,
            mu: l.mu,
            pad: 0.0,
        }
    }
}

/// Per-run constants (one uniform buffer, rewritten on upload).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Params {
    pub n: u32,
    /// History slots per particle (0: no tangential history).
    pub slots: u32,
    /// Neighbour-list capacity per particle (a row is stride + 1 words: count, then indices).
    pub stride: u32,
    pub n_walls: u32,
    pub nx: u32,
    pub ny: u32,
    pub nz: u32,
    pub ncell: u32,
    pub periodic_x: u32,
    pub periodic_y: u32,
    pub rotation: u32,
    pub has_sink: u32,
    /// Cells per block of the cell-start scan (WORKGROUP_SIZE × SCAN_ITEMS).
    pub scan_chunk: u32,
    pub n_chunks: u32,
    /// 1: each list build also sorts the particles by cell (`scatter`, `settle`).
    pub reorder: u32,
    /// History slots (16-byte records) in the `HIST` binding; the rest are in `HIST_HI`
    /// (`GpuBuffers::new`: a buffer larger than one binding is bound in two).
    pub hist_split: u32,
    pub lo_x: f32,
    pub lo_y: f32,
    pub lo_z: f32,
    pub sink_z: f32,
    pub width_x: f32,
    pub width_y: f32,
    pub width_z: f32,
    pub skin: f32,
    pub box_lo_x: f32,
    pub box_lo_y: f32,
    pub box_len_x: f32,
    pub box_len_y: f32,
    pub gravity_x: f32,
    pub gravity_y: f32,
    pub gravity_z: f32,
    pub dt: f32,
    pub half_dt: f32,
    /// (skin/2)²: the displacement that triggers a list rebuild, squared.
    pub half_skin2: f32,
    pub overlap_limit: f32,
    /// skin/2: how far a rod's ends may move (|Δc| + (l/2)|Δu|) before the lists are rebuilt.
    pub half_skin: f32,
    pub law_pp: LawGpu,
    pub law_pw: LawGpu,
    /// This job's index in the batch.
    pub job: u32,
    /// Slots per job block (every job's, a multiple of the workgroup size).
    pub n_job: u32,
    /// Where this job's cells start in the batch's grid.
    pub cell_offset: u32,
    /// 1 while the job runs; 0 once the host masked it (its particles are left as they are).
    pub running: u32,
    /// List words in the `NBR` binding; the rest are in `NBR_HI`.
    pub nbr_split: u32,
    pub pad2: u32,
    pub pad3: u32,
    pub pad4: u32,
}

/// A wall as the shaders read it (the same numbers as `WallKernel<f32>`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WallGpu {
    pub a: [f32; 4],
    pub b: [f32; 4],
    /// Rotation centre (x, y, 0) and angular velocity (rad/s) in w.
    pub rot: [f32; 4],
    /// 0 plane, 1 cylinder, 2 orifice plate.
    pub kind: u32,
    pub r: f32,
    pub z0: f32,
    pub z1: f32,
}

impl WallGpu {
    /// The same conversion as `Wall::kernel::<f32>()` (whose fields are private to engine/walls/).
    pub fn of(w: &Wall) -> Self {
        let f = |x: f64| x as f32;
        let rot = match w.rotation {
            Some(r) => [f(r.axis_xy[0]), f(r.axis_xy[1]), 0.0, f(r.omega_rad_per_s)],
            None => [0.0; 4],
        };
        match w.shape {
            WallShape::Plane { point, normal } => {
                let l = (normal[0].powi(2) + normal[1].powi(2) + normal[2].powi(2)).sqrt();
                Self {
                    a: [f(point[0]), f(point[1]), f(point[2]), 0.0],
                    b: [f(normal[0] / l), f(normal[1] / l), f(normal[2] / l), 0.0],
                    rot,
                    kind: 0,
                    r: 0.0,
                    z0: 0.0,
                    z1: 0.0,
                }
            }
            WallShape::Cylinder {
                axis_xy,
                radius,
                z_min,
                z_max,
            } => Self {
                a: [f(axis_xy[0]), f(axis_xy[1]), 0.0, 0.0],
                b: [0.0; 4],
                rot,
                kind: 1,
                r: f(radius),
                z0: f(z_min),
                z1: f(z_max),
            },
            WallShape::OrificePlate {
                z,
                center_xy,
                orifice_radius,
            } => Self {
                a: [f(center_xy[0]), f(center_xy[1]), f(z), 0.0],
                b: [0.0; 4],
                rot,
                kind: 2,
                r: f(orifice_radius),
                z0: f(z),
                z1: 0.0,
            },
        }
    }
}

/// Per-particle constants and the alive flag.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Info {
    pub id: u32,
    /// 1 alive, 0 removed by the sink (kept in place until the host compacts).
    pub alive: u32,
    pub mass: f32,
    /// Spheres: 1/I; oriented runs: 1/I⊥ (the rods' effective mass).
    pub inv_inertia: f32,
}

/// The rotational state of an oriented particle (State's orientation, ang_mom,
/// inv_inertia_body and half_length), allocated only for oriented runs. The unit axis the
/// contacts read is derived from `q` and kept in the second block of the position buffer
/// (`shaders/common.wgsl`, `shape_at`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RodGpu {
    /// Orientation quaternion (x, y, z, w), body → lab.
    pub q: [f32; 4],
    /// Lab-frame angular momentum L (kg m²/s); w unused.
    pub ang_mom: [f32; 4],
    /// Inverse principal moments (body frame, 1/(kg m²)), zero when fixed; w = l/2 (m).
    pub inv_inertia_h: [f32; 4],
}

/// One contact as `record_contacts` leaves it (contacts.wgsl `Rec`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct RecordGpu {
    /// Slot of i, id of i, slot of j or the wall's index, flags (1 wall, 2 j fixed).
    pub who: [u32; 4],
    /// Position of i; w: the id of j, as bits.
    pub pos: [f32; 4],
    pub branch: [f32; 4],
    pub force: [f32; 4],
}

/// Force and torque of the last evaluation; force.w holds the contact count, torque.w the
/// particle's largest overlap ratio.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Load {
    pub force: [f32; 4],
    pub torque: [f32; 4],
}

/// One history slot: the tangential spring and the partner key (`EMPTY` when free).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Slot {
    pub spring: [f32; 3],
    pub key: u32,
}

impl Default for Slot {
    fn default() -> Self {
        Self {
            spring: [0.0; 3],
            key: EMPTY,
        }
    }
}

const _: () = assert!(std::mem::size_of::<Params>() == 240);
const _: () = assert!(std::mem::size_of::<WallGpu>() == 64);
const _: () = assert!(std::mem::size_of::<Slot>() == 16);
const _: () = assert!(std::mem::size_of::<RodGpu>() == 48);

#[cfg(test)]
mod tests {
    #[test]
    fn hexadecimal_literals_are_exact() {
        assert_eq!(super::hex_f32(1.0), "0x1.000000p0f");
        assert_eq!(super::hex_f32(0.75), "0x1.800000p-1f");
        assert_eq!(super::hex_f32(f32::MIN_POSITIVE), "0x1.000000p-126f");
    }
}
