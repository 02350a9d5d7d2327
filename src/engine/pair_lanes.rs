//! The sphere pair kernel, evaluated for `LANES` touching pairs at once.
//!
//! The pair pass first finds a block's touching pairs (a distance test per list entry), then
//! evaluates them here in groups: inputs laid out one array per component, one branch-free loop
//! body per lane, so that the compiler turns the loop into SIMD instructions (the square roots
//! and divisions of several contacts in flight together instead of one latency chain after
//! another). Each lane performs exactly the operations of `contact_force` and of the scalar pair
//! loop it replaced, in the same order, so the results are the same bits.

use multiversion::multiversion;

use super::contact::LawKernel;
use super::real::{Real, V3};

/// Pairs per group.
pub(super) const LANES: usize = 8;

/// The inputs of a group of pairs (i, j): one array per component.
#[derive(Clone, Copy, Default)]
pub(super) struct LaneInput<R: Real> {
    /// Separation from j to i (minimum image) and its square.
    pub d: [[R; LANES]; 3],
    pub dist2: [R; LANES],
    pub vi: [[R; LANES]; 3],
    pub wi: [[R; LANES]; 3],
    pub vj: [[R; LANES]; 3],
    pub wj: [[R; LANES]; 3],
    pub ri: [R; LANES],
    pub rj: [R; LANES],
    pub sum: [R; LANES],
    pub r_eff: [R; LANES],
    pub m_eff: [R; LANES],
    /// The stored spring (zero for a new contact or when springs are not kept).
    pub spring: [[R; LANES]; 3],
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
    /// Half the overlap, and the overlap.
    pub h: [R; LANES],
    pub overlap: [R; LANES],
}

#[inline(always)]
fn get<R: Real>(a: &[[R; LANES]; 3], l: usize) -> V3<R> {
    V3::new(a[0][l], a[1][l], a[2][l])
}

#[inline(always)]
fn put<R: Real>(a: &mut [[R; LANES]; 3], l: usize, v: V3<R>) {
    a[0][l] = v.x;
    a[1][l] = v.y;
    a[2][l] = v.z;
}

#[inline(always)]
fn select<R: Real>(c: bool, a: V3<R>, b: V3<R>) -> V3<R> {
    V3::new(
        if c { a.x } else { b.x },
        if c { a.y } else { b.y },
        if c { a.z } else { b.z },
    )
}

