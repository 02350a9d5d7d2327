//! Coarse-grained fields on a z grid over a periodic x–y box of area A (the chute): deposit
//! particles and contacts, read velocity, shear rate and stress, and the bulk stress ratio.
//!
//! Fields are x–y averages: a particle adds m φ(z − z_i)/A to ρ(z), with φ the 1-D kernel, so
//! ∫ρ A dz = Σm exactly for particles whose support lies on the grid. A contact adds
//! f ⊗ r ψ(z)/A to σᶜ, ψ(z) = ∫_0^1 φ(z − z_i + s z_ij) ds being the kernel along its branch
//! (Weinhart et al. 2012), so that ∂σᶜ_az/∂z is exactly minus the coarse-grained contact force
//! density: the momentum balance holds field by field, not only on average.

use serde::{Deserialize, Serialize};

use super::fields::{PointFields, Tensor};
use super::kernel::Kernel;
use super::z_grid::ZGrid;
use crate::engine::contact::ContactRecord;

/// Fields on a z grid: one snapshot's sums, or a time average of them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZProfile {
    pub grid: ZGrid,
    /// One entry per grid point.
    pub points: Vec<PointFields>,
}

impl ZProfile {
    /// All fields zero.
    pub fn new(grid: ZGrid) -> Self {
        Self {
            grid,
            points: vec![PointFields::default(); grid.n],
        }
    }

    /// Adds density, momentum and momentum flux of particles at `pos` (m) with velocity `vel`
    /// (m/s) and mass `mass` (kg), over a box of horizontal area `area_m2`.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn deposit_particles(
        &mut self,
        kernel: &Kernel,
        area_m2: f64,
        pos: &[[f64; 3]],
        vel: &[[f64; 3]],
        mass: &[f64],
    ) {
        assert!(pos.len() == vel.len() && pos.len() == mass.len());
        let k1 = kernel.one_d();
        let reach = k1.cutoff_m();
        for ((p, v), &m) in pos.iter().zip(vel).zip(mass) {
            let zi = p[2];
            for k in self.grid.indices_near(zi - reach, zi + reach) {
                let w = m * k1.value(self.grid.z(k) - zi) / area_m2;
                if w == 0.0 {
                    continue;
                }
                let f = &mut self.points[k];
                f.density += w;
                for a in 0..3 {
                    f.momentum[a] += w * v[a];
                    for b in 0..3 {
                        f.momentum_flux[a][b] += w * v[a] * v[b];
                    }
                }
            }
        }
    }

    /// Adds the contact stress f_ij ⊗ r_ij ψ_ij/A of each contact: r_ij is the record's branch
    /// (c_i − c_j, or c_i − contact point for a wall), f_ij the force on i, and the line integral
    /// runs from z_i to z_i − r_z.
    pub fn deposit_contacts(&mut self, kernel: &Kernel, area_m2: f64, contacts: &[ContactRecord]) {
        let k1 = kernel.one_d();
        let reach = k1.cutoff_m();
        for c in contacts {
            let zi = c.pos_i[2];
            let h = c.branch[2];
            let zj = zi - h;
            let mut fr: Tensor = [[0.0; 3]; 3];
            for (a, row) in fr.iter_mut().enumerate() {
                for (b, v) in row.iter_mut().enumerate() {
                    *v = c.force_on_i[a] * c.branch[b] / area_m2;
                }
            }
            for k in self
                .grid
                .indices_near(zi.min(zj) - reach, zi.max(zj) + reach)
            {
                let psi = k1.line(self.grid.z(k) - zi, h);
                if psi == 0.0 {
                    continue;
                }
                let s = &mut self.points[k].contact_stress;
                for a in 0..3 {
                    for b in 0..3 {
                        s[a][b] += fr[a][b] * psi;
                    }
                }
            }
        }
    }

    /// ρ(z) (kg/m³).
    pub fn density(&self) -> Vec<f64> {
        self.points.iter().map(|f| f.density).collect()
    }

    /// V_x(z) = P_x/ρ (m/s); NaN where ρ = 0.
    pub fn velocity_x(&self) -> Vec<f64> {
        self.points.iter().map(|f| f.velocity()[0]).collect()
    }

    /// γ̇(z) = dV_x/dz (1/s) by central differences (V_{k+1} − V_{k−1})/(2 dz), second-order
    /// accurate; one-sided (first-order) where a neighbour is missing (grid end, or ρ = 0 there);
    /// NaN where V_x itself is undefined.
    pub fn shear_rate(&self) -> Vec<f64> {
        let v = self.velocity_x();
        let dz = self.grid.dz_m;
        let at = |k: Option<usize>| k.and_then(|k| v.get(k)).copied().filter(|x| x.is_finite());
        (0..v.len())
            .map(
                |k| match (at(k.checked_sub(1)), at(Some(k)), at(Some(k + 1))) {
                    (_, None, _) => f64::NAN,
                    (Some(lo), _, Some(hi)) => (hi - lo) / (2.0 * dz),
                    (None, Some(c), Some(hi)) => (hi - c) / dz,
                    (Some(lo), Some(c), None) => (c - lo) / dz,
                    (None, Some(_), None) => f64::NAN,
                },
            )
            .collect()
    }

    /// Total stress component σ_ab(z) = σᵏ + σᶜ (Pa), compressive positive.
    pub fn stress(&self, a: usize, b: usize) -> Vec<f64> {
        self.points.iter().map(|f| f.stress()[a][b]).collect()
    }
}

/// The bulk friction μ = −∫σ_xz dz / ∫σ_zz dz over [z_lo, z_hi] (m, the grid's coordinates),
/// total stress (kinetic + contact).
///
/// The sign: stresses are compressive positive, so for a flow along +x (gravity
/// g (sin α, 0, −cos α)) the steady momentum balance gives σ_xz/σ_zz = −tan α at every height;
/// the minus makes this ratio tend to +tan α. None when ∫σ_zz ≤ 0 or no grid segment overlaps.
pub fn bulk_stress_ratio(profile: &ZProfile, z_lo: f64, z_hi: f64) -> Option<f64> {
    let g = &profile.grid;
    let (xz, covered) = g.integrate(&profile.stress(0, 2), z_lo, z_hi);
    let (zz, _) = g.integrate(&profile.stress(2, 2), z_lo, z_hi);
    (covered > 0.0 && zz > 0.0).then(|| -xz / zz)
}
