//! Rotation of a rigid body with a diagonal body-frame inertia tensor I = diag(I1, I2, I3): Euler's
//! equations (as a reference) and the integrator the engine uses. Owns no contacts and no state
//! arrays; the orientation is a unit [`Quat`] (body → lab).
//!
//! # Scheme
//! The state is the orientation q and the angular momentum **L in the lab frame**; the body-frame
//! momentum is π = Rᵀ(q) L and ω_body = I⁻¹ π. The Hamiltonian H = T(q, L) + U splits into
//! kick–rotate–kick (the rotational half of velocity Verlet; Dullweber, Leimkuhler & McLachlan,
//! J. Chem. Phys. 107, 5840 (1997), the scheme NO_SQUISH (Miller et al., J. Chem. Phys. 116, 8649
//! (2002)) writes in quaternion momenta):
//! 1. L ← L + τ dt/2 (τ the lab-frame torque: the exact flow of U);
//! 2. q ← free rotation for dt with L held ([`rotate_free`]), renormalised;
//! 3. torques at the new q, L ← L + τ dt/2 (a fused-kick Verlet loop merges it with the next 1).
//!
//! The free rotation is exact for a symmetric top (I1 = I2, every spherocylinder):
//! T = |L|²/2I1 + π3²/2 (1/I3 − 1/I1), two commuting flows — a turn of the body about the fixed
//! lab vector L by |L| dt/I1 and a turn about its own axis e3 by (1/I3 − 1/I1) π3 dt — so
//! q ← exp(½|L| dt/I1 · L̂) q exp(½ (1/I3 − 1/I1) π3 dt · e3). For an asymmetric top it is the
//! symmetric splitting T = T1 + T2 + T3, Tk = πk²/2Ik, each an exact turn about body axis k:
//! R1(dt/2) R2(dt/2) R3(dt) R2(dt/2) R1(dt/2) (Dullweber et al. 1997, the same split as NO_SQUISH).
//!
//! Properties: second order, time-reversible, symplectic; torque-free, L is conserved exactly (it
//! is held fixed) and the kinetic energy oscillates at O(dt²) without drift. It stands in for the
//! paper's "modified leap-frog" rotation (its ref. 29); `tests/spherocylinder.rs` checks it.

use super::quat::{sin_cos, sin_cos_small, Quat};
use crate::engine::real::{Real, V3};

/// Euler's equations in the body frame, I ω̇ + ω × (I ω) = τ: returns ω̇ (rad/s²) for body-frame
/// ω and τ and principal moments `inertia` = (I1, I2, I3) (kg m²). The integrator does not call
/// it (it follows the same flow through L and q); tests integrate it as the reference.
#[inline]
pub fn euler_rhs<R: Real>(inertia: V3<R>, omega: V3<R>, torque: V3<R>) -> V3<R> {
    let i = inertia;
    let w = omega;
    V3::new(
        (torque.x + (i.y - i.z) * w.y * w.z) / i.x,
        (torque.y + (i.z - i.x) * w.z * w.x) / i.y,
        (torque.z + (i.x - i.y) * w.x * w.y) / i.z,
    )
}

/// The lab-frame angular velocity ω = R I⁻¹ Rᵀ L (rad/s) of a body at orientation `q` with lab
/// angular momentum `l` and body-frame inverse principal moments `inv_inertia` (1/(kg m²)).
#[inline]
pub fn angular_velocity<R: Real>(q: Quat<R>, inv_inertia: V3<R>, l: V3<R>) -> V3<R> {
    let pi = q.rotate_inv(l);
    q.rotate(V3::new(
        pi.x * inv_inertia.x,
        pi.y * inv_inertia.y,
        pi.z * inv_inertia.z,
    ))
}

