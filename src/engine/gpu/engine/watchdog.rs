//! The energy watchdog on the device, with the CPU engine's criterion (`engine/watchdog.rs`):
//! K₁ is the chunk's closing kinetic-energy sum, U₀ the elastic energy `contact_energy` sums right
//! after the chunk's opening list build, K₀ the previous chunk's K₁ (at the first chunk after an
//! upload, the uploaded state's). The mobile mass and the wall speed are fixed at the upload; the
//! mass loses what the sink removes.

use super::*;
use crate::engine::walls::WallShape;
use crate::engine::watchdog::{wall_speed, EnergyBudget};

/// What a job's budgets need besides its energies.
#[derive(Clone, Copy, Debug)]
pub(super) struct BudgetBase {
    /// K of the uploaded state (J): K₀ of the first chunk.
    pub kinetic_at_upload_j: f64,
    /// M of the live mobile particles (kg).
    pub mobile_mass_kg: f64,
    /// v_w (m/s), `wall_speed_bound`.
    pub wall_speed_m_per_s: f64,
}

impl BudgetBase {
    pub(super) fn of(config: &EngineConfig, s: &State<f64>) -> Self {
        Self {
            kinetic_at_upload_j: s.kinetic_energy(),
            mobile_mass_kg: (0..s.len())
                .filter(|&i| s.inv_mass[i] != 0.0)
                .map(|i| s.mass[i])
                .sum(),
            wall_speed_m_per_s: wall_speed_bound(config, s),
        }
    }
}

/// v_w for every chunk of an upload: the device keeps no positions on the host, so the CPU's
/// per-chunk reach (`wall_speed`) is taken at the upload and widened to every cylinder wall's
/// rim, which confines the particles of a silo however they move.
fn wall_speed_bound(config: &EngineConfig, s: &State<f64>) -> f64 {
    let reach_of = |i: usize| s.radius[i] + s.half_length.get(i).copied().unwrap_or(0.0);
    let particle_reach = (0..s.len())
        .filter(|&i| s.inv_mass[i] != 0.0)
        .map(reach_of)
        .fold(0.0, f64::max);
    let mut v = wall_speed(&config.walls, s);
    for rot in config.walls.iter().filter_map(|w| w.rotation) {
        for w in &config.walls {
            if let WallShape::Cylinder {
                axis_xy, radius, ..
            } = w.shape
            {
                let apart = (axis_xy[0] - rot.axis_xy[0]).hypot(axis_xy[1] - rot.axis_xy[1]);
                let rim = apart + radius + particle_reach;
                v = v.max(rot.omega_rad_per_s.abs() * rim);
            }
        }
    }
    v
}

impl GpuEngine {
    /// Whether chunks check the energy (`Watchdog::max_kinetic_growth` finite), and so sum U₀.
    pub(super) fn checks_energy(&self) -> bool {
        self.options.watchdog.max_kinetic_growth.is_finite()
    }

    /// K₁ / B of job j's chunk of `steps` from step `step0`, or `EnergyBlowUp` past the limit.
    pub(super) fn energy_check(
        &self,
        job: &JobRun,
        j: usize,
        step0: u64,
        steps: u64,
        elastic_j: f64,
        kinetic_end_j: f64,
    ) -> Result<f64, EngineError> {
        let c = &self.configs[j];
        let g = c.gravity;
        let g = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        let budget = EnergyBudget {
            kinetic_j: job.energy.unwrap_or(job.budget.kinetic_at_upload_j),
            elastic_j,
            mobile_mass_kg: job.budget.mobile_mass_kg,
            speed_gain_m_per_s: g * steps as f64 * c.dt_s + job.budget.wall_speed_m_per_s,
            first_step: step0 + 1,
        };
        budget.check(
            kinetic_end_j,
            step0 + steps,
            self.options.watchdog.max_kinetic_growth,
        )
    }
}

impl GpuEngine {
    /// Job j's elastic energy stored in the contacts (J), summed on the device as a chunk's
    /// start sums U₀: normal springs plus tangential springs as stored. Uses the lists the last
    /// chunk left (valid at its end); 0 before the first chunk of an upload.
    ///
    /// # Errors
    /// A failed dispatch or read-back.
    pub fn elastic_energy_job(&mut self, j: usize) -> Result<f64, EngineError> {
        let Some(run) = self.run.as_ref() else {
            return Ok(0.0);
        };
        if run.jobs[j].energy.is_none() {
            return Ok(0.0);
        }
        let word = (j * STATUS_WORDS + ST_U_MAX) as u64 * 4;
        self.dev
            .queue
            .write_buffer(&run.bufs.status, word, bytemuck::bytes_of(&0u32));
        let groups = (run.bufs.n as u32).div_ceil(WORKGROUP_SIZE);
        let mut enc = self
            .dev
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("elastic energy"),
            });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("elastic energy"),
                timestamp_writes: None,
            });
            for k in [kernel::CONTACT_ENERGY, kernel::ELASTIC_SUM] {
                pass.set_pipeline(&self.pipes.pipelines[k]);
                pass.set_bind_group(0, run.binds.at(false, k), &[]);
                let (x, y) = dispatch_size(k, groups, self.row_groups());
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        self.dev.queue.submit([enc.finish()]);
        let per_job = run.n_job as u64 / WORKGROUP_SIZE as u64;
        let at = (run.bufs.n as u64 + 2 * (groups as u64 + j as u64 * per_job)) * 4;
        let raw = buffers::read_at(&self.dev, &run.bufs.energy, at, per_job * 8)?;
        let max = buffers::read_at(&self.dev, &run.bufs.status, word, 4)?;
        let sums: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&raw);
        let max = u32::from_le_bytes([max[0], max[1], max[2], max[3]]);
        Ok(super::readback::fixed_point_energy(&sums, max))
    }
}
