//! The spherocylinder step's block passes on the team: the near-pair pick, the pair pass, and
//! the per-particle sums (pairs, then walls) fused with the next step's kick, rotation and drift
//! and its skin tests.

use super::oriented;
use super::pair_pass::{PairSlot, BLOCK};
use super::particle::Status;
use super::passes::{block_bounds, scaled, split_blocks};
use super::rod_kick::{self, RotLanes, LANES};
use super::rod_pass::{RodContext, RodKin, RodMotion, RodScratch, RodSum};
use super::verlet;
use super::{CpuEngine, NEAR_LIMIT, ROD_NEAR};
use crate::engine::contact::Inertial;
use crate::engine::grid::Periodic;
use crate::engine::real::{Real, V3};
use crate::engine::shape::{Quat, Spherocylinder};

/// What a rod block's sums, kick and drift found.
#[derive(Clone, Copy)]
pub(super) struct RodSwept<R: Real> {
    /// Some particle fell through the sink.
    pub(super) died: bool,
    /// Some rod end moved half the skin since the lists were built.
    pub(super) moved: bool,
    /// Some rod end moved `NEAR_LIMIT` of the near margin since the last pick.
    pub(super) repick: bool,
    /// The largest wall overlap ratio.
    pub(super) wall_overlap: R,
    /// The most contacts of one particle.
    pub(super) fullest: u32,
}

impl<R: Real> Default for RodSwept<R> {
    fn default() -> Self {
        Self {
            died: false,
            moved: false,
            repick: false,
            wall_overlap: R::zero(),
            fullest: 0,
        }
    }
}

impl<R: Real> RodSwept<R> {
    fn merge(self, o: Self) -> Self {
        Self {
            died: self.died || o.died,
            moved: self.moved || o.moved,
            repick: self.repick || o.repick,
            wall_overlap: self.wall_overlap.max(o.wall_overlap),
            fullest: self.fullest.max(o.fullest),
        }
    }
}

/// The pieces of the per-particle arrays a block of the sum pass writes.
struct RodBlock<'a, R: Real> {
    force: &'a mut [V3<R>],
    torque: &'a mut [V3<R>],
    nc: &'a mut [u32],
    vel: &'a mut [V3<R>],
    pos: &'a mut [V3<R>],
    lo: &'a mut [V3<R>],
    alive: &'a mut [Status],
    q: &'a mut [Quat<R>],
    ang_mom: &'a mut [V3<R>],
    omega: &'a mut [V3<R>],
    axis: &'a mut [V3<R>],
    walls: &'a mut [PairSlot<R>],
    kin: &'a mut [RodKin<R>],
}

/// Per particle: its position and axis at some earlier step (a skin test's reference).
type References<'a, R> = (&'a [V3<R>], &'a [V3<R>]);

/// The kick, rotation and drift of a step, and the skin tests' references.
struct RodKick<'a, R: Real> {
    kick: R,
    dt: R,
    g: V3<R>,
    periodic: Periodic<R>,
    sink_z: Option<R>,
    half_skin: R,
    near_limit: R,
    inv_mass: &'a [R],
    inv_inertia: &'a [V3<R>],
    half_length: &'a [R],
    /// Positions and axes at the last list build (None when stale) and at the last pick.
    list_ref: Option<References<'a, R>>,
    near_ref: Option<References<'a, R>>,
}

