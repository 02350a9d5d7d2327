//! The GPU backend: the CPU engine's velocity Verlet as compute passes, in f32, with the state
//! resident on the device. A step is two dispatches, `kick_drift` (kick, drift, sink, skin check;
//! oriented runs also turn) and `compute_forces`, plus the six list-build passes at the steps
//! where the host records a build: at each chunk's start, as on the CPU, and where
//! `BuildSchedule` predicts the lists will go stale. The device finds staleness itself: the
//! first stale step is written to the status block and every later kernel returns at once, so
//! the host, which keeps two command buffers in flight and reads each one's stale word
//! asynchronously, redoes that step with a build and goes on. Builds never change the results
//! (lists sorted by index), so neither the schedule nor `steps_per_submit` does.
//!
//! At the chunk's end `finish` checks finiteness, counts contacts and sums the kinetic energy per
//! workgroup; only the status block, those sums and the sink events are read back. Particles
//! removed by the sink stay in place (flagged dead, skipped by every kernel) until the host
//! compacts them with a download and upload once they exceed 1/8 of the slots; a download never
//! shows them, as on the CPU.
//!
//! Oriented runs (spherocylinders, `Specialization::oriented`) turn in `kick_drift`: the
//! rotational kick and the exact free rotor of `shape::rigid`, ω refreshed, the axis re-derived,
//! and the skin criterion |Δc| + (l/2)|Δu| > skin/2 of the CPU engine; the contact kernel then
//! evaluates every rod pair in the CPU's canonical order (lower id first).

use std::collections::VecDeque;

