//! What a chunk's status block and sink events say: the `ChunkReport`, the simulated time, and
//! the failure the kernels flagged, as the `EngineError` the CPU engine returns for it. Kernels
//! cannot stop a chunk midway, so a failure is found at the chunk's end and named by the step at
//! which it first happened.

use super::layout::{
    ST_BUILDS, ST_CONTACTS, ST_DEATHS, ST_FULL_INDEX, ST_FULL_STEP, ST_LIST_OVERFLOW,
    ST_MAX_OVERLAP, ST_NONFINITE, ST_OVERLAP_STEP,
};
use crate::engine::backend::{ChunkReport, EngineError, SinkEvent};

/// What the host knows of the chunk it just ran.
pub struct ChunkContext<'a> {
    /// (id, mass) of the job's particles, by id.
    pub masses: &'a [(u32, f32)],
    /// Live slots and live mobile particles at the chunk's start.
    pub alive: usize,
    pub mobile: usize,
    pub slots: usize,
    /// Neighbour-list capacity.
    pub stride: u32,
    pub time0: f64,
    pub step0: u64,
    pub steps: u64,
    pub dt: f64,
    pub overlap_limit: f64,
}

/// The chunk as the CPU engine would report it.
pub struct ChunkOutcome {
    pub report: ChunkReport,
    /// Simulated time at the chunk's end (one f64 addition of dt per step, as on the CPU).
    pub time: f64,
    /// Live slots and live mobile particles at the chunk's end.
    pub alive: usize,
    pub mobile: usize,
    pub error: Option<EngineError>,
}

/// Reads the status words `st` and the sink `events` (id, 0-based step) of a chunk.
pub fn read_chunk(c: &ChunkContext<'_>, st: &[u32], events: &[[u32; 2]]) -> ChunkOutcome {
    let deaths = (st[ST_DEATHS] as usize).min(events.len());
    let mut events = events[..deaths].to_vec();
    events.sort_by_key(|&[id, k]| (k, id));
    let mass_of = |id: u32| {
        c.masses
            .binary_search_by_key(&id, |&(i, _)| i)
            .map_or(0.0, |k| c.masses[k].1 as f64)
    };
    let mut report = ChunkReport::default();
    let mut t = c.time0;
    let mut next = events.iter().peekable();
    let mut dead_steps = 0u64;
    for k in 0..c.steps {
        t += c.dt;
        while let Some(&&[id, _]) = next.peek().filter(|e| e[1] as u64 == k) {
            report.removed.push(SinkEvent {
                id,
                mass_kg: mass_of(id),
                time_s: t,
            });
            // Not counted from the step it fell on.
            dead_steps += c.steps - k;
            next.next();
        }
    }
    // Only mobile particles fall through the sink (fixed ones never move).
    let (alive, mobile) = (c.alive - deaths, c.mobile - deaths);
    report.steps = c.steps;
    report.particle_steps = c.mobile as u64 * c.steps - dead_steps;
    report.max_overlap_ratio = f32::from_bits(st[ST_MAX_OVERLAP]) as f64;
    report.contacts_per_particle = st[ST_CONTACTS] as f64 / alive.max(1) as f64;
    report.list_builds = st[ST_BUILDS] as u64;
    let (full_k, ov_k, nonfinite) = (st[ST_FULL_STEP], st[ST_OVERLAP_STEP], st[ST_NONFINITE]);
    let error = if st[ST_LIST_OVERFLOW] > 0 {
        Some(EngineError::Device(format!(
            "a particle has {} neighbours within r_i + r_j + skin, more than the {} a GPU list row holds: the run is diverging or the skin is far too large",
            st[ST_LIST_OVERFLOW], c.stride
        )))
    } else if full_k != u32::MAX && full_k <= ov_k {
        // The CPU checks the table during the step, before the step count advances.
        Some(EngineError::HistoryFull {
            id: st[ST_FULL_INDEX],
            slots: c.slots,
            step: c.step0 + full_k as u64 - 1,
        })
    } else if ov_k != u32::MAX {
        Some(EngineError::Overlap {
            ratio: report.max_overlap_ratio,
            limit: c.overlap_limit,
            step: c.step0 + ov_k as u64,
            detail: String::new(),
        })
    } else if nonfinite != u32::MAX {
        Some(EngineError::NonFinite {
            what: match nonfinite % 4 {
                0 => "position",
                1 => "velocity",
                2 => "angular velocity",
                _ => "orientation",
            },
            id: nonfinite / 4,
            step: c.step0 + c.steps,
            time_s: t,
        })
    } else {
        None
    };
    ChunkOutcome {
        report,
        time: t,
        alive,
        mobile,
        error,
    }
}
