//! Running a chunk: its steps recorded two command buffers ahead, the stale word of each read
//! as it completes (the step where the lists went stale redone with a build), then the closing
//! read-back of the status words and energy sums.

use super::readback::fixed_point_energy;
use super::*;

impl GpuEngine {
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
        // Per workgroup: the kinetic sums, then the elastic (U₀ at the chunk's start).
        let sums: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&closing[status_bytes..]);
        let (kinetic_sums, elastic_sums) = sums.split_at(sums.len() / 2);
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
            let groups = j * per_job_groups..(j + 1) * per_job_groups;
            let energy = fixed_point_energy(&kinetic_sums[groups.clone()], st[ST_KE_MAX]);
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
            let removed_kg: f64 = out.report.removed.iter().map(|e| e.mass_kg).sum();
            updates.push(Some((out.alive, out.mobile, energy, out.time, removed_kg)));
            outs.push(match out.error {
                Some(e) => Err(e),
                None if self.checks_energy() => {
                    let elastic = fixed_point_energy(&elastic_sums[groups], st[ST_U_MAX]);
                    let mut report = out.report;
                    self.energy_check(jr, j, self.step[j], steps, elastic, energy)
                        .map(|growth| {
                            report.kinetic_growth = Some(growth);
                            report
                        })
                }
                None => Ok(out.report),
            });
        }
        for (j, u) in updates.into_iter().enumerate() {
            if let Some((alive, mobile, energy, time, removed_kg)) = u {
                if let Some(r) = self.run.as_mut() {
                    let jr = &mut r.jobs[j];
                    jr.alive = alive;
                    jr.mobile = mobile;
                    jr.energy = Some(energy);
                    jr.budget.mobile_mass_kg -= removed_kg;
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
            parity: Vec::with_capacity(steps as usize),
            odd: false,
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
            c.parity.truncate(s as usize + 1);
            c.odd = c.parity[s as usize];
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
        let steady = if self.pipes.fused { 1 } else { STEP_DISPATCHES };
        for &d in &c.per_step {
            if d == steady {
                c.count.steady_steps += 1;
                c.count.steady_dispatches += d as u64;
                c.count.max_steady_step = c.count.max_steady_step.max(d as u64);
            }
        }
        Ok(c)
    }

    /// Records and submits the chunk's next command buffer: a pending build (chunk start or a
    /// redone step), up to `steps_per_submit` steps, and the closing passes after the last.
    ///
    /// Two dispatches per step (`kick_drift`, `compute_forces`), or with `fused_step` one
    /// (`fused_step`, the forces of step k fused with step k's kick and drift): the chunk's
    /// first step kicks and drifts alone, the closing forces are computed alone, and each fused
    /// dispatch reads one copy of the state and writes the other. A list build sits where it
    /// does in the two-dispatch step, between a drift and the next forces.
    fn submit(&self, run: &Run, c: &mut Chunk) -> InFlight {
        let gp = (run.bufs.n as u32).div_ceil(WORKGROUP_SIZE);
        let fused = self.pipes.fused;
        let build_dispatches = BUILD_DISPATCHES + run.reorder as u8;
        let step_dispatches = if fused { 1 } else { STEP_DISPATCHES };
        let sorting = run.reorder as u64;
        let mut rec = Recorder {
            pipes: &self.pipes,
            binds: &run.binds,
            row: self.row_groups(),
            groups: gp,
            odd: c.odd,
            dispatches: 0,
            fused_steps: 0,
        };
        let mut closing = false;
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
                rec.build(&mut pass, run);
                c.count.builds += 1;
                c.count.sorting_builds += sorting;
                if self.checks_energy() {
                    // U₀ for the energy watchdog, from the fresh lists.
                    rec.dispatch(&mut pass, kernel::CONTACT_ENERGY);
                    rec.dispatch(&mut pass, kernel::ELASTIC_SUM);
                }
            }
            if let Some(s) = c.redo.take() {
                rec.build(&mut pass, run);
                c.count.builds += 1;
                c.count.sorting_builds += sorting;
                c.builds.push(s as i64);
                c.per_step[s as usize] = step_dispatches + build_dispatches;
                if !fused {
                    rec.dispatch(&mut pass, kernel::COMPUTE_FORCES);
                    c.per_step[s as usize] += 1;
                }
                // Fused, the next step's dispatch computes the redone forces.
            }
            let end = c.steps.min(c.next + self.options.steps_per_submit.max(1));
            for k in c.next..end {
                let last = c.builds.last().copied().unwrap_or(-1);
                let due = match self.options.build_every {
                    Some(n) => (k as i64 - last) >= n.max(1) as i64,
                    None => c.schedule.due(k as i64, last),
                };
                if fused && k > 0 {
                    rec.fused(&mut pass, k as u32);
                } else {
                    rec.dispatch(&mut pass, kernel::KICK_DRIFT);
                }
                if due {
                    rec.build(&mut pass, run);
                    c.count.builds += 1;
                    c.count.sorting_builds += sorting;
                    c.builds.push(k as i64);
                    c.schedule.scheduled();
                }
                if !fused {
                    rec.dispatch(&mut pass, kernel::COMPUTE_FORCES);
                }
                c.per_step.push(if due {
                    step_dispatches + build_dispatches
                } else {
                    step_dispatches
                });
                c.parity.push(rec.odd);
            }
            c.next = end;
            if end == c.steps && !c.closed {
                if fused {
                    rec.dispatch(&mut pass, kernel::COMPUTE_FORCES);
                }
                // The closing half kick, then finiteness, contact counts and kinetic energy.
                rec.dispatch(&mut pass, kernel::CLOSE_KICK);
                rec.dispatch(&mut pass, kernel::FINISH);
                rec.dispatch(&mut pass, kernel::ENERGY_SUM);
                if rec.odd {
                    // The chunk ends on the second copy: back to the first, which read-backs,
                    // uploads and the next chunk use.
                    rec.dispatch(&mut pass, kernel::ADOPT);
                    c.count.copies_back += 1;
                }
                c.closed = true;
                closing = true;
            }
        }
        c.odd = rec.odd;
        let dispatches = rec.dispatches;
        c.count.fused_steps += rec.fused_steps;
        // The stale word; after the closing passes also every job's status words and the
        // energies' workgroup sums (kinetic, then elastic), so the chunk's end needs no
        // read-back of its own.
        let n = run.bufs.n as u64;
        let status_bytes = (self.jobs() * STATUS_WORDS) as u64 * 4;
        let sums_bytes = n.div_ceil(WORKGROUP_SIZE as u64) * 16;
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

/// The (kernel, workgroups) of one list build: histogram, scan_blocks, scan_totals, scan_apply,
/// scatter, then `settle` when builds sort by cell, then build_list.
pub(super) fn build_passes(run: &Run) -> Vec<(usize, u32)> {
    let gp = (run.bufs.n as u32).div_ceil(WORKGROUP_SIZE);
    let gc = run.grid.n_chunks;
    let mut v = Vec::with_capacity(7);
    for (p, &k) in kernel::BUILD.iter().enumerate() {
        if p == 5 && run.reorder {
            v.push((kernel::SETTLE, gp));
        }
        v.push((
            k,
            match p {
                1 | 3 => gc,
                2 => 1,
                _ => gp,
            },
        ));
    }
    v
}

/// Records dispatches into a compute pass with the bind groups of the copy of the state the
/// chunk is on, and counts them.
struct Recorder<'a> {
    pipes: &'a Pipelines,
    binds: &'a BindGroups,
    /// Workgroups per row (`dispatch_size`) and per-slot workgroups.
    row: u32,
    groups: u32,
    /// Which copy of the state the kernels read (odd: the second).
    odd: bool,
    dispatches: u64,
    fused_steps: u64,
}

