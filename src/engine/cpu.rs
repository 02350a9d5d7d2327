//! The CPU backend: velocity Verlet over rayon, generic over the precision.
//!
//! Spheres: half Verlet lists with a skin (`grid::build_half`, rebuilt only when a particle has
//! moved half the skin, which a displacement bound watches: `skin.rs`), each pair evaluated once
//! (Newton's third law) with its tangential spring kept in the pair's entry. The pair pass runs
//! over fixed blocks of particles and adds each pair's force to i, and to j when j lies in the
//! same block; a touching pair whose partner lies in a later block hands its reaction over in
//! a list per destination block, and a second pass adds, per particle, those reactions in entry
//! order, the walls it may reach (picked at each list build), and the kick and drift. The hot
//! loops avoid branches whose outcome is a coin flip (touching or not, same block or not):
//! instruction counts and mispredicts are measured with cachegrind, which is deterministic where
//! this VM's timings are not. Every value is written by exactly one task and summed in a fixed
//! order, so results are bitwise identical for any thread count. While a chunk
//! runs, the spheres' motion lives in packed records (`kinematics.rs`). The springs go back
//! into the state's per-particle history table (keyed by partner id, the checkpoint and GPU
//! format) at the end of each `advance`, and come from it at the start of the next.
//!
//! Spherocylinders keep the full-list gather (`oriented.rs`), where each particle gathers its
//! own forces and updates only its own history rows.

use rayon::prelude::*;

use super::backend::{Backend, BackendInfo, ChunkReport, EngineError, SinkEvent};
use super::config::EngineConfig;
use super::contact::{elastic_energy, ContactRecord, LawKernel};
use super::gather::{
    ForceContext, PairBlock, PairContext, PairScratch, PairSlot, Props, SumContext, BLOCK,
};
use super::grid::{self, HalfList, NeighbourList, Periodic};
use super::history::{wall_key, History, Rows, EMPTY, MAX_SLOTS};
use super::kick::{Kick, KickBlock};
use super::kinematics::{self, Kin};
use super::oriented;
use super::real::{Real, V3};
use super::skin::DisplacementBound;
use super::state::State;
use super::team::Team;
use super::walls::WallKernel;
pub use super::watchdog::Watchdog;
use super::watchdog::{wall_speed, EnergyBudget};
use std::sync::Mutex;

/// Smallest piece of work a rayon task takes: small runs stay on one thread.
const MIN_LEN: usize = 512;
pub(super) const ALIVE: u8 = 1;
pub(super) const DYING: u8 = 2;
const DEAD: u8 = 0;

