//! The sphere step's per-particle integration: velocity Verlet's kick (force and torque, already
//! complete, into velocity and angular velocity) and, at a step's opening, its drift (position,
//! periodic wrap, the sink), over one block of motion records.

use multiversion::multiversion;

use super::kinematics::Kin;
use super::particle::{Props, Status};
use super::verlet;
use crate::engine::grid::Periodic;
use crate::engine::real::{Real, V3};

/// What every particle's kick and drift reads besides its own arrays.
#[derive(Clone, Copy)]
pub(super) struct Kick<R: Real> {
    /// The kick's time: dt/2.
    pub(super) kick: R,
    pub(super) dt: R,
    pub(super) g: V3<R>,
    /// Whether to drift after the kick (the next step's opening).
    pub(super) drift: bool,
    pub(super) rotation: bool,
    pub(super) periodic: Periodic<R>,
    /// Particles below this height fall through the sink (−∞ without one).
    pub(super) sink_z: R,
}

/// One block's arrays, each cut to the block's particles (`torque` empty without rotation).
pub(super) struct KickBlock<'a, R: Real> {
    pub(super) kin: &'a mut [Kin<R>],
    pub(super) force: &'a mut [V3<R>],
    pub(super) torque: &'a mut [V3<R>],
    pub(super) alive: &'a mut [Status],
    pub(super) nc: &'a mut [u32],
    pub(super) props: &'a [Props<R>],
}

/// What a block's kick found: whether a particle fell through the sink, the largest squared
/// speed of a drifted particle (the lists' skin test needs only the fastest), the most contacts
/// of one particle.
pub(super) struct Kicked<R: Real> {
    pub(super) died: bool,
    pub(super) v_max2: R,
    pub(super) fullest: u32,
}

impl<R: Real> Kick<R> {
    /// Kicks (and with `drift`, drifts) the block's live, mobile particles; a particle no longer
    /// alive gets zero force, torque and contact count. A particle that drifts below the sink
    /// becomes `Dying` and stops interacting (`Kin::bury`).
    pub(super) fn block(&self, b: KickBlock<'_, R>) -> Kicked<R> {
        #[cfg(target_arch = "x86_64")]
        if super::simd::is_f32::<R>() {
            /// SAFETY: only for R = f32: each cast is then to the type the value has.
            unsafe fn cast<R: Real>(b: KickBlock<'_, R>) -> KickBlock<'_, f32> {
                unsafe {
                    KickBlock {
                        kin: &mut *(b.kin as *mut [Kin<R>] as *mut [Kin<f32>]),
                        force: &mut *(b.force as *mut [V3<R>] as *mut [V3<f32>]),
                        torque: &mut *(b.torque as *mut [V3<R>] as *mut [V3<f32>]),
                        alive: b.alive,
                        nc: b.nc,
                        props: &*(b.props as *const [Props<R>] as *const [Props<f32>]),
                    }
                }
            }
            // SAFETY: R is f32.
            let b = unsafe { cast(b) };
            // SAFETY: as above.
            let k = unsafe { &*(self as *const Kick<R> as *const Kick<f32>) };
            let r = match (self.rotation, self.drift) {
                (true, true) => quads::kick_f32::<true, true>(k, b),
                (true, false) => quads::kick_f32::<true, false>(k, b),
                (false, true) => quads::kick_f32::<false, true>(k, b),
                (false, false) => quads::kick_f32::<false, false>(k, b),
            };
            return Kicked {
                died: r.died,
                // Exact: an f32 through f64 back to f32.
                v_max2: R::from_f64(r.v_max2.into()),
                fullest: r.fullest,
            };
        }
        // Each case compiled apart, so that the loop carries no test of either.
        match (self.rotation, self.drift) {
            (true, true) => kick_in::<R, true, true>(self, b),
            (true, false) => kick_in::<R, true, false>(self, b),
            (false, true) => kick_in::<R, false, true>(self, b),
            (false, false) => kick_in::<R, false, false>(self, b),
        }
    }
}

/// `Kick::block` with `ROT` for rotation and `DRIFT` for the drift. Compiled also for AVX2 and
/// chosen at run time, like the pair pass: the baseline's two-operand SSE spent a fifth of this
/// loop on register copies and reloads of spilled constants. Rust never fuses a multiply and an
/// add, so every clone computes the same bits.
#[multiversion(targets("x86_64+avx2+avx"))]
fn kick_in<R: Real, const ROT: bool, const DRIFT: bool>(
    k: &Kick<R>,
    b: KickBlock<'_, R>,
) -> Kicked<R> {
    // The constants in locals (registers), not read through `k` in the loop.
    let (kick, dt, g, periodic) = (k.kick, k.dt, k.g, k.periodic);
    each::<R, ROT, DRIFT>(b, k.sink_z, |kl, f, t, pr| {
        if ROT {
            kl.omega += t * (pr.inv_i * kick);
        }
        verlet::kick(&mut kl.vel, f, pr.inv_m, g, kick);
        if DRIFT {
            verlet::drift(&mut kl.pos, &mut kl.lo, kl.vel, dt, &periodic);
        }
        kl.vel.norm2()
    })
}

/// The loop both kicks share, over a block's particles: a particle no longer alive gets zero
/// force, torque and contact count; a fixed one is skipped; `step` kicks (and with `DRIFT`
/// drifts and wraps) each live, mobile one, given its force, torque (zero without rotation)
/// and constants, and returns its squared speed. After the drift a particle below `sink_z`
/// becomes `Dying` and stops interacting (`Kin::bury`).
#[inline(always)]
fn each<R: Real, const ROT: bool, const DRIFT: bool>(
    b: KickBlock<'_, R>,
    sink_z: R,
    mut step: impl FnMut(&mut Kin<R>, V3<R>, V3<R>, Props<R>) -> R,
) -> Kicked<R> {
    // Every array cut to the block's length once: the loop's indexing needs no bounds checks.
    let count = b.kin.len();
    let kin = b.kin;
    let (force, alive, nc, props) = (
        &mut b.force[..count],
        &mut b.alive[..count],
        &mut b.nc[..count],
        &b.props[..count],
    );
    let torque = &mut b.torque[..if ROT { count } else { 0 }];
    let (mut died, mut v_max2, mut fullest) = (false, R::zero(), 0u32);
    for (l, kl) in kin.iter_mut().enumerate() {
        if alive[l] != Status::Alive {
            force[l] = V3::zero();
            if ROT {
                torque[l] = V3::zero();
            }
            nc[l] = 0;
            continue;
        }
        fullest = fullest.max(nc[l]);
        let pr = props[l];
        if pr.inv_m == R::zero() {
            continue;
        }
        let t = if ROT { torque[l] } else { V3::zero() };
        let v2 = step(kl, force[l], t, pr);
        if !DRIFT {
            continue;
        }
        if kl.pos.z < sink_z {
            alive[l] = Status::Dying;
            kl.bury();
            died = true;
        }
        v_max2 = v_max2.max(v2);
    }
    Kicked {
        died,
        v_max2,
        fullest,
    }
}

/// The f32 kick on x86-64 with each record's three 4-vectors (`Kin`: position and r, velocity
/// and m, angular velocity and a pad) in 4-wide SSE operations: the generic loop compiles to
/// scalar code on 12-byte vectors, and LLVM's vectorizer, given the same in 4-wide arrays, merged the vectors into 8-wide
/// operations with more blends and shuffles than it saved. Per component the same operations
/// in the same order as the generic loop, so the same bits (the bench checksums).
#[cfg(target_arch = "x86_64")]
mod quads {
    use multiversion::multiversion;

