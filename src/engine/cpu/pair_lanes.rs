//! The sphere pair kernel, evaluated for `LANES` touching pairs at once.
//!
//! The pair pass first finds a block's touching pairs (a distance test per list entry), then
//! evaluates them here in groups: inputs laid out one array per component, one branch-free loop
//! body per lane, so that the compiler turns the loop into SIMD instructions (the square roots
//! and divisions of several contacts in flight together instead of one latency chain after
//! another). Each lane performs exactly the operations of the scalar pair loop it replaced, in
//! the same order, and the contact law is the one law (`contact_force_in` with selects), so the
//! results are the same bits.

use multiversion::multiversion;

use super::kinematics::Kin;
#[cfg(target_arch = "x86_64")]
use super::simd::{self, F32x4};
use crate::engine::choice::Select;
use crate::engine::contact::{contact_force_in, ContactInput, LawKernel};
use crate::engine::real::{Real, V3};

/// Pairs per group.
pub(super) const LANES: usize = 8;

/// Pairs per chunk: the pair pass tests this many list entries, then evaluates the touching
/// ones a group at a time.
pub(super) const CHUNK: usize = 256;
const _: () = assert!(CHUNK.is_power_of_two() && CHUNK.is_multiple_of(LANES));

/// Groups per chunk.
pub(super) const GROUPS: usize = CHUNK / LANES;

/// One input component of a chunk's pairs: pair t is lane t % LANES of group t / LANES, which
/// is place t of the flattened groups, so the pair pass writes it with no address arithmetic
/// (`LaneInput::at`).
#[derive(Clone, Copy, Default)]
pub(super) struct Column<R: Real> {
    groups: [[R; LANES]; GROUPS],
    /// Unused. Without it the columns would start a power of two (1 or 2 KiB) apart, so that
    /// place t of all 22 columns would fall into two to four sets of the 8-way first-level
    /// cache and evict each other.
    _pad: [R; LANES],
}

impl<R: Real> std::ops::Index<usize> for Column<R> {
    type Output = [R; LANES];
    #[inline(always)]
    fn index(&self, g: usize) -> &[R; LANES] {
        &self.groups[g]
    }
}

/// The inputs of a chunk's pairs (i, j): one array per component. Lanes past the chunk's last
/// touching pair hold stale inputs.
#[derive(Clone, Copy, Default)]
pub(super) struct LaneInput<R: Real> {
    /// Separation from j to i (minimum image).
    pub d: [Column<R>; 3],
    pub vi: [Column<R>; 3],
    pub wi: [Column<R>; 3],
    pub vj: [Column<R>; 3],
    pub wj: [Column<R>; 3],
    pub ri: Column<R>,
    pub rj: Column<R>,
    /// Masses, zero for a fixed particle (infinitely heavy).
    pub mi: Column<R>,
    pub mj: Column<R>,
    /// The stored spring (zero for a new contact or when springs are not kept).
    pub spring: [Column<R>; 3],
}

/// Writes into place t of a chunk's columns.
pub(super) struct Place<'a, R: Real> {
    inp: &'a mut LaneInput<R>,
    t: usize,
}

impl<R: Real> LaneInput<R> {
    /// Place `t` (below CHUNK: it is masked) of the chunk.
    #[inline(always)]
    pub(super) fn at(&mut self, t: usize) -> Place<'_, R> {
        Place {
            inp: self,
            t: t & (CHUNK - 1),
        }
    }
}

