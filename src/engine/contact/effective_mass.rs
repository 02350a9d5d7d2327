//! The effective mass of a contact along its normal, rotation included: the mass m* for which
//! the normal motion of the contact points obeys m* δ̈ = −F_n. For bodies a and b with lever
//! arms r_a, r_b from their centres to the contact point and normal n,
//! 1/m* = 1/m_a + 1/m_b + (r_a × n)·I_a⁻¹(r_a × n) + (r_b × n)·I_b⁻¹(r_b × n).
//! A spherocylinder's arm is its axis point plus a multiple of n, so r × n is perpendicular to
//! its axis and only I⊥ enters: (r × n)·I⁻¹(r × n) = |r × n|²/I⊥. A rod hit at its tip across
//! its axis is the lightest case (|r × n| = l/2): for ξ = 3 rotation more than doubles its
//! inverse mass, so the reduced mass alone would make the damping too strong for the
//! restitution asked for and overstate the contact time. A sphere's arm lies along n: its
//! term is zero, and a pair of spheres keeps the reduced mass m_a m_b/(m_a + m_b) bit for bit.
//! A fixed body has 1/m = 1/I = 0 (infinitely heavy).

use crate::engine::real::{Real, V3};

/// |r × n|²/I⊥ for a rod (half-length `h` > 0, inverse perpendicular moment `inv_i_perp`),
/// zero for a sphere (h = 0).
#[inline(always)]
fn turn<R: Real>(h: R, inv_i_perp: R, arm: V3<R>, n: V3<R>) -> R {
    let c = arm.cross(n);
    if h > R::zero() {
        c.norm2() * inv_i_perp
    } else {
        R::zero()
    }
}

/// One body of a contact as its effective mass sees it.
#[derive(Clone, Copy, Debug)]
pub struct Inertial<R> {
    pub mass: R,
    /// 1/m, zero when fixed.
    pub inv_mass: R,
    /// 1/I⊥ (body frame x), zero when fixed.
    pub inv_i_perp: R,
    /// l/2 (m), zero for a sphere.
    pub half_length: R,
}

/// m* of bodies a and b touching with arms `arm_a`, `arm_b` along normal `n` (module doc).
/// Branch-free (the rod lanes run it): every case is computed, one is selected.
#[inline(always)]
pub fn pair_effective_mass<R: Real>(
    a: Inertial<R>,
    b: Inertial<R>,
    arm_a: V3<R>,
    arm_b: V3<R>,
    n: V3<R>,
) -> R {
    let zero = R::zero();
    let (ma, mb) = (a.mass, b.mass);
    // Two spheres: the reduced mass, a fixed partner acting as infinitely heavy.
    let reduced = if b.inv_mass == zero {
        ma
    } else if a.inv_mass == zero {
        mb
    } else {
        ma * mb / (ma + mb)
    };
    let turns =
        turn(a.half_length, a.inv_i_perp, arm_a, n) + turn(b.half_length, b.inv_i_perp, arm_b, n);
    let with_turns = R::one() / ((a.inv_mass + b.inv_mass) + turns);
    let rods = (a.half_length > zero) | (b.half_length > zero);
    if rods {
        with_turns
    } else {
        reduced
    }
}

/// m* of body a against a wall (infinitely heavy) with arm `arm` along normal `n`.
#[inline(always)]
pub fn wall_effective_mass<R: Real>(a: Inertial<R>, arm: V3<R>, n: V3<R>) -> R {
    let with_turn = R::one() / (a.inv_mass + turn(a.half_length, a.inv_i_perp, arm, n));
    if a.half_length > R::zero() {
        with_turn
    } else {
        a.mass
    }
}
