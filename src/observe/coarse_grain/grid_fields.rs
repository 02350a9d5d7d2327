//! One snapshot's coarse-grained sums on a `FieldGrid` (the silo paper's Eqs. 2, 3 and 5):
//! ρ = Σ m φ, P = Σ m v φ, Σ m v⊗v φ and σᶜ = Σ f ⊗ r_ij ψ, deposited from particles and
//! contacts. The sphere kernel (`SphereKernel`) on Cartesian grids; its ring average (`Ring`) on
//! (r, z) grids, vectors and tensors in the cylindrical basis there.
//!
//! Stress is compressive positive, as in `PointFields`: the paper's Eqs. 5 and 6 carry a minus
//! sign (tensile positive); its p^k = tr σᵏ maps are positive, i.e. this convention.

use serde::{Deserialize, Serialize};

use super::field_grid::{FieldGrid, GridKind};
use super::ring::{gauss_legendre, Ring};
use super::{Kernel, SphereKernel};
use crate::engine::contact::ContactRecord;

/// Gauss–Legendre nodes along a branch on (r, z) grids (the Cartesian line integral is exact).
/// A branch spans ≈ 2w at w = particle radius; 8 nodes integrate the kernel's smooth part to
/// 10⁻⁶, the jump at the cutoff to ~10⁻³ of a contact's contribution.
const BRANCH_NODES: usize = 8;

/// Sums at every point of a grid (SI); tensors row-major, 9 per point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridFields {
    pub grid: FieldGrid,
    /// ρ (kg/m³), one per point.
    pub density: Vec<f64>,
    /// P (kg m⁻² s⁻¹), 3 per point.
    pub momentum: Vec<f64>,
    /// Σ m v⊗v φ (Pa), 9 per point.
    pub momentum_flux: Vec<f64>,
    /// σᶜ (Pa), 9 per point; empty unless contacts were deposited.
    pub contact_stress: Vec<f64>,
}

