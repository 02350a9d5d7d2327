//! The CPU backend: velocity Verlet over rayon, generic over the precision. Each particle gathers
//! the forces on itself from its full neighbour list (`gather.rs`; `oriented.rs` for rods) and
//! updates only its own contact history, so results are bitwise identical for any thread count.

use rayon::prelude::*;

use super::backend::{Backend, BackendInfo, ChunkReport, EngineError, SinkEvent};
use super::config::EngineConfig;
use super::contact::{ContactRecord, LawKernel};
use super::gather::ForceContext;
use super::grid::{self, NeighbourList, Periodic};
use super::history::{Rows, MAX_SLOTS};
use super::oriented;
use super::real::{Real, V3};
use super::state::State;
use super::walls::WallKernel;
pub use super::watchdog::Watchdog;
use super::watchdog::{wall_speed, EnergyBudget};

/// Smallest piece of work a rayon task takes: small runs stay on one thread.
const MIN_LEN: usize = 512;
pub(super) const ALIVE: u8 = 1;
const DYING: u8 = 2;
const DEAD: u8 = 0;

/// Number of history slots per particle (spheres rarely exceed 12 contacts plus walls).
pub const HISTORY_SLOTS: usize = 16;
const _: () = assert!(HISTORY_SLOTS <= MAX_SLOTS);

/// The CPU engine in precision `R`.
pub struct CpuEngine<R: Real> {
    pub state: State<R>,
    config: EngineConfig,
    law_pp: LawKernel<R>,
    law_pw: LawKernel<R>,
    walls: Vec<WallKernel<R>>,
    periodic: Periodic<R>,
    gravity: V3<R>,
    dt: R,
    skin: R,
    sink_z: Option<R>,
    list: NeighbourList<R>,
    /// ALIVE, or DYING (fell through the sink this step, to be reported) or DEAD.
    alive: Vec<u8>,
    // Scratch, per particle: new force, new torque, contact count.
    f_new: Vec<V3<R>>,
    t_new: Vec<V3<R>>,
    contacts: Vec<u32>,
    /// Shared so `advance` can enter it once per chunk: the per-step parallel passes then run
    /// inside the pool instead of handing work over to it several times a step.
    pool: std::sync::Arc<rayon::ThreadPool>,
    threads: usize,
    pub watchdog: Watchdog,
}

