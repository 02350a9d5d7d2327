//! The spherocylinder (oriented) path: full neighbour lists, each particle gathering its own
//! forces and history rows (`oriented.rs`), one velocity-Verlet step at a time.

use rayon::prelude::*;

use super::{CpuEngine, MIN_LEN};
use crate::engine::backend::{ChunkReport, EngineError, SinkEvent};
use crate::engine::force_gather::ForceContext;
use crate::engine::history::Rows;
use crate::engine::oriented;
use crate::engine::particle::Status;
use crate::engine::real::{Real, V3};
use crate::engine::verlet;
use crate::engine::watchdog::EnergyBudget;

impl<R: Real> CpuEngine<R> {
    /// A chunk of spherocylinder steps on the full lists: `step` after `step`, the first
    /// opening with a half kick, then the closing half kick (`close_kick`).
    pub(super) fn advance_rods(
        &mut self,
        steps: u64,
        report: &mut ChunkReport,
        budget: &mut Option<EnergyBudget>,
        check_energy: bool,
    ) -> Result<(), EngineError> {
        self.rebuild();
        if check_energy {
            *budget = Some(self.energy_budget(steps));
        }
        let half = self.dt * R::from_f64(0.5);
        let mut live = self.mobile_count();
        for k in 0..steps {
            let removed_before = report.removed.len();
            let ov = self.step(if k == 0 { half } else { self.dt }, &mut report.removed)?;
            live -= (report.removed.len() - removed_before) as u64;
            report.max_overlap_ratio = report.max_overlap_ratio.max(ov);
            report.steps += 1;
            report.particle_steps += live;
        }
        if steps > 0 {
            self.close_kick();
        }
        Ok(())
    }

    /// One velocity-Verlet step (with the closing half kick deferred, see `kick_drift`).
    fn step(&mut self, kick: R, removed: &mut Vec<SinkEvent>) -> Result<f64, EngineError> {
        let (died, moved) = self.kick_drift(kick);
        let t_next = self.state.time + self.config.dt_s;
        if died {
            self.bury_dying(t_next, removed);
        }
        if moved {
            self.rebuild();
        }
        let max_ov = self.compute_forces()?.to_f64();
        self.state.time = t_next;
        self.state.step += 1;
        if max_ov > self.watchdog.max_overlap_ratio {
            return Err(EngineError::Overlap {
                ratio: max_ov,
                limit: self.watchdog.max_overlap_ratio,
                step: self.state.step,
            });
        }
        Ok(max_ov)
    }

