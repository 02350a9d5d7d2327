//! What the CPU engine hands the watchdog: the energy budget at a chunk's start and the
//! check that every live particle's motion is finite.

use super::particle::Status;
use super::CpuEngine;
use crate::engine::backend::EngineError;
use crate::engine::real::Real;
use crate::engine::watchdog::{wall_speed, EnergyBudget};

impl<R: Real> CpuEngine<R> {
    /// The energy watchdog's budget for a chunk of `steps` starting now (`watchdog.rs`); needs
    /// fresh lists. O(N) plus one contact pass, once per chunk.
    pub(super) fn energy_budget(&self, steps: u64) -> EnergyBudget {
        let mut b = self.energy_budget_without_elastic(steps);
        b.elastic_j = self.sum_elastic_energy();
        b
    }

    /// `energy_budget` but for the elastic energy (left at zero).
    pub(super) fn energy_budget_without_elastic(&self, steps: u64) -> EnergyBudget {
        let s = &self.state;
        let mobile_mass_kg: f64 = (0..s.len())
            .filter(|&i| s.inv_mass[i] != R::zero())
            .map(|i| s.mass[i].to_f64())
            .sum();
        let g = self.config.gravity;
        let g = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        EnergyBudget {
            kinetic_j: s.kinetic_energy(),
            elastic_j: 0.0,
            mobile_mass_kg,
            speed_gain_m_per_s: g * steps as f64 * self.config.dt_s
                + wall_speed(&self.config.walls, s),
            first_step: s.step + 1,
        }
    }

    /// `energy_budget` with the elastic energy from the half lists (fresh at a chunk's start).
    pub(super) fn energy_budget_spheres(&self, steps: u64) -> EnergyBudget {
        let mut b = self.energy_budget_without_elastic(steps);
        b.elastic_j = self.pair_elastic_energy();
        b
    }

    pub(super) fn check_finite(&self) -> Result<(), EngineError> {
        let s = &self.state;
        for i in 0..s.len() {
            if self.alive[i] != Status::Alive {
                continue;
            }
            let what = if !s.pos[i].is_finite() {
                "position"
            } else if !s.vel[i].is_finite() {
                "velocity"
            } else if s.rotation && !s.omega[i].is_finite() {
                "angular velocity"
            } else if s.oriented && !(s.orientation[i].norm2().is_finite()) {
                "orientation"
            } else {
                continue;
            };
            return Err(EngineError::NonFinite {
                what,
                id: s.id[i],
                step: s.step,
                time_s: s.time,
            });
        }
        Ok(())
    }
}
