//! A uniform 1-D grid in z, and integrals and means of grid values over a z range (the
//! piecewise-linear interpolant, so block means do not depend on where grid points fall).
//!
//! Only geometry and quadrature; the fields on the grid live in `ZProfile`.

use serde::{Deserialize, Serialize};

/// Points z_k = z0 + k dz, k = 0..n.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZGrid {
    /// First point (m).
    pub z0_m: f64,
    /// Spacing (m).
    pub dz_m: f64,
    /// Number of points.
    pub n: usize,
}

impl ZGrid {
    /// The grid from `z_lo` to at most `z_hi` (m) with spacing `dz` (m): floor((z_hi − z_lo)/dz)
    /// + 1 points, the last one within 10⁻⁹ dz of z_hi counted in.
    pub fn spanning(z_lo: f64, z_hi: f64, dz: f64) -> Self {
        let n = ((z_hi - z_lo) / dz + 1e-9).floor().max(0.0) as usize + 1;
        Self {
            z0_m: z_lo,
            dz_m: dz,
            n,
        }
    }

    /// z of point k (m).
    pub fn z(&self, k: usize) -> f64 {
        self.z0_m + k as f64 * self.dz_m
    }

    /// Every point's z (m).
    pub fn points(&self) -> Vec<f64> {
        (0..self.n).map(|k| self.z(k)).collect()
    }

    /// Indices of the points with z in [z_lo, z_hi], as a range clipped to the grid.
    pub fn indices_near(&self, z_lo: f64, z_hi: f64) -> std::ops::Range<usize> {
        let first = ((z_lo - self.z0_m) / self.dz_m).ceil().max(0.0);
        let last = ((z_hi - self.z0_m) / self.dz_m).floor();
        if last < 0.0 || first >= self.n as f64 || !(first <= last) {
            return 0..0;
        }
        first as usize..(last as usize + 1).min(self.n)
    }

    /// ∫ v dz over [z_lo, z_hi] ∩ grid extent of the linear interpolant of `values` (one per
    /// point), skipping segments with a non-finite end; with the length that was covered (m).
    pub fn integrate(&self, values: &[f64], z_lo: f64, z_hi: f64) -> (f64, f64) {
        assert_eq!(values.len(), self.n, "one value per grid point");
        let (mut sum, mut covered) = (0.0, 0.0);
        for k in 0..self.n.saturating_sub(1) {
            let (a, b) = (self.z(k), self.z(k + 1));
            let (lo, hi) = (a.max(z_lo), b.min(z_hi));
            let (va, vb) = (values[k], values[k + 1]);
            if hi <= lo || !va.is_finite() || !vb.is_finite() {
                continue;
            }
            let at = |z: f64| va + (vb - va) * (z - a) / self.dz_m;
            sum += 0.5 * (at(lo) + at(hi)) * (hi - lo);
            covered += hi - lo;
        }
        (sum, covered)
    }

    /// Mean of the linear interpolant over [z_lo, z_hi]; None when no finite segment overlaps.
    pub fn mean_over(&self, values: &[f64], z_lo: f64, z_hi: f64) -> Option<f64> {
        let (sum, covered) = self.integrate(values, z_lo, z_hi);
        (covered > 0.0).then(|| sum / covered)
    }
}
