//! Force kernels of the CPU engine's spherocylinder step (`cpu/rods.rs`): the near-pair pick,
//! one evaluation per pair of the half lists (Newton's third law: force and torque on both
//! rods), and the per-particle sum, in blocks of `BLOCK` particles as for spheres.
//!
//! Each particle's sum adds its pairs in ascending order of the partner's place (the order the
//! full-list gather of `oriented.rs` used, so both give the same bits): first the reactions
//! handed over by earlier blocks (their owners come before the block), then the block's own
//! touching pairs replayed in entry order (owners before the particle as partners, then its
//! own entries), then its walls. Each pair is evaluated in one canonical order, the lower id as
//! "a" (`oriented.rs`), and its spring is that of a's view.

use super::pair_pass::{PairSlot, Reaction, BLOCK};
use super::particle::Status;
use super::rod_lanes::{self, RodLaneInput, RodLaneOutput, LANES};
use super::rod_pick_lanes::{self, PickLanes};
use crate::engine::contact::{
    contact_force, pair_effective_mass, wall_effective_mass, ContactInput, Inertial, LawKernel,
};
use crate::engine::grid::Image;
use crate::engine::position::separation;
use crate::engine::real::{Real, V3};
use crate::engine::shape::{contact_spherocylinders, Spherocylinder};
use crate::engine::state::State;
use crate::engine::walls::WallKernel;

/// Particle k as the effective mass of its contacts sees it.
#[inline(always)]
pub(super) fn inertial<R: Real>(s: &State<R>, k: usize) -> Inertial<R> {
    Inertial {
        mass: s.mass[k],
        inv_mass: s.inv_mass[k],
        inv_i_perp: s.inv_inertia_body[k].x,
        half_length: s.half_length[k],
    }
}

/// One rod's motion and constants packed in one record, what the pair pass reads of both rods
/// of a pair (from a dozen state arrays that cost a dozen cache lines per rod). Copies of the
/// state's values: written at each list build and by the kick.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct RodKin<R: Real> {
    pub(super) pos: V3<R>,
    pub(super) r: R,
    /// The rest of the position (`position.rs`).
    pub(super) lo: V3<R>,
    /// l/2.
    pub(super) h: R,
    /// The unit axis, `orientation.axis_z()`.
    pub(super) axis: V3<R>,
    /// 1/m, zero when fixed.
    pub(super) inv_m: R,
    pub(super) vel: V3<R>,
    pub(super) m: R,
    pub(super) omega: V3<R>,
    /// 1/I⊥, zero when fixed.
    pub(super) inv_i: R,
    pub(super) id: u32,
}

impl<R: Real> RodKin<R> {
    /// Particle k of the state, with its axis `axis`.
    pub(super) fn of(s: &State<R>, k: usize, axis: V3<R>) -> Self {
        Self {
            pos: s.pos[k],
            r: s.radius[k],
            lo: s.lo(k),
            h: s.half_length[k],
            axis,
            inv_m: s.inv_mass[k],
            vel: s.vel[k],
            m: s.mass[k],
            omega: s.omega[k],
            inv_i: s.inv_inertia_body[k].x,
            id: s.id[k],
        }
    }

    #[inline(always)]
    fn shape(&self) -> Spherocylinder<R> {
        Spherocylinder {
            half_length: self.h,
            radius: self.r,
        }
    }

    #[inline(always)]
    fn body(&self) -> Inertial<R> {
        Inertial {
            mass: self.m,
            inv_mass: self.inv_m,
            inv_i_perp: self.inv_i,
            half_length: self.h,
        }
    }
}

/// What a rod pass reads: the rods' records and liveness.
pub(super) struct RodContext<'a, R: Real> {
    pub(super) kin: &'a [RodKin<R>],
    pub(super) alive: &'a [Status],
    pub(super) law: &'a LawKernel<R>,
    pub(super) image: Image<R>,
    pub(super) dt: R,
    /// Whether springs are kept from step to step (history slots > 0).
    pub(super) keep_springs: bool,
}

/// A touching pair of a block: its owner o and partner j, the force and torque on o, and the
/// torque on j (the force on j is −f).
#[derive(Clone, Copy, Debug)]
pub(super) struct RodTouch<R: Real> {
    o: u32,
    j: u32,
    f: V3<R>,
    t_o: V3<R>,
    t_j: V3<R>,
}