    /// Contact forces and torques on every spherocylinder, from the current positions and
    /// velocities (full lists, each particle gathering its own).
    fn compute_forces(&mut self) -> Result<R, EngineError> {
        debug_assert!(self.state.oriented, "spheres run advance_spheres");
        let n = self.state.len();
        self.f_new.resize(n, V3::zero());
        self.t_new.resize(n, V3::zero());
        self.contacts.resize(n, 0);
        let slots = self.state.history.slots;
        // NOTE: the history is taken out of the state while the rest is read by every task; each
        // task writes only its own particle's rows.
        let mut hist = std::mem::take(&mut self.state.history);
        let ctx = ForceContext {
            s: &self.state,
            list: &self.list,
            alive: &self.alive,
            law_pp: &self.law_pp,
            law_pw: &self.law_pw,
            walls: &self.walls,
            periodic: &self.periodic,
            dt: self.dt,
        };

        // Spheres never come here: they run `advance_spheres` on the half lists.
        let full = self.pool.install(|| {
            let out = self
                .f_new
                .par_iter_mut()
                .zip(self.t_new.par_iter_mut())
                .zip(self.contacts.par_iter_mut());
            if slots == 0 {
                return out
                    .enumerate()
                    .with_min_len(MIN_LEN)
                    .map(|(i, ((f, t), nc))| {
                        let r = ctx.oriented(i).particle::<false>(i, None, &mut Vec::new());
                        *f = r.0;
                        *t = r.1;
                        *nc = r.3;
                        (r.4, r.2)
                    })
                    .reduce(|| (false, R::zero()), |a, b| (a.0 || b.0, a.1.max(b.1)));
            }
            out.zip(
                hist.partner
                    .par_chunks_mut(slots)
                    .zip(hist.spring.par_chunks_mut(slots)),
            )
            .enumerate()
            .with_min_len(MIN_LEN)
            .map(|(i, (((f, t), nc), (p, s)))| {
                let mut rows = Rows::open(p, s);
                let r = ctx
                    .oriented(i)
                    .particle::<false>(i, Some(&mut rows), &mut Vec::new());
                *f = r.0;
                *t = r.1;
                *nc = r.3;
                (r.4, r.2)
            })
            .reduce(|| (false, R::zero()), |a, b| (a.0 || b.0, a.1.max(b.1)))
        });
        self.state.history = hist;
        let (full, max_ov) = full;
        if full {
            let id = (0..n)
                .find(|&i| self.contacts[i] as usize > slots)
                .map_or(0, |i| self.state.id[i]);
            return Err(EngineError::HistoryFull {
                id,
                slots,
                step: self.state.step,
            });
        }
        std::mem::swap(&mut self.state.force, &mut self.f_new);
        if self.state.rotation {
            std::mem::swap(&mut self.state.torque, &mut self.t_new);
        }
        Ok(max_ov)
    }

    /// Oriented particles: kick by `kick` (dt/2 at a chunk's first step, dt after: the previous
    /// step's closing half kick and this step's opening one fused), then drift; flags particles
    /// that fell through the sink. Returns (some particle died, the lists need a rebuild).
    fn kick_drift(&mut self, kick: R) -> (bool, bool) {
        let (dt, g, periodic, sink) = (self.dt, self.gravity, self.periodic, self.sink_z);
        let (s, alive) = (&mut self.state, &mut self.alive);
        let refs = &self.list.ref_pos;
        let ref_axis = &self.list.ref_axis;
        let stale = refs.len() != s.pos.len() || ref_axis.len() != s.pos.len();
        let half_skin = self.skin * R::from_f64(0.5);
        self.pool.install(|| {
            (
                (
                    s.vel.par_iter_mut(),
                    s.pos.par_iter_mut(),
                    s.pos_lo.par_iter_mut(),
                    s.force.par_iter(),
                    s.inv_mass.par_iter(),
                    alive.par_iter_mut(),
                ),
                (
                    s.orientation.par_iter_mut(),
                    s.ang_mom.par_iter_mut(),
                    s.omega.par_iter_mut(),
                    s.torque.par_iter(),
                    s.inv_inertia_body.par_iter(),
                    s.half_length.par_iter(),
                ),
            )
                .into_par_iter()
                .enumerate()
                .with_min_len(MIN_LEN)
                .map(|(i, ((v, x, lo, &f, &im, a), (q, l, w, &t, &ii, &h)))| {
                    if im == R::zero() || *a != Status::Alive {
                        return (false, false);
                    }
                    verlet::kick(v, f, im, g, kick);
                    verlet::drift(x, lo, *v, dt, &periodic);
                    let turned = oriented::kick_rotate(
                        q,
                        l,
                        w,
                        t,
                        ii,
                        h,
                        (!stale).then(|| ref_axis[i]),
                        kick,
                        dt,
                    );
                    let died = matches!(sink, Some(zs) if x.z < zs);
                    if died {
                        *a = Status::Dying;
                    }
                    // The ends of a rod move by at most |Δc| + (l/2)|Δu|.
                    let moved = stale || periodic.delta(refs[i], *x).norm() + turned > half_skin;
                    (died, moved)
                })
                .reduce(|| (false, false), |p, q| (p.0 || q.0, p.1 || q.1))
        })
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
