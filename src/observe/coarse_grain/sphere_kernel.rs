//! The 3-D coarse-graining function of the silo: a Gaussian of width w truncated on the sphere
//! |Δ| ≤ c·w and normalised there, φ(Δ) = e^{−|Δ|²/2w²}/N, ∫φ dV = 1 exactly.
//!
//! The cutoff is spherical, not the cube of a product of 1-D kernels: only an isotropic kernel
//! gives an azimuthal average (`ring`) that does not depend on a particle's azimuth, and it keeps
//! the fields objective. Owns values and the branch-line integral; knows nothing of grids.

use super::kernel::{erf_difference, Kernel};

/// Below |h| = this × w the branch line integral is the midpoint value (as `Kernel1d::line`).
const LINE_MIDPOINT_BELOW: f64 = 1e-5;

/// A truncated isotropic Gaussian in three dimensions, constants precomputed.
#[derive(Clone, Copy, Debug)]
pub struct SphereKernel {
    width: f64,
    cutoff: f64,
    cutoff2: f64,
    inv_two_w2: f64,
    inv_norm: f64,
}

impl SphereKernel {
    /// The spherical form of `kernel` (same width and cutoff).
    pub fn new(kernel: &Kernel) -> Self {
        let w = kernel.width_m;
        let c = kernel.cutoff_widths;
        // ∫_{|Δ|≤cw} e^{−|Δ|²/2w²} dV = (2π w²)^{3/2} [erf(c/√2) − √(2/π) c e^{−c²/2}].
        let inner = libm::erf(c / std::f64::consts::SQRT_2)
            - (2.0 / std::f64::consts::PI).sqrt() * c * (-0.5 * c * c).exp();
        let norm = (2.0 * std::f64::consts::PI * w * w).powf(1.5) * inner;
        let cutoff = kernel.cutoff_m();
        Self {
            width: w,
            cutoff,
            cutoff2: cutoff * cutoff,
            inv_two_w2: 1.0 / (2.0 * w * w),
            inv_norm: 1.0 / norm,
        }
    }

    /// Width w (m).
    pub fn width_m(&self) -> f64 {
        self.width
    }

    /// Cutoff distance c·w (m).
    pub fn cutoff_m(&self) -> f64 {
        self.cutoff
    }

    /// φ at squared distance `d2` (m²), in 1/m³.
    pub fn value_sq(&self, d2: f64) -> f64 {
        if d2 > self.cutoff2 {
            0.0
        } else {
            (-d2 * self.inv_two_w2).exp() * self.inv_norm
        }
    }

    /// The Gaussian without truncation, e^{−d2/2w²}/N (the ring average applies the cutoff).
    pub(super) fn gaussian_sq(&self, d2: f64) -> f64 {
        (-d2 * self.inv_two_w2).exp() * self.inv_norm
    }

    /// ψ = ∫_0^1 φ(x0 + s h) ds (1/m³): the kernel along a branch starting at offset `x0` from
    /// the evaluation point and spanning `h` (Goldhirsch's line integral, the silo paper's
    /// Eq. 5).
    ///
    /// |x0 + s h|² = |h|²(s + b)² + d⊥² with b = x0·h/|h|², so along the line the kernel is a
    /// 1-D Gaussian in s, cut where |h|²(s + b)² ≤ c²w² − d⊥²: an erf difference, exact.
    pub fn line(&self, x0: [f64; 3], h: [f64; 3]) -> f64 {
        let h2 = dot(h, h);
        if h2.sqrt() < LINE_MIDPOINT_BELOW * self.width {
            let m = [x0[0] + 0.5 * h[0], x0[1] + 0.5 * h[1], x0[2] + 0.5 * h[2]];
            return self.value_sq(dot(m, m));
        }
        let b = dot(x0, h) / h2;
        let perp2 = (dot(x0, x0) - b * b * h2).max(0.0);
        if perp2 > self.cutoff2 {
            return 0.0;
        }
        let hl = h2.sqrt();
        // s + b within ±half (the chord through the sphere), clipped to the branch s ∈ [0, 1].
        let half = (self.cutoff2 - perp2).sqrt() / hl;
        let lo = (-b - half).max(0.0);
        let hi = (-b + half).min(1.0);
        if hi <= lo {
            return 0.0;
        }
        let k = hl / (std::f64::consts::SQRT_2 * self.width);
        // ∫ e^{−|h|²(s+b)²/2w²} ds = w √(π/2)/|h| · [erf(k (s + b))].
        let along = self.width * (0.5 * std::f64::consts::PI).sqrt() / hl
            * erf_difference(k * (lo + b), k * (hi + b));
        (-perp2 * self.inv_two_w2).exp() * self.inv_norm * along
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
