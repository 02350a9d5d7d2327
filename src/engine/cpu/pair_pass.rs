//! Force kernels of the CPU engine. `PairContext` and `SumContext` are the sphere step: one
//! evaluation per pair of the half lists, then a fixed-order sum per particle (`cpu/passes.rs`).
//! The per-particle gather over full lists is `force_gather.rs`.

use super::kinematics::{Kin, Separation};
use super::pair_lanes::{self, LaneInput, LaneOutput, CHUNK, LANES};
use super::particle::Props;
use crate::engine::contact::{contact_force, LawKernel};
use crate::engine::grid::Periodic;
use crate::engine::real::{Real, V3};
use crate::engine::walls::WallKernel;
use multiversion::multiversion;

/// One entry of the half list as the pair pass keeps it: the pair's tangential spring (i's view;
/// j's is its negative) and whether the pair touched at the last evaluation. The pair's
/// constants (r_i, r_j, masses) come with the partner's motion record (`Kin`), which the pass
/// reads anyway; m* and R* are computed in the lanes, with the operations the list build used.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(super) struct PairSlot<R: Real> {
    /// Zero whenever the pair does not touch (`h` < 0).
    pub(super) spring: V3<R>,
    /// Half the overlap, or −1 when the pair does not touch.
    pub(super) h: R,
}

impl<R: Real> Default for PairSlot<R> {
    /// A new entry: no spring, not touching.
    fn default() -> Self {
        Self {
            spring: V3::zero(),
            h: -R::one(),
        }
    }
}

impl<R: Real> PairSlot<R> {
    #[inline(always)]
    pub(super) fn touching(&self) -> bool {
        self.h >= R::zero()
    }
}

/// What a touching pair (i, j) does to its partner j when j lies in a later block than i: force,
/// torque and j. The pair pass of i's block hands it over; j's sum adds it. i adds its own share
/// during the pair pass.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Reaction<R: Real> {
    pub(super) f: V3<R>,
    pub(super) t: V3<R>,
    pub(super) j: u32,
}

/// Particles per task of the sphere passes. Fixed, not derived from the thread count: which
/// pairs hand their reaction over to a later block, and so the order of each particle's force
/// sum, depends on it. 2048 rather than 1024: fewer pairs cross blocks (a same-block or
/// cross-block partner is a branch the predictor often loses); not 4096, which leaves too few
/// blocks to share out among threads in small runs. A constant, and a power of two: the pair pass finds a partner's block
/// with a shift, not a division.
pub(super) const BLOCK: usize = 2048;
const _: () = assert!(BLOCK.is_power_of_two());

/// Everything the sphere pair pass reads.
pub(super) struct PairContext<'a, R: Real> {
    pub(super) kin: &'a [Kin<R>],
    pub(super) rotation: bool,
    pub(super) law: &'a LawKernel<R>,
    pub(super) periodic: &'a Periodic<R>,
    pub(super) dt: R,
    /// Whether springs are kept from step to step (history slots > 0).
    pub(super) keep_springs: bool,
    /// The half list's build count (`HalfList::builds`): a pick belongs to one build.
    pub(super) list_build: u64,
}

/// A chunk's touching pairs, found by the distance test and evaluated `LANES` at a time.
/// Kept by the engine per block so that its vectors grow once.
#[derive(Default)]
pub(super) struct PairScratch<R: Real> {
    /// Place in `pick` of each of a chunk's touching pairs, in entry order.
    entry: Vec<u32>,
    /// Their contact law's inputs.
    lanes: Box<LaneInput<R>>,
    /// Whether fewer than `SPARSE_BELOW` of the block's entries touched at the last pass.
    sparse: bool,
    /// The reactions this block hands over, by the partner's block: `handed[k]` goes to the
    /// block k + 1 after this one, in entry order. Only touching pairs: in a dilute bed most
    /// cross entries do not touch, and a partner then reads nothing for them.
    handed: Vec<Vec<Reaction<R>>>,
    /// How many of `handed` hold this pass's reactions (the rest are empty).
    reach: usize,
    /// The block's entries (block-local, ascending) within the near margin at the last
    /// `PairContext::pick`: the only ones the pass tests, each as [entry, owner, partner] (the
    /// pass then reads the particles' records straight from the pick, not through the list).
    pick: Vec<[u32; 3]>,
    /// The half list's build count at that pick.
    picked_in: u64,
    /// The block's particles at that pick: every picked owner lies among them.
    picked_for: std::ops::Range<usize>,
}

