//! The spherocylinder pair kernel, evaluated for `LANES` pairs at once: the segment–segment
//! closest points (`shape::segment::closest_points`), the contact geometry
//! (`shape::contact_spherocylinders`) and the force law (`contact::contact_force`), each
//! branch computed and chosen by a select, one array per input component, so that the compiler
//! turns the loop into SIMD instructions (as `pair_lanes.rs` does for spheres). Each lane
//! performs exactly the scalar code's operations in its order, so the results are its bits. A
//! pair whose axes touch exactly (the normal then comes from `touching_normal`, a branchy
//! fallback that never happens in a stable run) is flagged for the scalar code.

use multiversion::multiversion;

use crate::engine::contact::{pair_effective_mass, Inertial, LawKernel};
use crate::engine::real::{Real, V3};
use crate::engine::shape::{PARALLEL_SIN, POINT_LEN2};

/// Pairs per group.
pub(super) const LANES: usize = 8;

type Col<R> = [R; LANES];

/// A group's pairs (a, b) in canonical order (a the lower id), one array per component.
#[derive(Clone, Copy, Default)]
pub(super) struct RodLaneInput<R: Real> {
    /// c_a − c_b (minimum image).
    pub(super) d: [Col<R>; 3],
    pub(super) ua: [Col<R>; 3],
    pub(super) ub: [Col<R>; 3],
    pub(super) va: [Col<R>; 3],
    pub(super) wa: [Col<R>; 3],
    pub(super) vb: [Col<R>; 3],
    pub(super) wb: [Col<R>; 3],
    pub(super) spring: [Col<R>; 3],
    /// Radii.
    pub(super) ra: Col<R>,
    pub(super) rb: Col<R>,
    /// Mass, 1/m, 1/I⊥ (both zero when fixed) and l/2 of a and b (`Inertial`).
    pub(super) body: [[Col<R>; 4]; 2],
}

/// What the group's pairs give, in canonical order.
#[derive(Clone, Copy, Default)]
pub(super) struct RodLaneOutput<R: Real> {
    /// Whether the pair touches.
    pub(super) touch: [bool; LANES],
    /// Whether the axes touch exactly: evaluate the pair with the scalar code instead.
    pub(super) exact: [bool; LANES],
    /// Force on a.
    pub(super) f: [Col<R>; 3],
    /// Torques on a (arm_a × f) and on b (arm_b × −f).
    pub(super) ta: [Col<R>; 3],
    pub(super) tb: [Col<R>; 3],
    pub(super) spring: [Col<R>; 3],
    pub(super) half_overlap: Col<R>,
    pub(super) ratio: Col<R>,
}

impl<R: Real> RodLaneInput<R> {
    /// Writes lane `l`'s inputs: [d, u_a, u_b, v_a, ω_a, v_b, ω_b, spring], [r_a, r_b] and
    /// the bodies.
    #[inline(always)]
    pub(super) fn set(&mut self, l: usize, v: [V3<R>; 8], r: [R; 2], body: [Inertial<R>; 2]) {
        let l = l % LANES;
        for (col, x) in [
            &mut self.d,
            &mut self.ua,
            &mut self.ub,
            &mut self.va,
            &mut self.wa,
            &mut self.vb,
            &mut self.wb,
            &mut self.spring,
        ]
        .into_iter()
        .zip(v)
        {
            put(col, l, x);
        }
        (self.ra[l], self.rb[l]) = (r[0], r[1]);
        for (cols, b) in self.body.iter_mut().zip(body) {
            for (col, x) in cols
                .iter_mut()
                .zip([b.mass, b.inv_mass, b.inv_i_perp, b.half_length])
            {
                col[l] = x;
            }
        }
    }

    /// Body `k` (0: a, 1: b) of lane `l`.
    #[inline(always)]
    fn body(&self, k: usize, l: usize) -> Inertial<R> {
        let b = &self.body[k];
        Inertial {
            mass: b[0][l],
            inv_mass: b[1][l],
            inv_i_perp: b[2][l],
            half_length: b[3][l],
        }
    }
}

#[inline(always)]
fn get<R: Real>(a: &[Col<R>; 3], l: usize) -> V3<R> {
    V3::new(a[0][l], a[1][l], a[2][l])
}

#[inline(always)]
fn put<R: Real>(a: &mut [Col<R>; 3], l: usize, v: V3<R>) {
    a[0][l] = v.x;
    a[1][l] = v.y;
    a[2][l] = v.z;
}

