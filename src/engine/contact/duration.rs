//! Contact duration t_c, from which dt = t_c / n_c.

use super::law::{beta, ContactLaw, NormalModel};

/// The smallest and largest bodies that can meet, to bound t_c from below.
#[derive(Clone, Copy, Debug)]
pub struct ContactPair {
    /// Effective radius R* (m).
    pub r_eff: f64,
    /// Reduced mass m* (kg).
    pub m_eff: f64,
}

/// Contact duration (s). Linear: t_c = π / √(k_n/m* − (γ_n/2m*)²), exact for the damped
/// oscillator. Hertz: the elastic Hertz time 2.87 (m*² / (R* Y*² v))^{1/5} at impact speed
/// `impact_speed` (m/s) — the fastest expected impact gives the shortest contact, and damping only
/// lengthens it, so this is a lower bound.
pub fn contact_time(law: &ContactLaw, pair: ContactPair, impact_speed: f64) -> f64 {
    match law.normal {
        NormalModel::Hertz(el) => {
            let (y, _) = el.effective();
            let v = impact_speed.max(1e-6);
            2.87 * (pair.m_eff * pair.m_eff / (pair.r_eff * y * y * v)).powf(0.2)
        }
        NormalModel::Linear { kn_n_per_m, .. } => {
            let b = beta(law.restitution).abs();
            let gamma = 2.0 * b * (kn_n_per_m * pair.m_eff).sqrt();
            let eta = gamma / (2.0 * pair.m_eff);
            std::f64::consts::PI / (kn_n_per_m / pair.m_eff - eta * eta).sqrt()
        }
    }
}
