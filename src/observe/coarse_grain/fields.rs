//! The coarse-grained fields at one point, whatever the grid: the four linear sums (density,
//! momentum, momentum flux, contact stress) and what derives from them (velocity, kinetic and
//! total stress).
//!
//! Only the linear sums are stored, so a time average is the average of each sum, and the
//! derived fields of an average follow from averaged sums (the convention of Weinhart et al. and
//! of MercuryDPM's CG fields): V = ⟨P⟩/⟨ρ⟩ and σᵏ = ⟨Σ m v⊗v φ⟩ − ⟨P⟩⊗⟨P⟩/⟨ρ⟩, i.e. fluctuations
//! about the time-averaged V, temporal ones included.
//!
//! Stress is compressive positive (a momentum flux): σ_ab = Σ f_a r_b ψ/A with f the force on i
//! and r = c_i − c_j, so σ_zz > 0 under weight, and in a flow along +x with dV_x/dz > 0 both the
//! kinetic and the contact σ_xz are negative (the steady chute has σ_xz/σ_zz = −tan α).

use serde::{Deserialize, Serialize};

/// A 3×3 tensor, row a, column b.
pub type Tensor = [[f64; 3]; 3];

/// Linear coarse-grained sums at one point (SI: kg/m³, kg/(m² s), Pa).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointFields {
    /// ρ = Σ m φ (kg/m³).
    pub density: f64,
    /// P = Σ m v φ (kg m⁻² s⁻¹).
    pub momentum: [f64; 3],
    /// Σ m v⊗v φ (Pa), symmetric.
    pub momentum_flux: Tensor,
    /// σᶜ = Σ f ⊗ r ψ (Pa), compressive positive.
    pub contact_stress: Tensor,
}

impl PointFields {
    /// Adds `other` × `scale`, field by field.
    pub fn add_scaled(&mut self, other: &Self, scale: f64) {
        self.density += other.density * scale;
        for a in 0..3 {
            self.momentum[a] += other.momentum[a] * scale;
            for b in 0..3 {
                self.momentum_flux[a][b] += other.momentum_flux[a][b] * scale;
                self.contact_stress[a][b] += other.contact_stress[a][b] * scale;
            }
        }
    }

    /// V = P/ρ (m/s); NaN where ρ = 0 (no particle within the kernel's reach).
    pub fn velocity(&self) -> [f64; 3] {
        if self.density > 0.0 {
            self.momentum.map(|p| p / self.density)
        } else {
            [f64::NAN; 3]
        }
    }

    /// σᵏ = Σ m v⊗v φ − ρ V⊗V (Pa); zero where ρ = 0.
    pub fn kinetic_stress(&self) -> Tensor {
        let mut s = self.momentum_flux;
        if self.density > 0.0 {
            for (a, row) in s.iter_mut().enumerate() {
                for (b, v) in row.iter_mut().enumerate() {
                    *v -= self.momentum[a] * self.momentum[b] / self.density;
                }
            }
        }
        s
    }

    /// σ = σᵏ + σᶜ (Pa), compressive positive.
    pub fn stress(&self) -> Tensor {
        let mut s = self.kinetic_stress();
        for (a, row) in s.iter_mut().enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                *v += self.contact_stress[a][b];
            }
        }
        s
    }
}