use super::buffers::{self, pack, unpack, GpuBuffers};
use super::device::GpuDevice;
use super::grid::{plan_grid, GridSpec};
use super::layout::{
    scratch_bytes, status_initial, LawGpu, Params, RecordGpu, WallGpu, KE_BITS, MAX_JOBS,
    MAX_WALLS, SCAN_ITEMS, STATUS_WORDS, ST_BUILDS, ST_DEATHS, ST_KE_MAX, ST_RECORDS, ST_STALE,
    ST_STEP, ST_STEP_NEXT, WORKGROUP_SIZE,
};
use super::pipelines::{kernel, BindGroups, Pipelines, Specialization};
use super::schedule::BuildSchedule;
use super::status::{read_chunk, ChunkContext};
use crate::engine::backend::{Backend, BackendInfo, ChunkReport, DispatchCount, EngineError};
use crate::engine::config::EngineConfig;
use crate::engine::contact::ContactRecord;
use crate::engine::cpu::Watchdog;
use crate::engine::history::MAX_SLOTS;
use crate::engine::state::State;

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
    /// Only `max_overlap_ratio` applies: the energy check also needs the elastic energy and the
    /// work of gravity and the walls, which the kernels do not sum.
    pub watchdog: Watchdog,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self {
            steps_per_submit: 64,
            build_every: None,
            reorder_by_cell: true,
            watchdog: Watchdog::default(),
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
        let s0 = states[0];
        let pipes = Pipelines::new(
            dev,
            Specialization::of(&configs[0], s0.rotation, s0.oriented, s0.history.slots),
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

    /// Job j's record for the kernels: its own grid, walls, laws and sink, the batch's sizes.
    fn params(
        &self,
        j: usize,
        run_n: usize,
        n_job: usize,
        g: &GridSpec,
        all: &GridSpec,
        cell_offset: u32,
    ) -> Params {
        let c = &self.configs[j];
        let f = |x: f64| x as f32;
        // As CpuEngine: the box ends are rounded to f32, the length is their f32 difference.
        let lo = |p: Option<[f64; 2]>| p.map_or(0.0, |[a, _]| f(a));
        let len = |p: Option<[f64; 2]>| p.map_or(0.0, |[a, b]| f(b) - f(a));
        let dt = f(c.dt_s);
        let skin = f(c.skin_m);
        Params {
            n: run_n as u32,
            slots: self.slots as u32,
            stride: all.stride,
            n_walls: c.walls.len() as u32,
            nx: g.dims[0],
            ny: g.dims[1],
            nz: g.dims[2],
            ncell: all.ncell,
            periodic_x: c.periodic_x.is_some() as u32,
            periodic_y: c.periodic_y.is_some() as u32,
            rotation: self.rotation as u32,
            has_sink: c.sink_z.is_some() as u32,
            scan_chunk: all.scan_chunk,
            n_chunks: all.n_chunks,
            reorder: 0,
            pad1: 0,
            lo_x: g.lo[0],
            lo_y: g.lo[1],
            lo_z: g.lo[2],
            sink_z: f(c.sink_z.unwrap_or(0.0)),
            width_x: g.width[0],
            width_y: g.width[1],
            width_z: g.width[2],
            skin,
            box_lo_x: lo(c.periodic_x),
            box_lo_y: lo(c.periodic_y),
            box_len_x: len(c.periodic_x),
            box_len_y: len(c.periodic_y),
            gravity_x: f(c.gravity[0]),
            gravity_y: f(c.gravity[1]),
            gravity_z: f(c.gravity[2]),
            dt,
            half_dt: dt * 0.5,
            half_skin2: skin * skin * 0.25,
            overlap_limit: f(self.options.watchdog.max_overlap_ratio),
            half_skin: skin * 0.5,
            law_pp: LawGpu::from(c.particle_law.kernel::<f32>()),
            law_pw: LawGpu::from(c.wall_law.kernel::<f32>()),
            job: j as u32,
            n_job: n_job as u32,
            cell_offset,
            running: self.active[j] as u32,
        }
    }

    /// Replaces the device state by `states`, one per job.
    fn load(&mut self, states: &[&State<f64>]) -> Result<(), EngineError> {
        self.run = None;
        let s0 = states[0];
        self.slots = s0.history.slots;
        self.rotation = s0.rotation;
        self.oriented = s0.oriented;
        if self.slots > MAX_SLOTS {
            return Err(EngineError::Device(format!(
                "{} history slots per particle; the GPU backend holds at most {MAX_SLOTS}",
                self.slots
            )));
        }
        // The kernels are compiled for the effects of the state they run: recompile when an
        // upload changes them (never within one job).
        let spec = Specialization::of(&self.configs[0], s0.rotation, s0.oriented, self.slots);
        for (j, s) in states.iter().enumerate() {
            self.time[j] = s.time;
            self.step[j] = s.step;
            if let Some(k) = asymmetric_top(s) {
                return Err(EngineError::Device(format!(
                    "particle {} is not a symmetric top about its axis (I1 ≠ I2); the GPU kernels rotate symmetric tops only (every spherocylinder is one): run it with --backend cpu",
                    s.id[k]
                )));
            }
            let c = &self.configs[j];
            let theirs = Specialization::of(c, s.rotation, s.oriented, s.history.slots);
            if theirs != spec || c.dt_s != self.configs[0].dt_s {
                return Err(EngineError::Device(format!(
                    "job {j} of the batch differs from job 0 in dt or in the effects the kernels are built for ({theirs:?} against {spec:?}): run it in another batch"
                )));
            }
        }
        if spec != self.pipes.spec {
            self.pipes = Pipelines::new(&self.dev, spec);
            if let Some(e) = self.dev.take_error() {
                return Err(EngineError::Device(format!("building the kernels: {e}")));
            }
        }
        let longest = states.iter().map(|s| s.len()).max().unwrap_or(0);
        if longest == 0 {
            return Ok(());
        }
        // Whole workgroups per job: a workgroup's kinetic-energy sum is one job's.
        let n_job = longest.next_multiple_of(WORKGROUP_SIZE as usize);
        let total = n_job * states.len();
        let grids: Vec<GridSpec> = states
            .iter()
            .zip(&self.configs)
            .map(|(s, c)| plan_grid(s, c))
            .collect();
        let ncell: u32 = grids.iter().map(|g| g.ncell).sum();
        let scan_chunk = WORKGROUP_SIZE * SCAN_ITEMS;
        let all = GridSpec {
            ncell,
            stride: grids.iter().map(|g| g.stride).max().unwrap_or(1),
            scan_chunk,
            n_chunks: ncell.div_ceil(scan_chunk),
            ..grids[0]
        };
        let max_groups = self.dev.limits.max_compute_workgroups_per_dimension;
        let groups = (total as u32).div_ceil(WORKGROUP_SIZE);
        if groups.max(all.n_chunks) > max_groups {
            return Err(EngineError::Device(format!(
                "{total} particle slots need {groups} workgroups of {WORKGROUP_SIZE}; {} dispatches at most {max_groups}",
                self.dev.info.name
            )));
        }
        // Builds sort the particles by cell unless the scratch for it would not bind.
        let reorder = self.options.reorder_by_cell
            && scratch_bytes(total, self.oriented, self.slots)
                <= self.dev.limits.max_storage_buffer_binding_size;
        let mut params = Vec::with_capacity(states.len());
        let mut offset = 0u32;
        for (j, g) in grids.iter().enumerate() {
            let mut p = self.params(j, total, n_job, g, &all, offset);
            p.reorder = reorder as u32;
            params.push(p);
            offset += g.ncell;
        }
        let packed = buffers::concat(states.iter().map(|s| pack(s)).collect(), n_job, self.slots);
        let bufs = GpuBuffers::new(&self.dev, &params, &self.walls, &packed, &all)?;
        let binds = self.pipes.bind(&self.dev, &bufs);
        let jobs = states
            .iter()
            .zip(&grids)
            .map(|(s, g)| JobRun {
                masses: {
                    let mut m: Vec<(u32, f32)> =
                        s.id.iter()
                            .zip(&s.mass)
                            .map(|(&i, &m)| (i, m as f32))
                            .collect();
                    m.sort_unstable_by_key(|&(i, _)| i);
                    m
                },
                loaded: s.len(),
                alive: s.len(),
                mobile: s.inv_mass.iter().filter(|&&m| m != 0.0).count(),
                energy: None,
                grid: *g,
            })
            .collect();
        self.run = Some(Run {
            bufs,
            binds,
            grid: all,
            n_job,
            jobs,
            reorder,
        });
        Ok(())
    }

    /// Every job's live particles, read back.
    fn read_states(&self) -> Result<Vec<State<f64>>, EngineError> {
        let empty = |j: usize| {
            let mut s = if self.oriented {
                State::new_oriented(self.slots)
            } else {
                State::new(self.rotation, self.slots)
            };
            s.time = self.time[j];
            s.step = self.step[j];
            s
        };
        match &self.run {
            None => Ok((0..self.jobs()).map(empty).collect()),
            Some(run) => {
                let p = run.bufs.read_particles(&self.dev)?;
                Ok((0..self.jobs())
                    .map(|j| {
                        let b = buffers::block(&p, j, run.n_job, self.slots);
                        unpack(&b, self.slots, self.rotation, self.time[j], self.step[j])
                    })
                    .collect())
            }
        }
    }

    /// Job j's live particles, read back.
    ///
    /// # Errors
    /// A failed read-back.
    pub fn download_job(&self, j: usize) -> Result<State<f64>, EngineError> {
        Ok(self.read_states()?.swap_remove(j))
    }

    /// Replaces job j's particles (the others are read back and uploaded unchanged).
    ///
    /// # Errors
    /// As `new`.
    pub fn upload_job(&mut self, j: usize, state: &State<f64>) -> Result<(), EngineError> {
        let mut all = self.read_states()?;
        all[j] = state.clone();
        let refs: Vec<&State<f64>> = all.iter().collect();
        self.load(&refs)
    }

    /// Whether a job of `config` and `state` can join this batch: the same dt and compiled
    /// effects as its jobs, and room for it.
    pub fn accepts(&self, config: &EngineConfig, state: &State<f64>) -> bool {
        let c0 = &self.configs[0];
        self.jobs() < MAX_JOBS
            && config.dt_s == c0.dt_s
            && config.walls.len() <= MAX_WALLS
            && state.history.slots == self.slots
            && Specialization::of(config, state.rotation, state.oriented, state.history.slots)
                == self.pipes.spec
    }

    /// Adds a job to the batch (the others are read back and uploaded unchanged); returns its
    /// index.
    ///
    /// # Errors
    /// As `new`; the batch is then as it was.
    pub fn add_job(
        &mut self,
        config: EngineConfig,
        state: &State<f64>,
    ) -> Result<usize, EngineError> {
        if !self.accepts(&config, state) {
            return Err(EngineError::Device(
                "this job cannot share the batch (different dt or effects, or the batch is full)"
                    .into(),
            ));
        }
        let mut all = self.read_states()?;
        let j = all.len();
        let mut walls = [WallGpu::default(); MAX_WALLS];
        for (w, wall) in walls.iter_mut().zip(&config.walls) {
            *w = WallGpu::of(wall);
        }
        self.walls.extend(walls);
        self.configs.push(config);
        self.time.push(state.time);
        self.step.push(state.step);
        self.active.push(true);
        all.push(state.clone());
        let refs: Vec<&State<f64>> = all.iter().collect();
        if let Err(e) = self.load(&refs) {
            // Back to the batch without it.
            self.walls.truncate(j * MAX_WALLS);
            self.configs.pop();
            self.time.pop();
            self.step.pop();
            self.active.pop();
            all.pop();
            let refs: Vec<&State<f64>> = all.iter().collect();
            self.load(&refs)?;
            return Err(e);
        }
        Ok(j)
    }

    /// Stops (false) or restarts job j: a stopped job's particles stay as they are and its
    /// reports are empty, while the others go on.
    pub fn set_active(&mut self, j: usize, on: bool) {
        self.active[j] = on;
        if let Some(run) = &self.run {
            let offset = (j * std::mem::size_of::<Params>()) as u64
                + std::mem::offset_of!(Params, running) as u64;
            self.dev
                .queue
                .write_buffer(&run.bufs.params, offset, bytemuck::bytes_of(&(on as u32)));
        }
    }

    /// Every contact of job j's current state, each once, computed on the device by the contact
    /// kernel's own arithmetic (nothing changes): in the order of a download's particles, each
    /// particle's partners by id, then its walls.
    ///
    /// # Errors
    /// A failed dispatch or read-back.
    pub fn contact_records_job(&mut self, j: usize) -> Result<Vec<ContactRecord>, EngineError> {
        let Some(run) = self.run.as_mut() else {
            return Ok(Vec::new());
        };
        let per = std::mem::size_of::<RecordGpu>() as u64;
        let groups = (run.bufs.n as u32).div_ceil(WORKGROUP_SIZE);
        let (count, raw) = loop {
            let capacity = run.bufs.records.size() / per;
            self.dev.queue.write_buffer(
                &run.bufs.status,
                ST_RECORDS as u64 * 4,
                bytemuck::bytes_of(&0u32),
            );
            let mut enc = self
                .dev
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("contact records"),
                });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("contact records"),
                    timestamp_writes: None,
                });
                let k = kernel::RECORD_CONTACTS;
                pass.set_pipeline(&self.pipes.pipelines[k]);
                pass.set_bind_group(0, &run.binds.0[k], &[]);
                pass.dispatch_workgroups(groups, 1, 1);
            }
            self.dev.queue.submit([enc.finish()]);
            let w = buffers::read_at(&self.dev, &run.bufs.status, ST_RECORDS as u64 * 4, 4)?;
            let count = u32::from_le_bytes([w[0], w[1], w[2], w[3]]) as u64;
            if count <= capacity {
                let raw = if count > 0 {
                    buffers::read_at(&self.dev, &run.bufs.records, 0, count * per)?
                } else {
                    Vec::new()
                };
                break (count, raw);
            }
            // Too short: grow with room to spare and run again.
            run.bufs.records =
                buffers::records_buffer(&self.dev, (count + count / 4 + 64) as usize);
            run.binds = self.pipes.bind(&self.dev, &run.bufs);
        };
        debug_assert_eq!(raw.len() as u64, count * per);
        let base = (j * run.n_job) as u32;
        let mut recs: Vec<RecordGpu> = bytemuck::pod_collect_to_vec::<u8, RecordGpu>(&raw)
            .into_iter()
            .filter(|r| r.who[0] >= base && r.who[0] < base + run.n_job as u32)
            .collect();
        // Atomics appended them in any order: by particle id, then partners by id, walls last
        // (by index), whatever slots the particles sit in.
        recs.sort_by_key(|r| {
            let wall = r.who[3] & 1;
            let partner = if wall == 0 {
                r.pos[3].to_bits()
            } else {
                r.who[2]
            };
            (r.who[1], wall, partner)
        });
        let v = |a: [f32; 4]| [a[0] as f64, a[1] as f64, a[2] as f64];
        Ok(recs
            .iter()
            .map(|r| ContactRecord {
                i: r.who[1],
                j: (r.who[3] & 1 == 0).then_some(r.pos[3].to_bits()),
                pos_i: v(r.pos),
                branch: v(r.branch),
                force_on_i: v(r.force),
                j_fixed: r.who[3] & 2 != 0,
            })
            .collect())
    }

    /// Job j's kinetic energy (summed on the device at the last chunk's end).
    ///
    /// # Errors
    /// A failed read-back.
    pub fn kinetic_energy_job(&self, j: usize) -> Result<f64, EngineError> {
        match self.run.as_ref().map(|r| r.jobs[j].energy) {
            None => Ok(0.0),
            Some(Some(e)) => Ok(e),
            Some(None) => Ok(self.download_job(j)?.kinetic_energy()),
        }
    }

    /// At a chunk's start: the removed particles dropped once they fill more than 1/8 of some
    /// job's slots (builds that sort by cell move them to the end of the job's block, but the
    /// dispatches still cover them).
    fn compact(&mut self) -> Result<(), EngineError> {
        let Some(run) = &self.run else {
            return Ok(());
        };
        if run.jobs.iter().any(|j| (j.loaded - j.alive) * 8 > j.loaded) {
            let all = self.read_states()?;
            let refs: Vec<&State<f64>> = all.iter().collect();
            self.load(&refs)?;
        }
        Ok(())
    }

    /// Advances every running job by `steps` steps in the same dispatches; returns each job's
    /// report (an empty one for a stopped job) or the failure its kernels flagged.
    ///
    /// # Errors
    /// A device failure (every job's).
    pub fn advance_batch(
        &mut self,
        steps: u64,
    ) -> Result<Vec<Result<ChunkReport, EngineError>>, EngineError> {
        if let Some(e) = self.pending.take() {
            return Err(e);
        }
        if let Some(e) = self.dev.take_error() {
            return Err(EngineError::Device(e));
        }
        let jobs = self.jobs();
        if steps == 0 {
            return Ok((0..jobs).map(|_| Ok(ChunkReport::default())).collect());
        }
        self.compact()?;
        let dt = self.configs[0].dt_s;
        let Some(run) = &self.run else {
            let mut out = Vec::new();
            for j in 0..jobs {
                let mut report = ChunkReport::default();
                if self.active[j] {
                    for _ in 0..steps {
                        self.time[j] += dt;
                    }
                    self.step[j] += steps;
                    report.steps = steps;
                }
                out.push(Ok(report));
            }
            return Ok(out);
        };
        let initial: Vec<u32> = (0..jobs).flat_map(|_| status_initial()).collect();
        self.dev
            .queue
            .write_buffer(&run.bufs.status, 0, bytemuck::cast_slice(&initial));
        let mut chunk = self.run_steps(run, steps)?;
        // The status words and the energy's workgroup sums, copied by the closing submission.
        let closing = chunk.closing_read.take().ok_or_else(|| {
            EngineError::Device("the chunk's closing read-back never completed".into())
        })?;
        let status_bytes = jobs * STATUS_WORDS * 4;
        let st_all: Vec<u32> = bytemuck::pod_collect_to_vec(&closing[..status_bytes]);
        let sums: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&closing[status_bytes..]);
        let per_job_groups = run.n_job / WORKGROUP_SIZE as usize;
        let mut outs = Vec::with_capacity(jobs);
        let mut updates = Vec::with_capacity(jobs);
        for j in 0..jobs {
            let jr = &run.jobs[j];
            if !self.active[j] {
                outs.push(Ok(ChunkReport::default()));
                updates.push(None);
                continue;
            }
            let base = j * run.n_job;
            let mut st = st_all[j * STATUS_WORDS..(j + 1) * STATUS_WORDS].to_vec();
            // The batch's word.
            st[ST_BUILDS] = st_all[ST_BUILDS];
            let deaths = (st[ST_DEATHS] as u64).min(run.n_job as u64);
            let events: Vec<[u32; 2]> = if deaths > 0 {
                let p = buffers::read_at(&self.dev, &run.bufs.events, base as u64 * 8, deaths * 8)?;
                bytemuck::pod_collect_to_vec::<u8, [u32; 2]>(&p)
            } else {
                Vec::new()
            };
            let energy = fixed_point_energy(
                &sums[j * per_job_groups..(j + 1) * per_job_groups],
                st[ST_KE_MAX],
            );
            let out = read_chunk(
                &ChunkContext {
                    masses: &jr.masses,
                    alive: jr.alive,
                    mobile: jr.mobile,
                    slots: self.slots,
                    stride: run.grid.stride,
                    time0: self.time[j],
                    step0: self.step[j],
                    steps,
                    dt,
                    overlap_limit: self.options.watchdog.max_overlap_ratio,
                },
                &st,
                &events,
            );
            updates.push(Some((out.alive, out.mobile, energy, out.time)));
            outs.push(match out.error {
                Some(e) => Err(e),
                None => Ok(out.report),
            });
        }
        for (j, u) in updates.into_iter().enumerate() {
            if let Some((alive, mobile, energy, time)) = u {
                if let Some(r) = self.run.as_mut() {
                    let jr = &mut r.jobs[j];
                    jr.alive = alive;
                    jr.mobile = mobile;
                    jr.energy = Some(energy);
                }
                self.time[j] = time;
                self.step[j] += steps;
            }
        }
        self.schedule = chunk.schedule;
        self.dispatches.add(&chunk.count);
        Ok(outs)
    }

    /// Runs `steps` steps on the device: records them two command buffers ahead, reads each
    /// one's stale word as it completes, and redoes the step where the lists went stale.
    fn run_steps(&self, run: &Run, steps: u64) -> Result<Chunk, EngineError> {
        let mut c = Chunk {
            schedule: self.schedule,
            steps,
            next: 0,
            redo: None,
            start_build: true,
            closed: false,
            builds: vec![-1],
            per_step: Vec::with_capacity(steps as usize),
            count: DispatchCount::default(),
            closing_read: None,
        };
        let mut flight: VecDeque<InFlight> = VecDeque::new();
        loop {
            let work_left = c.next < steps || c.redo.is_some() || !c.closed;
            if work_left && flight.len() < 2 {
                flight.push_back(self.submit(run, &mut c));
                continue;
            }
            let Some(f) = flight.pop_front() else {
                break;
            };
            let (stale, closing) = f.wait(&self.dev)?;
            if stale == u32::MAX {
                if closing.is_some() {
                    c.closing_read = closing;
                }
                continue;
            }
            // Everything recorded past step `stale` (this buffer's rest and the next one's) was
            // void on the device: redo the step with a build and go on from there.
            flight.clear();
            let s = stale as u64;
            let voided = c.next - (s + 1);
            c.count.voided_steps += voided;
            c.per_step.truncate(s as usize + 1);
            c.builds.retain(|&b| b < s as i64);
            let last = c.builds.last().copied().unwrap_or(-1);
            if self.options.build_every.is_none() {
                c.schedule.stale((s as i64 - last) as u64);
            }
            for (word, value) in [(ST_STEP, s as u32), (ST_STEP_NEXT, s as u32 + 1)] {
                self.dev.queue.write_buffer(
                    &run.bufs.status,
                    word as u64 * 4,
                    bytemuck::bytes_of(&value),
                );
            }
            c.next = s + 1;
            c.redo = Some(s);
            c.closed = false;
        }
        c.count.steps = steps;
        for &d in &c.per_step {
            if d == STEP_DISPATCHES {
                c.count.steady_steps += 1;
                c.count.steady_dispatches += d as u64;
                c.count.max_steady_step = c.count.max_steady_step.max(d as u64);
            }
        }
        Ok(c)
    }

    /// Records and submits the chunk's next command buffer: a pending build (chunk start or a
    /// redone step), up to `steps_per_submit` steps, and the closing passes after the last.
    fn submit(&self, run: &Run, c: &mut Chunk) -> InFlight {
        let gp = (run.bufs.n as u32).div_ceil(WORKGROUP_SIZE);
        let gc = run.grid.n_chunks;
        let build_dispatches = BUILD_DISPATCHES + run.reorder as u8;
        let sorting = run.reorder as u64;
        let pipes = &self.pipes;
        let binds = &run.binds;
        let mut dispatches = 0u64;
        let mut closing = false;
        let mut dispatch = |pass: &mut wgpu::ComputePass<'_>, k: usize, groups: u32| {
            pass.set_pipeline(&pipes.pipelines[k]);
            pass.set_bind_group(0, &binds.0[k], &[]);
            pass.dispatch_workgroups(groups, 1, 1);
            dispatches += 1;
        };
        let build =
            |pass: &mut wgpu::ComputePass<'_>,
             dispatch: &mut dyn FnMut(&mut wgpu::ComputePass<'_>, usize, u32)| {
                for (p, &k) in kernel::BUILD.iter().enumerate() {
                    // histogram, scan_blocks, scan_totals, scan_apply, scatter, build_list.
                    let groups = match p {
                        1 | 3 => gc,
                        2 => 1,
                        _ => gp,
                    };
                    if k == kernel::BUILD[5] && run.reorder {
                        dispatch(pass, kernel::SETTLE, gp);
                    }
                    dispatch(pass, k, groups);
                }
            };
        let mut enc = self
            .dev
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("steps"),
            });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("steps"),
                timestamp_writes: None,
            });
            if std::mem::take(&mut c.start_build) {
                // NOTE: every chunk starts from fresh lists, as on the CPU.
                build(&mut pass, &mut dispatch);
                c.count.builds += 1;
                c.count.sorting_builds += sorting;
            }
            if let Some(s) = c.redo.take() {
                build(&mut pass, &mut dispatch);
                dispatch(&mut pass, kernel::COMPUTE_FORCES, gp);
                c.count.builds += 1;
                c.count.sorting_builds += sorting;
                c.builds.push(s as i64);
                c.per_step[s as usize] = 1 + build_dispatches + 1;
            }
            let end = c.steps.min(c.next + self.options.steps_per_submit.max(1));
            for k in c.next..end {
                let last = c.builds.last().copied().unwrap_or(-1);
                let due = match self.options.build_every {
                    Some(n) => (k as i64 - last) >= n.max(1) as i64,
                    None => c.schedule.due(k as i64, last),
                };
                dispatch(&mut pass, kernel::KICK_DRIFT, gp);
                if due {
                    build(&mut pass, &mut dispatch);
                    c.count.builds += 1;
                    c.count.sorting_builds += sorting;
                    c.builds.push(k as i64);
                    c.schedule.scheduled();
                }
                dispatch(&mut pass, kernel::COMPUTE_FORCES, gp);
                c.per_step.push(if due {
                    STEP_DISPATCHES + build_dispatches
                } else {
                    STEP_DISPATCHES
                });
            }
            c.next = end;
            if end == c.steps && !c.closed {
                // The closing half kick, then finiteness, contact counts and kinetic energy.
                dispatch(&mut pass, kernel::CLOSE_KICK, gp);
                dispatch(&mut pass, kernel::FINISH, gp);
                dispatch(&mut pass, kernel::ENERGY_SUM, gp);
                c.closed = true;
                closing = true;
            }
        }
        // The stale word; after the closing passes also every job's status words and the
        // energy's workgroup sums, so the chunk's end needs no read-back of its own.
        let n = run.bufs.n as u64;
        let status_bytes = (self.jobs() * STATUS_WORDS) as u64 * 4;
        let sums_bytes = n.div_ceil(WORKGROUP_SIZE as u64) * 8;
        let stale = self.dev.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stale step"),
            size: if closing {
                4 + status_bytes + sums_bytes
            } else {
                4
            },
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        enc.copy_buffer_to_buffer(&run.bufs.status, ST_STALE as u64 * 4, &stale, 0, 4);
        if closing {
            enc.copy_buffer_to_buffer(&run.bufs.status, 0, &stale, 4, status_bytes);
            enc.copy_buffer_to_buffer(
                &run.bufs.energy,
                n * 4,
                &stale,
                4 + status_bytes,
                sums_bytes,
            );
        }
        let index = self.dev.queue.submit([enc.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        stale.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        c.count.dispatches += dispatches;
        c.count.submissions += 1;
        InFlight {
            index,
            stale,
            rx,
            closing,
        }
    }
}

