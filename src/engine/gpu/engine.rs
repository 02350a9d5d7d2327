//! The GPU backend: the CPU engine's velocity Verlet as compute passes, in f32, with the state
//! resident on the device. A step is two dispatches, `kick_drift` (kick, drift, sink, skin check;
//! oriented runs also turn) and `compute_forces`, plus the six list-build passes at the steps
//! where the host records a build: at each chunk's start, as on the CPU, and where
//! `BuildSchedule` predicts the lists will go stale. The device finds staleness itself: the
//! first stale step is written to the status block and every later kernel returns at once, so
//! the host, which keeps two command buffers in flight and reads each one's stale word
//! asynchronously, redoes that step with a build and goes on. Builds never change the results
//! (lists sorted by index), so neither the schedule nor `steps_per_submit` does. With
//! `GpuOptions::fused_step` a step is one dispatch over two copies of the state (fused.wgsl,
//! docs/design.md "The one-dispatch step"), with the same bits.
//!
//! At the chunk's end `finish` checks finiteness, counts contacts and sums the kinetic energy per
//! workgroup; only the status block, those sums and the sink events are read back. The energy
//! watchdog's elastic energy is summed likewise after the chunk's opening build (`watchdog`). Particles
//! removed by the sink stay in place (flagged dead, skipped by every kernel) until the host
//! compacts them with a download and upload once they exceed 1/8 of the slots; a download never
//! shows them, as on the CPU.
//!
//! Oriented runs (spherocylinders, `Specialization::oriented`) turn in `kick_drift`: the
//! rotational kick and the exact free rotor of `shape::rigid`, ω refreshed, the axis re-derived,
//! and the skin criterion |Δc| + (l/2)|Δu| > skin/2 of the CPU engine; the contact kernel then
//! evaluates every rod pair in the CPU's canonical order (lower id first).
//!
//! The engine is one struct over several files: uploading a batch (`upload`), running a chunk
//! (`chunk`), batch membership (`membership`), compaction (`compaction`), reading back
//! (`readback`) and the `Backend` of one job (`single`).

use std::collections::VecDeque;

use super::buffers::{self, pack, unpack, GpuBuffers};
use super::device::GpuDevice;
use super::grid::{plan_grid, GridSpec};
use super::layout::{
    scratch_bytes, status_initial, LawGpu, Params, RecordGpu, WallGpu, KE_BITS, MAX_JOBS,
    MAX_WALLS, SCAN_ITEMS, STATUS_WORDS, ST_BUILDS, ST_DEATHS, ST_KE_MAX, ST_RECORDS, ST_STALE,
    ST_STEP, ST_STEP_NEXT, ST_U_MAX, WORKGROUP_SIZE,
};
use super::pipelines::{dispatch_size, kernel, BindGroups, Pipelines, Specialization, KERNELS};
use super::schedule::BuildSchedule;
use super::status::{read_chunk, ChunkContext};
use crate::engine::backend::{Backend, BackendInfo, ChunkReport, DispatchCount, EngineError};
use crate::engine::config::EngineConfig;
use crate::engine::contact::ContactRecord;
use crate::engine::history::MAX_SLOTS;
use crate::engine::state::State;
use crate::engine::watchdog::Watchdog;

mod chunk;
mod compaction;
mod membership;
mod profile;
mod readback;
mod single;
mod upload;
mod watchdog;

