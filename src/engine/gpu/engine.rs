//! The GPU backend: the CPU engine's velocity Verlet as compute passes, in f32, with the state
//! resident on the device. One chunk is: a list rebuild, then per step `kick_drift` → `plan_step`
//! → the rebuild passes (dispatched indirectly, with zero workgroups unless some particle moved
//! more than skin/2) → `compute_forces`; then the closing half kick and `finish`. Many steps go
//! into one command buffer; only the status block and the sink events are read back per chunk.
//! Particles removed by the sink stay in place (flagged dead, skipped by every kernel) until the
//! host compacts them with a download and upload once they exceed 1/8 of the slots; a download
//! never shows them, as on the CPU.
//!
//! Oriented runs (spherocylinders, `Specialization::oriented`) add `kick_rotate` after
//! `kick_drift`: the rotational kick and the exact free rotor of `shape::rigid`, ω refreshed, the
//! axis re-derived, and the skin criterion |Δc| + (l/2)|Δu| > skin/2 of the CPU engine; the
//! contact kernel then evaluates every rod pair in the CPU's canonical order (lower id first).

use super::buffers::{self, pack, unpack, GpuBuffers};
use super::device::GpuDevice;
use super::grid::{plan_grid, GridSpec};
use super::layout::{
    status_initial, LawGpu, Params, WallGpu, MAX_WALLS, REBUILD_PASSES, STATUS_WORDS,
    WORKGROUP_SIZE,
};
use super::pipelines::{kernel, BindGroups, Pipelines, Specialization};
use super::status::{read_chunk, ChunkContext};
use crate::engine::backend::{Backend, BackendInfo, ChunkReport, EngineError};
use crate::engine::config::EngineConfig;
use crate::engine::contact::ContactRecord;
use crate::engine::cpu::Watchdog;
use crate::engine::history::MAX_SLOTS;
use crate::engine::state::State;

/// Tunables of the GPU engine that do not change the physics.
#[derive(Clone, Copy, Debug)]
pub struct GpuOptions {
    /// Steps recorded into one command buffer before it is submitted. Larger amortises the
    /// submission; smaller bounds the memory of recorded commands.
    pub steps_per_submit: u64,
    /// Run length of the chunked prefix scan (default ⌈√cells⌉).
    pub scan_chunk: Option<u32>,
    /// Only `max_overlap_ratio` applies: the energy check needs the kinetic energy, which the
    /// status block does not carry (a device-side sum would need float atomics or a reduction
    /// pass per chunk).
    pub watchdog: Watchdog,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self {
            steps_per_submit: 64,
            scan_chunk: None,
            watchdog: Watchdog::default(),
        }
    }
}

/// Device resources of the particles currently uploaded (none when there are no particles).
struct Run {
    bufs: GpuBuffers,
    binds: BindGroups,
    grid: GridSpec,
    /// Host copies of the per-slot id and mass, for sink events.
    ids: Vec<u32>,
    masses: Vec<f32>,
    /// Slots still alive.
    alive: usize,
    /// Live mobile particles (what particle-steps count, as on the CPU).
    mobile: usize,
}

/// The GPU engine (f32).
pub struct GpuEngine {
    dev: GpuDevice,
    config: EngineConfig,
    pipes: Pipelines,
    walls: [WallGpu; MAX_WALLS],
    run: Option<Run>,
    slots: usize,
    rotation: bool,
    /// Whether the uploaded particles are oriented (spherocylinders).
    oriented: bool,
    time: f64,
    step: u64,
    /// An upload that failed, reported by the next `advance`.
    pending: Option<EngineError>,
    options: GpuOptions,
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
        if config.walls.len() > MAX_WALLS {
            return Err(EngineError::Device(format!(
                "{} walls; the GPU backend holds at most {MAX_WALLS}",
                config.walls.len()
            )));
        }
        let mut walls = [WallGpu::default(); MAX_WALLS];
        for (w, wall) in walls.iter_mut().zip(&config.walls) {
            *w = WallGpu::of(wall);
        }
        let pipes = Pipelines::new(
            dev,
            Specialization::of(&config, state.rotation, state.oriented, state.history.slots),
        );
        if let Some(e) = dev.take_error() {
            return Err(EngineError::Device(format!("building the kernels: {e}")));
        }
        let mut e = Self {
            dev: dev.clone(),
            config,
            pipes,
            walls,
            run: None,
            slots: 0,
            rotation: false,
            oriented: false,
            time: 0.0,
            step: 0,
            pending: None,
            options,
        };
        e.load(state)?;
        Ok(e)
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    /// The grid of the current upload (None without particles).
    pub fn grid(&self) -> Option<GridSpec> {
        self.run.as_ref().map(|r| r.grid)
    }

