//! Uploading a batch: each job's record for the kernels (`params`) and its particles packed
//! into the device buffers, sized for the batch (`load`).

use super::*;

impl GpuEngine {
    /// The most bytes one storage binding may hold: the device's limit, or
    /// `GpuOptions::max_binding_bytes` where that is lower.
    fn max_binding(&self) -> u64 {
        let device = self.dev.limits.max_storage_buffer_binding_size;
        self.options
            .max_binding_bytes
            .map_or(device, |b| b.min(device))
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
            // Set by GpuBuffers::new, which splits the bindings.
            hist_split: 0,
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
            nbr_split: 0,
            pad2: 0,
            pad3: 0,
            pad4: 0,
        }
    }

    /// Replaces the device state by `states`, one per job.
    pub(super) fn load(&mut self, states: &[&State<f64>]) -> Result<(), EngineError> {
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
            self.pipes = Pipelines::new(&self.dev, spec, self.options.fused_step);
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
        // Slots dispatch in rows (`dispatch_size`); the cell scan in one.
        let max_groups = self.dev.limits.max_compute_workgroups_per_dimension;
        if all.n_chunks > max_groups {
            return Err(EngineError::Device(format!(
                "{total} particle slots in {ncell} cells need {} scan workgroups; {} dispatches at most {max_groups} along one dimension",
                all.n_chunks, self.dev.info.name
            )));
        }
        // Builds sort the particles by cell unless the scratch for it would not bind.
        let max_binding = self.max_binding();
        let reorder = self.options.reorder_by_cell
            && scratch_bytes(total, self.oriented, self.slots) <= max_binding;
        let mut params = Vec::with_capacity(states.len());
        let mut offset = 0u32;
        for (j, g) in grids.iter().enumerate() {
            let mut p = self.params(j, total, n_job, g, &all, offset);
            p.reorder = reorder as u32;
            params.push(p);
            offset += g.ncell;
        }
        let packed = buffers::concat(states.iter().map(|s| pack(s)).collect(), n_job, self.slots);
        let bufs = GpuBuffers::new(
            &self.dev,
            max_binding,
            &params,
            &self.walls,
            &packed,
            &all,
            self.options.fused_step,
        )?;
        let binds = self.pipes.bind(&self.dev, &bufs);
        let jobs = states
            .iter()
            .zip(&grids)
            .zip(&self.configs)
            .map(|((s, g), c)| JobRun {
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
                budget: watchdog::BudgetBase::of(c, s),
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
