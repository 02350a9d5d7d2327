//! A unit quaternion over the run's `Real`, the orientation of a non-spherical particle. glam's
//! `DQuat`/`Quat` fix the precision at compile time, and the kernels are generic over `Real` and
//! keep orientations in Pod state arrays, so this is a small generic one laid out as glam's and
//! WGSL's `vec4` (x, y, z, w); glam stays at the edges (`from_glam`/`to_glam`, f64).
//!
//! Convention: `q` maps body-frame vectors to the lab frame, v_lab = q v_body q*; the body z axis
//! is a spherocylinder's symmetry axis. It owns no dynamics (that is `rigid`).

use std::ops::Mul;

use crate::engine::real::{Real, V3};

/// A quaternion x i + y j + z k + w; orientations are kept at unit norm.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quat<R> {
    pub x: R,
    pub y: R,
    pub z: R,
    pub w: R,
}

// SAFETY: repr(C) of four Pod fields of the same type: no padding.
unsafe impl<R: Real> bytemuck::Zeroable for Quat<R> {}
unsafe impl<R: Real> bytemuck::Pod for Quat<R> {}

/// sin and cos of an angle. `Real` has no trigonometry, so it goes through f64 (exact enough for
/// f32, and one call per rotation, not per contact).
#[inline]
pub fn sin_cos<R: Real>(angle: R) -> (R, R) {
    let (s, c) = angle.to_f64().sin_cos();
    (R::from_f64(s), R::from_f64(c))
}

/// Below this |angle| (rad) `sin_cos_small` uses its polynomial. A rotation step turns a rod by
/// ω dt/2, some 10⁻² rad in a dense flow; 0.25 rad leaves a wide margin.
pub const SMALL_ANGLE: f64 = 0.25;

/// sin and cos of an angle by their Taylor polynomials in `R` (through x¹¹ and x¹²), branch-free
/// (the SIMD lanes of the rod kick run it): for |x| ≤ [`SMALL_ANGLE`] the first neglected term
/// is below 3·10⁻¹⁷ of the result, under f64's rounding.
#[inline(always)]
pub fn sin_cos_poly<R: Real>(x: R) -> (R, R) {
    let c = R::from_f64;
    let x2 = x * x;
    let s = x
        * (R::one()
            + x2 * (c(-1.0 / 6.0)
                + x2 * (c(1.0 / 120.0)
                    + x2 * (c(-1.0 / 5040.0)
                        + x2 * (c(1.0 / 362_880.0) + x2 * c(-1.0 / 39_916_800.0))))));
    let k = R::one()
        + x2 * (c(-0.5)
            + x2 * (c(1.0 / 24.0)
                + x2 * (c(-1.0 / 720.0)
                    + x2 * (c(1.0 / 40_320.0)
                        + x2 * (c(-1.0 / 3_628_800.0) + x2 * c(1.0 / 479_001_600.0))))));
    (s, k)
}

/// Whether `sin_cos_small` takes its polynomial for `x` (false for NaN).
#[inline(always)]
pub fn is_small_angle<R: Real>(x: R) -> bool {
    x.abs() <= R::from_f64(SMALL_ANGLE)
}

/// sin and cos of an angle: the polynomial `sin_cos_poly` for a small one (a rotation step),
/// else `sin_cos`. The per-particle rotation calls it twice a step, and the library call
/// through f64 cost more than the rest of the rotation.
#[inline(always)]
pub fn sin_cos_small<R: Real>(x: R) -> (R, R) {
    if is_small_angle(x) {
        sin_cos_poly(x)
    } else {
        sin_cos(x)
    }
}

impl<R: Real> Quat<R> {
    /// The quaternion with vector part `v` and scalar part `w`.
    #[inline(always)]
    pub fn from_parts(v: V3<R>, w: R) -> Self {
        Self {
            x: v.x,
            y: v.y,
            z: v.z,
            w,
        }
    }

    /// No rotation: body frame = lab frame.
    #[inline(always)]
    pub fn identity() -> Self {
        Self::from_parts(V3::zero(), R::one())
    }

    /// From `[x, y, z, w]` in f64 (checkpoints, scene building).
    pub fn from_f64(q: [f64; 4]) -> Self {
        Self::from_parts(V3::from_f64([q[0], q[1], q[2]]), R::from_f64(q[3]))
    }

    /// As `[x, y, z, w]` in f64.
    pub fn to_f64(self) -> [f64; 4] {
        [
            self.x.to_f64(),
            self.y.to_f64(),
            self.z.to_f64(),
            self.w.to_f64(),
        ]
    }

    /// From glam's f64 quaternion (same component order and convention).
    pub fn from_glam(q: glam::DQuat) -> Self {
        Self::from_f64(q.to_array())
    }

    /// To glam's f64 quaternion.
    pub fn to_glam(self) -> glam::DQuat {
        glam::DQuat::from_array(self.to_f64())
    }