impl<R: Real> Place<'_, R> {
    #[inline(always)]
    fn set(c: &mut Column<R>, t: usize, v: R) {
        c.groups.as_flattened_mut()[t] = v;
    }
    #[inline(always)]
    fn set3(c: &mut [Column<R>; 3], t: usize, v: V3<R>) {
        Self::set(&mut c[0], t, v.x);
        Self::set(&mut c[1], t, v.y);
        Self::set(&mut c[2], t, v.z);
    }
    /// The pair's kinematics: separation from j to i, velocities and angular velocities.
    #[inline(always)]
    pub(super) fn kinematics(&mut self, d: V3<R>, vi: V3<R>, vj: V3<R>, wi: V3<R>, wj: V3<R>) {
        let (inp, t) = (&mut *self.inp, self.t);
        Self::set3(&mut inp.d, t, d);
        Self::set3(&mut inp.vi, t, vi);
        Self::set3(&mut inp.vj, t, vj);
        Self::set3(&mut inp.wi, t, wi);
        Self::set3(&mut inp.wj, t, wj);
    }
    /// `kinematics` from the pair's motion records. In f32 on x86-64 each velocity and angular
    /// velocity is read as the record's 4-vector (one load, not three; `Kin`), and its three
    /// places written into the columns from the register.
    #[inline(always)]
    pub(super) fn motion(&mut self, d: V3<R>, ki: &Kin<R>, kj: &Kin<R>) {
        #[cfg(target_arch = "x86_64")]
        if simd::is_f32::<R>() {
            Self::set3(&mut self.inp.d, self.t, d);
            let t = self.t;
            // SAFETY: R is f32.
            let (inp, ki, kj) = unsafe {
                (
                    &mut *(self.inp as *mut LaneInput<R>).cast::<LaneInput<f32>>(),
                    &*(ki as *const Kin<R>).cast::<Kin<f32>>(),
                    &*(kj as *const Kin<R>).cast::<Kin<f32>>(),
                )
            };
            let put = |c: &mut [Column<f32>; 3], q: F32x4| Place::set3(c, t, q.xyz());
            // SAFETY: a `Kin<f32>` is 16-byte aligned with its velocity at place 4 and its
            // angular velocity at place 8 (`Kin::quad`).
            unsafe {
                put(&mut inp.vi, F32x4::load(ki.quad(1)));
                put(&mut inp.vj, F32x4::load(kj.quad(1)));
                put(&mut inp.wi, F32x4::load(ki.quad(2)));
                put(&mut inp.wj, F32x4::load(kj.quad(2)));
            }
            return;
        }
        self.kinematics(d, ki.vel, kj.vel, ki.omega, kj.omega);
    }

    /// The pair's radii and masses (zero for a fixed particle) and its stored spring.
    #[inline(always)]
    pub(super) fn pair(&mut self, ri: R, rj: R, mi: R, mj: R, spring: V3<R>) {
        let (inp, t) = (&mut *self.inp, self.t);
        Self::set(&mut inp.ri, t, ri);
        Self::set(&mut inp.rj, t, rj);
        Self::set(&mut inp.mi, t, mi);
        Self::set(&mut inp.mj, t, mj);
        Self::set3(&mut inp.spring, t, spring);
    }
}

/// What a group of pairs gives.
#[derive(Clone, Copy, Default)]
pub(super) struct LaneOutput<R: Real> {
    /// Force on i.
    pub f: [[R; LANES]; 3],
    /// (n × f) (r_i − h): what i's torque loses.
    pub ti: [[R; LANES]; 3],
    /// −(n × f) (r_j − h): j's torque.
    pub tj: [[R; LANES]; 3],
    pub spring: [[R; LANES]; 3],
    /// Half the overlap.
    pub h: [R; LANES],
    /// The overlap over the smaller diameter (what the watchdog checks).
    pub ratio: [R; LANES],
}

/// Group g of a three-component column.
#[inline(always)]
fn col3<R: Real>(c: &[Column<R>; 3], g: usize) -> [&[R; LANES]; 3] {
    [&c[0][g], &c[1][g], &c[2][g]]
}

#[inline(always)]
fn get<R: Real>(a: [&[R; LANES]; 3], l: usize) -> V3<R> {
    V3::new(a[0][l], a[1][l], a[2][l])
}

#[inline(always)]
fn put<R: Real>(a: &mut [[R; LANES]; 3], l: usize, v: V3<R>) {
    a[0][l] = v.x;
    a[1][l] = v.y;
    a[2][l] = v.z;
}

