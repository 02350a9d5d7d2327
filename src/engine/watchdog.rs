//! The CPU engine's watchdog: its limits, and the energy criterion it checks once per chunk. The
//! per-step overlap check, the per-chunk finiteness check and the elastic-energy gathers live
//! with the steps they watch (`cpu/`, `oriented.rs`); this file owns the criterion
//! (`EnergyBudget`) and the wall-speed bound it uses. The GPU engine checks the same criterion
//! with energies summed on the device (`gpu/engine/watchdog.rs`).

use super::backend::EngineError;
use super::real::Real;
use super::state::State;
use super::walls::Wall;

/// Watchdog limits.
#[derive(Clone, Copy, Debug)]
pub struct Watchdog {
    /// Largest tolerated overlap as a fraction of the smaller diameter, checked every step.
    pub max_overlap_ratio: f64,
    /// Largest tolerated ratio K₁ / B of a chunk's final kinetic energy to its energy budget
    /// (`EnergyBudget`), checked once per `advance`. `f64::INFINITY` switches the check off (and
    /// skips its O(N) passes and its contact pass).
    pub max_kinetic_growth: f64,
}

impl Default for Watchdog {
    fn default() -> Self {
        Self {
            // 20 % of d is far past any physical deformation: only a diverging run gets there.
            max_overlap_ratio: 0.2,
            // The budget is a bound a healthy run stays under up to what it neglects (see
            // `EnergyBudget`: a rebound off a moving wall at up to 2 v_w is 4× the energy of v_w;
            // the Verlet energy error at dt ≤ t_c/5 is far smaller). An instability grows
            // geometrically and passes 4 within a few of its own e-folding times.
            max_kinetic_growth: 4.0,
        }
    }
}

/// What a chunk may do to the kinetic energy of the mobile particles, fixed at its start.
///
/// Let E = K + U: kinetic energy (translational and rotational) plus the elastic energy stored
/// in the contacts (normal springs and tangential springs, `contact::elastic_energy`). Contacts
/// only store or dissipate energy and static walls do no work, so the only source is gravity:
/// dE/dt ≤ Σ mᵢ g·vᵢ ≤ g √(2 M K) ≤ g √(2 M E) (Cauchy–Schwarz), that is d√E/dt ≤ g √(M/2),
/// and over a chunk of duration T
///
///   √E₁ ≤ √E₀ + g T √(M/2),
///
/// with equality for a block in free fall, the fastest any flow gains energy (a chute above its
/// critical angle, a silo discharge, a poured gas falling). A wall moving at surface speed up
/// to v_w drags particles up to its own speed, which adds v_w to the rms speed √(2K/M). Hence
/// the budget
///
///   B = (√(K₀ + U₀) + √(M/2) (g T + v_w))²
///
/// and the criterion K₁ ≤ `max_kinetic_growth` · B, where K₀, U₀ and the mobile mass M are taken
/// at the chunk's start, K₁ over the particles alive at its end, g = |g|, and v_w is the largest
/// |Ω| times the reach of a mobile particle from a rotating wall's axis at the chunk's start.
/// Overlaps relaxing after an insertion turn U₀ into K and stay within B; a numerical
/// instability (dt far above t_c, a stiffness mistake) creates energy from nothing and passes
/// any fixed factor. A blow-up slower than `max_kinetic_growth` per chunk is not caught here;
/// the overlap and non-finite checks catch it later.
#[derive(Clone, Copy, Debug)]
pub(super) struct EnergyBudget {
    /// K₀ (J).
    pub kinetic_j: f64,
    /// U₀ (J).
    pub elastic_j: f64,
    /// M (kg).
    pub mobile_mass_kg: f64,
    /// g T + v_w (m/s).
    pub speed_gain_m_per_s: f64,
    /// First step of the chunk (the state's step count at its start, plus one).
    pub first_step: u64,
}

impl EnergyBudget {
    /// B (J).
    pub fn budget_j(&self) -> f64 {
        let a = (self.kinetic_j + self.elastic_j).sqrt()
            + (0.5 * self.mobile_mass_kg).sqrt() * self.speed_gain_m_per_s;
        a * a
    }

    /// K₁ / B (0 when both vanish: nothing can move).
    pub fn growth(&self, kinetic_end_j: f64) -> f64 {
        let b = self.budget_j();
        if b > 0.0 {
            kinetic_end_j / b
        } else if kinetic_end_j > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }

    /// K₁ / B, or `EnergyBlowUp` when it exceeds `limit`; `step` is the chunk's last step.
    pub fn check(&self, kinetic_end_j: f64, step: u64, limit: f64) -> Result<f64, EngineError> {
        let growth = self.growth(kinetic_end_j);
        if growth > limit {
            return Err(EngineError::EnergyBlowUp {
                from_j: self.kinetic_j,
                to_j: kinetic_end_j,
                budget_j: self.budget_j(),
                growth,
                limit,
                first_step: self.first_step,
                step,
            });
        }
        Ok(growth)
    }
}

/// v_w (m/s): over the rotating walls, |Ω| times the farthest reach (horizontal distance of the
/// centre from the axis, plus radius and half length) of a mobile particle.
pub(super) fn wall_speed<R: Real>(walls: &[Wall], s: &State<R>) -> f64 {
    let mut v: f64 = 0.0;
    for rot in walls.iter().filter_map(|w| w.rotation) {
        let omega = rot.omega_rad_per_s.abs();
        if omega == 0.0 {
            continue;
        }
        let mut reach: f64 = 0.0;
        for i in 0..s.len() {
            if s.inv_mass[i] == R::zero() {
                continue;
            }
            let p = s.pos[i].to_f64();
            let (dx, dy) = (p[0] - rot.axis_xy[0], p[1] - rot.axis_xy[1]);
            let half = if s.oriented {
                s.half_length[i].to_f64()
            } else {
                0.0
            };
            reach = reach.max((dx * dx + dy * dy).sqrt() + s.radius[i].to_f64() + half);
        }
        v = v.max(omega * reach);
    }
    v
}