/// Tunables of the GPU engine that do not change the physics.
#[derive(Clone, Copy, Debug)]
pub struct GpuOptions {
    /// Steps recorded into one command buffer before it is submitted (two are in flight).
    /// Larger amortises the submission; smaller wastes fewer void steps when the lists go stale
    /// before a predicted build.
    pub steps_per_submit: u64,
    /// Record a list build every this many steps instead of predicting (tests: builds must not
    /// change the results).
    pub build_every: Option<u64>,
    /// Sort each job's particles by cell at every list build, on the device, so that
    /// neighbours are read from nearby memory (one more dispatch per build, and a scratch of
    /// every particle's record).
    pub reorder_by_cell: bool,
    /// The CPU engine's limits: the overlap is checked every step, the energy once per chunk
    /// (with one more contact pass at its start, `watchdog`); `max_kinetic_growth` infinite
    /// switches that pass off.
    pub watchdog: Watchdog,
    /// Dispatch at most this many workgroups along x, below the device's limit per dimension
    /// (tests: a small bed then runs the 2-D dispatches of a bed past 4.19·10⁶ slots).
    pub max_row_groups: Option<u32>,
    /// Bind at most this many bytes per storage binding, below the device's own limit (tests:
    /// the history and lists of a small bed then take two bindings each, as a large bed's do).
    pub max_binding_bytes: Option<u64>,
    /// Take each step in one dispatch (`fused.wgsl`: the forces fused with the next kick and
    /// drift) over two copies of the state, instead of two dispatches over one; the same bits.
    pub fused_step: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self {
            steps_per_submit: 64,
            build_every: None,
            reorder_by_cell: true,
            watchdog: Watchdog::default(),
            max_binding_bytes: None,
            max_row_groups: None,
            fused_step: false,
        }
    }
}

/// A live slot as the device holds it: the particle's id and position (`slots_job`).
pub type SlotView = (u32, [f32; 3]);

/// The host's record of one job of the uploaded batch.
struct JobRun {
    /// (id, mass) of the job's particles at the upload, by id: sink events name ids.
    masses: Vec<(u32, f32)>,
    /// Particles at the upload, slots still alive, and live mobile particles (what
    /// particle-steps count, as on the CPU).
    loaded: usize,
    alive: usize,
    mobile: usize,
    /// Kinetic energy at the last chunk's end (None before the first chunk of this upload).
    energy: Option<f64>,
    grid: GridSpec,
    /// The energy watchdog's inputs other than the energies.
    budget: watchdog::BudgetBase,
}

/// Device resources of the particles currently uploaded (none when no job has particles).
struct Run {
    bufs: GpuBuffers,
    binds: BindGroups,
    /// The batch's grid sizes: all jobs' cells, the widest list row.
    grid: GridSpec,
    /// Slots per job block.
    n_job: usize,
    jobs: Vec<JobRun>,
    /// Whether each list build also sorts the particles by cell (`settle` recorded).
    reorder: bool,
}

/// The GPU engine (f32). It advances a batch of jobs in the same dispatches (`batch`): each job
/// its own block of particle slots, walls, parameters, grid cells, status words and sink
/// events, so that a job's bits do not depend on the batch it runs in. As a `Backend` it runs
/// one job.
pub struct GpuEngine {
    dev: GpuDevice,
    configs: Vec<EngineConfig>,
    pipes: Pipelines,
    /// MAX_WALLS per job.
    walls: Vec<WallGpu>,
    run: Option<Run>,
    slots: usize,
    rotation: bool,
    /// Whether the uploaded particles are oriented (spherocylinders).
    oriented: bool,
    time: Vec<f64>,
    step: Vec<u64>,
    active: Vec<bool>,
    /// An upload that failed, reported by the next `advance`.
    pending: Option<EngineError>,
    options: GpuOptions,
    schedule: BuildSchedule,
    dispatches: DispatchCount,
}

impl GpuEngine {
    /// An engine on `dev` holding `state`.
    ///
    /// # Errors
    /// More walls or history slots than the kernels hold, buffers beyond the device's limits, or
    /// a shader the device rejects (`EngineError::Device`).
    pub fn new(
        dev: &GpuDevice,
        config: EngineConfig,
        state: &State<f64>,
        options: GpuOptions,
    ) -> Result<Self, EngineError> {
        Self::batch(dev, vec![config], &[state], options)
    }