/// Dispatches of a step without a build, and of one build.
const STEP_DISPATCHES: u8 = 2;
const BUILD_DISPATCHES: u8 = 6;

/// The host's record of the chunk being run.
struct Chunk {
    /// The engine's build schedule, learning during the chunk.
    schedule: BuildSchedule,
    steps: u64,
    /// The next step to record.
    next: u64,
    /// A step whose lists were found stale: to redo with a build before the next step.
    redo: Option<u64>,
    start_build: bool,
    /// Whether the closing passes are recorded (after the last step).
    closed: bool,
    /// Steps after whose drift a build was recorded (−1: the chunk's start), ascending.
    builds: Vec<i64>,
    /// Dispatches recorded per step taken.
    per_step: Vec<u8>,
    count: DispatchCount,
    /// Every job's status words then the energy's workgroup sums, as the closing submission
    /// copied them (once it completed without a stale step).
    closing_read: Option<Vec<u8>>,
}

/// A submitted command buffer and the pending read of its stale word.
struct InFlight {
    index: wgpu::SubmissionIndex,
    stale: wgpu::Buffer,
    rx: std::sync::mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
    /// Whether it records the chunk's closing passes (and copies their results).
    closing: bool,
}

impl InFlight {
    /// Waits for the buffer and returns the first stale step it saw (u32::MAX: none) and, for the
    /// closing submission, the status words and energy sums it copied.
    fn wait(self, dev: &GpuDevice) -> Result<(u32, Option<Vec<u8>>), EngineError> {
        dev.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(self.index),
                timeout: None,
            })
            .map_err(|e| EngineError::Device(format!("waiting for the device: {e}")))?;
        self.rx
            .recv()
            .map_err(|e| EngineError::Device(format!("readback never completed: {e}")))?
            .map_err(|e| EngineError::Device(format!("reading the status back: {e}")))?;
        if let Some(e) = dev.take_error() {
            return Err(EngineError::Device(e));
        }
        let view = self
            .stale
            .get_mapped_range(..)
            .map_err(|e| EngineError::Device(format!("reading the status back: {e}")))?;
        let word = u32::from_le_bytes([view[0], view[1], view[2], view[3]]);
        let closing = self.closing.then(|| view[4..].to_vec());
        Ok((word, closing))
    }
}