impl<R: Real> RodKick<'_, R> {
    /// The block's particles (from `first`): kick, free rotation (`LANES` at a time,
    /// `rod_kick.rs`) and drift; returns whether one fell through the sink, moved beyond the
    /// list's skin, beyond the pick's margin.
    fn block(&self, first: usize, k: &mut RodBlock<'_, R>) -> (bool, bool, bool) {
        let count = k.force.len();
        let mut found = (false, false, false);
        let mut lanes = RotLanes::<R>::default();
        for g0 in (0..count).step_by(LANES) {
            let group = g0..(g0 + LANES).min(count);
            let mut moving = [false; LANES];
            for l in group.clone() {
                let i = first + l;
                if self.inv_mass[i] == R::zero() || k.alive[l] != Status::Alive {
                    continue;
                }
                moving[l - g0] = true;
                lanes.set(
                    l - g0,
                    k.q[l],
                    k.ang_mom[l],
                    k.torque[l],
                    self.inv_inertia[i],
                );
            }
            rod_kick::rotate(&mut lanes, self.kick, self.dt);
            for l in group {
                if !moving[l - g0] {
                    continue;
                }
                let f = self.particle(first + l, l, k, lanes.get(l - g0));
                found = (found.0 | f.0, found.1 | f.1, found.2 | f.2);
            }
        }
        found
    }

    /// Particle i (place l of the block) with its rotation from the lanes (`rotated`, else the
    /// scalar code): kick, drift, skin tests (`block`).
    #[inline]
    fn particle(
        &self,
        i: usize,
        l: usize,
        k: &mut RodBlock<'_, R>,
        rotated: Option<(Quat<R>, V3<R>, V3<R>)>,
    ) -> (bool, bool, bool) {
        let (v, x) = (&mut k.vel[l], &mut k.pos[l]);
        verlet::kick(v, k.force[l], self.inv_mass[i], self.g, self.kick);
        verlet::drift(x, &mut k.lo[l], *v, self.dt, &self.periodic);
        let h = self.half_length[i];
        let ii = self.inv_inertia[i];
        // As `oriented::kick_rotate`: a body without inverse inertia does not turn.
        let turned = if ii.x == R::zero() {
            R::zero()
        } else {
            if let Some((q, am, w)) = rotated {
                (k.q[l], k.ang_mom[l], k.omega[l]) = (q, am, w);
            } else {
                let (q, am, w) = (&mut k.q[l], &mut k.ang_mom[l], &mut k.omega[l]);
                oriented::kick_rotate(q, am, w, k.torque[l], ii, h, None, self.kick, self.dt);
            }
            match self.list_ref {
                Some((_, a)) if h > R::zero() => (k.q[l].axis_z() - a[i]).norm() * h,
                _ => R::zero(),
            }
        };
        let u = k.q[l].axis_z();
        k.axis[l] = u;
        let rec = &mut k.kin[l];
        (rec.pos, rec.lo, rec.vel, rec.omega, rec.axis) = (*x, k.lo[l], *v, k.omega[l], u);
        let died = matches!(self.sink_z, Some(zs) if x.z < zs);
        if died {
            k.alive[l] = Status::Dying;
        }
        // The ends of a rod move by at most |Δc| + (l/2)|Δu|.
        let moved = match self.list_ref {
            Some((p, _)) => self.periodic.delta(p[i], *x).norm() + turned > self.half_skin,
            None => true,
        };
        let repick = match self.near_ref {
            Some((p, a)) => {
                self.periodic.delta(p[i], *x).norm() + (u - a[i]).norm() * h > self.near_limit
            }
            None => true,
        };
        (died, moved, repick)
    }
}

impl<R: Real> CpuEngine<R> {
    /// Sizes the per-block scratch for the current half lists; returns the block bounds
    /// (particles, entries).
    fn rod_blocks(&mut self) -> (Vec<usize>, Vec<usize>) {
        let (parts, entries) = block_bounds(&self.half.start, self.state.len());
        let nblocks = parts.len() - 1;
        if self.rod_scratch.len() < nblocks {
            self.rod_scratch.resize_with(nblocks, RodScratch::default);
        }
        (parts, entries)
    }

    /// Picks in each block the entries within the near margin (`ROD_NEAR` of the skin) of touching,
    /// the only ones the pair pass evaluates until the next pick, and notes where the rods are.
    pub(super) fn pick_rods(&mut self) {
        let (_, entries) = self.rod_blocks();
        let margin = self.skin * R::from_f64(ROD_NEAR);
        let blocks = split_blocks(&mut self.pair_slots, &entries)
            .into_iter()
            .zip(self.rod_scratch.iter_mut())
            .collect::<Vec<_>>();
        let ctx = RodContext {
            kin: &self.rod_kin,
            alive: &self.alive,
            law: &self.law_pp,
            image: self.periodic.image(),
            dt: self.dt,
            keep_springs: self.slots > 0,
        };
        let (owner, nbr) = (&self.half.owner, &self.half.nbr);
        self.team.run_blocks(blocks, |b, (slots, scratch)| {
            let owner = &owner[entries[b]..entries[b + 1]];
            ctx.pick(owner, nbr, entries[b], slots, margin, scratch);
        });
        self.near_ref.clone_from(&self.state.pos);
        self.near_ref_axis.clone_from(&self.axis);
    }

    /// Evaluates every picked pair once (`RodContext::block`); returns the largest overlap
    /// ratio.
    pub(super) fn rod_pair_pass(&mut self) -> R {
        let (parts, entries) = self.rod_blocks();
        let blocks = split_blocks(&mut self.pair_slots, &entries)
            .into_iter()
            .zip(self.rod_scratch.iter_mut())
            .collect::<Vec<_>>();
        let ctx = RodContext {
            kin: &self.rod_kin,
            alive: &self.alive,
            law: &self.law_pp,
            image: self.periodic.image(),
            dt: self.dt,
            keep_springs: self.slots > 0,
        };
        self.team
            .run_blocks(blocks, |b, (slots, scratch)| {
                ctx.block(parts[b], parts[b + 1] - parts[b], slots, scratch)
            })
            .into_iter()
            .fold(R::zero(), |a, b| a.max(b))
    }

