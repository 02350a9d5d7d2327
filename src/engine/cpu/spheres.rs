//! The sphere path's chunk: the step loop of velocity Verlet over the half lists (pick, pair
//! pass, sums with kick and drift, skin tests), and the chunk's opening kick and drift.

use rayon::prelude::*;

use super::kinematics;
use super::particle::Status;
use super::skin::DisplacementBound;
use super::verlet;
use super::{CpuEngine, MIN_LEN, NEAR, NEAR_LIMIT};
use crate::engine::backend::{ChunkReport, EngineError};
use crate::engine::real::Real;
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
        let mut watch = SkinWatch::new(self);
        let mut moved = watch.opened;
        let mut repick = true;
        for k in 0..steps {
            let t_next = self.state.time + self.config.dt_s;
            if died {
                live -= self.bury_dying(t_next, &mut report.removed);
            }
            if moved {
                self.rebuild_half(true);
                watch.bound.rebuilt();
                repick = true;
            }
            if repick {
                self.pick_pairs();
                watch.near_bound.rebuilt();
            }
            let ov_pairs = self.pair_pass();
            let step = self.state.step;
            self.state.time = t_next;
            self.state.step += 1;
            let last = k + 1 == steps;
            let swept = if last {
                self.sum_kick_drift(half, false)
            } else {
                self.sum_kick_drift(self.dt, true)
            };
            (moved, repick) = if last {
                (false, false)
            } else {
                self.skin_tests(&mut watch, swept.v_max2.to_f64().sqrt())
            };
            self.check_history_room(swept.fullest, step)?;
            died = swept.died;
            let ov = ov_pairs.max(swept.wall_overlap).to_f64();
            if ov > self.watchdog.max_overlap_ratio {
                // The report reads the state, which holds the motion only once `kin` is back.
                kinematics::scatter_to(&self.kin, &mut self.state);
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
        Ok(())
    }

    /// After a step's drift: whether the lists must be rebuilt (a particle moved half the skin
    /// since they were built) and, if not, whether the near pairs must be picked again (one
    /// moved `NEAR_LIMIT` of the near margin since the last pick). Each exact measurement runs
    /// only when its bound, advanced by the fastest speed, says it might be due (skin.rs).
    fn skin_tests(&mut self, watch: &mut SkinWatch<R>, v_max: f64) -> (bool, bool) {
        let dt = self.config.dt_s;
        if watch.bound.drifted(v_max, dt) {
            let d = self.measure_displacements(false, watch.half_skin);
            watch.bound.measured(d.max, d.scale + watch.skin);
            if d.beyond {
                return (true, false);
            }
        }
        if watch.near_bound.drifted(v_max, dt) {
            let d = self.measure_displacements(true, watch.near_limit);
            watch.near_bound.measured(d.max, d.scale + watch.near);
            return (false, d.beyond);
        }
        (false, false)
    }

    /// Fails at the step where the history table would not hold this step's contacts (as the
    /// GPU does), not when the chunk writes the table back.
    pub(super) fn check_history_room(&self, fullest: u32, step: u64) -> Result<(), EngineError> {
        if self.slots == 0 || fullest as usize <= self.slots {
            return Ok(());
        }
        let i = (0..self.state.len())
            .find(|&i| self.contacts[i] as usize > self.slots)
            .unwrap_or(0);
        Err(EngineError::HistoryFull {
            id: self.state.id[i],
            slots: self.slots,
            step,
        })
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
                s.pos_lo.par_iter_mut(),
                s.force.par_iter(),
                s.inv_mass.par_iter(),
                alive.par_iter_mut(),
            )
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|(v, x, lo, &f, &im, a)| {
                    if im == R::zero() || *a != Status::Alive {
                        return false;
                    }
                    verlet::kick(v, f, im, g, kick);
                    verlet::drift(x, lo, *v, dt, &periodic);
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

/// The two displacement bounds of a chunk of sphere steps: the lists' (half the skin since they
/// were built) and the near pairs' (`NEAR_LIMIT` of the near margin since the last pick).
struct SkinWatch<R: Real> {
    bound: DisplacementBound,
    near_bound: DisplacementBound,
    skin: f64,
    near: f64,
    half_skin: R,
    near_limit: R,
    /// Some particle lay beyond half the skin at the chunk's opening.
    opened: bool,
}

impl<R: Real> SkinWatch<R> {
    /// Measures the opening drift against the lists' reference positions.
    fn new(engine: &mut CpuEngine<R>) -> Self {
        let skin = engine.skin.to_f64();
        let half_skin = engine.skin * R::from_f64(0.5);
        let d = engine.measure_displacements(false, half_skin);
        let near = skin * NEAR;
        // The near bound measures from 0.9 of its limit (`DisplacementBound` measures at 0.45
        // of the skin it is given), not at it: otherwise every later step would measure.
        Self {
            bound: DisplacementBound::new(skin, d.max, d.scale, R::EPSILON),
            near_bound: DisplacementBound::new(
                near * NEAR_LIMIT * 2.0 * 0.9,
                0.0,
                d.scale,
                R::EPSILON,
            ),
            skin,
            near,
            half_skin,
            near_limit: engine.skin * R::from_f64(NEAR * NEAR_LIMIT),
            opened: d.beyond,
        }
    }
}