impl<R: Real> CpuEngine<R> {
    /// A new engine; `threads` = 0 uses all cores.
    pub fn new(config: EngineConfig, state: State<R>, threads: usize) -> Self {
        let pool: std::sync::Arc<rayon::ThreadPool> = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool")
            .into();
        let threads = pool.current_num_threads();
        let periodic = Periodic {
            x: config
                .periodic_x
                .map(|[a, b]| (R::from_f64(a), R::from_f64(b))),
            y: config
                .periodic_y
                .map(|[a, b]| (R::from_f64(a), R::from_f64(b))),
        };
        Self {
            law_pp: config.particle_law.kernel(),
            law_pw: config.wall_law.kernel(),
            walls: config.walls.iter().map(|w| w.kernel()).collect(),
            periodic,
            gravity: V3::from_f64(config.gravity),
            dt: R::from_f64(config.dt_s),
            skin: R::from_f64(config.skin_m),
            sink_z: config.sink_z.map(R::from_f64),
            list: NeighbourList::default(),
            alive: Vec::new(),
            f_new: Vec::new(),
            t_new: Vec::new(),
            contacts: Vec::new(),
            pool,
            threads,
            watchdog: Watchdog::default(),
            state,
            config,
        }
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    /// Removes dead particles, sorts by cell and rebuilds the neighbour lists.
    fn rebuild(&mut self) {
        self.compact();
        let (periodic, skin) = (self.periodic, self.skin);
        let state = &mut self.state;
        let list = &mut self.list;
        self.pool
            .install(|| grid::build(state, &periodic, skin, list));
        self.alive = vec![ALIVE; self.state.len()];
    }

    /// Drops dead particles from the state (order preserved).
    fn compact(&mut self) {
        if self.alive.len() == self.state.len() && self.alive.iter().any(|&a| a != ALIVE) {
            let keep: Vec<bool> = self.alive.iter().map(|&a| a == ALIVE).collect();
            self.state.retain(&keep);
            self.alive = vec![ALIVE; self.state.len()];
            self.list.ref_pos.clear();
        }
    }

    /// Contact forces and torques on every particle, from the current positions and velocities.
    fn compute_forces(&mut self) -> Result<R, EngineError> {
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

        let full = self.pool.install(|| {
            if self.state.oriented && slots == 0 {
                return self
                    .f_new
                    .par_iter_mut()
                    .zip(self.t_new.par_iter_mut())
                    .zip(self.contacts.par_iter_mut())
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
            if self.state.oriented {
                let out = self
                    .f_new
                    .par_iter_mut()
                    .zip(self.t_new.par_iter_mut())
                    .zip(self.contacts.par_iter_mut());
                return out
                    .zip(
                        hist.partner
                            .par_chunks_mut(slots)
                            .zip(hist.spring.par_chunks_mut(slots)),
                    )
                    .enumerate()
                    .with_min_len(MIN_LEN)
                    .map(|(i, (((f, t), nc), (p, s)))| {
                        let mut rows = Rows::open(p, s);
                        let r =
                            ctx.oriented(i)
                                .particle::<false>(i, Some(&mut rows), &mut Vec::new());
                        *f = r.0;
                        *t = r.1;
                        *nc = r.3;
                        (r.4, r.2)
                    })
                    .reduce(|| (false, R::zero()), |a, b| (a.0 || b.0, a.1.max(b.1)));
            }
            let out = self
                .f_new
                .par_iter_mut()
                .zip(self.t_new.par_iter_mut())
                .zip(self.contacts.par_iter_mut());
            if slots > 0 {
                out.zip(
                    hist.partner
                        .par_chunks_mut(slots)
                        .zip(hist.spring.par_chunks_mut(slots)),
                )
                .enumerate()
                .with_min_len(MIN_LEN)
                .map(|(i, (((f, t), nc), (p, s)))| {
                    let mut rows = Rows::open(p, s);
                    let r = ctx.particle::<false>(i, Some(&mut rows), &mut Vec::new());
                    *f = r.0;
                    *t = r.1;
                    *nc = r.3;
                    (r.4, r.2)
                })
                .reduce(|| (false, R::zero()), |a, b| (a.0 || b.0, a.1.max(b.1)))
            } else {
                out.enumerate()
                    .with_min_len(MIN_LEN)
                    .map(|(i, ((f, t), nc))| {
                        let r = ctx.particle::<false>(i, None, &mut Vec::new());
                        *f = r.0;
                        *t = r.1;
                        *nc = r.3;
                        (r.4, r.2)
                    })
                    .reduce(|| (false, R::zero()), |a, b| (a.0 || b.0, a.1.max(b.1)))
            }
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

    /// Kick by `kick` (dt/2 at a chunk's first step, dt after: the previous step's closing
    /// half kick and this step's opening one fused), then drift; flags particles that fell
    /// through the sink. Returns (some particle died, the lists need a rebuild).
    fn kick_drift(&mut self, kick: R) -> (bool, bool) {
        let dt = self.dt;
        let g = self.gravity;
        let periodic = self.periodic;
        let sink = self.sink_z;
        let half2 = self.skin * self.skin * R::from_f64(0.25);
        let s = &mut self.state;
        let alive = &mut self.alive;
        let refs = &self.list.ref_pos;
        let stale = refs.len() != s.pos.len();
        if s.oriented {
            let ref_axis = &self.list.ref_axis;
            let stale = stale || ref_axis.len() != s.pos.len();
            let half_skin = self.skin * R::from_f64(0.5);
            return self.pool.install(|| {
                (
                    (
                        s.vel.par_iter_mut(),
                        s.pos.par_iter_mut(),
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
                    .map(|(i, ((v, x, &f, &im, a), (q, l, w, &t, &ii, &h)))| {
                        if im == R::zero() || *a != ALIVE {
                            return (false, false);
                        }
                        *v += (f * im + g) * kick;
                        *x += *v * dt;
                        periodic.wrap(x);
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
                            *a = DYING;
                        }
                        // The ends of a rod move by at most |Δc| + (l/2)|Δu|.
                        let moved =
                            stale || periodic.delta(refs[i], *x).norm() + turned > half_skin;
                        (died, moved)
                    })
                    .reduce(|| (false, false), |p, q| (p.0 || q.0, p.1 || q.1))
            });
        }
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
                .enumerate()
                .with_min_len(MIN_LEN)
                .map(|(i, (v, x, &f, &im, a))| {
                    if im == R::zero() || *a != ALIVE {
                        return (false, false);
                    }
                    *v += (f * im + g) * kick;
                    *x += *v * dt;
                    periodic.wrap(x);
                    let died = matches!(sink, Some(zs) if x.z < zs);
                    if died {
                        *a = DYING;
                    }
                    let moved = stale || periodic.delta(refs[i], *x).norm2() > half2;
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
                    if im != R::zero() && a == ALIVE {
                        *v += (f * im + g) * half;
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

    /// One velocity-Verlet step (with the closing half kick deferred, see `kick_drift`).
    fn step(&mut self, kick: R, removed: &mut Vec<SinkEvent>) -> Result<f64, EngineError> {
        let (died, moved) = self.kick_drift(kick);
        let t_next = self.state.time + self.config.dt_s;
        if died {
            let s = &self.state;
            for i in 0..s.len() {
                if self.alive[i] == DYING {
                    removed.push(SinkEvent {
                        id: s.id[i],
                        mass_kg: s.mass[i].to_f64(),
                        time_s: t_next,
                    });
                    self.alive[i] = DEAD;
                }
            }
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

    /// A gather over the current lists that reads forces without advancing any spring (dt = 0):
    /// what contact records and the elastic energy need.
    fn reading_context(&self) -> ForceContext<'_, R> {
        ForceContext {
            s: &self.state,
            list: &self.list,
            alive: &self.alive,
            law_pp: &self.law_pp,
            law_pw: &self.law_pw,
            walls: &self.walls,
            periodic: &self.periodic,
            dt: R::zero(),
        }
    }

    /// Every contact of the current state, each once, with the force of the last step (the
    /// stored springs, not advanced: dt = 0), for stress observers. Runs only when asked.
    pub fn contact_records(&mut self) -> Vec<ContactRecord> {
        self.rebuild();
        let n = self.state.len();
        let slots = self.state.history.slots;
        let mut hist = self.state.history.clone();
        let ctx = self.reading_context();
        let mut out = Vec::new();
        for i in 0..n {
            let mut rows = (slots > 0).then(|| {
                Rows::open(
                    &mut hist.partner[i * slots..(i + 1) * slots],
                    &mut hist.spring[i * slots..(i + 1) * slots],
                )
            });
            if self.state.oriented {
                ctx.oriented(i).particle::<true>(i, rows.as_mut(), &mut out);
            } else {
                ctx.particle::<true>(i, rows.as_mut(), &mut out);
            }
        }
        out
    }

    /// Elastic energy stored in the contacts of the current state (J): normal springs plus
    /// tangential springs as stored (`contact::elastic_energy`). Runs only when asked.
    pub fn elastic_energy(&mut self) -> f64 {
        self.rebuild();
        self.sum_elastic_energy()
    }

    /// `elastic_energy` from the current (fresh) lists. Summed in particle order, so the same
    /// for any thread count.
    fn sum_elastic_energy(&self) -> f64 {
        let ctx = self.reading_context();
        let oriented = self.state.oriented;
        let per: Vec<f64> = self.pool.install(|| {
            (0..self.state.len())
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|i| {
                    if oriented {
                        ctx.oriented(i).elastic_energy(i)
                    } else {
                        ctx.elastic_energy(i)
                    }
                })
                .collect()
        });
        per.iter().sum()
    }

    /// The energy watchdog's budget for a chunk of `steps` starting now (`watchdog.rs`); needs
    /// fresh lists. O(N) plus one contact pass, once per chunk.
    fn energy_budget(&self, steps: u64) -> EnergyBudget {
        let s = &self.state;
        let mobile_mass_kg: f64 = (0..s.len())
            .filter(|&i| s.inv_mass[i] != R::zero())
            .map(|i| s.mass[i].to_f64())
            .sum();
        let g = self.config.gravity;
        let g = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        EnergyBudget {
            kinetic_j: s.kinetic_energy(),
            elastic_j: self.sum_elastic_energy(),
            mobile_mass_kg,
            speed_gain_m_per_s: g * steps as f64 * self.config.dt_s
                + wall_speed(&self.config.walls, s),
            first_step: s.step + 1,
        }
    }

    fn check_finite(&self) -> Result<(), EngineError> {
        let s = &self.state;
        for i in 0..s.len() {
            if self.alive[i] != ALIVE {
                continue;
            }
            let what = if !s.pos[i].is_finite() {
                "position"
            } else if !s.vel[i].is_finite() {
                "velocity"
            } else if s.rotation && !s.omega[i].is_finite() {
                "angular velocity"
            } else if s.oriented && !(s.orientation[i].norm2().is_finite()) {
                "orientation"
            } else {
                continue;
            };
            return Err(EngineError::NonFinite {
                what,
                id: s.id[i],
                step: s.step,
                time_s: s.time,
            });
        }
        Ok(())
    }
}

impl<R: Real> Backend for CpuEngine<R> {
    fn advance(&mut self, steps: u64) -> Result<ChunkReport, EngineError> {
        let mut report = ChunkReport::default();
        let builds0 = self.list.builds;
        // NOTE: a chunk always starts from a fresh sort and list, so that a run resumed from a
        // checkpoint (taken between chunks) follows exactly the same operations as one that never
        // stopped.
        let pool = self.pool.clone();
        let check_energy = steps > 0 && self.watchdog.max_kinetic_growth.is_finite();
        let mut budget = None;
        pool.install(|| -> Result<(), EngineError> {
            self.rebuild();
            if check_energy {
                budget = Some(self.energy_budget(steps));
            }
            let half = self.dt * R::from_f64(0.5);
            // Particle-steps count mobile particles only (fixed base particles are not integrated).
            let mut live = self
                .state
                .inv_mass
                .iter()
                .filter(|&&m| m != R::zero())
                .count() as u64;
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
        })?;
        self.check_finite()?;
        // Dead particles leave the state before anyone sees it (observers, checkpoints).
        let n_before = self.state.len();
        self.compact();
        if self.state.len() != n_before {
            self.contacts.clear();
        }
        let n = self.contacts.len().max(1);
        report.contacts_per_particle =
            self.contacts.iter().map(|&c| c as f64).sum::<f64>() / n as f64;
        report.list_builds = self.list.builds - builds0;
        // NOTE: after the finiteness check (a NaN must be reported as such) and the compaction
        // (particles removed by the sink no longer count).
        if let Some(b) = budget {
            let k1 = self.state.kinetic_energy();
            let growth = b.check(k1, self.state.step, self.watchdog.max_kinetic_growth)?;
            report.kinetic_growth = Some(growth);
        }
        Ok(report)
    }

    fn download(&mut self) -> State<f64> {
        self.state.convert()
    }

    fn upload(&mut self, state: &State<f64>) {
        self.state = state.convert();
        self.alive = vec![ALIVE; self.state.len()];
        self.list = NeighbourList::default();
    }

    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError> {
        Ok(self.contact_records())
    }

    fn describe(&self) -> BackendInfo {
        BackendInfo {
            kind: "cpu".into(),
            precision: R::NAME.into(),
            adapter: format!("rayon, {} threads", self.threads),
            threads: self.threads,
        }
    }
}
