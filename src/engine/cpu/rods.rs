//! The spherocylinder (oriented) path: half lists and Newton's third law, as for spheres. Each
//! step evaluates every pair within the near margin once (`rod_pass.rs`: force and torque on
//! both rods), sums each particle's pairs in ascending order of the partner and then its walls,
//! and fuses that sum with the next step's kick, free rotation, drift and skin tests
//! (`rod_passes.rs`), in blocks on the team. The sums add the same values in the same order as
//! the full-list gather of `oriented.rs` (each pair in canonical order), and the lists are
//! rebuilt at the same steps, so the results are those of that gather, bit for bit. While a
//! chunk runs, the springs live in the pair slots and the state's table is empty
//! (`rod_lists.rs`).

use rayon::prelude::*;

use super::oriented;
use super::particle::Status;
use super::verlet;
use super::{CpuEngine, MIN_LEN};
use crate::engine::backend::{ChunkReport, EngineError};
use crate::engine::history::History;
use crate::engine::real::Real;
use crate::engine::watchdog::EnergyBudget;

impl<R: Real> CpuEngine<R> {
    /// A chunk of spherocylinder steps: velocity Verlet with the closing half kick of each step
    /// fused with the next one's opening kick (and both with the force sums), the first step
    /// opening with a half kick and the chunk closing with one (`close_kick`).
    pub(super) fn advance_rods(
        &mut self,
        steps: u64,
        report: &mut ChunkReport,
        budget: &mut Option<EnergyBudget>,
        check_energy: bool,
    ) -> Result<(), EngineError> {
        if steps == 0 {
            self.rebuild();
            if check_energy {
                *budget = Some(self.energy_budget(steps));
            }
            return Ok(());
        }
        // NOTE: a chunk always starts from a fresh sort and list built from the state's table,
        // so that a run resumed from a checkpoint follows exactly the same operations.
        self.rebuild_rods(false);
        if check_energy {
            let mut b = self.energy_budget_without_elastic(steps);
            b.elastic_j = self.rod_elastic_energy();
            *budget = Some(b);
        }
        // The table stays out of the state while the chunk runs (the slots hold the history).
        self.state.history = History::new(0);
        self.near_ref.clear();
        let half = self.dt * R::from_f64(0.5);
        let mut live = self.mobile_count();
        let mut swept = self.rod_sum_kick_drift(false, Some(half));
        let mut repick = true;
        for k in 0..steps {
            let t_next = self.state.time + self.config.dt_s;
            if swept.died {
                live -= self.bury_dying(t_next, &mut report.removed);
            }
            if swept.moved {
                self.rebuild_rods(true);
                self.state.history = History::new(0);
                repick = true;
            }
            if repick || swept.repick {
                self.pick_rods();
            }
            let ov_pairs = self.rod_pair_pass();
            let last = k + 1 == steps;
            swept = self.rod_sum_kick_drift(true, (!last).then_some(self.dt));
            repick = false;
            self.check_history_room(swept.fullest, self.state.step)?;
            self.state.time = t_next;
            self.state.step += 1;
            let ov = ov_pairs.max(swept.wall_overlap).to_f64();
            if ov > self.watchdog.max_overlap_ratio {
                return Err(EngineError::Overlap {
                    ratio: ov,
                    limit: self.watchdog.max_overlap_ratio,
                    step: self.state.step,
                    detail: format!("; {}", self.overlap_report()),
                });
            }
            report.max_overlap_ratio = report.max_overlap_ratio.max(ov);
            report.steps += 1;
            report.particle_steps += live;
        }
        self.close_kick();
        Ok(())
    }

    /// The closing half kick of a chunk, so that velocities are at full steps between chunks.
    fn close_kick(&mut self) {
        let half = self.dt * R::from_f64(0.5);
        let g = self.gravity;
        let s = &mut self.state;
        let alive = &self.alive;
        self.pool.install(|| {
            (
                s.vel.par_iter_mut(),
                s.force.par_iter(),
                s.inv_mass.par_iter(),
                alive.par_iter(),
            )
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .for_each(|(v, &f, &im, &a)| {
                    if im != R::zero() && a == Status::Alive {
                        verlet::kick(v, f, im, g, half);
                    }
                });
            if s.oriented {
                oriented::close_kick(s, half);
            } else if s.rotation {
                (
                    s.omega.par_iter_mut(),
                    s.torque.par_iter(),
                    s.inv_inertia.par_iter(),
                )
                    .into_par_iter()
                    .with_min_len(MIN_LEN)
                    .for_each(|(w, &t, &ii)| {
                        *w += t * (ii * half);
                    });
            }
        });
    }
}