    fn params(&self, n: usize, g: &GridSpec) -> Params {
        let c = &self.config;
        let f = |x: f64| x as f32;
        // As CpuEngine: the box ends are rounded to f32, the length is their f32 difference.
        let lo = |p: Option<[f64; 2]>| p.map_or(0.0, |[a, _]| f(a));
        let len = |p: Option<[f64; 2]>| p.map_or(0.0, |[a, b]| f(b) - f(a));
        let dt = f(c.dt_s);
        let skin = f(c.skin_m);
        let groups = |k: usize| (k as u32).div_ceil(WORKGROUP_SIZE);
        Params {
            n: n as u32,
            slots: self.slots as u32,
            stride: g.stride,
            n_walls: c.walls.len() as u32,
            nx: g.dims[0],
            ny: g.dims[1],
            nz: g.dims[2],
            ncell: g.ncell,
            periodic_x: c.periodic_x.is_some() as u32,
            periodic_y: c.periodic_y.is_some() as u32,
            rotation: self.rotation as u32,
            has_sink: c.sink_z.is_some() as u32,
            scan_chunk: g.scan_chunk,
            n_chunks: g.n_chunks,
            groups_particles: groups(n),
            groups_chunks: groups(g.n_chunks as usize),
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
        }
    }

    /// Replaces the device state by `state`.
    fn load(&mut self, state: &State<f64>) -> Result<(), EngineError> {
        self.run = None;
        self.time = state.time;
        self.step = state.step;
        self.slots = state.history.slots;
        self.rotation = state.rotation;
        self.oriented = state.oriented;
        if self.slots > MAX_SLOTS {
            return Err(EngineError::Device(format!(
                "{} history slots per particle; the GPU backend holds at most {MAX_SLOTS}",
                self.slots
            )));
        }
        if let Some(k) = asymmetric_top(state) {
            return Err(EngineError::Device(format!(
                "particle {} is not a symmetric top about its axis (I1 ≠ I2); the GPU kernels rotate symmetric tops only (every spherocylinder is one): run it with --backend cpu",
                state.id[k]
            )));
        }
        // The kernels are compiled for the effects of the state they run: recompile when an
        // upload changes them (never within one job).
        let spec = Specialization::of(
            &self.config,
            state.rotation,
            state.oriented,
            state.history.slots,
        );
        if spec != self.pipes.spec {
            self.pipes = Pipelines::new(&self.dev, spec);
            if let Some(e) = self.dev.take_error() {
                return Err(EngineError::Device(format!("building the kernels: {e}")));
            }
        }
        if state.is_empty() {
            return Ok(());
        }
        let n = state.len();
        let grid = plan_grid(state, &self.config, self.options.scan_chunk);
        let params = self.params(n, &grid);
        let max_groups = self.dev.limits.max_compute_workgroups_per_dimension;
        if params.groups_particles.max(params.groups_chunks) > max_groups {
            return Err(EngineError::Device(format!(
                "{n} particles need {} workgroups of {WORKGROUP_SIZE}; {} dispatches at most {max_groups}",
                params.groups_particles, self.dev.info.name
            )));
        }
        let bufs = GpuBuffers::new(&self.dev, &params, &self.walls, &pack(state), &grid)?;
        let binds = self.pipes.bind(&self.dev, &bufs);
        self.run = Some(Run {
            bufs,
            binds,
            grid,
            ids: state.id.clone(),
            masses: state.mass.iter().map(|&m| m as f32).collect(),
            alive: n,
            mobile: state.inv_mass.iter().filter(|&&m| m != 0.0).count(),
        });
        Ok(())
    }

    /// The live particles, read back.
    fn read_state(&self) -> Result<State<f64>, EngineError> {
        match &self.run {
            None => {
                let mut s = if self.oriented {
                    State::new_oriented(self.slots)
                } else {
                    State::new(self.rotation, self.slots)
                };
                s.time = self.time;
                s.step = self.step;
                Ok(s)
            }
            Some(run) => {
                let p = run.bufs.read_particles(&self.dev)?;
                Ok(unpack(&p, self.slots, self.rotation, self.time, self.step))
            }
        }
    }

    /// Drops removed particles once they fill more than 1/8 of the slots.
    fn compact_if_sparse(&mut self) -> Result<(), EngineError> {
        let sparse = self
            .run
            .as_ref()
            .is_some_and(|r| (r.bufs.n - r.alive) * 8 > r.bufs.n);
        if sparse {
            let s = self.read_state()?;
            self.load(&s)?;
        }
        Ok(())
    }