impl<R: Real> PairScratch<R> {
    /// The reactions handed over to the block `k + 1` after this one at the last pass, in entry
    /// order.
    pub(super) fn handed(&self, k: usize) -> &[Reaction<R>] {
        self.handed.get(k).map_or(&[], |v| v.as_slice())
    }

    /// One more than the farthest block (counted after this one) handed a reaction at the last
    /// pass.
    pub(super) fn reach(&self) -> usize {
        self.reach
    }
}

/// Below this fraction of touching entries (a dilute, flowing bed: 0.16 in the flowing chute) a
/// pair that does not touch is skipped by a branch the predictor mostly gets right, instead of
/// having its inputs written and overwritten (18 stores). Either way the lanes get the same
/// inputs, so the choice changes no result.
const SPARSE_BELOW: f64 = 0.35;

/// One block's share of the pair pass: the particles `first..first + force.len()`, their half
/// list entries' slots (the pairs themselves come from the block's pick, `PairContext::pick`)
/// and the block's force, torque and contact counts.
pub(super) struct PairBlock<'a, R: Real> {
    pub(super) first: usize,
    pub(super) slots: &'a mut [PairSlot<R>],
    pub(super) force: &'a mut [V3<R>],
    pub(super) torque: &'a mut [V3<R>],
    pub(super) nc: &'a mut [u32],
}

impl<R: Real> PairContext<'_, R> {
    /// Picks the block's entries (`owner`, the half list `nbr` from `e0`, `slots`) whose pair
    /// lies within `margin` of touching, in entry order: the only ones `block` tests until the
    /// next pick. The engine picks again before any particle has moved half the margin, so no
    /// other pair can touch meanwhile, and the pass evaluates the same touching pairs in the same
    /// order as over the whole list (the same bits). The others' slots are reset, as the pass
    /// would: they do not touch. `particles` is the block's range of owners: every owner must
    /// lie in it (checked here once per pick, so that the pass can index the block's sums by
    /// the picked owners unchecked).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn pick(
        &self,
        particles: std::ops::Range<usize>,
        owner: &[u32],
        nbr: &[u32],
        e0: usize,
        slots: &mut [PairSlot<R>],
        margin: R,
        scratch: &mut PairScratch<R>,
    ) {
        // The pass's own separation (minimum image on every axis: a length of zero leaves an
        // axis that is not periodic as it is).
        let sep = Separation::new(self.periodic.image());
        scratch.pick.clear();
        scratch.picked_in = self.list_build;
        let count = particles.len();
        let mut owners_inside = true;
        for (e, (&o, sl)) in owner.iter().zip(slots.iter_mut()).enumerate() {
            owners_inside &= (o as usize).wrapping_sub(particles.start) < count;
            let j = nbr[e0 + e];
            let (ki, kj) = (&self.kin[o as usize], &self.kin[j as usize]);
            // False for a particle that no longer interacts (NaN radius): it is left out.
            let cut = ki.r + kj.r + margin;
            if sep.of::<true>(ki, kj).1 < cut * cut {
                scratch.pick.push([e as u32, o, j]);
            } else {
                *sl = PairSlot::default();
            }
        }
        assert!(owners_inside, "a half-list owner outside its block");
        scratch.picked_for = particles;
    }

    /// Evaluates every picked pair (i, j > i) of the block's particles once (`pick`: every pair
    /// that can touch): advances the springs in
    /// place and writes into `force`, `torque` and `nc` (count of touching pairs) what the
    /// block's pairs do to its particles, in entry order; a touching pair whose partner lies in
    /// a later block hands its reaction over instead (`PairScratch::handed`). Returns the
    /// largest overlap ratio. Every value
    /// belongs to one block, so any split over threads writes the same bits.
    pub(super) fn block(&self, b: PairBlock<'_, R>, scratch: &mut PairScratch<R>) -> R {
        // Without periodic axes the minimum image is the plain difference: the folds would be
        // work in the distance test for nothing (the same bits). Each case
        // compiled apart, so that neither pays for the other's branch.
        let periodic = self.periodic.x.is_some() || self.periodic.y.is_some();
        match (periodic, scratch.sparse) {
            (true, false) => block_in::<R, true, false>(self, b, scratch),
            (true, true) => block_in::<R, true, true>(self, b, scratch),
            (false, false) => block_in::<R, false, false>(self, b, scratch),
            (false, true) => block_in::<R, false, true>(self, b, scratch),
        }
    }
}