/// Evaluates `LANES` touching pairs (lanes past the group's end hold stale inputs, possibly of pairs
/// that do not touch; their results, NaN or not, are ignored).
/// Compiled also for AVX2 and AVX-512 and chosen at run time: the baseline x86-64 target
/// (SSE2, no blend instruction) leaves this loop scalar. Rust never fuses a multiply and an
/// add, so every clone computes the same bits.
#[multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2+avx"))]
pub(super) fn evaluate<R: Real>(
    law: &LawKernel<R>,
    dt: R,
    inp: &LaneInput<R>,
    out: &mut LaneOutput<R>,
) {
    let half = R::from_f64(0.5);
    let three_halves = R::from_f64(1.5);
    for l in 0..LANES {
        let d = get(&inp.d, l);
        let dist = inp.dist2[l].sqrt();
        let n = d * (R::one() / dist);
        let overlap = inp.sum[l] - dist;
        let h = overlap * half;
        let (li, lj) = (inp.ri[l] - h, inp.rj[l] - h);
        let bi = -(n * li);
        let bj = n * lj;
        let v_rel = (get(&inp.vi, l) + get(&inp.wi, l).cross(bi))
            - (get(&inp.vj, l) + get(&inp.wj, l).cross(bj));
        // contact_force (contact/force.rs), with its branches as selects.
        let vn = v_rel.dot(n);
        let sq = if law.hertz {
            (inp.r_eff[l] * overlap).sqrt()
        } else {
            R::one()
        };
        let (kn, sn) = if law.hertz {
            let kn = law.kn_coef * sq;
            (kn, kn * three_halves)
        } else {
            (law.kn_coef, law.kn_coef)
        };
        let gamma_n = law.damp_n * (sn * inp.m_eff[l]).sqrt();
        let fn_mag = kn * overlap - gamma_n * vn;
        let mut f = n * fn_mag;
        let mut spring = get(&inp.spring, l);
        if law.tangential {
            let kt = law.kt_coef * sq;
            let gamma_t = law.damp_t * (kt * inp.m_eff[l]).sqrt();
            let vt = v_rel - n * vn;
            let old = spring;
            let old2 = old.norm2();
            let mut s = old - n * old.dot(n);
            let s2 = s.norm2();
            // s · 1 is s exactly: the select keeps the scalar code's bits.
            let keep_length = if s2 > R::zero() {
                (old2 / s2).sqrt()
            } else {
                R::one()
            };
            s = s * keep_length;
            s += vt * dt;
            let ft = -(s * kt) - vt * gamma_t;
            let limit = law.mu * fn_mag.abs();
            let ft2 = ft.norm2();
            let slides = ft2 > limit * limit;
            let ft_slide = ft * (limit / ft2.sqrt());
            let s_slide = -(ft_slide + vt * gamma_t) * (R::one() / kt);
            spring = select(slides, s_slide, s);
            f += select(slides, ft_slide, ft);
        }
        let nf = n.cross(f);
        put(&mut out.f, l, f);
        put(&mut out.ti, l, nf * li);
        put(&mut out.tj, l, -(nf * lj));
        put(&mut out.spring, l, spring);
        out.h[l] = h;
        out.overlap[l] = overlap;
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

    /// The scalar pair evaluation the lanes replaced: (force, (n × f)(r_i − h), −(n × f)(r_j − h),
    /// spring, h).
    fn scalar<R: Real>(law: &LawKernel<R>, dt: R, inp: &LaneInput<R>, l: usize) -> [V3<R>; 4] {
        let d = get(&inp.d, l);
        let dist = inp.dist2[l].sqrt();
        let n = d * (R::one() / dist);
        let overlap = inp.sum[l] - dist;
        let h = overlap * R::from_f64(0.5);
        let (li, lj) = (inp.ri[l] - h, inp.rj[l] - h);
        let (bi, bj) = (-(n * li), n * lj);
        let v_rel = (get(&inp.vi, l) + get(&inp.wi, l).cross(bi))
            - (get(&inp.vj, l) + get(&inp.wj, l).cross(bj));
        let c = ContactInput {
            overlap,
            normal: n,
            v_rel,
            r_eff: inp.r_eff[l],
            m_eff: inp.m_eff[l],
        };
        let mut spring = get(&inp.spring, l);
        let f = contact_force(law, &c, &mut spring, dt);
        let nf = n.cross(f);
        [f, nf * li, -(nf * lj), spring]
    }

    /// Random touching pairs: overlaps up to 5 % of d, velocities up to 1 m/s, spins up to
    /// 100 rad/s, springs up to 0.1 mm (many beyond the Coulomb limit: the sliding branch), some
    /// zero (the new-contact branch).
    fn random_group<R: Real>(rng: &mut ChaCha8Rng) -> LaneInput<R> {
        let mut inp = LaneInput::<R>::default();
        let mut u = |s: f64| R::from_f64(s * (2.0 * rng.random::<f64>() - 1.0));
        for l in 0..LANES {
            let (ri, rj) = (0.0029 * (1.0 + 0.04 * u(1.0).to_f64()), 0.0029);
            let sum = ri + rj;
            let dir = [u(1.0), u(1.0), u(1.0)];
            let dn = (dir.iter().map(|x| x.to_f64().powi(2)).sum::<f64>()).sqrt();
            let dist = sum * (1.0 - 0.05 * (0.5 + 0.5 * u(1.0).to_f64()));
            for (k, dk) in dir.iter().enumerate() {
                inp.d[k][l] = R::from_f64(dk.to_f64() / dn * dist);
                inp.vi[k][l] = u(1.0);
                inp.vj[k][l] = u(1.0);
                inp.wi[k][l] = u(100.0);
                inp.wj[k][l] = u(100.0);
                inp.spring[k][l] = if l % 3 == 0 { R::zero() } else { u(1e-4) };
            }
            inp.dist2[l] = get(&inp.d, l).norm2();
            inp.ri[l] = R::from_f64(ri);
            inp.rj[l] = R::from_f64(rj);
            inp.sum[l] = inp.ri[l] + inp.rj[l];
            inp.r_eff[l] = inp.ri[l] * inp.rj[l] / inp.sum[l];
            inp.m_eff[l] = R::from_f64(1.4e-4);
        }
        inp
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
            for _ in 0..200 {
                let inp = random_group::<R>(&mut rng);
                let mut out = LaneOutput::<R>::default();
                evaluate(&k, dt, &inp, &mut out);
                for l in 0..LANES {
                    let [f, ti, tj, s] = scalar(&k, dt, &inp, l);
                    let bits = |v: V3<R>| [v.x, v.y, v.z].map(|x| x.to_f64().to_bits());
                    assert_eq!(bits(get(&out.f, l)), bits(f), "force, lane {l}");
                    assert_eq!(bits(get(&out.ti, l)), bits(ti), "torque on i, lane {l}");
                    assert_eq!(bits(get(&out.tj, l)), bits(tj), "torque on j, lane {l}");
                    assert_eq!(bits(get(&out.spring, l)), bits(s), "spring, lane {l}");
                    if law.friction > 0.0 {
                        let n = V3::from_f64(get(&inp.d, l).to_f64());
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