    /// An engine advancing `states.len()` jobs together, job j with `configs[j]`. The jobs must
    /// share dt and the effects the kernels are compiled for (rotation, orientation, history
    /// slots, contact law kinds, walls, periodicity, sink); particle counts may differ.
    ///
    /// # Errors
    /// As `new`, and jobs that cannot share the dispatches, or more than `MAX_JOBS`.
    pub fn batch(
        dev: &GpuDevice,
        configs: Vec<EngineConfig>,
        states: &[&State<f64>],
        options: GpuOptions,
    ) -> Result<Self, EngineError> {
        let jobs = states.len();
        if jobs == 0 || jobs > MAX_JOBS || configs.len() != jobs {
            return Err(EngineError::Device(format!(
                "a batch holds 1 to {MAX_JOBS} jobs with one configuration each; got {jobs} states and {} configurations",
                configs.len()
            )));
        }
        let mut walls = vec![WallGpu::default(); jobs * MAX_WALLS];
        for (j, c) in configs.iter().enumerate() {
            if c.walls.len() > MAX_WALLS {
                return Err(EngineError::Device(format!(
                    "{} walls; the GPU backend holds at most {MAX_WALLS}",
                    c.walls.len()
                )));
            }
            for (w, wall) in walls[j * MAX_WALLS..].iter_mut().zip(&c.walls) {
                *w = WallGpu::of(wall);
            }
        }
        if let Some(why) = options
            .fused_step
            .then(|| dev.fused_step_unsupported())
            .flatten()
        {
            return Err(EngineError::Device(format!(
                "the one-dispatch step cannot run here: {why}; run without it (the two-dispatch step gives the same bits)"
            )));
        }
        let s0 = states[0];
        let pipes = Pipelines::new(
            dev,
            Specialization::of(&configs[0], s0.rotation, s0.oriented, s0.history.slots),
            options.fused_step,
        );
        if let Some(e) = dev.take_error() {
            return Err(EngineError::Device(format!("building the kernels: {e}")));
        }
        let mut e = Self {
            dev: dev.clone(),
            configs,
            pipes,
            walls,
            run: None,
            slots: 0,
            rotation: false,
            oriented: false,
            time: vec![0.0; jobs],
            step: vec![0; jobs],
            active: vec![true; jobs],
            pending: None,
            options,
            schedule: BuildSchedule::default(),
            dispatches: DispatchCount::default(),
        };
        e.load(states)?;
        Ok(e)
    }

    pub fn config(&self) -> &EngineConfig {
        &self.configs[0]
    }

    /// Job j's configuration.
    pub fn config_of(&self, j: usize) -> &EngineConfig {
        &self.configs[j]
    }

    /// Jobs in the batch.
    pub fn jobs(&self) -> usize {
        self.configs.len()
    }

    /// Workgroups per row of a dispatch (`dispatch_size`): the device's limit per dimension, or
    /// `GpuOptions::max_row_groups` where that is lower.
    fn row_groups(&self) -> u32 {
        let device = self.dev.limits.max_compute_workgroups_per_dimension;
        self.options
            .max_row_groups
            .map_or(device, |g| g.clamp(1, device))
    }

    /// Bytes of the history and of the neighbour lists, and whether each takes two bindings
    /// (past the binding limit, `GpuOptions::max_binding_bytes`).
    pub fn split_bindings(&self) -> [(u64, bool); 2] {
        self.run.as_ref().map_or([(0, false); 2], |r| {
            let b = &r.bufs;
            let hist = (b.n * b.slots * 16) as u64;
            [
                (hist, b.hist_split_bytes < hist),
                (b.nbr.size(), b.nbr_split_bytes < b.nbr.size()),
            ]
        })
    }

    /// The grid of the first job's upload (None without particles).
    pub fn grid(&self) -> Option<GridSpec> {
        self.run.as_ref().map(|r| r.jobs[0].grid)
    }

    /// The id in each slot of job j's block and its position there (None: an empty slot), as
    /// the device holds them: the order the builds left (`GpuOptions::reorder_by_cell`).
    ///
    /// # Errors
    /// A failed read-back.
    pub fn slots_job(&self, j: usize) -> Result<Vec<Option<SlotView>>, EngineError> {
        let Some(run) = &self.run else {
            return Ok(Vec::new());
        };
        let p = run.bufs.read_particles(&self.dev)?;
        let b = buffers::block(&p, j, run.n_job, self.slots);
        Ok(b.info
            .iter()
            .zip(&b.pos_r)
            .map(|(m, x)| (m.alive != 0).then_some((m.id, [x[0], x[1], x[2]])))
            .collect())
    }
}