/// A particle or contact point's cylindrical basis e_r, e_θ (e_z is z); the x and y axes on the
/// axis itself (any basis will do there: the ring weights of cos Δ vanish).
fn cylindrical_basis(x: f64, y: f64) -> (f64, [f64; 3], [f64; 3]) {
    let r = x.hypot(y);
    if r > 0.0 {
        (r, [x / r, y / r, 0.0], [-y / r, x / r, 0.0])
    } else {
        (0.0, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl GridFields {
    /// All sums zero.
    pub fn new(grid: FieldGrid) -> Self {
        let n = grid.len();
        Self {
            grid,
            density: vec![0.0; n],
            momentum: vec![0.0; 3 * n],
            momentum_flux: vec![0.0; 9 * n],
            contact_stress: Vec::new(),
        }
    }

    /// Adds particles at `pos` (m) with velocity `vel` (m/s) and mass `mass` (kg).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn deposit_particles(
        &mut self,
        kernel: &Kernel,
        pos: &[[f64; 3]],
        vel: &[[f64; 3]],
        mass: &[f64],
    ) {
        assert!(pos.len() == vel.len() && pos.len() == mass.len());
        let sk = SphereKernel::new(kernel);
        match self.grid.kind {
            GridKind::Rz => {
                let ring = Ring::new(sk);
                for ((p, v), &m) in pos.iter().zip(vel).zip(mass) {
                    let (ri, er, et) = cylindrical_basis(p[0], p[1]);
                    let u = [dot(*v, er), dot(*v, et), v[2]];
                    let mut uu = [0.0; 9];
                    for a in 0..3 {
                        for b in 0..3 {
                            uu[3 * a + b] = u[a] * u[b];
                        }
                    }
                    self.deposit_ring(&ring, ri, p[2], |f, q, w| {
                        f.density[q] += m * w.c0;
                        f.momentum[3 * q] += m * u[0] * w.c1;
                        f.momentum[3 * q + 1] += m * u[1] * w.c1;
                        f.momentum[3 * q + 2] += m * u[2] * w.c0;
                        w.add_tensor(&mut f.momentum_flux[9 * q..9 * q + 9], &uu, m);
                    });
                }
            }
            GridKind::Xyz => {
                for ((p, v), &m) in pos.iter().zip(vel).zip(mass) {
                    self.deposit_cartesian(&sk, *p, *p, |f, q, x| {
                        let d = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
                        let w = m * sk.value_sq(dot(d, d));
                        if w == 0.0 {
                            return;
                        }
                        f.density[q] += w;
                        for a in 0..3 {
                            f.momentum[3 * q + a] += w * v[a];
                            for b in 0..3 {
                                f.momentum_flux[9 * q + 3 * a + b] += w * v[a] * v[b];
                            }
                        }
                    });
                }
            }
        }
    }

    /// Adds the contact stress f_ij ⊗ r_ij ψ of each contact (r_ij the record's branch
    /// c_i − c_j, or c_i − contact point for a wall; ψ the kernel along the branch from c_i).
    pub fn deposit_contacts(&mut self, kernel: &Kernel, contacts: &[ContactRecord]) {
        if self.contact_stress.is_empty() {
            self.contact_stress = vec![0.0; 9 * self.grid.len()];
        }
        let sk = SphereKernel::new(kernel);
        match self.grid.kind {
            GridKind::Rz => {
                let ring = Ring::new(sk);
                let (xs, ws) = gauss_legendre(BRANCH_NODES);
                for c in contacts {
                    for (x, wq) in xs.iter().zip(&ws) {
                        // Node on the branch c_i − s r_ij, s = (1 + x)/2, weight wq/2.
                        let s = 0.5 * (1.0 + x);
                        let p = [0, 1, 2].map(|a| c.pos_i[a] - s * c.branch[a]);
                        let (rp, er, et) = cylindrical_basis(p[0], p[1]);
                        let ez = [0.0, 0.0, 1.0];
                        let f = [
                            dot(c.force_on_i, er),
                            dot(c.force_on_i, et),
                            c.force_on_i[2],
                        ];
                        let b = [dot(c.branch, er), dot(c.branch, et), dot(c.branch, ez)];
                        let mut fb = [0.0; 9];
                        for a in 0..3 {
                            for bb in 0..3 {
                                fb[3 * a + bb] = f[a] * b[bb];
                            }
                        }
                        let scale = 0.5 * wq;
                        self.deposit_ring(&ring, rp, p[2], |g, q, w| {
                            w.add_tensor(&mut g.contact_stress[9 * q..9 * q + 9], &fb, scale);
                        });
                    }
                }
            }
            GridKind::Xyz => {
                for c in contacts {
                    let pj = [0, 1, 2].map(|a| c.pos_i[a] - c.branch[a]);
                    self.deposit_cartesian(&sk, c.pos_i, pj, |g, q, x| {
                        let x0 = [0, 1, 2].map(|a| x[a] - c.pos_i[a]);
                        let psi = sk.line(x0, c.branch);
                        if psi == 0.0 {
                            return;
                        }
                        for a in 0..3 {
                            for b in 0..3 {
                                g.contact_stress[9 * q + 3 * a + b] +=
                                    c.force_on_i[a] * c.branch[b] * psi;
                            }
                        }
                    });
                }
            }
        }
    }

    /// Calls `add(self, point, weights)` for every (r, z) point within the cutoff of a source at
    /// radius `ri`, height `zi`.
    fn deposit_ring(
        &mut self,
        ring: &Ring,
        ri: f64,
        zi: f64,
        mut add: impl FnMut(&mut Self, usize, &super::ring::RingWeights),
    ) {
        let reach = ring.kernel().cutoff_m();
        let g = self.grid;
        for j in g.range(1, zi - reach, zi + reach) {
            let dz = g.coord(1, j) - zi;
            for i in g.range(0, ri - reach, ri + reach) {
                let w = ring.weights(g.coord(0, i), ri, dz);
                if w.c0 == 0.0 {
                    continue;
                }
                add(self, g.index(i, j, 0), &w);
            }
        }
    }

    /// Calls `add(self, point, position)` for every Cartesian point in the box spanning `a`
    /// and `b` widened by the cutoff.
    fn deposit_cartesian(
        &mut self,
        sk: &SphereKernel,
        a: [f64; 3],
        b: [f64; 3],
        mut add: impl FnMut(&mut Self, usize, [f64; 3]),
    ) {
        let reach = sk.cutoff_m();
        let g = self.grid;
        let r = |ax: usize| g.range(ax, a[ax].min(b[ax]) - reach, a[ax].max(b[ax]) + reach);
        for k in r(2) {
            for j in r(1) {
                for i in r(0) {
                    let x = [g.coord(0, i), g.coord(1, j), g.coord(2, k)];
                    add(self, g.index(i, j, k), x);
                }
            }
        }
    }

    /// σᵏ = Σ m v⊗v φ − P⊗P/ρ at point `p` (Pa): the momentum flux of the fluctuations about
    /// V = P/ρ (Eqs. 6–7: Σ m v'⊗v' φ with v' = v − V(r) expands to this exactly); zero where
    /// ρ = 0.
    pub fn kinetic_stress(&self, p: usize) -> [f64; 9] {
        let mut s = [0.0; 9];
        s.copy_from_slice(&self.momentum_flux[9 * p..9 * p + 9]);
        let rho = self.density[p];
        if rho > 0.0 {
            let m = &self.momentum[3 * p..3 * p + 3];
            for a in 0..3 {
                for b in 0..3 {
                    s[3 * a + b] -= m[a] * m[b] / rho;
                }
            }
        }
        s
    }

    /// ∫ f dV of a scalar given per point (midpoint rule of the grid's volumes).
    pub fn integrate(&self, values: &[f64]) -> f64 {
        values
            .iter()
            .enumerate()
            .map(|(p, v)| v * self.grid.volume(p))
            .sum()
    }
}
