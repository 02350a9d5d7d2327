//! The CPU backend: velocity Verlet over rayon, generic over the precision.
//!
//! Spheres: half Verlet lists with a skin (`grid::build_half`, rebuilt only when a particle has
//! moved half the skin, which a displacement bound watches: `skin.rs`), each pair evaluated once
//! (Newton's third law) with its tangential spring kept in the pair's entry. The pair pass runs
//! over fixed blocks of particles and adds each pair's force to i, and to j when j lies in the
//! same block; a touching pair whose partner lies in a later block hands its reaction over in
//! a list per destination block, and a second pass adds, per particle, those reactions in entry
//! order, the walls it may reach (picked at each list build), and the kick and drift. The hot
//! loops avoid branches whose outcome is a coin flip (touching or not, same block or not).
//! Every value is written by exactly one task and summed in a fixed
//! order, so results are bitwise identical for any thread count. While a chunk
//! runs, the spheres' motion lives in packed records (`kinematics.rs`). The springs go back
//! into the state's per-particle history table (keyed by partner id, the checkpoint and GPU
//! format) at the end of each `advance`, and come from it at the start of the next.
//!
//! Spherocylinders run the same design (`rods.rs`): half lists, each near pair evaluated once
//! (`rod_pass.rs`, `LANES` at a time in `rod_lanes.rs`) with force and torque on both rods,
//! fixed-order sums fused with the kick, rotation and drift, on the team. The full-list gather
//! (`oriented.rs`) remains for contact records and the elastic energy of observers.
//!
//! Files: `mod.rs` the engine, its constructor and the `Backend` impl (which dispatches to
//! the two paths); `spheres.rs` the sphere chunk (the step loop); `passes.rs` the sphere
//! step's block passes (pair pass, pick, sums with kick and drift, skin test);
//! `half_lists.rs` the half lists' build and the history between the pair slots and the
//! state's table; `rods.rs` the spherocylinder path; `contacts.rs` contact records and
//! elastic energy for observers; `watchdog.rs` the energy budget and finiteness check;
//! `rod_lists.rs` the rods' half lists and history; `rod_passes.rs` the rod step's passes.

mod contacts;
mod force_gather;
mod half_lists;
mod kept_spring;
mod kick;
mod kinematics;
mod oriented;
mod overlap_report;
mod pair_lanes;
mod pair_pass;
mod particle;
mod passes;
mod rod_kick;
mod rod_lanes;
mod rod_lists;
mod rod_pass;
mod rod_passes;
mod rod_pick_lanes;
mod rods;
#[cfg(target_arch = "x86_64")]
mod simd;
mod skin;
mod spheres;
mod team;
mod thread_room;
mod verlet;
mod watchdog;

use self::kinematics::Kin;
use self::pair_pass::{PairScratch, PairSlot};
use self::particle::{Props, Status};
use self::rod_pass::{RodKin, RodScratch};
use self::team::Team;
use super::backend::{Backend, BackendInfo, ChunkReport, EngineError, SinkEvent};
use super::config::EngineConfig;
use super::contact::{ContactRecord, LawKernel};
use super::grid::{self, HalfList, NeighbourList, Periodic};
use super::real::{Real, V3};
use super::state::State;
use super::walls::WallKernel;
pub use super::watchdog::Watchdog;
use crate::engine::cpu_clock::WorkerClocks;

/// Smallest piece of work a rayon task takes: small runs stay on one thread.
const MIN_LEN: usize = 512;

/// The near margin, as a fraction of the skin: the pair pass tests only the half-list entries
/// whose pair was within this margin of touching at the last pick (`pick_pairs`). A smaller
/// margin skips more entries in a settled bed but makes a flowing one pick so often, and
/// measure displacements in between, that it gains nothing; this margin helps both. A dense
/// flow keeps most of its entries at any margin: its first neighbour shell lies within 1.05 d.
const NEAR: f64 = 0.25;
/// The rods' near margin, as a fraction of the skin. Their pick (an exact segment–segment
/// distance per entry) costs more than the pair pass it saves in a fast chute flow, where the
/// whole bed's motion renews it every few steps: a wider margin picks less often.
const ROD_NEAR: f64 = 0.5;
/// The pick is renewed once a particle has moved this fraction of the near margin (a little
/// under half, so that rounding in the exact measurement cannot let a pair through).
const NEAR_LIMIT: f64 = 0.45;

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
    /// Spherocylinders, while a chunk runs: each rod's unit axis, the axes at the last list
    /// build and at the last pick (`near_ref` holds the positions), each block's pair-pass
    /// lists, and a spring and touching flag per rod and wall. The pair slots and `half` serve
    /// both paths.
    axis: Vec<V3<R>>,
    rod_ref_axis: Vec<V3<R>>,
    near_ref_axis: Vec<V3<R>>,
    rod_scratch: Vec<RodScratch<R>>,
    rod_walls: Vec<PairSlot<R>>,
    /// The rods' packed records, what the pair pass reads.
    rod_kin: Vec<RodKin<R>>,
    /// The walls each sphere may touch before the next list build (bit w for wall w < 32).
    near_walls: Vec<u32>,
    /// The spheres whose wall sum runs (ascending): those that may touch a wall (`near_walls`
    /// nonzero, or any sphere past 32 walls) and the fixed ones (their sum zeroes their wall
    /// springs). The rest, most of a bed, are not scanned each step.
    wall_list: Vec<u32>,
    props: Vec<Props<R>>,
    /// History slots per particle of the state's table.
    slots: usize,
    /// Alive, or dying (fell through the sink this step, to be reported) or dead.
    alive: Vec<Status>,
    /// Scratch, per particle: contact count.
    contacts: Vec<u32>,
    /// Shared so `advance` can enter it once per chunk: the per-step parallel passes then run
    /// inside the pool instead of handing work over to it several times a step.
    pool: std::sync::Arc<rayon::ThreadPool>,
    /// The sphere step's passes run on this team (its threads stay awake between passes).
    team: Team,
    /// The CPU clocks of the pool's and the team's threads (`Backend::workers_cpu_s`).
    clocks: WorkerClocks,
    threads: usize,
    pub watchdog: Watchdog,
}