/// The lab-frame angular momentum L = R I Rᵀ ω (kg m²/s) for lab angular velocity `omega`.
#[inline]
pub fn angular_momentum<R: Real>(q: Quat<R>, inertia: V3<R>, omega: V3<R>) -> V3<R> {
    let w = q.rotate_inv(omega);
    q.rotate(V3::new(w.x * inertia.x, w.y * inertia.y, w.z * inertia.z))
}

/// Rotational kinetic energy ½ π·I⁻¹π (J), π = Rᵀ L.
#[inline]
pub fn rotational_energy<R: Real>(q: Quat<R>, inv_inertia: V3<R>, l: V3<R>) -> R {
    let pi = q.rotate_inv(l);
    (pi.x * pi.x * inv_inertia.x + pi.y * pi.y * inv_inertia.y + pi.z * pi.z * inv_inertia.z)
        * R::from_f64(0.5)
}

/// One torque-free rotation of the orientation over `dt` with lab angular momentum `l` held
/// fixed: exact for a symmetric top (`inv_inertia.x == inv_inertia.y`), the symmetric
/// principal-axis splitting otherwise (module doc). Returns the new orientation, at unit norm.
#[inline]
pub fn rotate_free<R: Real>(q: Quat<R>, l: V3<R>, inv_inertia: V3<R>, dt: R) -> Quat<R> {
    if inv_inertia.x == inv_inertia.y {
        rotate_free_symmetric(q, l, inv_inertia, dt)
    } else {
        rotate_free_split(q, l, inv_inertia, dt)
    }
}

/// The exact free rotation of a symmetric top (I1 = I2, symmetry axis body z):
/// q ← exp(½ α L̂) q exp(½ β e3), α = |L| dt/I1, β = (1/I3 − 1/I1) π3 dt, π3 = L·axis.
/// `inv_inertia.y` is not read.
#[inline]
pub fn rotate_free_symmetric<R: Real>(q: Quat<R>, l: V3<R>, inv_inertia: V3<R>, dt: R) -> Quat<R> {
    rotate_symmetric_with(q, l, inv_inertia, dt, sin_cos_small)
}

/// `rotate_free_symmetric` with the sine and cosine of `sc`, branch-free (selects): the scalar
/// code passes `sin_cos_small`, the SIMD lanes of the rod kick its polynomial.
#[inline(always)]
pub fn rotate_symmetric_with<R: Real>(
    q: Quat<R>,
    l: V3<R>,
    inv_inertia: V3<R>,
    dt: R,
    sc: impl Fn(R) -> (R, R),
) -> Quat<R> {
    let half = R::from_f64(0.5);
    // π3 is conserved by both factors, so it may be read before either.
    let pi3 = l.dot(q.axis_z());
    let (sb, cb) = sc((inv_inertia.z - inv_inertia.x) * pi3 * dt * half);
    let spin = Quat::from_parts(V3::new(R::zero(), R::zero(), sb), cb);
    let l_norm = l.norm();
    let (sa, ca) = sc(l_norm * inv_inertia.x * dt * half);
    let about_l = Quat::from_parts(l * (sa / l_norm), ca) * q;
    // No momentum, no turn about it (the product above is then NaN).
    let moving = l_norm > R::zero();
    let turned = Quat {
        x: if moving { about_l.x } else { q.x },
        y: if moving { about_l.y } else { q.y },
        z: if moving { about_l.z } else { q.z },
        w: if moving { about_l.w } else { q.w },
    };
    (turned * spin).normalize()
}

/// The angles (rad) whose sine and cosine `rotate_symmetric_with` takes: the spin about the
/// axis and the turn about L.
#[inline(always)]
pub fn symmetric_angles<R: Real>(q: Quat<R>, l: V3<R>, inv_inertia: V3<R>, dt: R) -> [R; 2] {
    let half = R::from_f64(0.5);
    let pi3 = l.dot(q.axis_z());
    [
        (inv_inertia.z - inv_inertia.x) * pi3 * dt * half,
        l.norm() * inv_inertia.x * dt * half,
    ]
}