    /// Records and submits `steps` steps (plus the chunk's opening rebuild and closing passes).
    fn encode_chunk(&self, run: &Run, steps: u64) {
        let n = run.bufs.n;
        let gp = (n as u32).div_ceil(WORKGROUP_SIZE);
        let pipes = &self.pipes;
        let binds = &run.binds;
        let dispatch = |pass: &mut wgpu::ComputePass<'_>, k: usize, groups: u32| {
            pass.set_pipeline(&pipes.pipelines[k]);
            pass.set_bind_group(0, &binds.0[k], &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        };
        let rebuild = |pass: &mut wgpu::ComputePass<'_>| {
            for (slot, &k) in kernel::REBUILD.iter().enumerate() {
                pass.set_pipeline(&pipes.pipelines[k]);
                pass.set_bind_group(0, &binds.0[k], &[]);
                pass.dispatch_workgroups_indirect(&run.bufs.indirect, slot as u64 * 12);
            }
        };
        debug_assert_eq!(kernel::REBUILD.len(), REBUILD_PASSES.len());
        let mut done = 0;
        while done < steps {
            let batch = (steps - done).min(self.options.steps_per_submit.max(1));
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
                if done == 0 {
                    // NOTE: every chunk starts from fresh lists, as on the CPU.
                    dispatch(&mut pass, kernel::PLAN_START, 1);
                    rebuild(&mut pass);
                }
                for _ in 0..batch {
                    // Kick (dt/2 at the chunk's first step, dt after), drift, sink, staleness.
                    dispatch(&mut pass, kernel::KICK_DRIFT, gp);
                    if self.oriented {
                        // Rotational kick, free rotation, axes, and the rods' skin criterion.
                        dispatch(&mut pass, kernel::KICK_ROTATE, gp);
                    }
                    // Count the step; size the rebuild passes (0 when the lists still hold).
                    dispatch(&mut pass, kernel::PLAN_STEP, 1);
                    // Histogram, scan, scatter, lists.
                    rebuild(&mut pass);
                    // Forces, torques and history from the new positions.
                    dispatch(&mut pass, kernel::COMPUTE_FORCES, gp);
                }
                if done + batch == steps {
                    // The closing half kick, then finiteness and contact counts.
                    dispatch(&mut pass, kernel::CLOSE_KICK, gp);
                    dispatch(&mut pass, kernel::FINISH, gp);
                }
            }
            self.dev.queue.submit([enc.finish()]);
            done += batch;
        }
    }
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
        if let Some(e) = self.pending.take() {
            return Err(e);
        }
        if let Some(e) = self.dev.take_error() {
            return Err(EngineError::Device(e));
        }
        let mut report = ChunkReport::default();
        if steps == 0 {
            return Ok(report);
        }
        self.compact_if_sparse()?;
        let (time0, step0) = (self.time, self.step);
        let dt = self.config.dt_s;
        let Some(run) = &self.run else {
            for _ in 0..steps {
                self.time += dt;
            }
            self.step += steps;
            report.steps = steps;
            return Ok(report);
        };
        let n = run.bufs.n;
        self.dev
            .queue
            .write_buffer(&run.bufs.status, 0, bytemuck::bytes_of(&status_initial()));
        self.encode_chunk(run, steps);
        let parts = buffers::read(
            &self.dev,
            &[
                (&run.bufs.status, STATUS_WORDS as u64 * 4),
                (&run.bufs.events, n as u64 * 8),
            ],
        )?;
        let st: Vec<u32> = bytemuck::pod_collect_to_vec(&parts[0]);
        let events: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&parts[1]);
        let out = read_chunk(
            &ChunkContext {
                ids: &run.ids,
                masses: &run.masses,
                alive: run.alive,
                mobile: run.mobile,
                slots: self.slots,
                stride: run.grid.stride,
                time0,
                step0,
                steps,
                dt,
                overlap_limit: self.options.watchdog.max_overlap_ratio,
            },
            &st,
            &events,
        );
        if let Some(r) = self.run.as_mut() {
            r.alive = out.alive;
            r.mobile = out.mobile;
        }
        self.time = out.time;
        self.step = step0 + steps;
        match out.error {
            Some(e) => Err(e),
            None => Ok(out.report),
        }
    }

    /// # Panics
    /// When the device fails while reading back (it is lost); `advance` reports device errors
    /// before that, so a checkpoint is never written from a failed device.
    fn download(&mut self) -> State<f64> {
        match self.read_state() {
            Ok(s) => s,
            Err(e) => panic!("GPU backend: {e}"),
        }
    }

    fn try_download(&mut self) -> Result<State<f64>, EngineError> {
        self.read_state()
    }

    fn upload(&mut self, state: &State<f64>) {
        if let Err(e) = self.load(state) {
            self.pending = Some(e);
        }
    }

    /// Computed from a download by the CPU engine's f32 kernels (the same arithmetic as the
    /// device's): stress observers sample rarely, so one O(N) copy per sample is cheap.
    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError> {
        let state = self.read_state()?;
        let mut cpu =
            crate::engine::cpu::CpuEngine::<f32>::new(self.config.clone(), state.convert(), 1);
        Ok(cpu.contact_records())
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