impl<R: Real> CpuEngine<R> {
    /// A new engine; `threads` = 0 uses all cores.
    ///
    /// # Panics
    /// The system refuses the engine's threads (see [`CpuEngine::try_new`]).
    pub fn new(config: EngineConfig, state: State<R>, threads: usize) -> Self {
        Self::try_new(config, state, threads).unwrap_or_else(|e| panic!("{e}"))
    }

    /// A new engine, or why its `threads` threads cannot be started (a process or thread
    /// limit: `ulimit -u`, a cgroup's pids.max).
    ///
    /// # Errors
    /// The system refuses a thread.
    pub fn try_new(
        config: EngineConfig,
        mut state: State<R>,
        threads: usize,
    ) -> anyhow::Result<Self> {
        // Every run keeps a rest per position (zero where positions are not split), so that the
        // integration loops zip the same arrays in every precision.
        state.pos_lo.resize(state.len(), V3::zero());
        let refused = |e: &dyn std::fmt::Display| {
            anyhow::anyhow!(
                "cannot start {threads} CPU engine thread(s): {e} (a limit on processes or threads, `ulimit -u` or a cgroup's pids.max, or on memory for their stacks, `ulimit -v`; ask for fewer with --threads)"
            )
        };
        if let Some(why) = thread_room::lacking_room(threads) {
            return Err(refused(&why));
        }
        let clocks = WorkerClocks::default();
        let pool_clocks = clocks.clone();
        let pool: std::sync::Arc<rayon::ThreadPool> = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .start_handler(move |_| pool_clocks.register_this_thread())
            .build()
            .map_err(|e| refused(&e))?
            .into();
        let threads = pool.current_num_threads();
        let team = Team::try_new(threads, &clocks).map_err(|e| refused(&e))?;
        let periodic = Periodic {
            x: config
                .periodic_x
                .map(|[a, b]| (R::from_f64(a), R::from_f64(b))),
            y: config
                .periodic_y
                .map(|[a, b]| (R::from_f64(a), R::from_f64(b))),
        };
        Ok(Self {
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
            axis: Vec::new(),
            rod_ref_axis: Vec::new(),
            near_ref_axis: Vec::new(),
            rod_scratch: Vec::new(),
            rod_walls: Vec::new(),
            rod_kin: Vec::new(),
            near_walls: Vec::new(),
            wall_list: Vec::new(),
            props: Vec::new(),
            slots: state.history.slots,
            alive: Vec::new(),
            contacts: Vec::new(),
            pool,
            team,
            clocks,
            threads,
            watchdog: Watchdog::default(),
            state,
            config,
        })
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
        self.alive = vec![Status::Alive; self.state.len()];
    }

    /// Drops dead particles from the state (order preserved).
    fn compact(&mut self) {
        if self.alive.len() == self.state.len() && self.alive.iter().any(|&a| a != Status::Alive) {
            let keep: Vec<bool> = self.alive.iter().map(|&a| a == Status::Alive).collect();
            self.state.retain(&keep);
            self.alive = vec![Status::Alive; self.state.len()];
            self.list.ref_pos.clear();
            self.half.ref_pos.clear();
        }
    }

    /// Reports the particles that fell through the sink this step (at `time_s`) and marks them
    /// dead; returns how many.
    fn bury_dying(&mut self, time_s: f64, removed: &mut Vec<SinkEvent>) -> u64 {
        let s = &self.state;
        let mut buried = 0;
        for i in 0..s.len() {
            if self.alive[i] == Status::Dying {
                removed.push(SinkEvent {
                    id: s.id[i],
                    mass_kg: s.mass[i].to_f64(),
                    time_s,
                });
                self.alive[i] = Status::Dead;
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
}

impl<R: Real> Backend for CpuEngine<R> {
    fn workers_cpu_s(&self) -> Option<f64> {
        self.clocks.total_s()
    }

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
            let r =
                pool.install(|| self.advance_rods(steps, &mut report, &mut budget, check_energy));
            let stored = self.store_history();
            r?;
            stored?;
        }
        self.check_finite()?;
        // What a checkpoint would write and read back, so that a resumed run goes on with the
        // same bits (`position.rs`).
        self.state.canonical_positions();
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
        self.state.pos_lo.resize(self.state.len(), V3::zero());
        self.alive = vec![Status::Alive; self.state.len()];
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