/// A block's working lists, kept by the engine so that their vectors grow once.
#[derive(Default)]
pub(super) struct RodScratch<R: Real> {
    /// The block's entries within the near margin at the last pick, as [entry (block-local),
    /// owner, partner], in entry order: the only ones the pass evaluates.
    pick: Vec<[u32; 3]>,
    /// This pass's touching pairs, in entry order.
    touch: Vec<RodTouch<R>>,
    /// The reactions handed over to the block k + 1 after this one, in entry order.
    handed: Vec<Vec<Reaction<R>>>,
    /// How many of `handed` hold this pass's reactions.
    reach: usize,
}

impl<R: Real> RodScratch<R> {
    pub(super) fn reach(&self) -> usize {
        self.reach
    }
}

/// One evaluated pair, seen from its owner o.
struct Evaluated<R: Real> {
    f: V3<R>,
    t_o: V3<R>,
    t_j: V3<R>,
    ratio: R,
    half_overlap: R,
}

impl<R: Real> RodContext<'_, R> {
    /// c_a − c_b (minimum image), as `State::separation(b, a)`.
    #[inline(always)]
    fn centre_gap(&self, a: &RodKin<R>, b: &RodKin<R>) -> V3<R> {
        self.image.fold(separation(b.pos, b.lo, a.pos, a.lo))
    }

    /// Picks the entries of the block (owners `owner`, partners `nbr` from entry `e0`) whose
    /// axes lie within `margin` of touching; resets the others' slots (they do not touch). The
    /// engine picks again before any rod end has moved `NEAR_LIMIT` of the margin, so no other
    /// pair can touch meanwhile (a rod's axis points move by at most |Δc| + (l/2)|Δu|).
    pub(super) fn pick(
        &self,
        owner: &[u32],
        nbr: &[u32],
        e0: usize,
        slots: &mut [PairSlot<R>],
        margin: R,
        scratch: &mut RodScratch<R>,
    ) {
        scratch.pick.clear();
        let mut group = PickLanes::default();
        let mut lanes = [[0u32; 3]; LANES];
        let mut near = [false; LANES];
        let mut keep = |lanes: &[[u32; 3]], near: &[bool]| {
            for (&entry, &near) in lanes.iter().zip(near) {
                if near {
                    scratch.pick.push(entry);
                } else {
                    slots[entry[0] as usize] = PairSlot::default();
                }
            }
        };
        // The axes' squared distance against cut², as `contact_spherocylinders` measures it,
        // LANES entries at a time.
        for (e, &o) in owner.iter().enumerate() {
            let j = nbr[e0 + e];
            let (ko, kj) = (&self.kin[o as usize], &self.kin[j as usize]);
            let cut = ko.r + kj.r + margin;
            let l = e % LANES;
            group.set(
                l,
                self.centre_gap(ko, kj),
                ko.axis * ko.h,
                kj.axis * kj.h,
                cut * cut,
            );
            lanes[l] = [e as u32, o, j];
            if l == LANES - 1 {
                rod_pick_lanes::near(&group, &mut near);
                keep(&lanes, &near);
            }
        }
        let rest = owner.len() % LANES;
        if rest > 0 {
            rod_pick_lanes::near(&group, &mut near);
            keep(&lanes[..rest], &near[..rest]);
        }
    }

    /// The pair (o, j) in canonical order with spring `spring` (advanced in place), if they
    /// touch: the operations of `OrientedContext::particle`, once for both rods.
    #[inline]
    fn evaluate(&self, o: usize, j: usize, spring: &mut V3<R>) -> Option<Evaluated<R>> {
        let (ko, kj) = (&self.kin[o], &self.kin[j]);
        let o_is_a = ko.id < kj.id;
        let (a, b) = if o_is_a { (ko, kj) } else { (kj, ko) };
        let (sa, sb) = (a.shape(), b.shape());
        let pc = contact_spherocylinders(self.centre_gap(a, b), a.axis, &sa, b.axis, &sb)?;
        let v_rel = (a.vel + a.omega.cross(pc.arm_i)) - (b.vel + b.omega.cross(pc.arm_j));
        let m_eff = pair_effective_mass(a.body(), b.body(), pc.arm_i, pc.arm_j, pc.normal);
        let c = ContactInput {
            overlap: pc.overlap,
            normal: pc.normal,
            v_rel,
            r_eff: sa.radius * sb.radius / (sa.radius + sb.radius),
            m_eff,
        };
        let fc = contact_force(self.law, &c, spring, self.dt);
        let (f_o, arm_o, arm_j) = if o_is_a {
            (fc, pc.arm_i, pc.arm_j)
        } else {
            (-fc, pc.arm_j, pc.arm_i)
        };
        Some(Evaluated {
            f: f_o,
            t_o: arm_o.cross(f_o),
            t_j: arm_j.cross(-f_o),
            ratio: pc.overlap / (sa.radius.min(sb.radius) * R::from_f64(2.0)),
            half_overlap: pc.overlap * R::from_f64(0.5),
        })
    }

    /// Evaluates the block's picked pairs once, `LANES` at a time (`rod_lanes.rs`): springs
    /// advanced in `slots`, the touching pairs kept for the block's sum, the reactions on
    /// partners in later blocks handed over. `first..first + count` are the block's particles.
    /// Returns the largest overlap ratio.
    pub(super) fn block(
        &self,
        first: usize,
        count: usize,
        slots: &mut [PairSlot<R>],
        scratch: &mut RodScratch<R>,
    ) -> R {
        scratch.touch.clear();
        for h in &mut scratch.handed[..scratch.reach] {
            h.clear();
        }
        let mut reach = 0;
        let mut max_ov = R::zero();
        let zero = V3::zero();
        let mut inp = RodLaneInput::<R>::default();
        let mut out = RodLaneOutput::<R>::default();
        let pick = &scratch.pick;
        for (g, group) in pick.chunks(LANES).enumerate() {
            // The next group's records are requested now, so that their loads overlap this
            // group's work instead of stalling its gather.
            for &[_, o, j] in pick.iter().skip((g + 1) * LANES).take(LANES) {
                prefetch(&self.kin[o as usize]);
                prefetch(&self.kin[j as usize]);
            }
            // Which lanes hold a live pair, and whether its owner is "a".
            let mut live = [false; LANES];
            let mut o_is_a = [false; LANES];
            for (l, &[e, o, j]) in group.iter().enumerate() {
                let (oi, ji) = (o as usize, j as usize);
                if self.alive[oi] != Status::Alive || self.alive[ji] != Status::Alive {
                    slots[e as usize] = PairSlot::default();
                    continue;
                }
                live[l] = true;
                let (ko, kj) = (&self.kin[oi], &self.kin[ji]);
                o_is_a[l] = ko.id < kj.id;
                let (a, b) = if o_is_a[l] { (ko, kj) } else { (kj, ko) };
                let spring = if self.keep_springs {
                    slots[e as usize].spring
                } else {
                    zero
                };
                inp.set(
                    l,
                    [
                        self.centre_gap(a, b),
                        a.axis,
                        b.axis,
                        a.vel,
                        a.omega,
                        b.vel,
                        b.omega,
                        spring,
                    ],
                    [a.r, b.r],
                    [a.body(), b.body()],
                );
            }
            rod_lanes::evaluate(self.law, self.dt, &inp, &mut out);
            for (l, &[e, o, j]) in group.iter().enumerate() {
                if !live[l] {
                    continue;
                }
                let sl = &mut slots[e as usize];
                let (oi, ji) = (o as usize, j as usize);
                let ev = if out.exact[l] && out.touch[l] {
                    // Axes that touch exactly: the scalar code's normal.
                    let mut spring = if self.keep_springs { sl.spring } else { zero };
                    let ev = self.evaluate(oi, ji, &mut spring);
                    if let Some(ev) = &ev {
                        *sl = PairSlot {
                            spring,
                            h: ev.half_overlap,
                        };
                    }
                    ev
                } else if out.touch[l] {
                    let g = |c: &[[R; LANES]; 3]| V3::new(c[0][l], c[1][l], c[2][l]);
                    let (f, ta, tb) = (g(&out.f), g(&out.ta), g(&out.tb));
                    *sl = PairSlot {
                        spring: g(&out.spring),
                        h: out.half_overlap[l],
                    };
                    Some(if o_is_a[l] {
                        Evaluated {
                            f,
                            t_o: ta,
                            t_j: tb,
                            ratio: out.ratio[l],
                            half_overlap: out.half_overlap[l],
                        }
                    } else {
                        Evaluated {
                            f: -f,
                            t_o: tb,
                            t_j: ta,
                            ratio: out.ratio[l],
                            half_overlap: out.half_overlap[l],
                        }
                    })
                } else {
                    None
                };
                let Some(ev) = ev else {
                    *sl = PairSlot::default();
                    continue;
                };
                max_ov = max_ov.max(ev.ratio);
                scratch.touch.push(RodTouch {
                    o,
                    j,
                    f: ev.f,
                    t_o: ev.t_o,
                    t_j: ev.t_j,
                });
                let jl = ji - first;
                if jl >= count {
                    let later = jl / BLOCK - 1;
                    if later >= scratch.handed.len() {
                        scratch.handed.resize_with(later + 1, Vec::new);
                    }
                    reach = reach.max(later + 1);
                    scratch.handed[later].push(Reaction {
                        f: -ev.f,
                        t: ev.t_j,
                        j,
                    });
                }
            }
        }
        scratch.reach = reach;
        max_ov
    }
}