    /// Per block: with `sums`, each particle's force and torque (pairs in ascending order of
    /// the partner, then walls; zero for a fixed one) into `state.force`/`torque` and its count
    /// of contacts into `contacts`; then, with `kick`, the kick by it, the rotation and the
    /// drift over dt (the next step's opening) with the skin tests.
    pub(super) fn rod_sum_kick_drift(&mut self, sums: bool, kick: Option<R>) -> RodSwept<R> {
        let n = self.state.len();
        let nw = self.walls.len();
        let nblocks = n.div_ceil(BLOCK);
        let parts: Vec<usize> = (0..nblocks)
            .map(|b| b * BLOCK)
            .chain(std::iter::once(n))
            .collect();
        self.contacts.resize(n, 0);
        self.axis.resize(n, V3::zero());
        let pairs = &self.rod_scratch[..nblocks.min(self.rod_scratch.len())];
        let sum = RodSum {
            pairs,
            reach: pairs.iter().map(RodScratch::reach).max().unwrap_or(0),
            law_pw: &self.law_pw,
            walls: &self.walls,
            dt: self.dt,
            keep_springs: self.slots > 0,
        };
        let s = &mut self.state;
        let fresh = |r: &[V3<R>], a: &[V3<R>]| r.len() == n && a.len() == n;
        let step = RodKick {
            kick: kick.unwrap_or(R::zero()),
            dt: self.dt,
            g: self.gravity,
            periodic: self.periodic,
            sink_z: self.sink_z,
            half_skin: self.skin * R::from_f64(0.5),
            near_limit: self.skin * R::from_f64(ROD_NEAR * NEAR_LIMIT),
            inv_mass: &s.inv_mass,
            inv_inertia: &s.inv_inertia_body,
            half_length: &s.half_length,
            list_ref: fresh(&self.half.ref_pos, &self.rod_ref_axis)
                .then_some((&self.half.ref_pos[..], &self.rod_ref_axis[..])),
            near_ref: fresh(&self.near_ref, &self.near_ref_axis)
                .then_some((&self.near_ref[..], &self.near_ref_axis[..])),
        };
        let (mass, radius) = (&s.mass, &s.radius);
        let mut blocks = Vec::with_capacity(nblocks);
        let mut pieces = (
            split_blocks(&mut s.force, &parts).into_iter(),
            split_blocks(&mut s.torque, &parts).into_iter(),
            split_blocks(&mut self.contacts, &parts).into_iter(),
            split_blocks(&mut s.vel, &parts).into_iter(),
            split_blocks(&mut s.pos, &parts).into_iter(),
            split_blocks(&mut s.pos_lo, &parts).into_iter(),
            split_blocks(&mut self.alive, &parts).into_iter(),
            split_blocks(&mut s.orientation, &parts).into_iter(),
            split_blocks(&mut s.ang_mom, &parts).into_iter(),
            split_blocks(&mut s.omega, &parts).into_iter(),
            split_blocks(&mut self.axis, &parts).into_iter(),
            split_blocks(&mut self.rod_walls, &scaled(&parts, nw)).into_iter(),
            split_blocks(&mut self.rod_kin, &parts).into_iter(),
        );
        for _ in 0..nblocks {
            blocks.push(RodBlock {
                force: pieces.0.next().unwrap(),
                torque: pieces.1.next().unwrap(),
                nc: pieces.2.next().unwrap(),
                vel: pieces.3.next().unwrap(),
                pos: pieces.4.next().unwrap(),
                lo: pieces.5.next().unwrap(),
                alive: pieces.6.next().unwrap(),
                q: pieces.7.next().unwrap(),
                ang_mom: pieces.8.next().unwrap(),
                omega: pieces.9.next().unwrap(),
                axis: pieces.10.next().unwrap(),
                walls: pieces.11.next().unwrap(),
                kin: pieces.12.next().unwrap(),
            });
        }
        self.team
            .run_blocks(blocks, |b, k| {
                let first = parts[b];
                let count = k.force.len();
                let mut out = RodSwept::<R>::default();
                if sums {
                    sum.pairs(b, first, k.force, k.torque, k.nc);
                }
                for l in 0..count {
                    let i = first + l;
                    if sums {
                        let wsl = &mut k.walls[l * nw..(l + 1) * nw];
                        if k.alive[l] == Status::Alive && step.inv_mass[i] != R::zero() {
                            let m = RodMotion {
                                pos: k.pos[l],
                                lo: k.lo[l],
                                vel: k.vel[l],
                                omega: k.omega[l],
                                axis: k.axis[l],
                                body: Inertial {
                                    mass: mass[i],
                                    inv_mass: step.inv_mass[i],
                                    inv_i_perp: step.inv_inertia[i].x,
                                    half_length: step.half_length[i],
                                },
                                shape: Spherocylinder {
                                    half_length: step.half_length[i],
                                    radius: radius[i],
                                },
                            };
                            let (f, t, c) = (&mut k.force[l], &mut k.torque[l], &mut k.nc[l]);
                            let ov = sum.walls(&m, f, t, c, wsl);
                            out.wall_overlap = out.wall_overlap.max(ov);
                        } else {
                            wsl.fill(PairSlot::default());
                            // Fixed particles feel no force.
                            k.force[l] = V3::zero();
                            k.torque[l] = V3::zero();
                        }
                        out.fullest = out.fullest.max(k.nc[l]);
                    }
                }
                if kick.is_some() {
                    (out.died, out.moved, out.repick) = step.block(first, k);
                }
                out
            })
            .into_iter()
            .fold(RodSwept::default(), RodSwept::merge)
    }
}