#[inline(always)]
fn sel<R: Real>(c: bool, a: R, b: R) -> R {
    if c {
        a
    } else {
        b
    }
}

#[inline(always)]
fn sel3<R: Real>(c: bool, a: V3<R>, b: V3<R>) -> V3<R> {
    V3::new(sel(c, a.x, b.x), sel(c, a.y, b.y), sel(c, a.z, b.z))
}

#[inline(always)]
fn clamp01<R: Real>(x: R) -> R {
    x.max(R::zero()).min(R::one())
}

/// `segment::general`, branch-free.
#[inline(always)]
fn general<R: Real>(s_line: R, a: R, b: R, c: R, e: R, f: R) -> (R, R) {
    let s = clamp01(s_line);
    let t = (b * s + f) / e;
    let below = t < R::zero();
    let above = t > R::one();
    let s_lo = clamp01(-c / a);
    let s_hi = clamp01((b - c) / a);
    (
        sel(below, s_lo, sel(above, s_hi, s)),
        sel(below, R::zero(), sel(above, R::one(), t)),
    )
}

/// `segment::parallel`, branch-free.
#[inline(always)]
fn parallel<R: Real>(a: R, b: R, c: R, e: R, f: R) -> (R, R) {
    let zero = R::zero();
    let one = R::one();
    let s0 = -c / a;
    let s1 = (b - c) / a;
    let ordered = s0 <= s1;
    let (lo, hi) = (sel(ordered, s0, s1), sel(ordered, s1, s0));
    let (lo_in, hi_in) = (lo.max(zero), hi.min(one));
    let overlapping = lo_in <= hi_in;
    let s_mid = (lo_in + hi_in) * R::from_f64(0.5);
    let t_mid = clamp01((b * s_mid + f) / e);
    let s_end = sel(hi < zero, zero, one);
    let t_end = clamp01((b * s_end + f) / e);
    let s_back = clamp01((b * t_end - c) / a);
    (
        sel(overlapping, s_mid, s_back),
        sel(overlapping, t_mid, t_end),
    )
}

/// `segment::closest_points`, branch-free: (s, t, p, q, |p − q|²).
#[inline(always)]
fn closest<R: Real>(p1: V3<R>, d1: V3<R>, p2: V3<R>, d2: V3<R>) -> (R, R, V3<R>, V3<R>, R) {
    let zero = R::zero();
    let one = R::one();
    let tiny = R::from_f64(POINT_LEN2);
    let r = p1 - p2;
    let a = d1.norm2();
    let e = d2.norm2();
    let c = d1.dot(r);
    let f = d2.dot(r);
    let b = d1.dot(d2);
    let n = d1.cross(d2);
    let n2 = n.norm2();
    let ae = a * e;
    let lim2 = R::from_f64(PARALLEL_SIN * PARALLEL_SIN);
    let s_line = n.dot(d2.cross(r)) / n2;
    let (sg, tg) = general(s_line, a, b, c, e, f);
    let (sp, tp) = parallel(a, b, c, e, f);
    let w = (n2 / ae).sqrt() / R::from_f64(PARALLEL_SIN) - one;
    let s_blend = sp + (sg - sp) * w.max(zero).min(one);
    let t_blend = clamp01((b * s_blend + f) / e);
    let exact = n2 > R::from_f64(4.0) * lim2 * ae;
    let flat = n2 <= lim2 * ae;
    let s_both = sel(exact, sg, sel(flat, sp, s_blend));
    let t_both = sel(exact, tg, sel(flat, tp, t_blend));
    let (a_pt, e_pt) = (a <= tiny, e <= tiny);
    let s = sel(a_pt, zero, sel(e_pt, clamp01(-c / a), s_both));
    let t = sel(
        a_pt & e_pt,
        zero,
        sel(a_pt, clamp01(f / e), sel(e_pt, zero, t_both)),
    );
    let p = p1 + d1 * s;
    let q = p2 + d2 * t;
    (s, t, p, q, (p - q).norm2())
}

