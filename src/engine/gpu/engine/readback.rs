//! Reading back: states, contact records and kinetic energies of the jobs, as the device holds
//! them.

use super::*;

impl GpuEngine {
    /// Every job's live particles, read back.
    pub(super) fn read_states(&self) -> Result<Vec<State<f64>>, EngineError> {
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

    /// Every contact of job j's current state, each once, computed on the device by the contact
    /// kernel's own arithmetic (nothing changes): in the order of a download's particles, each
    /// particle's partners by id, then its walls.
    ///
    /// # Errors
    /// A failed dispatch or read-back.
    pub fn contact_records_job(&mut self, j: usize) -> Result<Vec<ContactRecord>, EngineError> {
        let row = self.row_groups();
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
                pass.set_bind_group(0, run.binds.at(false, k), &[]);
                let (x, y) = dispatch_size(k, groups, row);
                pass.dispatch_workgroups(x, y, 1);
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
}

/// A job's kinetic energy from `energy_sum`'s workgroup sums (low, high words) of particle
/// energies in units of 2^(e − KE_BITS), 2^e bounding the largest (`max_bits`, its f32 bits).
pub(super) fn fixed_point_energy(sums: &[[u32; 2]], max_bits: u32) -> f64 {
    let total: u128 = sums
        .iter()
        .map(|&[lo, hi]| ((hi as u128) << 32) | lo as u128)
        .sum();
    let exponent = ((max_bits >> 23) & 0xff) as i32 - 126;
    total as f64 * 2f64.powi(exponent - KE_BITS)
}