/// Hands a partner's share over to the pass of its block (`jl` counted from this block's first
/// particle), counted from the block after this one; `reach` is how many blocks got one.
#[inline(always)]
fn hand_over<R: Real>(
    handed: &mut Vec<Vec<Reaction<R>>>,
    reach: &mut usize,
    jl: usize,
    r: Reaction<R>,
) {
    let later = jl / BLOCK - 1;
    if later >= handed.len() {
        handed.resize_with(later + 1, Vec::new);
    }
    *reach = (*reach).max(later + 1);
    handed[later].push(r);
}

/// Dense blocks: a pair that does not touch holds no spring and `h` < 0, so every picked slot
/// of the chunk is reset; the touching pairs' are written after the contact law.
#[inline(always)]
fn reset_picked(slots: &mut [PairSlot<impl Real>], pick: &[[u32; 3]]) {
    for &[e, ..] in pick {
        slots[e as usize] = PairSlot::default();
    }
}

impl<R: Real> PairScratch<R> {
    /// Zeroes a block's sums and empties the reactions it handed over last time. The sums are
    /// then indexed unchecked by the picked owners (inside the block, asserted in `block_in`)
    /// and by partners in the block (tested): every sum holds as many places as `force`.
    #[inline(always)]
    fn open_sums(&mut self, rot: bool, force: &mut [V3<R>], torque: &mut [V3<R>], nc: &mut [u32]) {
        let count = force.len();
        assert!(nc.len() == count && (!rot || torque.len() == count));
        if self.entry.len() < CHUNK {
            self.entry.resize(CHUNK, 0);
        }
        for l in 0..count {
            force[l] = V3::zero();
            if rot {
                torque[l] = V3::zero();
            }
            nc[l] = 0;
        }
        for h in &mut self.handed[..self.reach] {
            h.clear();
        }
    }
}