/// Evaluates the `LANES` pairs of group `g` (lanes past the last touching pair hold stale
/// inputs, possibly of pairs that do not touch; their results, NaN or not, are ignored).
/// Compiled also for AVX2 and AVX-512, once per contact law, and chosen at run time: the
/// baseline x86-64 target (SSE2, no blend instruction) leaves this loop scalar. Rust never fuses
/// a multiply and an add, so every clone computes the same bits.
#[inline]
pub(super) fn evaluate<R: Real>(
    law: &LawKernel<R>,
    dt: R,
    inp: &LaneInput<R>,
    g: usize,
    out: &mut LaneOutput<R>,
) {
    // With the law known when compiling, the linear law's stiffnesses are constants (no
    // per-lane products, and 1/k_t is one division per group, not per lane).
    if law.hertz {
        lanes::<R, true>(law, dt, inp, g, out);
    } else {
        lanes::<R, false>(law, dt, inp, g, out);
    }
}

/// The lanes of `evaluate`, with `HERTZ` for `law.hertz`.
#[multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2+avx"))]
fn lanes<R: Real, const HERTZ: bool>(
    law: &LawKernel<R>,
    dt: R,
    inp: &LaneInput<R>,
    g: usize,
    out: &mut LaneOutput<R>,
) {
    let (dd, vi, wi, vj, wj) = (
        col3(&inp.d, g),
        col3(&inp.vi, g),
        col3(&inp.wi, g),
        col3(&inp.vj, g),
        col3(&inp.wj, g),
    );
    let (ri, rj, stored) = (&inp.ri[g], &inp.rj[g], col3(&inp.spring, g));
    let (mi, mj) = (&inp.mi[g], &inp.mj[g]);
    for l in 0..LANES {
        let c = contact::<R, HERTZ>(
            law,
            dt,
            [get(dd, l), get(vi, l), get(wi, l), get(vj, l), get(wj, l)],
            [ri[l], rj[l], mi[l], mj[l]],
            get(stored, l),
        );
        put(&mut out.f, l, c.f);
        put(&mut out.ti, l, c.ti);
        put(&mut out.tj, l, c.tj);
        put(&mut out.spring, l, c.spring);
        out.h[l] = c.h;
        out.ratio[l] = c.ratio;
    }
}

/// What one touching pair gives (one lane of `LaneOutput`).
struct PairContact<R: Real> {
    f: V3<R>,
    ti: V3<R>,
    tj: V3<R>,
    spring: V3<R>,
    h: R,
    ratio: R,
}