    use super::verlet;
    use super::{Kick, KickBlock, Kicked};
    use crate::engine::cpu::simd::F32x4;

    /// `kick_in` for f32. Compiled also for AVX2 (three-operand forms), like the generic loop.
    #[multiversion(targets("x86_64+avx2+avx"))]
    pub(super) fn kick_f32<const ROT: bool, const DRIFT: bool>(
        k: &Kick<f32>,
        b: KickBlock<'_, f32>,
    ) -> Kicked<f32> {
        // The fourth places get + 0 (zero gravity, force and torque components, a zero time
        // step), which leaves r, m and the pad as they were.
        let g = F32x4::from_v3(&k.g);
        let (inf, ninf) = (f32::INFINITY, f32::NEG_INFINITY);
        let (xb, yb) = (
            k.periodic.x.unwrap_or((ninf, inf)),
            k.periodic.y.unwrap_or((ninf, inf)),
        );
        let (dt, kick) = (F32x4::new(k.dt, k.dt, k.dt, 0.0), F32x4::splat(k.kick));
        // The box along the periodic axes (the others unbounded): a position inside it needs
        // no wrap, the test one compare per bound for all axes.
        let lo = F32x4::new(xb.0, yb.0, ninf, ninf);
        let hi = F32x4::new(xb.1, yb.1, inf, inf);
        super::each::<f32, ROT, DRIFT>(b, k.sink_z, |kl, f, t, pr| {
            let rec = (kl as *mut super::Kin<f32>).cast::<f32>();
            // SAFETY (each load and store): `Kin<f32>` is repr(C, align(64)) of four 16-byte
            // 4-vectors at offsets 0, 16, 32 and 48 (`Kin`), so each is aligned and within the
            // record.
            if ROT {
                let s = F32x4::splat(pr.inv_i * k.kick);
                let w = unsafe { F32x4::load(rec.add(8)) } + F32x4::from_v3(&t) * s;
                unsafe { w.store(rec.add(8)) };
            }
            let a = F32x4::from_v3(&f) * F32x4::splat(pr.inv_m) + g;
            let v = unsafe { F32x4::load(rec.add(4)) } + a * kick;
            unsafe { v.store(rec.add(4)) };
            if DRIFT {
                // `position::drift`: the step and the rest, added to the position by TwoSum.
                let rest = unsafe { F32x4::load(rec.add(12)) };
                let x = unsafe { F32x4::load(rec) };
                let step = v * dt + rest;
                let p = x + step;
                let bb = p - x;
                let e = (x - (p - bb)) + (step - bb);
                unsafe {
                    p.store(rec);
                    e.store(rec.add(12));
                }
                if !(p.ge(lo) & p.lt(hi)).all() {
                    verlet::wrap_split(&k.periodic, &mut kl.pos, &mut kl.lo);
                }
            }
            // |v|² as `V3::norm2` sums it: (x² + y²) + z².
            let vv = (v * v).xyz();
            vv.x + vv.y + vv.z
        })
    }
}
