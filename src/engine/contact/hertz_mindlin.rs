//! The force of one contact on particle i, as a pure function shared by particle–particle and
//! particle–wall contacts (mirrored in WGSL for the GPU backend).

use super::law::LawKernel;
use crate::engine::real::{Real, V3};

/// Geometry and kinematics of one contact, seen from particle i.
#[derive(Clone, Copy, Debug)]
pub struct ContactInput<R: Real> {
    /// Overlap δ > 0 (m).
    pub overlap: R,
    /// Unit normal pointing from the partner to i.
    pub normal: V3<R>,
    /// Velocity of i's surface minus the partner's surface at the contact point (m/s).
    pub v_rel: V3<R>,
    /// Effective radius R* = Ri Rj/(Ri + Rj) (Ri for a wall) (m).
    pub r_eff: R,
    /// Reduced mass m* = mi mj/(mi + mj) (mi for a wall) (kg). The silo paper prints the inverse.
    pub m_eff: R,
}

/// Returns the force on i (N) and updates the tangential spring `spring` in place.
///
/// Normal: F_n = k_n δ − γ_n v_n along n (Hertz: k_n = 4/3 Y* √(R*δ), γ_n = 2√(5/6)|β|√(S_n m*),
/// S_n = 2 Y* √(R*δ); linear: constant k_n, γ_n = 2|β|√(k_n m*)).
/// Tangential: the spring is turned into the current tangent plane (magnitude kept), grows by
/// v_t dt, and F_t = −k_t ξ − γ_t v_t is truncated at μ|F_n|, the spring rescaled to match
/// (so sliding contacts keep |F_t| = μ|F_n| without storing excess elongation).
#[inline(always)]
pub fn contact_force<R: Real>(
    law: &LawKernel<R>,
    c: &ContactInput<R>,
    spring: &mut V3<R>,
    dt: R,
) -> V3<R> {
    let n = c.normal;
    let vn = c.v_rel.dot(n);
    // Hertz stiffnesses grow as √(R*δ); computed once for both directions.
    let sq = if law.hertz {
        (c.r_eff * c.overlap).sqrt()
    } else {
        R::one()
    };
    let (kn, sn) = if law.hertz {
        let kn = law.kn_coef * sq;
        // S_n = 2 Y* √(Rδ) = 3/2 k_n.
        (kn, kn * R::from_f64(1.5))
    } else {
        (law.kn_coef, law.kn_coef)
    };
    let gamma_n = law.damp_n * (sn * c.m_eff).sqrt();
    let fn_mag = kn * c.overlap - gamma_n * vn;
    let mut f = n * fn_mag;
    if law.tangential {
        let kt = law.kt_coef * sq;
        let gamma_t = law.damp_t * (kt * c.m_eff).sqrt();
        let vt = c.v_rel - n * vn;
        // Turn the old spring into the tangent plane, keeping its length.
        let old = *spring;
        let old2 = old.norm2();
        let mut s = old - n * old.dot(n);
        let s2 = s.norm2();
        if s2 > R::zero() {
            s = s * (old2 / s2).sqrt();
        }
        s += vt * dt;
        let mut ft = -(s * kt) - vt * gamma_t;
        let limit = law.mu * fn_mag.abs();
        let ft2 = ft.norm2();
        if ft2 > limit * limit {
            ft = ft * (limit / ft2.sqrt());
            s = -(ft + vt * gamma_t) * (R::one() / kt);
        }
        *spring = s;
        f += ft;
    }
    f
}

/// Elastic energy stored in one contact (J): the normal spring's potential plus the tangential
/// spring's ½ k_t |ξ|² (k_t at the current overlap). Hertz: U_n = ∫₀^δ 4/3 Y* √R* s^{3/2} ds
/// = 8/15 Y* √R* δ^{5/2} = 2/5 k_n δ² with k_n = 4/3 Y* √(R*δ); linear: U_n = ½ k_n δ².
/// Read only by the energy watchdog, at chunk boundaries (never in the step loop).
#[inline]
pub fn elastic_energy<R: Real>(law: &LawKernel<R>, overlap: R, r_eff: R, spring: V3<R>) -> R {
    let sq = if law.hertz {
        (r_eff * overlap).sqrt()
    } else {
        R::one()
    };
    let normal_share = R::from_f64(if law.hertz { 0.4 } else { 0.5 });
    let mut u = normal_share * law.kn_coef * sq * overlap * overlap;
    if law.tangential {
        u += R::from_f64(0.5) * law.kt_coef * sq * spring.norm2();
    }
    u
}