/// Asks the cache for the record at `r` (both of its lines: a record may straddle two).
#[inline(always)]
fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = (r as *const T).cast::<i8>();
        // SAFETY: a prefetch is a hint: it never faults, whatever the address.
        unsafe {
            _mm_prefetch(p, _MM_HINT_T0);
            _mm_prefetch(p.wrapping_add(std::mem::size_of::<T>() - 1), _MM_HINT_T0);
        }
    }
}

/// What a block's sum reads besides its own particles.
pub(super) struct RodSum<'a, R: Real> {
    /// Every block's scratch after the pair pass.
    pub(super) pairs: &'a [RodScratch<R>],
    /// The largest `RodScratch::reach` of `pairs`.
    pub(super) reach: usize,
    pub(super) law_pw: &'a LawKernel<R>,
    pub(super) walls: &'a [WallKernel<R>],
    pub(super) dt: R,
    pub(super) keep_springs: bool,
}

impl<R: Real> RodSum<'_, R> {
    /// The pairs' forces and torques on the particles `first..first + force.len()` (block
    /// `b`), in ascending order of the partner (module doc), and their counts in `nc`.
    pub(super) fn pairs(
        &self,
        b: usize,
        first: usize,
        force: &mut [V3<R>],
        torque: &mut [V3<R>],
        nc: &mut [u32],
    ) {
        force.fill(V3::zero());
        torque.fill(V3::zero());
        nc.fill(0);
        for a in b.saturating_sub(self.reach)..b {
            for r in self.pairs[a].handed.get(b - a - 1).map_or(&[][..], |v| v) {
                let l = r.j as usize - first;
                force[l] += r.f;
                torque[l] += r.t;
                nc[l] += 1;
            }
        }
        let count = force.len();
        for t in &self.pairs[b].touch {
            let l = t.o as usize - first;
            force[l] += t.f;
            torque[l] += t.t_o;
            nc[l] += 1;
            let jl = t.j as usize - first;
            if jl < count {
                force[jl] += -t.f;
                torque[jl] += t.t_j;
                nc[jl] += 1;
            }
        }
    }

    /// Adds the walls to the force `f` and torque `t` of the mobile particle `k` (wall springs
    /// and touching flags in `slots`, one per wall). Returns the largest wall overlap ratio.
    #[inline]
    pub(super) fn walls(
        &self,
        k: &RodMotion<R>,
        f: &mut V3<R>,
        t: &mut V3<R>,
        nc: &mut u32,
        slots: &mut [PairSlot<R>],
    ) -> R {
        let shape = k.shape;
        let mut max_ov = R::zero();
        for (wall, sl) in self.walls.iter().zip(slots.iter_mut()) {
            let Some((pc, wall_velocity)) = wall.touch_oriented(k.pos, k.lo, k.axis, &shape) else {
                *sl = PairSlot::default();
                continue;
            };
            let v_rel = k.vel + k.omega.cross(pc.arm) - wall_velocity;
            let c = ContactInput {
                overlap: pc.overlap,
                normal: pc.normal,
                v_rel,
                r_eff: shape.radius,
                m_eff: wall_effective_mass(k.body, pc.arm, pc.normal),
            };
            let mut spring = if self.keep_springs {
                sl.spring
            } else {
                V3::zero()
            };
            let fc = contact_force(self.law_pw, &c, &mut spring, self.dt);
            *sl = PairSlot {
                spring,
                h: pc.overlap * R::from_f64(0.5),
            };
            *f += fc;
            *t += pc.arm.cross(fc);
            max_ov = max_ov.max(pc.overlap / (shape.radius * R::from_f64(2.0)));
            *nc += 1;
        }
        max_ov
    }
}

/// One particle's motion and shape, as its wall contacts read them.
pub(super) struct RodMotion<R: Real> {
    pub(super) pos: V3<R>,
    pub(super) lo: V3<R>,
    pub(super) vel: V3<R>,
    pub(super) omega: V3<R>,
    pub(super) axis: V3<R>,
    pub(super) body: Inertial<R>,
    pub(super) shape: Spherocylinder<R>,
}