/// A job's kinetic energy from `energy_sum`'s workgroup sums (low, high words) of particle
/// energies in units of 2^(e − KE_BITS), 2^e bounding the largest (`max_bits`, its f32 bits).
fn fixed_point_energy(sums: &[[u32; 2]], max_bits: u32) -> f64 {
    let total: u128 = sums
        .iter()
        .map(|&[lo, hi]| ((hi as u128) << 32) | lo as u128)
        .sum();
    let exponent = ((max_bits >> 23) & 0xff) as i32 - 126;
    total as f64 * 2f64.powi(exponent - KE_BITS)
}

/// The first oriented particle whose inertia is not that of a symmetric top about its axis
/// (I1 ≠ I2 in f32): the GPU's free rotor is the symmetric top's exact one only (fixed particles
/// have all three inverse moments zero).
fn asymmetric_top(state: &State<f64>) -> Option<usize> {
    if !state.oriented {
        return None;
    }
    state
        .inv_inertia_body
        .iter()
        .position(|ii| ii.x as f32 != ii.y as f32)
}

impl Backend for GpuEngine {
    fn advance(&mut self, steps: u64) -> Result<ChunkReport, EngineError> {
        self.advance_batch(steps)?.swap_remove(0)
    }

    /// # Panics
    /// When the device fails while reading back (it is lost); `advance` reports device errors
    /// before that, so a checkpoint is never written from a failed device.
    fn download(&mut self) -> State<f64> {
        match self.download_job(0) {
            Ok(s) => s,
            Err(e) => panic!("GPU backend: {e}"),
        }
    }

    fn try_download(&mut self) -> Result<State<f64>, EngineError> {
        self.download_job(0)
    }

    fn upload(&mut self, state: &State<f64>) {
        let r = if self.jobs() == 1 {
            self.load(&[state])
        } else {
            self.upload_job(0, state)
        };
        if let Err(e) = r {
            self.pending = Some(e);
        }
    }

    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError> {
        self.contact_records_job(0)
    }

    /// Summed on the device at the last chunk's end (per workgroup, then in f64 here), so a
    /// chunk reads back a few hundred numbers instead of the state.
    fn kinetic_energy(&mut self) -> Result<f64, EngineError> {
        self.kinetic_energy_job(0)
    }

    fn dispatches(&self) -> Option<DispatchCount> {
        Some(self.dispatches)
    }

    fn describe(&self) -> BackendInfo {
        BackendInfo {
            kind: "gpu".into(),
            precision: "f32".into(),
            adapter: self.dev.info.name.clone(),
            threads: 0,
        }
    }
}