/// Evaluates the group's pairs. Compiled also for AVX2 and AVX-512, once per contact law, and
/// chosen at run time; Rust never fuses a multiply and an add, so every clone computes the
/// same bits.
#[inline]
pub(super) fn evaluate<R: Real>(
    law: &LawKernel<R>,
    dt: R,
    inp: &RodLaneInput<R>,
    out: &mut RodLaneOutput<R>,
) {
    if law.hertz {
        lanes::<R, true>(law, dt, inp, out);
    } else {
        lanes::<R, false>(law, dt, inp, out);
    }
}

#[multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2+avx"))]
fn lanes<R: Real, const HERTZ: bool>(
    law: &LawKernel<R>,
    dt: R,
    inp: &RodLaneInput<R>,
    out: &mut RodLaneOutput<R>,
) {
    for l in 0..LANES {
        lane::<R, HERTZ>(law, dt, inp, out, l);
    }
}

/// Lane `l`: `RodContext::evaluate` (rod_pass.rs) with its branches as selects.
#[inline(always)]
fn lane<R: Real, const HERTZ: bool>(
    law: &LawKernel<R>,
    dt: R,
    inp: &RodLaneInput<R>,
    out: &mut RodLaneOutput<R>,
    l: usize,
) {
    let half = R::from_f64(0.5);
    let two = R::from_f64(2.0);
    let d = get(&inp.d, l);
    let (ua, ub) = (get(&inp.ua, l), get(&inp.ub, l));
    let (ra, rb) = (inp.ra[l], inp.rb[l]);
    // contact_spherocylinders.
    let (body_a, body_b) = (inp.body(0, l), inp.body(1, l));
    let hi = ua * body_a.half_length;
    let hj = ub * body_b.half_length;
    let (s, t, p, q, dist2) = closest(d - hi, hi + hi, -hj, hj + hj);
    let sum = ra + rb;
    out.touch[l] = dist2 < sum * sum;
    let dist = dist2.sqrt();
    out.exact[l] = !(dist > R::zero());
    let normal = (p - q) * (R::one() / dist);
    let overlap = sum - dist;
    let half_ov = overlap * half;
    let on_i = hi * (s * two - R::one());
    let on_j = hj * (t * two - R::one());
    let arm_a = on_i - normal * (ra - half_ov);
    let arm_b = on_j + normal * (rb - half_ov);
    // RodContext::evaluate.
    let v_rel = (get(&inp.va, l) + get(&inp.wa, l).cross(arm_a))
        - (get(&inp.vb, l) + get(&inp.wb, l).cross(arm_b));
    let m_eff = pair_effective_mass(body_a, body_b, arm_a, arm_b, normal);
    let r_eff = ra * rb / (ra + rb);
    // contact_force.
    let n = normal;
    let vn = v_rel.dot(n);
    let sq = if HERTZ {
        (r_eff * overlap).sqrt()
    } else {
        R::one()
    };
    let (kn, sn) = if HERTZ {
        let kn = law.kn_coef * sq;
        (kn, kn * R::from_f64(1.5))
    } else {
        (law.kn_coef, law.kn_coef)
    };
    let gamma_n = law.damp_n * (sn * m_eff).sqrt();
    let fn_mag = kn * overlap - gamma_n * vn;
    let mut f = n * fn_mag;
    let mut spring = get(&inp.spring, l);
    if law.tangential {
        let kt = law.kt_coef * sq;
        let gamma_t = law.damp_t * (kt * m_eff).sqrt();
        let vt = v_rel - n * vn;
        let old = spring;
        let old2 = old.norm2();
        let mut sp = old - n * old.dot(n);
        let s2 = sp.norm2();
        // s · 1 is s exactly: the select keeps the scalar code's bits.
        sp = sp * sel(s2 > R::zero(), (old2 / s2).sqrt(), R::one());
        sp += vt * dt;
        let ft = -(sp * kt) - vt * gamma_t;
        let limit = law.mu * fn_mag.abs();
        let ft2 = ft.norm2();
        let slides = ft2 > limit * limit;
        let ft_slide = ft * (limit / ft2.sqrt());
        let s_slide = -(ft_slide + vt * gamma_t) * (R::one() / kt);
        spring = sel3(slides, s_slide, sp);
        f += sel3(slides, ft_slide, ft);
    }
    put(&mut out.f, l, f);
    put(&mut out.ta, l, arm_a.cross(f));
    put(&mut out.tb, l, arm_b.cross(-f));
    put(&mut out.spring, l, spring);
    out.half_overlap[l] = half_ov;
    out.ratio[l] = overlap / (ra.min(rb) * two);
}
