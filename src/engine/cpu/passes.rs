//! The sphere step's passes over fixed blocks of particles: the pair pass, the near-pair pick,
//! the per-particle sums fused with the kick and drift, the exact skin test; block helpers.

use super::{CpuEngine, NEAR};
use crate::engine::kick::{Kick, KickBlock};
use crate::engine::pair_pass::{PairBlock, PairContext, PairScratch, SumContext, BLOCK};
use crate::engine::particle::Status;
use crate::engine::real::{Real, V3};
use std::sync::Mutex;

impl<R: Real> CpuEngine<R> {
    // ---- Spheres: half lists, one evaluation per pair, fixed-order per-particle sums. ----

    /// Evaluates every pair once: springs into the slots, each partner's share into
    /// `reactions`, each particle's own share into `state.force`/`torque` (and its count of
    /// touching pairs into `contacts`). Returns the largest overlap ratio.
    pub(super) fn pair_pass(&mut self) -> R {
        let n = self.state.len();
        // The pair pass reads the records at the half list's indices unchecked (pair_pass.rs).
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
    pub(super) fn pick_pairs(&mut self) {
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
    pub(super) fn sum_kick_drift(&mut self, kick: R, drift: bool) -> (bool, R, R, u32) {
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
                // registers, into stack loads and stores. Same
                // order of each particle's sum: pairs, reactions, walls.
                let a = wall_list.partition_point(|&i| (i as usize) < first);
                let z = a + wall_list[a..].partition_point(|&i| (i as usize) < first + count);
                for &i in &wall_list[a..z] {
                    let l = i as usize - first;
                    if alive[l] != Status::Alive {
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
    pub(super) fn measure_displacements(&mut self, from_pick: bool, limit: R) -> (bool, f64, f64) {
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
        // and the rayon filter-map-reduce it replaces cost more per call.
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
                    if !matches!(a, Status::Alive | Status::Dying) || pr.inv_m == R::zero() {
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
}

/// Block boundaries of the sphere passes: particles `parts[b]..parts[b + 1]` and their half-list
/// entries `entries[b]..entries[b + 1]`.
pub(super) fn block_bounds(start: &[u32], n: usize) -> (Vec<usize>, Vec<usize>) {
    let parts: Vec<usize> = (0..n.div_ceil(BLOCK))
        .map(|b| b * BLOCK)
        .chain(std::iter::once(n))
        .collect();
    let entries = parts.iter().map(|&p| start[p] as usize).collect();
    (parts, entries)
}

/// `bounds` times `k` (arrays with k values per particle).
pub(super) fn scaled(bounds: &[usize], k: usize) -> Vec<usize> {
    bounds.iter().map(|&b| b * k).collect()
}

/// Splits `v` into the disjoint pieces `bounds[b]..bounds[b + 1]`, so that parallel tasks each
/// own one; an empty `v` (an array the run does not have) gives empty pieces.
pub(super) fn split_blocks<'a, T>(mut v: &'a mut [T], bounds: &[usize]) -> Vec<&'a mut [T]> {
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
