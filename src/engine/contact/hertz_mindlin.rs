//! The force of one contact on particle i, as a pure function shared by particle–particle and
//! particle–wall contacts, one contact at a time or in SIMD lanes (mirrored in WGSL for the GPU
//! backend).

use super::law::LawKernel;
use crate::engine::choice::{pick, Branch, Choice};
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

/// Returns the force on i (N) and updates the tangential spring `spring` in place: the law for
/// one contact at a time ([`contact_force_in`] with branches).
#[inline(always)]
pub fn contact_force<R: Real>(
    law: &LawKernel<R>,
    c: &ContactInput<R>,
    spring: &mut V3<R>,
    dt: R,
) -> V3<R> {
    let (f, s) = if law.hertz {
        contact_force_in::<R, Branch, true>(law, c, *spring, dt)
    } else {
        contact_force_in::<R, Branch, false>(law, c, *spring, dt)
    };
    *spring = s;
    f
}

/// The contact law, written once: the force on i (N) and the new tangential spring, from the
/// stored one. `C` takes its two-way choices (`Branch` for one contact, `Select` for the lane
/// kernels, which give the same bits); `HERTZ` is `law.hertz`, known when compiling.
///
/// Normal: F_n = k_n δ − γ_n v_n along n (Hertz: k_n = 4/3 Y* √(R*δ), γ_n = 2√(5/6)|β|√(S_n m*),
/// S_n = 2 Y* √(R*δ); linear: constant k_n, γ_n = 2|β|√(k_n m*)).
/// Tangential: the spring is turned into the current tangent plane (magnitude kept), grows by
/// v_t dt, and F_t = −k_t ξ − γ_t v_t is truncated at μ|F_n|, the spring rescaled to match
/// (so sliding contacts keep |F_t| = μ|F_n| without storing excess elongation).
#[inline(always)]
pub fn contact_force_in<R: Real, C: Choice, const HERTZ: bool>(
    law: &LawKernel<R>,
    c: &ContactInput<R>,
    spring: V3<R>,
    dt: R,
) -> (V3<R>, V3<R>) {
    let n = c.normal;
    let vn = c.v_rel.dot(n);
    // Hertz stiffnesses grow as √(R*δ); computed once for both directions.
    let sq = if HERTZ {
        (c.r_eff * c.overlap).sqrt()
    } else {
        R::one()
    };
    let (kn, sn) = if HERTZ {
        let kn = law.kn_coef * sq;
        // S_n = 2 Y* √(Rδ) = 3/2 k_n.
        (kn, kn * R::from_f64(1.5))
    } else {
        (law.kn_coef, law.kn_coef)
    };
    let gamma_n = law.damp_n * (sn * c.m_eff).sqrt();
    let fn_mag = kn * c.overlap - gamma_n * vn;
    let f = n * fn_mag;
    if !law.tangential {
        return (f, spring);
    }
    let kt = law.kt_coef * sq;
    let gamma_t = law.damp_t * (kt * c.m_eff).sqrt();
    let vt = c.v_rel - n * vn;
    // Turn the old spring into the tangent plane, keeping its length (s · 1 is s exactly).
    let old2 = spring.norm2();
    let s = spring - n * spring.dot(n);
    let s2 = s.norm2();
    let s = s * pick!(C, s2 > R::zero(), (old2 / s2).sqrt(), R::one());
    let s = s + vt * dt;
    let ft = -(s * kt) - vt * gamma_t;
    let limit = law.mu * fn_mag.abs();
    let ft2 = ft.norm2();
    let slides = ft2 > limit * limit;
    let (ft, s) = pick!(
        C,
        slides,
        {
            let ft = ft * (limit / ft2.sqrt());
            (ft, -(ft + vt * gamma_t) * (R::one() / kt))
        },
        (ft, s)
    );
    (f + ft, s)
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