/// Number of history slots per particle (spheres rarely exceed 12 contacts plus walls).
pub const HISTORY_SLOTS: usize = 16;
/// The near margin, as a fraction of the skin: the pair pass tests only the half-list entries
/// whose pair was within this margin of touching at the last pick (`pick_pairs`). Measured
/// (cachegrind, N = 3·10⁴, 100 + 100 steps; instructions against testing every entry): 0.1
/// gives the settled silo-bed −10 % and the flowing chute-bed +0.2 % (it picks every ~16 steps
/// and measures displacements in between); 0.25 gives −7 % and −2 %. The flowing chute keeps
/// 69 % of its entries even at 0.25: a dense flow's first neighbour shell lies within 1.05 d.
const NEAR: f64 = 0.25;
/// The pick is renewed once a particle has moved this fraction of the near margin (a little
/// under half, so that rounding in the exact measurement cannot let a pair through).
const NEAR_LIMIT: f64 = 0.45;
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
    /// Spheres: half lists, one slot per pair (spring and last force), one spring per particle
    /// and wall, packed constants. While a chunk runs, these hold the contact history and the
    /// state's table is empty; `store_history` writes it back at the chunk's end.
    half: HalfList<R>,
    /// The spheres' motion while a chunk runs (the state's arrays are stale meanwhile).
    kin: Vec<Kin<R>>,
    pair_slots: Vec<PairSlot<R>>,
    /// Per block of the pair pass: its touching pairs (vectors reused from step to step).
    pair_scratch: Vec<PairScratch<R>>,
    /// Positions at the last pick of the entries the pair pass tests (`pick_pairs`).
    near_ref: Vec<V3<R>>,
    wall_springs: Vec<V3<R>>,
    /// The walls each sphere may touch before the next list build (bit w for wall w < 32).
    near_walls: Vec<u32>,
    /// The spheres whose wall sum runs (ascending): those that may touch a wall (`near_walls`
    /// nonzero, or any sphere past 32 walls) and the fixed ones (their sum zeroes their wall
    /// springs). The rest, most of a bed, are not scanned each step.
    wall_list: Vec<u32>,
    props: Vec<Props<R>>,
    /// History slots per particle of the state's table.
    slots: usize,
    /// ALIVE, or DYING (fell through the sink this step, to be reported) or DEAD.
    alive: Vec<u8>,
    // Scratch, per particle: new force, new torque, contact count.
    f_new: Vec<V3<R>>,
    t_new: Vec<V3<R>>,
    contacts: Vec<u32>,
    /// Shared so `advance` can enter it once per chunk: the per-step parallel passes then run
    /// inside the pool instead of handing work over to it several times a step.
    pool: std::sync::Arc<rayon::ThreadPool>,
    /// The sphere step's passes run on this team (its threads stay awake between passes).
    team: Team,
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
            half: HalfList::default(),
            kin: Vec::new(),
            pair_slots: Vec::new(),
            pair_scratch: Vec::new(),
            near_ref: Vec::new(),
            wall_springs: Vec::new(),
            near_walls: Vec::new(),
            wall_list: Vec::new(),
            props: Vec::new(),
            slots: state.history.slots,
            alive: Vec::new(),
            f_new: Vec::new(),
            t_new: Vec::new(),
            contacts: Vec::new(),
            pool,
            team: Team::new(threads),
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
            self.half.ref_pos.clear();
        }
    }

    // ---- Spheres: half lists, one evaluation per pair, fixed-order per-particle sums. ----

    /// Writes the contact history held by the pair slots and wall springs into a `History`
    /// table (row of particle k: its own pairs, the pairs where it is the partner with the spring
    /// negated, then its walls; only touching contacts with a non-zero spring). `slots` = None
    /// sizes the rows to the fullest particle (a carrier across a mid-chunk re-sort); Some(k)
    /// is the state's format, and a particle with more contacts than k is an error (its id).
    fn pairs_to_history(&self, slots: Option<usize>) -> Result<History<R>, u32> {
        let n = self.state.len();
        let nw = self.walls.len();
        let (half, ps, ws, id) = (
            &self.half,
            &self.pair_slots,
            &self.wall_springs,
            &self.state.id,
        );
        let zero = V3::zero();
        // Every stored (partner key, spring) of particle k, in row order.
        let row = |k: usize, put: &mut dyn FnMut(u32, V3<R>)| {
            for e in half.start[k] as usize..half.start[k + 1] as usize {
                let sl = &ps[e];
                if sl.touching() && sl.spring != zero {
                    put(id[half.nbr[e] as usize], sl.spring);
                }
            }
            for r in half.rstart[k] as usize..half.rstart[k + 1] as usize {
                let sl = &ps[half.rslot[r] as usize];
                if sl.touching() && sl.spring != zero {
                    put(id[half.rowner[r] as usize], -sl.spring);
                }
            }
            for w in 0..nw {
                let s = ws[k * nw + w];
                if s != zero {
                    put(wall_key(w), s);
                }
            }
        };
        let counts: Vec<u32> = self.pool.install(|| {
            (0..n)
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|k| {
                    let mut c = 0u32;
                    row(k, &mut |_, _| c += 1);
                    c
                })
                .collect()
        });
        let fullest = counts.iter().copied().max().unwrap_or(0) as usize;
        let width = match slots {
            Some(k) => {
                if let Some(k_over) = (0..n).find(|&k_| counts[k_] as usize > k) {
                    return Err(id[k_over]);
                }
                k
            }
            None => fullest.max(1),
        };
        let mut h = History::new(width);
        h.partner = vec![EMPTY; n * width];
        h.spring = vec![V3::zero(); n * width];
        self.pool.install(|| {
            h.partner
                .par_chunks_mut(width)
                .zip(h.spring.par_chunks_mut(width))
                .enumerate()
                .with_min_len(MIN_LEN)
                .for_each(|(k, (p, s))| {
                    let mut m = 0;
                    row(k, &mut |key, v| {
                        p[m] = key;
                        s[m] = v;
                        m += 1;
                    });
                });
        });
        Ok(h)
    }

    /// Re-sorts the spheres by cell and rebuilds the half lists, carrying the springs over by
    /// partner id through a `History` table that the sort permutes with the particles. With
    /// `from_pairs` the springs come from the current slots (a rebuild inside a chunk);
    /// otherwise from the state's table (a chunk's start), which is then taken out of the state.
    fn rebuild_half(&mut self, from_pairs: bool) {
        if from_pairs {
            kinematics::scatter_to(&self.kin, &mut self.state);
            let carrier = self
                .pairs_to_history(None)
                .expect("unsized history rows cannot overflow");
            self.state.history = carrier;
        }
        self.compact();
        let (periodic, skin) = (self.periodic, self.skin);
        let state = &mut self.state;
        let half = &mut self.half;
        self.pool
            .install(|| grid::build_half(state, &periodic, skin, half));
        let n = self.state.len();
        self.alive = vec![ALIVE; n];
        let s = &self.state;
        self.props = (0..n)
            .map(|i| Props {
                inv_m: s.inv_mass[i],
                inv_i: if s.rotation {
                    s.inv_inertia[i]
                } else {
                    R::zero()
                },
                inv_d: R::one() / (s.radius[i] * R::from_f64(2.0)),
            })
            .collect();
        let nw = self.walls.len();
        self.pair_slots.clear();
        self.pair_slots.resize(self.half.len(), PairSlot::default());
        self.wall_springs.clear();
        self.wall_springs.resize(n * nw, V3::zero());
        let hist = std::mem::take(&mut self.state.history);
        {
            let (half, id) = (&self.half, &self.state.id);
            let bounds = block_bounds(&half.start, n);
            let blocks = split_blocks(&mut self.pair_slots, &bounds.1);
            let wblocks = split_blocks(&mut self.wall_springs, &scaled(&bounds.0, nw));
            let hist = &hist;
            self.pool.install(|| {
                blocks
                    .into_par_iter()
                    .zip(wblocks)
                    .enumerate()
                    .for_each(|(b, (slots, wsp))| {
                        let first = bounds.0[b];
                        let mut e0 = half.start[first] as usize;
                        for i in first..bounds.0[b + 1] {
                            let e1 = half.start[i + 1] as usize;
                            for e in e0..e1 {
                                let j = half.nbr[e] as usize;
                                let sl = &mut slots[e - bounds.1[b]];
                                *sl = PairSlot::default();
                                if hist.slots > 0 {
                                    let sp = hist.spring_of(i, id[j]);
                                    sl.spring = sp;
                                    // A stored spring marks a contact that existed: keep it.
                                    if sp != V3::zero() {
                                        sl.h = R::zero();
                                    }
                                }
                            }
                            e0 = e1;
                            if hist.slots > 0 {
                                for w in 0..nw {
                                    wsp[(i - first) * nw + w] = hist.spring_of(i, wall_key(w));
                                }
                            }
                        }
                    });
            });
        }
        // The table stays out of the state while the chunk runs (the slots hold the history).
        self.state.history = History::new(0);
        kinematics::gather_from(&mut self.kin, &self.state, |_| true);
        // Each sphere's walls: those within its radius plus the skin (it moves less than half
        // the skin before the next build), and any it has a spring with.
        let (s, walls, wsp) = (&self.state, &self.walls, &self.wall_springs);
        let skin = self.skin;
        self.near_walls = self.pool.install(|| {
            (0..n)
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|i| {
                    (0..nw.min(32))
                        .filter(|&w| {
                            walls[w].may_touch(s.pos[i], s.radius[i], skin)
                                || wsp[i * nw + w] != V3::zero()
                        })
                        .fold(0u32, |mask, w| mask | 1 << w)
                })
                .collect()
        });
        let (near, props) = (&self.near_walls, &self.props);
        self.wall_list.clear();
        self.wall_list.extend(
            (0..n as u32).filter(|&i| {
                near[i as usize] != 0 || nw > 32 || props[i as usize].inv_m == R::zero()
            }),
        );
    }

    /// Puts the history back into the state in its format (`slots` per particle).
    fn store_history(&mut self) -> Result<(), EngineError> {
        if self.slots == 0 || self.state.history.slots == self.slots {
            return Ok(());
        }
        match self.pairs_to_history(Some(self.slots)) {
            Ok(h) => {
                self.state.history = h;
                Ok(())
            }
            Err(id) => {
                // Keep what fits, so the state stays readable; the run reports the overflow.
                let mut h = self.pairs_to_history(None).expect("unsized rows");
                let k = self.slots;
                let w = h.slots;
                let n = self.state.len();
                let (mut p, mut s) = (Vec::with_capacity(n * k), Vec::with_capacity(n * k));
                for i in 0..n {
                    p.extend_from_slice(&h.partner[i * w..i * w + k.min(w)]);
                    s.extend_from_slice(&h.spring[i * w..i * w + k.min(w)]);
                    for _ in w..k {
                        p.push(EMPTY);
                        s.push(V3::zero());
                    }
                }
                h.slots = k;
                h.partner = p;
                h.spring = s;
                self.state.history = h;
                Err(EngineError::HistoryFull {
                    id,
                    slots: k,
                    step: self.state.step,
                })
            }
        }
    }

    /// Evaluates every pair once: springs into the slots, each partner's share into
    /// `reactions`, each particle's own share into `state.force`/`torque` (and its count of
    /// touching pairs into `contacts`). Returns the largest overlap ratio.
    fn pair_pass(&mut self) -> R {
        let n = self.state.len();
        // The pair pass reads the records at the half list's indices unchecked (gather.rs).
        assert!(self.kin.len() == n && self.half.start.len() == n + 1);
        self.contacts.resize(n, 0);
        let (parts, entries) = self.pair_blocks();
        let s = &mut self.state;
        let ctx = PairContext {
            kin: &self.kin,
            rotation: s.rotation,
            law: &self.law_pp,
            periodic: &self.periodic,
            dt: self.dt,
            keep_springs: self.slots > 0,
            list_build: self.half.builds,
        };
        let blocks = split_blocks(&mut self.pair_slots, &entries)
            .into_iter()
            .zip(split_blocks(&mut s.force, &parts))
            .zip(split_blocks(&mut s.torque, &parts))
            .zip(split_blocks(&mut self.contacts, &parts))
            .zip(self.pair_scratch.iter_mut())
            .collect::<Vec<_>>();
        // One task per block, claimed by whichever team thread is free (the blocks' work
        // differs: walls, free surface); each block's slices behind an uncontended lock.
        let cells: Vec<Mutex<_>> = blocks.into_iter().map(Mutex::new).collect();
        self.team
            .run(cells.len(), |b| {
                let mut guard = cells[b].lock().unwrap();
                let ((((slots, force), torque), nc), scratch) = &mut *guard;
                let block = PairBlock {
                    first: parts[b],
                    slots,
                    force,
                    torque,
                    nc,
                };
                ctx.block(block, scratch)
            })
            .into_iter()
            .fold(R::zero(), |a, b| a.max(b))
    }

    /// The sphere passes' blocks for the current half list (particles, entries: `block_bounds`),
    /// each with its pair-pass scratch.
    fn pair_blocks(&mut self) -> (Vec<usize>, Vec<usize>) {
        let (parts, entries) = block_bounds(&self.half.start, self.state.len());
        let nblocks = parts.len() - 1;
        if self.pair_scratch.len() < nblocks {
            self.pair_scratch.resize_with(nblocks, PairScratch::default);
        }
        (parts, entries)
    }

    /// Picks in each block the half-list entries within the near margin (`NEAR` of the skin)
    /// of touching, the only ones the pair pass tests until the next pick
    /// (`PairContext::pick`), and notes where the particles are.
    fn pick_pairs(&mut self) {
        let n = self.state.len();
        assert!(self.kin.len() == n && self.half.start.len() == n + 1);
        let (parts, entries) = self.pair_blocks();
        let ctx = PairContext {
            kin: &self.kin,
            rotation: self.state.rotation,
            law: &self.law_pp,
            periodic: &self.periodic,
            dt: self.dt,
            keep_springs: self.slots > 0,
            list_build: self.half.builds,
        };
        let margin = self.skin * R::from_f64(NEAR);
        let blocks = split_blocks(&mut self.pair_slots, &entries)
            .into_iter()
            .zip(self.pair_scratch.iter_mut())
            .collect::<Vec<_>>();
        let (owner, nbr) = (&self.half.owner, &self.half.nbr);
        let cells: Vec<Mutex<_>> = blocks.into_iter().map(Mutex::new).collect();
        self.team.run(cells.len(), |b| {
            let mut guard = cells[b].lock().unwrap();
            let (slots, scratch) = &mut *guard;
            let owner = &owner[entries[b]..entries[b + 1]];
            ctx.pick(
                parts[b]..parts[b + 1],
                owner,
                nbr,
                entries[b],
                slots,
                margin,
                scratch,
            );
        });
        self.near_ref.clear();
        self.near_ref.extend(self.kin.iter().map(|k| k.pos));
    }

    /// Completes each particle's force and torque (own share from the pair pass, then the
    /// reactions where it is the partner in entry order, then its walls: a fixed order) in
    /// `state.force`/`torque`, then kicks by `kick` and, with `drift`, drifts (the next step's
    /// opening). Returns (some particle died, the largest squared speed of a drifted particle,
    /// largest wall overlap, most contacts of one particle).
    fn sum_kick_drift(&mut self, kick: R, drift: bool) -> (bool, R, R, u32) {
        let n = self.state.len();
        let nw = self.walls.len();
        let (dt, g, periodic, sink) = (self.dt, self.gravity, self.periodic, self.sink_z);
        let law_pw = self.law_pw;
        // This pass's blocks only: after the sink removed particles, the scratch of blocks past
        // the end holds an old pass's reactions.
        let pairs = &self.pair_scratch[..n.div_ceil(BLOCK).min(self.pair_scratch.len())];
        let ctx = SumContext {
            pairs,
            reach: pairs.iter().map(PairScratch::reach).max().unwrap_or(0),
            law_pw: &law_pw,
            walls: &self.walls,
            dt,
            keep_springs: self.slots > 0,
        };
        let parts: Vec<usize> = (0..n.div_ceil(BLOCK))
            .map(|b| b * BLOCK)
            .chain(std::iter::once(n))
            .collect();
        let s = &mut self.state;
        let rot = s.rotation;
        let props = &self.props;
        let blocks = split_blocks(&mut self.kin, &parts)
            .into_iter()
            .zip(split_blocks(&mut s.force, &parts))
            .zip(split_blocks(&mut s.torque, &parts))
            .zip(split_blocks(&mut self.alive, &parts))
            .zip(split_blocks(&mut self.contacts, &parts))
            .zip(split_blocks(&mut self.wall_springs, &scaled(&parts, nw)))
            .collect::<Vec<_>>();
        let (near_walls, wall_list) = (&self.near_walls, &self.wall_list);
        let step = Kick {
            kick,
            dt,
            g,
            drift,
            rotation: rot,
            periodic,
            sink_z: sink.unwrap_or(R::from_f64(f64::NEG_INFINITY)),
        };
        let cells: Vec<Mutex<_>> = blocks.into_iter().map(Mutex::new).collect();
        self.team
            .run(cells.len(), |b| {
                let mut guard = cells[b].lock().unwrap();
                let (((((kin, force), torque), alive), nc), wsp) = &mut *guard;
                let first = parts[b];
                ctx.reactions(first, force, torque, nc, rot);
                // The whole-particle arrays cut to the block (the kick cuts its own).
                let count = kin.len();
                let (props, near) = (&props[first..][..count], &near_walls[first..][..count]);
                let wsp = &mut wsp[..count * nw];
                let mut ov_max = R::zero();
                // First the walls, for the block's spheres in `wall_list`, in their own loop:
                // inlined into the kick, the wall sum's values pushed the kick's out of
                // registers (a third of its instructions were stack loads and stores). Same
                // order of each particle's sum: pairs, reactions, walls.
                let a = wall_list.partition_point(|&i| (i as usize) < first);
                let z = a + wall_list[a..].partition_point(|&i| (i as usize) < first + count);
                for &i in &wall_list[a..z] {
                    let l = i as usize - first;
                    if alive[l] != ALIVE {
                        continue;
                    }
                    let t = if rot { torque[l] } else { V3::zero() };
                    let (fw, tw, ov, c) = ctx.sum(
                        force[l],
                        t,
                        &kin[l],
                        props[l],
                        &mut wsp[l * nw..(l + 1) * nw],
                        near[l],
                    );
                    ov_max = ov_max.max(ov);
                    force[l] = fw;
                    nc[l] += c;
                    if rot {
                        torque[l] = tw;
                    }
                }
                let k = step.block(KickBlock {
                    kin,
                    force,
                    torque,
                    alive,
                    nc,
                    props,
                });
                (k.died, k.v_max2, ov_max, k.fullest)
            })
            .into_iter()
            .fold((false, R::zero(), R::zero(), 0), |p, q| {
                (p.0 || q.0, p.1.max(q.1), p.2.max(q.2), p.3.max(q.3))
            })
    }

    /// The exact skin test on the packed motion: whether a particle that drifted this step
    /// (alive, or fallen through the sink this step; not fixed) lies more than `limit` from
    /// `refs` (where the lists were built: half the skin; or the last pick), the largest such
    /// displacement and the largest coordinate magnitude (for `DisplacementBound`).
    fn measure_displacements(&mut self, from_pick: bool, limit: R) -> (bool, f64, f64) {
        let image = self.periodic.image();
        let half2 = limit * limit;
        let refs = if from_pick {
            &self.near_ref
        } else {
            &self.half.ref_pos
        };
        let (kin, alive, props) = (&self.kin, &self.alive, &self.props);
        let n = kin.len();
        // A plain loop per block on the team: with the pick's margin this runs every few steps,
        // and the rayon filter-map-reduce it replaces cost a quarter more (cachegrind).
        let (beyond, d2_max, scale) = self
            .team
            .run(n.div_ceil(BLOCK), |b| {
                let range = b * BLOCK..((b + 1) * BLOCK).min(n);
                let (mut beyond, mut d2_max, mut scale) = (false, 0.0f64, 0.0f64);
                for ((k, r), (&a, pr)) in kin[range.clone()]
                    .iter()
                    .zip(&refs[range.clone()])
                    .zip(alive[range.clone()].iter().zip(&props[range]))
                {
                    if !matches!(a, ALIVE | DYING) || pr.inv_m == R::zero() {
                        continue;
                    }
                    let p = k.pos;
                    let d2 = image.delta(*r, p).norm2();
                    beyond |= d2 > half2;
                    d2_max = d2_max.max(d2.to_f64());
                    scale = scale.max(p.x.abs().max(p.y.abs()).max(p.z.abs()).to_f64());
                }
                (beyond, d2_max, scale)
            })
            .into_iter()
            .fold((false, 0.0f64, 0.0f64), |a, b| {
                (a.0 || b.0, a.1.max(b.1), a.2.max(b.2))
            });
        (beyond, d2_max.sqrt(), scale)
    }

    /// Elastic energy of the contacts from the half lists and slots (each pair once), summed in
    /// particle order in f64 (the same for any thread count). Needs fresh lists.
    fn pair_elastic_energy(&self) -> f64 {
        let s = &self.state;
        let (half, ps, props) = (&self.half, &self.pair_slots, &self.props);
        let nw = self.walls.len();
        let per: Vec<f64> = self.pool.install(|| {
            (0..s.len())
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|i| {
                    if self.alive[i] != ALIVE {
                        return 0.0;
                    }
                    let (pi, ri) = (s.pos[i], s.radius[i]);
                    let mut e = 0.0;
                    let entries = half.start[i] as usize..half.start[i + 1] as usize;
                    for (&j, slot) in half.nbr[entries.clone()].iter().zip(&ps[entries]) {
                        let j = j as usize;
                        if self.alive[j] != ALIVE {
                            continue;
                        }
                        let rj = s.radius[j];
                        let sum = ri + rj;
                        let dist2 = self.periodic.delta(s.pos[j], pi).norm2();
                        if dist2 >= sum * sum {
                            continue;
                        }
                        let sp = if slot.touching() {
                            slot.spring
                        } else {
                            V3::zero()
                        };
                        e += elastic_energy(&self.law_pp, sum - dist2.sqrt(), ri * rj / sum, sp)
                            .to_f64();
                    }
                    if props[i].inv_m != R::zero() {
                        for (w, wall) in self.walls.iter().enumerate() {
                            if let Some(wc) = wall.touch(pi, ri) {
                                let sp = self.wall_springs[i * nw + w];
                                e += elastic_energy(&self.law_pw, wc.overlap, ri, sp).to_f64();
                            }
                        }
                    }
                    e
                })
                .collect()
        });
        per.iter().sum()
    }

    /// A chunk of sphere steps: velocity Verlet with the closing half kick of each step fused
    /// with the next step's opening one, and the force sums fused with the kick and drift (one
    /// pass over the particles per step besides the pair pass).
    fn advance_spheres(
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
        kinematics::gather_from(&mut self.kin, &self.state, |i| alive[i] == ALIVE);
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

    /// `energy_budget` with the elastic energy from the half lists (fresh at a chunk's start).
    fn energy_budget_spheres(&self, steps: u64) -> EnergyBudget {
        let mut b = self.energy_budget_without_elastic(steps);
        b.elastic_j = self.pair_elastic_energy();
        b
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
                    let moved = stale || periodic.delta(refs[i], *x).norm() + turned > half_skin;
                    (died, moved)
                })
                .reduce(|| (false, false), |p, q| (p.0 || q.0, p.1 || q.1))
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
                s.force.par_iter(),
                s.inv_mass.par_iter(),
                alive.par_iter_mut(),
            )
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|(v, x, &f, &im, a)| {
                    if im == R::zero() || *a != ALIVE {
                        return false;
                    }
                    *v += (f * im + g) * kick;
                    *x += *v * dt;
                    periodic.wrap(x);
                    let died = matches!(sink, Some(zs) if x.z < zs);
                    if died {
                        *a = DYING;
                    }
                    died
                })
                .reduce(|| false, |p, q| p || q)
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
    /// Reports the particles that fell through the sink this step (at `time_s`) and marks them
    /// dead; returns how many.
    fn bury_dying(&mut self, time_s: f64, removed: &mut Vec<SinkEvent>) -> u64 {
        let s = &self.state;
        let mut buried = 0;
        for i in 0..s.len() {
            if self.alive[i] == DYING {
                removed.push(SinkEvent {
                    id: s.id[i],
                    mass_kg: s.mass[i].to_f64(),
                    time_s,
                });
                self.alive[i] = DEAD;
                buried += 1;
            }
        }
        buried
    }

    /// Particles that are integrated (fixed base particles are not): what particle-steps count.
    fn mobile_count(&self) -> u64 {
        self.state
            .inv_mass
            .iter()
            .filter(|&&m| m != R::zero())
            .count() as u64
    }

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
        let mut b = self.energy_budget_without_elastic(steps);
        b.elastic_j = self.sum_elastic_energy();
        b
    }

    /// `energy_budget` but for the elastic energy (left at zero).
    fn energy_budget_without_elastic(&self, steps: u64) -> EnergyBudget {
        let s = &self.state;
        let mobile_mass_kg: f64 = (0..s.len())
            .filter(|&i| s.inv_mass[i] != R::zero())
            .map(|i| s.mass[i].to_f64())
            .sum();
        let g = self.config.gravity;
        let g = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        EnergyBudget {
            kinetic_j: s.kinetic_energy(),
            elastic_j: 0.0,
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
        let builds0 = self.list.builds + self.half.builds;
        // NOTE: a chunk always starts from a fresh sort and list, so that a run resumed from a
        // checkpoint (taken between chunks) follows exactly the same operations as one that never
        // stopped.
        let pool = self.pool.clone();
        let check_energy = steps > 0 && self.watchdog.max_kinetic_growth.is_finite();
        let mut budget = None;
        if !self.state.oriented {
            let r = pool
                .install(|| self.advance_spheres(steps, &mut report, &mut budget, check_energy));
            // The history goes back into the state whatever happened (observers, checkpoints
            // and error reports read it).
            let stored = self.store_history();
            r?;
            stored?;
        } else {
            pool.install(|| -> Result<(), EngineError> {
                self.rebuild();
                if check_energy {
                    budget = Some(self.energy_budget(steps));
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
            })?;
        }
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
        report.list_builds = self.list.builds + self.half.builds - builds0;
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
        self.half = HalfList::default();
        self.slots = self.state.history.slots;
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

/// Block boundaries of the sphere passes: particles `parts[b]..parts[b + 1]` and their half-list
/// entries `entries[b]..entries[b + 1]`.
fn block_bounds(start: &[u32], n: usize) -> (Vec<usize>, Vec<usize>) {
    let parts: Vec<usize> = (0..n.div_ceil(BLOCK))
        .map(|b| b * BLOCK)
        .chain(std::iter::once(n))
        .collect();
    let entries = parts.iter().map(|&p| start[p] as usize).collect();
    (parts, entries)
}

/// `bounds` times `k` (arrays with k values per particle).
fn scaled(bounds: &[usize], k: usize) -> Vec<usize> {
    bounds.iter().map(|&b| b * k).collect()
}

/// Splits `v` into the disjoint pieces `bounds[b]..bounds[b + 1]`, so that parallel tasks each
/// own one; an empty `v` (an array the run does not have) gives empty pieces.
fn split_blocks<'a, T>(mut v: &'a mut [T], bounds: &[usize]) -> Vec<&'a mut [T]> {
    let pieces = bounds.len().saturating_sub(1);
    if v.is_empty() {
        return (0..pieces).map(|_| <&mut [T]>::default()).collect();
    }
    let mut out = Vec::with_capacity(pieces);
    for w in bounds.windows(2) {
        let (a, rest) = v.split_at_mut(w[1] - w[0]);
        out.push(a);
        v = rest;
    }
    out
}
