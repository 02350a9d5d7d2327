//! The sphere step's passes over fixed blocks of particles: the pair pass, the near-pair pick,
//! the per-particle sums fused with the kick and drift, the exact skin test; block helpers.

use super::kick::{Kick, KickBlock};
use super::pair_pass::{PairBlock, PairContext, PairScratch, SumContext, BLOCK};
use super::particle::Status;
use super::{CpuEngine, NEAR};
use crate::engine::real::{Real, V3};

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
        // differs: walls, free surface).
        self.team
            .run_blocks(blocks, |b, block| {
                let ((((slots, force), torque), nc), scratch) = block;
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
        self.team.run_blocks(blocks, |b, block| {
            let (slots, scratch) = block;
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
    /// opening).
    pub(super) fn sum_kick_drift(&mut self, kick: R, drift: bool) -> Swept<R> {
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
        self.team
            .run_blocks(blocks, |b, block| {
                let (((((kin, force), torque), alive), nc), wsp) = block;
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
                Swept {
                    died: k.died,
                    v_max2: k.v_max2,
                    wall_overlap: ov_max,
                    fullest: k.fullest,
                }
            })
            .into_iter()
            .fold(Swept::default(), Swept::merge)
    }

    /// The exact skin test on the packed motion: whether a particle that drifted this step
    /// (alive, or fallen through the sink this step; not fixed) lies more than `limit` from
    /// `refs` (where the lists were built: half the skin; or the last pick).
    pub(super) fn measure_displacements(&mut self, from_pick: bool, limit: R) -> Displacements {
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
        self.team
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
                Displacements {
                    beyond,
                    max: d2_max.sqrt(),
                    scale,
                }
            })
            .into_iter()
            .fold(Displacements::default(), Displacements::merge)
    }
}

/// What a step's sums, kick and drift found, over every block.
#[derive(Clone, Copy)]
pub(super) struct Swept<R: Real> {
    /// Some particle fell through the sink.
    pub(super) died: bool,
    /// The largest squared speed of a drifted particle.
    pub(super) v_max2: R,
    /// The largest wall overlap ratio.
    pub(super) wall_overlap: R,
    /// The most contacts of one particle.
    pub(super) fullest: u32,
}

impl<R: Real> Default for Swept<R> {
    fn default() -> Self {
        Self {
            died: false,
            v_max2: R::zero(),
            wall_overlap: R::zero(),
            fullest: 0,
        }
    }
}

impl<R: Real> Swept<R> {
    fn merge(self, o: Self) -> Self {
        Self {
            died: self.died || o.died,
            v_max2: self.v_max2.max(o.v_max2),
            wall_overlap: self.wall_overlap.max(o.wall_overlap),
            fullest: self.fullest.max(o.fullest),
        }
    }
}

/// The exact skin test's findings (`DisplacementBound` takes the last two).
#[derive(Clone, Copy, Default)]
pub(super) struct Displacements {
    /// Some particle lies beyond the limit.
    pub(super) beyond: bool,
    /// The largest displacement, m.
    pub(super) max: f64,
    /// The largest coordinate magnitude, m.
    pub(super) scale: f64,
}

impl Displacements {
    fn merge(self, o: Self) -> Self {
        Self {
            beyond: self.beyond || o.beyond,
            max: self.max.max(o.max),
            scale: self.scale.max(o.scale),
        }
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