    /// Rotation by `angle` (rad, right-handed) about the unit vector `axis`.
    #[inline]
    pub fn from_axis_angle(axis: V3<R>, angle: R) -> Self {
        let (s, c) = sin_cos(angle * R::from_f64(0.5));
        Self::from_parts(axis * s, c)
    }

    /// The rotation that turns the body z axis onto the unit vector `axis` by the shortest arc
    /// (the remaining spin about the axis is irrelevant for a body of revolution). For `axis`
    /// = −z the arc is taken about the lab x axis.
    pub fn from_axis_z(axis: V3<R>) -> Self {
        let ez = V3::new(R::zero(), R::zero(), R::one());
        // q = (ez × a, 1 + ez·a) normalised is the half-angle rotation from ez to a; it is
        // accurate down to a ≈ −z, except for exactly −z where it is 0/0.
        let v = ez.cross(axis);
        let w = R::one() + ez.dot(axis);
        if v.norm2() <= R::from_f64(super::segment::POINT_LEN2) && w <= R::one() {
            return Self::from_parts(V3::new(R::one(), R::zero(), R::zero()), R::zero());
        }
        Self::from_parts(v, w).normalize()
    }

    /// The vector part.
    #[inline(always)]
    pub fn vector(self) -> V3<R> {
        V3::new(self.x, self.y, self.z)
    }

    /// The conjugate (the inverse rotation for a unit quaternion).
    #[inline(always)]
    pub fn conjugate(self) -> Self {
        Self::from_parts(-self.vector(), self.w)
    }

    /// |q|² = x² + y² + z² + w².
    #[inline(always)]
    pub fn norm2(self) -> R {
        self.x * self.x + self.y * self.y + self.z * self.z + self.w * self.w
    }

    /// This quaternion scaled to unit norm (done after every rotation step: rounding otherwise
    /// lets |q| random-walk away from 1, and a non-unit q scales as well as rotates).
    #[inline]
    pub fn normalize(self) -> Self {
        let k = R::one() / self.norm2().sqrt();
        Self::from_parts(self.vector() * k, self.w * k)
    }

    /// Body → lab: q v q*, for unit q (v + w t + u × t with t = 2 u × v).
    #[inline(always)]
    pub fn rotate(self, v: V3<R>) -> V3<R> {
        let u = self.vector();
        let t = u.cross(v) * R::from_f64(2.0);
        v + t * self.w + u.cross(t)
    }

    /// Lab → body: q* v q, for unit q.
    #[inline(always)]
    pub fn rotate_inv(self, v: V3<R>) -> V3<R> {
        self.conjugate().rotate(v)
    }

    /// The body z axis in the lab frame: a spherocylinder's unit axis.
    #[inline(always)]
    pub fn axis_z(self) -> V3<R> {
        let two = R::from_f64(2.0);
        V3::new(
            two * (self.x * self.z + self.w * self.y),
            two * (self.y * self.z - self.w * self.x),
            R::one() - two * (self.x * self.x + self.y * self.y),
        )
    }
}

impl<R: Real> Mul for Quat<R> {
    type Output = Self;
    /// The Hamilton product: `a * b` rotates by b, then by a.
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        let (u, v) = (self.vector(), b.vector());
        Self::from_parts(v * self.w + u * b.w + u.cross(v), self.w * b.w - u.dot(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_glam() {
        let g = glam::DQuat::from_axis_angle(glam::DVec3::new(1.0, -2.0, 0.5).normalize(), 0.7);
        let h = glam::DQuat::from_axis_angle(glam::DVec3::new(0.3, 0.1, 1.0).normalize(), -1.9);
        let (q, p) = (Quat::<f64>::from_glam(g), Quat::<f64>::from_glam(h));
        let v = V3::new(0.2, -1.0, 3.0);
        let gv = g * glam::DVec3::new(0.2, -1.0, 3.0);
        let qv = q.rotate(v);
        assert!((qv.x - gv.x).abs() + (qv.y - gv.y).abs() + (qv.z - gv.z).abs() < 1e-14);
        let gz = g * glam::DVec3::Z;
        let qz = q.axis_z();
        assert!((qz.x - gz.x).abs() + (qz.y - gz.y).abs() + (qz.z - gz.z).abs() < 1e-15);
        let prod = (q * p).to_glam();
        assert!(prod.abs_diff_eq(g * h, 1e-15));
        let back = q.rotate_inv(qv);
        assert!((back - v).norm() < 1e-14);
    }

    #[test]
    fn from_axis_z_turns_z_onto_the_axis() {
        for a in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 2.0, -3.0],
            [0.0, 1.0, 0.0],
        ] {
            let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            let axis = V3::<f64>::new(a[0] / n, a[1] / n, a[2] / n);
            let z = Quat::from_axis_z(axis).axis_z();
            assert!((z - axis).norm() < 1e-15, "{a:?}");
        }
    }
}