/// `PairContext::block`, with `PERIODIC` for whether any axis is periodic and `SPARSE` for
/// `scratch.sparse`. Compiled also for AVX2 and chosen at run time: three-operand instructions
/// need fewer register copies and spills than the generic form. No AVX-512 clone, unlike the
/// lanes: its gain here could not be measured. Rust never
/// fuses a multiply and an add, so every clone computes the same bits.
#[multiversion(targets("x86_64+avx2+avx"))]
fn block_in<R: Real, const PERIODIC: bool, const SPARSE: bool>(
    ctx: &PairContext<'_, R>,
    b: PairBlock<'_, R>,
    scratch: &mut PairScratch<R>,
) -> R {
    let PairBlock {
        first,
        slots,
        force,
        torque,
        nc,
    } = b;
    let rot = ctx.rotation;
    let count = force.len();
    scratch.open_sums(rot, force, torque, nc);
    // The picked entries only (`PairContext::pick`).
    let pick = &scratch.pick[..];
    let entries = pick.len();
    // The picks are ascending (`PairContext::pick`), so the last bounds them all: the slots
    // below are read without a bounds check each.
    let slots_len = slots.len();
    assert!(
        scratch.picked_in == ctx.list_build
            && scratch.picked_for == (first..first + count)
            && pick.last().is_none_or(|&[e, ..]| (e as usize) < slots_len)
    );
    let (mut touched, mut reach) = (0usize, 0usize);
    let handed = &mut scratch.handed;
    // The scratch as slices of exactly CHUNK places, indexed through a mask that changes
    // nothing (the place is below CHUNK) but lets the compiler drop the bounds checks and
    // the reloads of the vectors.
    let s_entry = &mut scratch.entry[..CHUNK];
    let lanes = &mut *scratch.lanes;
    const MASK: usize = CHUNK - 1;
    let sep = Separation::new(ctx.periodic.image());
    let mut max_ov = R::zero();
    let mut out = LaneOutput::<R>::default();
    // CHUNK entries at a time, so that their lane inputs stay in the first-level cache
    // between the distance test and the contact law; pairs still go in entry order.
    for c0 in (0..entries).step_by(CHUNK) {
        let c1 = (c0 + CHUNK).min(entries);
        // 1. The distance test: each touching pair's inputs straight into its lane, ended
        // contacts reset (a contact that ends loses its spring; the next one starts from
        // zero). Branch-free compaction: every entry is written at the next free place and
        // the place advances only for a touching pair (whether a pair touches is a coin
        // flip the branch predictor loses), unless few pairs touch (`SPARSE_BELOW`).
        let mut touching = 0usize;
        for (p, &[e, o, j]) in (c0..c1).zip(&pick[c0..c1]) {
            let (e, o, j) = (e as usize, o as usize, j as usize);
            debug_assert!(e < slots_len);
            // SAFETY: e < slots_len (the assertion above).
            let sl = unsafe { slots.get_unchecked_mut(e) };
            debug_assert!(o < ctx.kin.len() && j < ctx.kin.len());
            // SAFETY: every owner and partner of the half list (the pick holds this build's,
            // asserted above) is below the particle count
            // (`grid::build_half` indexes a vector of that length by each partner when it
            // builds the transpose, so a larger one would have panicked there), and
            // `CpuEngine::pair_pass` asserts that `kin` holds that many records. The bounds
            // checks would run once per entry in the hottest loop.
            let (ki, kj) = unsafe { (ctx.kin.get_unchecked(o), ctx.kin.get_unchecked(j)) };
            // From j to i.
            let (d, dist2) = sep.of::<PERIODIC>(ki, kj);
            let sum = ki.r + kj.r;
            // False for a particle that no longer interacts: its radius is NaN (`Kin::bury`).
            let touches = dist2 < sum * sum;
            if !SPARSE || touches {
                let mut lane = lanes.at(touching);
                // Angular velocities are zero when rotation is off.
                lane.motion(d, ki, kj);
                // A pair that does not touch holds a zero spring (see the reset below), so
                // the spring needs no test of whether the pair touched (a coin flip per
                // entry).
                let spring = if ctx.keep_springs {
                    sl.spring
                } else {
                    V3::zero()
                };
                lane.pair(ki.r, kj.r, ki.m, kj.m, spring);
                s_entry[touching & MASK] = p as u32;
            }
            touching += usize::from(touches);
            // Whether a pair touches is the coin flip; that one ends is rare. Dense: reset
            // below, since LLVM split this test there into a branch on the coin flip.
            if SPARSE && !touches & sl.touching() {
                *sl = PairSlot::default();
            }
        }
        if !SPARSE {
            reset_picked(slots, &pick[c0..c1]);
        }
        // 2. The contacts, LANES at a time (lanes past the end hold stale inputs; their
        // results are ignored); 3. their forces summed in entry order.
        for g in 0..touching.div_ceil(LANES) {
            pair_lanes::evaluate(ctx.law, ctx.dt, lanes, g, &mut out);
            for k in 0..(touching - g * LANES).min(LANES) {
                let c = g * LANES + k;
                // SAFETY: the places below `touching` were written in this chunk with a place
                // of `pick` (p < c1 <= entries); the pick's e < slots_len and its owner lies in
                // the block (l < count), both asserted above; force, torque (with rotation)
                // and nc hold count places (asserted above; force by definition); jl < count
                // is tested. The bounds checks were 8 compares and branches per touching pair.
                let [e, o, j] = unsafe { *pick.get_unchecked(s_entry[c & MASK] as usize) };
                let (e, l) = (e as usize, o as usize - first);
                let get = |a: &[[R; LANES]; 3]| V3::new(a[0][k], a[1][k], a[2][k]);
                let sl = unsafe { slots.get_unchecked_mut(e) };
                sl.spring = get(&out.spring);
                sl.h = out.h[k];
                let fc = get(&out.f);
                unsafe {
                    *force.get_unchecked_mut(l) += fc;
                    if rot {
                        *torque.get_unchecked_mut(l) -= get(&out.ti);
                    }
                    *nc.get_unchecked_mut(l) += 1;
                }
                // The partner's share: directly when it lies in this block (it comes after
                // the owner, so every particle's sum keeps one fixed order), else for its
                // pass.
                let jl = j as usize - first;
                if jl < count {
                    unsafe {
                        *force.get_unchecked_mut(jl) -= fc;
                        if rot {
                            *torque.get_unchecked_mut(jl) += get(&out.tj);
                        }
                        *nc.get_unchecked_mut(jl) += 1;
                    }
                } else {
                    let r = Reaction {
                        f: -fc,
                        t: get(&out.tj),
                        j,
                    };
                    hand_over(handed, &mut reach, jl, r);
                }
                max_ov = max_ov.max(out.ratio[k]);
            }
        }
        touched += touching;
    }
    scratch.sparse = (touched as f64) < SPARSE_BELOW * entries as f64;
    scratch.reach = reach;
    max_ov
}

