//! Per-pass GPU timings from timestamp queries, for `sweep bench`: a chunk's passes (its opening
//! build, the energy watchdog's sum, `steps` steps and the closing passes) each recorded in its
//! own compute pass whose start and end the device stamps. Where the device was not created with
//! `TIMESTAMP_QUERY` (the adapter lacks it) there is nothing to time. The state is put back
//! afterwards (download before, upload after), so the run goes on as if never profiled.

use super::*;
use crate::engine::backend::PassTime;

/// Most passes one query set times (two stamps each, within wgpu's 4 096 queries per set).
const PASSES_PER_SET: usize = 2048;

impl GpuEngine {
    /// The GPU time of each kernel over one chunk of `steps` steps from the current state (None
    /// without timestamp queries). Steps after the lists went stale return at once on the device;
    /// the result says how many were timed before that.
    ///
    /// # Errors
    /// A failed dispatch or read-back.
    pub fn profile_passes(&mut self, steps: u64) -> Result<Option<Vec<PassTime>>, EngineError> {
        if !self
            .dev
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            return Ok(None);
        }
        let Some(run) = &self.run else {
            return Ok(Some(Vec::new()));
        };
        let keep = self.read_states()?;
        let initial: Vec<u32> = (0..self.jobs()).flat_map(|_| status_initial()).collect();
        self.dev
            .queue
            .write_buffer(&run.bufs.status, 0, bytemuck::cast_slice(&initial));
        let passes = self.profiled_passes(run, steps);
        let row = self.row_groups();
        let period = self.dev.queue.get_timestamp_period() as f64;
        let mut ns = vec![0.0f64; passes.len()];
        for (set, chunk) in passes.chunks(PASSES_PER_SET).enumerate() {
            let queries = 2 * chunk.len() as u32;
            let qs = self.dev.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timings"),
                ty: wgpu::QueryType::Timestamp,
                count: queries,
            });
            let bytes = queries as u64 * 8;
            let resolved = self.dev.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pass timings"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let mut enc = self
                .dev
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("profiled passes"),
                });
            for (q, &(k, groups, odd, step)) in chunk.iter().enumerate() {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(KERNELS[k].entry),
                    timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                        query_set: &qs,
                        beginning_of_pass_write_index: Some(2 * q as u32),
                        end_of_pass_write_index: Some(2 * q as u32 + 1),
                    }),
                });
                pass.set_pipeline(&self.pipes.pipelines[k]);
                pass.set_bind_group(0, run.binds.at(odd, k), &[]);
                if let Some(step) = step {
                    pass.set_immediates(0, bytemuck::bytes_of(&step));
                }
                let (x, y) = dispatch_size(k, groups, row);
                pass.dispatch_workgroups(x, y, 1);
            }
            enc.resolve_query_set(&qs, 0..queries, &resolved, 0);
            self.dev.queue.submit([enc.finish()]);
            let raw = buffers::read_at(&self.dev, &resolved, 0, bytes)?;
            let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(&raw);
            for (q, pair) in stamps.chunks_exact(2).enumerate() {
                ns[set * PASSES_PER_SET + q] = pair[1].saturating_sub(pair[0]) as f64 * period;
            }
        }
        let stale = buffers::read_at(&self.dev, &run.bufs.status, ST_STALE as u64 * 4, 4)?;
        let stale = u32::from_le_bytes([stale[0], stale[1], stale[2], stale[3]]);
        let mut out: Vec<PassTime> = Vec::new();
        for (&(k, ..), t) in passes.iter().zip(&ns) {
            let name = KERNELS[k].entry;
            match out.iter_mut().find(|p| p.kernel == name) {
                Some(p) => {
                    p.calls += 1;
                    p.ns += t;
                }
                None => out.push(PassTime {
                    kernel: name.to_string(),
                    calls: 1,
                    ns: *t,
                    steps_timed: steps,
                }),
            }
        }
        if stale != u32::MAX {
            for p in &mut out {
                p.steps_timed = stale as u64;
            }
        }
        // Back to the state before: the profiled steps never happened.
        let states: Vec<&State<f64>> = keep.iter().collect();
        self.load(&states)?;
        Ok(Some(out))
    }

    /// The (kernel, workgroups, the copy of the state it reads, the one-dispatch step's index)
    /// of a chunk as `submit` records it, without a rebuild mid-chunk.
    fn profiled_passes(&self, run: &Run, steps: u64) -> Vec<(usize, u32, bool, Option<u32>)> {
        let gp = (run.bufs.n as u32).div_ceil(WORKGROUP_SIZE);
        let mut v: Vec<(usize, u32, bool, Option<u32>)> = super::chunk::build_passes(run)
            .into_iter()
            .map(|(k, g)| (k, g, false, None))
            .collect();
        if self.checks_energy() {
            v.push((kernel::CONTACT_ENERGY, gp, false, None));
            v.push((kernel::ELASTIC_SUM, gp, false, None));
        }
        let mut odd = false;
        if self.pipes.fused && steps > 0 {
            v.push((kernel::KICK_DRIFT, gp, false, None));
            for k in 1..steps as u32 {
                v.push((kernel::FUSED_STEP, gp, odd, Some(k)));
                odd = !odd;
            }
            v.push((kernel::COMPUTE_FORCES, gp, odd, None));
        } else {
            for _ in 0..steps {
                v.push((kernel::KICK_DRIFT, gp, false, None));
                v.push((kernel::COMPUTE_FORCES, gp, false, None));
            }
        }
        for k in [kernel::CLOSE_KICK, kernel::FINISH, kernel::ENERGY_SUM] {
            v.push((k, gp, odd, None));
        }
        if odd {
            v.push((kernel::ADOPT, gp, true, None));
        }
        v
    }
}
