//! The rods' rotational kick and free rotation (`oriented::kick_rotate`), `LANES` rods at once:
//! L += τ kick, the exact free rotation of a symmetric top over dt with the sine and cosine as
//! polynomials (`shape::sin_cos_poly`), ω refreshed, one array per component so that the
//! compiler turns the loop into SIMD instructions. A lane whose angle is not small, or whose
//! body is not a symmetric top, is flagged for the scalar code, which then gives the same bits
//! as every other path.

use multiversion::multiversion;

use crate::engine::real::{Real, V3};
use crate::engine::shape::{
    angular_velocity, is_small_angle, rotate_symmetric_with, sin_cos_poly, symmetric_angles, Quat,
};

/// Rods per group.
pub(super) const LANES: usize = 8;

type Col<R> = [R; LANES];

/// A group of rods' rotational state: in, then out.
#[derive(Clone, Copy, Default)]
pub(super) struct RotLanes<R: Real> {
    q: [Col<R>; 4],
    l: [Col<R>; 3],
    torque: [Col<R>; 3],
    inv_inertia: [Col<R>; 3],
    omega: [Col<R>; 3],
    /// Whether the lane went through the polynomial (else: the scalar code).
    ok: [bool; LANES],
}

impl<R: Real> RotLanes<R> {
    /// Lane `l`'s rod: orientation, angular momentum, torque, inverse principal moments.
    #[inline(always)]
    pub(super) fn set(&mut self, l: usize, q: Quat<R>, am: V3<R>, torque: V3<R>, ii: V3<R>) {
        let l = l % LANES;
        for (c, x) in self.q.iter_mut().zip([q.x, q.y, q.z, q.w]) {
            c[l] = x;
        }
        for (c, v) in [&mut self.l, &mut self.torque, &mut self.inv_inertia]
            .into_iter()
            .zip([am, torque, ii])
        {
            c[0][l] = v.x;
            c[1][l] = v.y;
            c[2][l] = v.z;
        }
    }

    /// Lane `l` after `rotate`: (orientation, angular momentum, ω), or None when the scalar
    /// code must take it.
    #[inline(always)]
    pub(super) fn get(&self, l: usize) -> Option<(Quat<R>, V3<R>, V3<R>)> {
        let l = l % LANES;
        let v = |c: &[Col<R>; 3]| V3::new(c[0][l], c[1][l], c[2][l]);
        self.ok[l].then(|| {
            (
                Quat {
                    x: self.q[0][l],
                    y: self.q[1][l],
                    z: self.q[2][l],
                    w: self.q[3][l],
                },
                v(&self.l),
                v(&self.omega),
            )
        })
    }
}

/// Kicks the angular momenta by `kick` and rotates every lane freely over `dt`. Compiled also
/// for AVX2 and AVX-512 and chosen at run time; Rust never fuses a multiply and an add, so
/// every clone computes the same bits.
#[multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2+avx"))]
pub(super) fn rotate<R: Real>(g: &mut RotLanes<R>, kick: R, dt: R) {
    for k in 0..LANES {
        let v = |c: &[Col<R>; 3]| V3::new(c[0][k], c[1][k], c[2][k]);
        let q = Quat {
            x: g.q[0][k],
            y: g.q[1][k],
            z: g.q[2][k],
            w: g.q[3][k],
        };
        let ii = v(&g.inv_inertia);
        // oriented::kick_rotate.
        let l = v(&g.l) + v(&g.torque) * kick;
        let [a, b] = symmetric_angles(q, l, ii, dt);
        g.ok[k] = is_small_angle(a) & is_small_angle(b) & (ii.x == ii.y);
        let q = rotate_symmetric_with(q, l, ii, dt, sin_cos_poly);
        let w = angular_velocity(q, ii, l);
        for (c, x) in g.q.iter_mut().zip([q.x, q.y, q.z, q.w]) {
            c[k] = x;
        }
        for (c, x) in [&mut g.l, &mut g.omega].into_iter().zip([l, w]) {
            c[0][k] = x.x;
            c[1][k] = x.y;
            c[2][k] = x.z;
        }
    }
}
