//! Time average of `GridFields` snapshots over a window, as the silo paper takes it: ρ, P and σᶜ
//! are linear and averaged as sums; the kinetic stress is averaged as each snapshot's σᵏ(t)
//! (fluctuations about that snapshot's V, the paper's ⟨σᵏ⟩_t of Eq. 6), not re-derived from the
//! averaged sums (which would also count the temporal fluctuations of V, as `ZProfileAverage`
//! does for the chute). V of an average is ⟨P⟩/⟨ρ⟩.

use serde::{Deserialize, Serialize};

use super::field_grid::FieldGrid;
use super::grid_fields::GridFields;

/// Running sums of snapshots on one grid (checkpointed with its observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridAverage {
    pub grid: FieldGrid,
    /// Snapshots added and the times of the first and last (s).
    pub samples: u64,
    pub t_first_s: f64,
    pub t_last_s: f64,
    density: Vec<f64>,
    momentum: Vec<f64>,
    kinetic_stress: Vec<f64>,
    /// Empty when no snapshot carried contact stress.
    contact_stress: Vec<f64>,
}

impl GridAverage {
    /// An empty average on `grid`.
    pub fn new(grid: FieldGrid) -> Self {
        let n = grid.len();
        Self {
            grid,
            samples: 0,
            t_first_s: 0.0,
            t_last_s: 0.0,
            density: vec![0.0; n],
            momentum: vec![0.0; 3 * n],
            kinetic_stress: vec![0.0; 9 * n],
            contact_stress: Vec::new(),
        }
    }

    /// Adds the snapshot `s` taken at `t_s`.
    ///
    /// # Panics
    /// If the snapshot's grid differs.
    pub fn add(&mut self, s: &GridFields, t_s: f64) {
        assert_eq!(s.grid, self.grid, "same grid");
        if self.samples == 0 {
            self.t_first_s = t_s;
        }
        self.t_last_s = t_s;
        self.samples += 1;
        add_into(&mut self.density, &s.density);
        add_into(&mut self.momentum, &s.momentum);
        for p in 0..self.grid.len() {
            add_into(
                &mut self.kinetic_stress[9 * p..9 * p + 9],
                &s.kinetic_stress(p),
            );
        }
        if !s.contact_stress.is_empty() {
            if self.contact_stress.is_empty() {
                self.contact_stress = vec![0.0; 9 * self.grid.len()];
            }
            add_into(&mut self.contact_stress, &s.contact_stress);
        }
    }

    fn mean_of(&self, v: &[f64]) -> Vec<f64> {
        let inv = 1.0 / self.samples.max(1) as f64;
        v.iter().map(|x| x * inv).collect()
    }

    /// ⟨ρ⟩ (kg/m³) per point.
    pub fn density(&self) -> Vec<f64> {
        self.mean_of(&self.density)
    }

    /// ⟨P⟩ (kg m⁻² s⁻¹), 3 per point.
    pub fn momentum(&self) -> Vec<f64> {
        self.mean_of(&self.momentum)
    }

    /// V = ⟨P⟩/⟨ρ⟩ (m/s), 3 per point; 0 where ⟨ρ⟩ = 0 (no particle ever within reach: the
    /// store holds finite numbers only, and φ = 0 says where V means nothing).
    pub fn velocity(&self) -> Vec<f64> {
        let rho = &self.density;
        self.momentum
            .iter()
            .enumerate()
            .map(|(k, p)| {
                if rho[k / 3] > 0.0 {
                    p / rho[k / 3]
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// ⟨σᵏ⟩_t (Pa), 9 per point.
    pub fn kinetic_stress(&self) -> Vec<f64> {
        self.mean_of(&self.kinetic_stress)
    }

    /// p^k = tr ⟨σᵏ⟩_t (Pa) per point (the paper's fig10; not divided by 3).
    pub fn kinetic_pressure(&self) -> Vec<f64> {
        self.kinetic_stress()
            .chunks_exact(9)
            .map(|s| s[0] + s[4] + s[8])
            .collect()
    }

    /// ⟨σᶜ⟩ (Pa), 9 per point; None when no snapshot carried contacts.
    pub fn contact_stress(&self) -> Option<Vec<f64>> {
        (!self.contact_stress.is_empty()).then(|| self.mean_of(&self.contact_stress))
    }
}

fn add_into(acc: &mut [f64], v: &[f64]) {
    for (a, b) in acc.iter_mut().zip(v) {
        *a += b;
    }
}
