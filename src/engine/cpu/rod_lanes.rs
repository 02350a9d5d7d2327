//! The spherocylinder pair kernel, evaluated for `LANES` pairs at once: the segment–segment
//! closest points (`shape::closest_points_in`) and the force law (`contact::contact_force_in`),
//! the same code as the scalar path's with selects for branches, and the contact geometry
//! (`shape::contact_spherocylinders`), one array per input component, so that the compiler
//! turns the loop into SIMD instructions (as `pair_lanes.rs` does for spheres). Each lane
//! performs exactly the scalar code's operations in its order, so the results are its bits. A
//! pair whose axes touch exactly (the normal then comes from `touching_normal`, a branchy
//! fallback that never happens in a stable run) is flagged for the scalar code.

use multiversion::multiversion;

use crate::engine::choice::Select;
use crate::engine::contact::{
    contact_force_in, pair_effective_mass, ContactInput, Inertial, LawKernel,
};
use crate::engine::real::{Real, V3};
use crate::engine::shape::closest_points_in;

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
    let cp = closest_points_in::<R, Select>(d - hi, hi + hi, -hj, hj + hj);
    let (s, t, p, q, dist2) = (cp.s, cp.t, cp.p, cp.q, cp.dist2);
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
    let c = ContactInput {
        overlap,
        normal,
        v_rel,
        r_eff,
        m_eff,
    };
    let (f, spring) = contact_force_in::<R, Select, HERTZ>(law, &c, get(&inp.spring, l), dt);
    put(&mut out.f, l, f);
    put(&mut out.ta, l, arm_a.cross(f));
    put(&mut out.tb, l, arm_b.cross(-f));
    put(&mut out.spring, l, spring);
    out.half_overlap[l] = half_ov;
    out.ratio[l] = overlap / (ra.min(rb) * two);
}