/// What the per-particle sum of particle k reads besides its own kinematics.
pub(super) struct SumContext<'a, R: Real> {
    /// The pair pass's blocks (of `BLOCK` particles), with the reactions they handed over.
    pub(super) pairs: &'a [PairScratch<R>],
    /// The largest `PairScratch::reach` of `pairs`.
    pub(super) reach: usize,
    pub(super) law_pw: &'a LawKernel<R>,
    pub(super) walls: &'a [WallKernel<R>],
    pub(super) dt: R,
    pub(super) keep_springs: bool,
}

impl<R: Real> SumContext<'_, R> {
    /// Adds to the shares from the pair pass of the particles `first..first + force.len()` (a
    /// block) the reactions of the touching pairs where they are the partner and the owner lies
    /// in an earlier block, and counts them in `nc`. Each particle adds its reactions in entry
    /// order: the blocks in order, each block's in its order. The pairs that do not touch hand
    /// over nothing, as a zero would add nothing (a sum that starts at +0 is never −0).
    pub(super) fn reactions(
        &self,
        first: usize,
        force: &mut [V3<R>],
        torque: &mut [V3<R>],
        nc: &mut [u32],
        rot: bool,
    ) {
        let c = first / BLOCK;
        for b in c.saturating_sub(self.reach)..c {
            for r in self.pairs[b].handed(c - b - 1) {
                let l = r.j as usize - first;
                force[l] += r.f;
                if rot {
                    torque[l] += r.t;
                }
                nc[l] += 1;
            }
        }
    }

    /// Adds to particle k's force and torque (`f`, `t`: the pair pass's shares and
    /// `reactions`) its walls (springs in `wall_springs`, one per wall), testing only the walls
    /// in `near` (bit w for wall w < 32; see `WallKernel::may_touch`). Returns force, torque,
    /// largest wall overlap ratio and the number of wall contacts. Fixed particles get zero.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sum(
        &self,
        mut f: V3<R>,
        mut t: V3<R>,
        k: &Kin<R>,
        pr: Props<R>,
        wall_springs: &mut [V3<R>],
        near: u32,
    ) -> (V3<R>, V3<R>, R, u32) {
        let mut nc = 0u32;
        let mut max_ov = R::zero();
        if pr.inv_m == R::zero() {
            // Fixed particles feel no wall (as on the GPU): no wall spring survives either.
            wall_springs.fill(V3::zero());
            return (V3::zero(), V3::zero(), max_ov, nc);
        }
        let (pk, vk, wk, rk) = (k.pos, k.vel, k.omega, k.r);
        // Only the walls the particle may reach before the next list build (the others give no
        // contact and hold a zero spring), in wall order: the set bits of `near`, then any
        // walls past the 32nd. Most particles reach none, and the test for that is one branch
        // that changes only at the edges of the bed, not one per wall and particle.
        let mut bits = near;
        let far = (32..self.walls.len()).map(|w| w as u32);
        let walls = std::iter::from_fn(|| {
            (bits != 0).then(|| {
                let w = bits.trailing_zeros();
                bits &= bits - 1;
                w
            })
        })
        .chain(far);
        for w in walls {
            let (wall, ws) = (&self.walls[w as usize], &mut wall_springs[w as usize]);
            let Some(wc) = wall.touch_split(pk, k.lo, rk) else {
                *ws = V3::zero();
                continue;
            };
            let (bi, c) = wc.sphere_input(rk, k.m, vk, wk);
            let mut spring = if self.keep_springs { *ws } else { V3::zero() };
            let fc = contact_force(self.law_pw, &c, &mut spring, self.dt);
            *ws = spring;
            f += fc;
            t += bi.cross(fc);
            max_ov = max_ov.max(wc.overlap * pr.inv_d);
            nc += 1;
        }
        (f, t, max_ov, nc)
    }
}