/// The free rotation by the symmetric splitting R1(dt/2) R2(dt/2) R3(dt) R2(dt/2) R1(dt/2), each
/// Rk an exact turn about body axis k at the rate πk/Ik, the body momentum π turned back with it
/// (Dullweber, Leimkuhler & McLachlan 1997). Valid for any diagonal inertia.
#[inline]
pub fn rotate_free_split<R: Real>(q: Quat<R>, l: V3<R>, inv_inertia: V3<R>, dt: R) -> Quat<R> {
    let half = dt * R::from_f64(0.5);
    let mut q = q;
    let mut pi = q.rotate_inv(l);
    for (axis, h) in [(0, half), (1, half), (2, dt), (1, half), (0, half)] {
        turn_about_body_axis(&mut q, &mut pi, inv_inertia, axis, h);
    }
    q.normalize()
}

/// The exact flow of Tk = πk²/2Ik for time h: the body turns by φ = h πk/Ik about its axis k
/// (q ← q exp(½ φ ek)) and π, seen from the body, turns by −φ (dπ/dt = π × ω, ω = φ/h ek).
#[inline(always)]
fn turn_about_body_axis<R: Real>(
    q: &mut Quat<R>,
    pi: &mut V3<R>,
    inv_inertia: V3<R>,
    axis: usize,
    h: R,
) {
    let zero = R::zero();
    let (pk, ik) = match axis {
        0 => (pi.x, inv_inertia.x),
        1 => (pi.y, inv_inertia.y),
        _ => (pi.z, inv_inertia.z),
    };
    let (s, c) = sin_cos(h * pk * ik * R::from_f64(0.5));
    // cos φ and sin φ from the half angle.
    let (cf, sf) = (c * c - s * s, R::from_f64(2.0) * s * c);
    let turn = |a: R, b: R| (cf * a + sf * b, cf * b - sf * a);
    match axis {
        0 => {
            *q = *q * Quat::from_parts(V3::new(s, zero, zero), c);
            (pi.y, pi.z) = turn(pi.y, pi.z);
        }
        1 => {
            *q = *q * Quat::from_parts(V3::new(zero, s, zero), c);
            (pi.z, pi.x) = turn(pi.z, pi.x);
        }
        _ => {
            *q = *q * Quat::from_parts(V3::new(zero, zero, s), c);
            (pi.x, pi.y) = turn(pi.x, pi.y);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_spin_about_a_principal_axis_is_a_uniform_turn() {
        // L along body (= lab) y of an asymmetric top: ω = L/I2, turns by ω t about y.
        let inv = V3::new(1.0, 0.5, 0.25);
        let l = V3::new(0.0, 2.0, 0.0);
        let mut q = Quat::<f64>::identity();
        for _ in 0..1000 {
            q = rotate_free_split(q, l, inv, 1e-3);
        }
        let expect = Quat::from_axis_angle(V3::new(0.0, 1.0, 0.0), 1.0);
        assert!((q.vector() - expect.vector()).norm() + (q.w - expect.w).abs() < 1e-12);
    }

    #[test]
    fn momentum_and_velocity_are_inverse() {
        let q = Quat::from_axis_angle(V3::new(0.6, 0.0, 0.8), 0.9);
        let inertia = V3::new(1.0, 2.0, 3.0);
        let inv = V3::new(1.0, 0.5, 1.0 / 3.0);
        let w = V3::new(0.3, -1.2, 2.0);
        let back = angular_velocity(q, inv, angular_momentum(q, inertia, w));
        assert!((back - w).norm() < 1e-14);
        let e = rotational_energy(q, inv, angular_momentum(q, inertia, w));
        let wb = q.rotate_inv(w);
        let expect = 0.5 * (wb.x * wb.x * 1.0 + wb.y * wb.y * 2.0 + wb.z * wb.z * 3.0);
        assert!((e - expect).abs() < 1e-14);
    }
}
