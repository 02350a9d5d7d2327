//! The sphere path's chunk: the step loop of velocity Verlet over the half lists (pick, pair
//! pass, sums with kick and drift, skin tests), and the chunk's opening kick and drift.

use rayon::prelude::*;

use super::{CpuEngine, MIN_LEN, NEAR, NEAR_LIMIT};
use crate::engine::backend::{ChunkReport, EngineError};
use crate::engine::kinematics;
use crate::engine::particle::Status;
use crate::engine::real::Real;
use crate::engine::skin::DisplacementBound;
use crate::engine::watchdog::EnergyBudget;

impl<R: Real> CpuEngine<R> {
    /// A chunk of sphere steps: velocity Verlet with the closing half kick of each step fused
    /// with the next step's opening one, and the force sums fused with the kick and drift (one
    /// pass over the particles per step besides the pair pass).
    pub(super) fn advance_spheres(
        &mut self,
        steps: u64,
        report: &mut ChunkReport,
        budget: &mut Option<EnergyBudget>,
        check_energy: bool,
    ) -> Result<(), EngineError> {
        let r = self.sphere_steps(steps, report, budget, check_energy);
        // Whatever happened, the state holds the motion again (errors report from it).
        kinematics::scatter_to(&self.kin, &mut self.state);
        r
    }

    /// `advance_spheres` with the motion in `kin`.
    fn sphere_steps(
        &mut self,
        steps: u64,
        report: &mut ChunkReport,
        budget: &mut Option<EnergyBudget>,
        check_energy: bool,
    ) -> Result<(), EngineError> {
        // NOTE: a chunk always starts from a fresh sort and list built from the state's own
        // history table, so that a run resumed from a checkpoint (taken between chunks) follows
        // exactly the same operations as one that never stopped.
        self.rebuild_half(false);
        if check_energy {
            *budget = Some(self.energy_budget_spheres(steps));
        }
        if steps == 0 {
            return Ok(());
        }
        let half = self.dt * R::from_f64(0.5);
        let mut live = self.mobile_count();
        let mut died = self.open_spheres(half);
        let alive = &self.alive;
        kinematics::gather_from(&mut self.kin, &self.state, |i| alive[i] == Status::Alive);
        let (skin, dt) = (self.skin.to_f64(), self.config.dt_s);
        let half_skin = self.skin * R::from_f64(0.5);
        let (mut moved, max_moved, scale) = self.measure_displacements(false, half_skin);
        let mut bound = DisplacementBound::new(skin, max_moved, scale, R::EPSILON);
        // The pair pass tests only the entries picked within the near margin; they are picked
        // again before a particle has moved `NEAR_LIMIT` of that margin since the last pick.
        let near = skin * NEAR;
        let near_limit = self.skin * R::from_f64(NEAR * NEAR_LIMIT);
        // Its exact measurement is taken from 0.9 of that (`DisplacementBound` measures at 0.45
        // of the skin it is given), not at it: otherwise every later step would measure.
        let mut near_bound =
            DisplacementBound::new(near * NEAR_LIMIT * 2.0 * 0.9, 0.0, scale, R::EPSILON);
        let mut repick = true;
        for k in 0..steps {
            let t_next = self.state.time + self.config.dt_s;
            if died {
                live -= self.bury_dying(t_next, &mut report.removed);
            }
            if moved {
                self.rebuild_half(true);
                bound.rebuilt();
                repick = true;
            }
            if repick {
                self.pick_pairs();
                near_bound.rebuilt();
                repick = false;
            }
            let ov_pairs = self.pair_pass();
            let step = self.state.step;
            self.state.time = t_next;
            self.state.step += 1;
            let last = k + 1 == steps;
            let (d, v_max2, ov_walls, fullest) = if last {
                self.sum_kick_drift(half, false)
            } else {
                self.sum_kick_drift(self.dt, true)
            };
            // The exact skin test only when the bound nears half the skin (skin.rs).
            let mut m = false;
            if !last && bound.drifted(v_max2.to_f64().sqrt(), dt) {
                let (beyond, max_moved, scale) = self.measure_displacements(false, half_skin);
                m = beyond;
                bound.measured(max_moved, scale + skin);
            }
            if !last && !m && near_bound.drifted(v_max2.to_f64().sqrt(), dt) {
                let (beyond, max_moved, scale) = self.measure_displacements(true, near_limit);
                repick = beyond;
                near_bound.measured(max_moved, scale + near);
            }
            // The history table would not hold this step's contacts: fail now, at the step
            // where it happens (as the GPU does), not when the chunk writes the table back.
            if self.slots > 0 && fullest as usize > self.slots {
                let i = (0..self.state.len())
                    .find(|&i| self.contacts[i] as usize > self.slots)
                    .unwrap_or(0);
                return Err(EngineError::HistoryFull {
                    id: self.state.id[i],
                    slots: self.slots,
                    step,
                });
            }
            (died, moved) = (d, m);
            let ov = ov_pairs.max(ov_walls).to_f64();
            if ov > self.watchdog.max_overlap_ratio {
                return Err(EngineError::Overlap {
                    ratio: ov,
                    limit: self.watchdog.max_overlap_ratio,
                    step: self.state.step,
                });
            }
            report.max_overlap_ratio = report.max_overlap_ratio.max(ov);
            report.steps += 1;
            report.particle_steps += live;
        }
        Ok(())
    }

    /// Spheres, at a chunk's opening: kick by `kick`, then drift; flags particles that fell
    /// through the sink and returns whether one did. The lists' skin test is then
    /// `measure_displacements`, on the packed motion.
    fn open_spheres(&mut self, kick: R) -> bool {
        let (dt, g, periodic, sink) = (self.dt, self.gravity, self.periodic, self.sink_z);
        let (s, alive) = (&mut self.state, &mut self.alive);
        self.pool.install(|| {
            if s.rotation {
                (
                    s.omega.par_iter_mut(),
                    s.torque.par_iter(),
                    s.inv_inertia.par_iter(),
                )
                    .into_par_iter()
                    .with_min_len(MIN_LEN)
                    .for_each(|(w, &t, &ii)| {
                        *w += t * (ii * kick);
                    });
            }
            (
                s.vel.par_iter_mut(),
                s.pos.par_iter_mut(),
                s.force.par_iter(),
                s.inv_mass.par_iter(),
                alive.par_iter_mut(),
            )
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|(v, x, &f, &im, a)| {
                    if im == R::zero() || *a != Status::Alive {
                        return false;
                    }
                    *v += (f * im + g) * kick;
                    *x += *v * dt;
                    periodic.wrap(x);
                    let died = matches!(sink, Some(zs) if x.z < zs);
                    if died {
                        *a = Status::Dying;
                    }
                    died
                })
                .reduce(|| false, |p, q| p || q)
        })
    }
}