/// One pair's contact, branch-free: `kin` is [separation from j to i, v_i, ω_i, v_j, ω_j],
/// `pair` is [r_i, r_j, m_i, m_j] (mass zero for a fixed particle), `stored` the spring.
#[inline(always)]
fn contact<R: Real, const HERTZ: bool>(
    law: &LawKernel<R>,
    dt: R,
    kin: [V3<R>; 5],
    pair: [R; 4],
    stored: V3<R>,
) -> PairContact<R> {
    let half = R::from_f64(0.5);
    let [d, vi, wi, vj, wj] = kin;
    let [ri, rj, mi, mj] = pair;
    let sum = ri + rj;
    // m*, a fixed partner acting as infinitely heavy (as selects).
    let m_both = mi * mj / (mi + mj);
    let m_eff = if mj == R::zero() {
        mi
    } else if mi == R::zero() {
        mj
    } else {
        m_both
    };
    // 1 / (2 min(r_i, r_j)) is the larger of the two 1 / (2 r) (division rounds
    // monotonically): the bits of the per-particle constant the walls use.
    let inv_d = R::one() / (ri.min(rj) * R::from_f64(2.0));
    let dist = d.norm2().sqrt();
    let n = d * (R::one() / dist);
    let overlap = sum - dist;
    let h = overlap * half;
    let (li, lj) = (ri - h, rj - h);
    let bi = -(n * li);
    let bj = n * lj;
    let v_rel = (vi + wi.cross(bi)) - (vj + wj.cross(bj));
    let c = ContactInput {
        overlap,
        normal: n,
        v_rel,
        r_eff: ri * rj / sum,
        m_eff,
    };
    let (f, spring) = contact_force_in::<R, Select, HERTZ>(law, &c, stored, dt);
    let nf = n.cross(f);
    PairContact {
        f,
        ti: nf * li,
        tj: -(nf * lj),
        spring,
        h,
        ratio: overlap * inv_d,
    }
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::engine::contact::{
        contact_force, ContactInput, ContactLaw, Elasticity, NormalModel,
    };

    /// m* of two masses, zero for a fixed particle (infinitely heavy): the other's mass when one is
    /// fixed, as the list build computed it before the lanes took it over.
    fn reduced_mass<R: Real>(mi: R, mj: R) -> R {
        if mj == R::zero() {
            mi
        } else if mi == R::zero() {
            mj
        } else {
            mi * mj / (mi + mj)
        }
    }

    /// Pair `l` of group `g` as the scalar code sees it: (separation, velocities, angular
    /// velocities, r_i, r_j, m*, spring).
    fn pair<R: Real>(inp: &LaneInput<R>, g: usize, l: usize) -> ([V3<R>; 5], [R; 3], V3<R>) {
        let c = |a: &[Column<R>; 3]| V3::new(a[0][g][l], a[1][g][l], a[2][g][l]);
        let m_eff = reduced_mass(inp.mi[g][l], inp.mj[g][l]);
        (
            [c(&inp.d), c(&inp.vi), c(&inp.wi), c(&inp.vj), c(&inp.wj)],
            [inp.ri[g][l], inp.rj[g][l], m_eff],
            c(&inp.spring),
        )
    }

    /// The scalar pair evaluation the lanes replaced: (force, (n × f)(r_i − h), −(n × f)(r_j − h),
    /// spring).
    fn scalar<R: Real>(
        law: &LawKernel<R>,
        dt: R,
        inp: &LaneInput<R>,
        g: usize,
        l: usize,
    ) -> [V3<R>; 4] {
        let ([d, vi, wi, vj, wj], [ri, rj, m_eff], mut spring) = pair(inp, g, l);
        let sum = ri + rj;
        let dist = d.norm2().sqrt();
        let n = d * (R::one() / dist);
        let overlap = sum - dist;
        let h = overlap * R::from_f64(0.5);
        let (li, lj) = (ri - h, rj - h);
        let (bi, bj) = (-(n * li), n * lj);
        let v_rel = (vi + wi.cross(bi)) - (vj + wj.cross(bj));
        let c = ContactInput {
            overlap,
            normal: n,
            v_rel,
            r_eff: ri * rj / sum,
            m_eff,
        };
        let f = contact_force(law, &c, &mut spring, dt);
        let nf = n.cross(f);
        [f, nf * li, -(nf * lj), spring]
    }

    /// Random touching pairs in group `g`: overlaps up to 5 % of d, velocities up to 1 m/s, spins
    /// up to 100 rad/s, springs up to 0.1 mm (many beyond the Coulomb limit: the sliding
    /// branch), some zero (the new-contact branch).
    fn random_group<R: Real>(rng: &mut ChaCha8Rng, inp: &mut LaneInput<R>, g: usize) {
        let mut u = |s: f64| R::from_f64(s * (2.0 * rng.random::<f64>() - 1.0));
        for l in 0..LANES {
            let (ri, rj) = (0.0029 * (1.0 + 0.04 * u(1.0).to_f64()), 0.0029);
            let sum = ri + rj;
            let dir = [u(1.0), u(1.0), u(1.0)];
            let dn = (dir.iter().map(|x| x.to_f64().powi(2)).sum::<f64>()).sqrt();
            let dist = sum * (1.0 - 0.05 * (0.5 + 0.5 * u(1.0).to_f64()));
            let d = dir.map(|dk| R::from_f64(dk.to_f64() / dn * dist));
            let v3 = |u: &mut dyn FnMut(f64) -> R, s: f64| V3::new(u(s), u(s), u(s));
            let (vi, vj, wi, wj) = (
                v3(&mut u, 1.0),
                v3(&mut u, 1.0),
                v3(&mut u, 100.0),
                v3(&mut u, 100.0),
            );
            let spring = if l % 3 == 0 {
                V3::zero()
            } else {
                v3(&mut u, 1e-4)
            };
            let mut at = inp.at(g * LANES + l);
            at.kinematics(V3::new(d[0], d[1], d[2]), vi, vj, wi, wj);
            // Now and then a fixed particle (mass zero) on either side.
            let mut m = |fixed: bool| {
                R::from_f64(if fixed {
                    0.0
                } else {
                    1.4e-4 * (1.0 + 0.1 * u(1.0).to_f64())
                })
            };
            let (mi, mj) = (m(l % 5 == 3), m(l % 5 == 4));
            at.pair(R::from_f64(ri), R::from_f64(rj), mi, mj, spring);
        }
    }

    fn same_bits<R: Real>() {
        let hertz = ContactLaw {
            normal: NormalModel::Hertz(Elasticity::YoungShear {
                youngs_modulus_pa: 3e7,
                shear_modulus_pa: 1e6,
            }),
            restitution: 0.9,
            tangential_restitution: 0.9,
            friction: 0.5,
        };
        let linear = ContactLaw {
            normal: NormalModel::Linear {
                kn_n_per_m: 2e5,
                kt_n_per_m: 2e5 * 2.0 / 7.0,
            },
            friction: 0.5,
            ..hertz
        };
        let frictionless = ContactLaw {
            friction: 0.0,
            ..hertz
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let dt = R::from_f64(1e-6);
        let (mut sliding, mut sticking) = (0, 0);
        for law in [hertz, linear, frictionless] {
            let k = law.kernel::<R>();
            let mut inp = Box::<LaneInput<R>>::default();
            for round in 0..200 {
                let g = round % GROUPS;
                random_group::<R>(&mut rng, &mut inp, g);
                let mut out = LaneOutput::<R>::default();
                evaluate(&k, dt, &inp, g, &mut out);
                for l in 0..LANES {
                    let [f, ti, tj, s] = scalar(&k, dt, &inp, g, l);
                    let bits = |v: V3<R>| [v.x, v.y, v.z].map(|x| x.to_f64().to_bits());
                    let got = |a: &[[R; LANES]; 3]| get([&a[0], &a[1], &a[2]], l);
                    assert_eq!(bits(got(&out.f)), bits(f), "force, lane {l}");
                    assert_eq!(bits(got(&out.ti)), bits(ti), "torque on i, lane {l}");
                    assert_eq!(bits(got(&out.tj)), bits(tj), "torque on j, lane {l}");
                    assert_eq!(bits(got(&out.spring)), bits(s), "spring, lane {l}");
                    let inv_d = |r: R| R::one() / (r * R::from_f64(2.0));
                    let ([d, ..], [ri, rj, _], _) = pair(&inp, g, l);
                    let ratio = (ri + rj - d.norm2().sqrt()) * inv_d(ri).max(inv_d(rj));
                    assert_eq!(out.ratio[l].to_f64().to_bits(), ratio.to_f64().to_bits());
                    if law.friction > 0.0 {
                        let n = V3::from_f64(pair(&inp, g, l).0[0].to_f64());
                        let n = n * (1.0 / n.norm());
                        let f = V3::<f64>::from_f64(f.to_f64());
                        let f_n = f.dot(n);
                        let f_t = (f - n * f_n).norm();
                        if f_t >= 0.5 * f_n.abs() * (1.0 - 1e-4) {
                            sliding += 1;
                        } else {
                            sticking += 1;
                        }
                    }
                }
            }
        }
        // Both branches of the Coulomb limit are exercised.
        assert!(
            sliding > 100 && sticking > 100,
            "{sliding} sliding, {sticking} sticking"
        );
    }

    /// The lanes (in whichever clone this CPU dispatches to: AVX-512, AVX2 or the baseline) give
    /// the scalar contact law's bits exactly, sliding and sticking, both laws, both precisions.
    #[test]
    fn lanes_give_the_scalar_contact_laws_bits() {
        same_bits::<f32>();
        same_bits::<f64>();
    }
}