impl Recorder<'_> {
    /// Kernel k over the slots (the scans over their own workgroups, `build_passes`).
    fn dispatch(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize) {
        self.dispatch_groups(pass, k, self.groups);
    }

    fn dispatch_groups(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize, groups: u32) {
        pass.set_pipeline(&self.pipes.pipelines[k]);
        pass.set_bind_group(0, self.binds.at(self.odd, k), &[]);
        let (x, y) = dispatch_size(k, groups, self.row);
        pass.dispatch_workgroups(x, y, 1);
        self.dispatches += 1;
    }

    /// A list build on the current copy.
    fn build(&mut self, pass: &mut wgpu::ComputePass<'_>, run: &Run) {
        for (k, groups) in build_passes(run) {
            self.dispatch_groups(pass, k, groups);
        }
    }

    /// The one-dispatch step of chunk-local step k; the copy it writes becomes the current one.
    fn fused(&mut self, pass: &mut wgpu::ComputePass<'_>, k: u32) {
        pass.set_pipeline(&self.pipes.pipelines[kernel::FUSED_STEP]);
        pass.set_bind_group(0, self.binds.at(self.odd, kernel::FUSED_STEP), &[]);
        pass.set_immediates(0, bytemuck::bytes_of(&k));
        let (x, y) = dispatch_size(kernel::FUSED_STEP, self.groups, self.row);
        pass.dispatch_workgroups(x, y, 1);
        self.dispatches += 1;
        self.fused_steps += 1;
        self.odd = !self.odd;
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
    /// Per step taken, which copy of the state its drift wrote (one-dispatch steps alternate).
    parity: Vec<bool>,
    /// Which copy the next recorded kernel reads.
    odd: bool,
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
