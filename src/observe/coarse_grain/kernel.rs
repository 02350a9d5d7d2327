//! The coarse-graining function: a Gaussian of width w truncated at c·w (Weinhart et al. 2013,
//! the chute paper's ω = L/4, r_c = 4ω), normalised on its truncated support.
//!
//! Owns the kernel's values, integrals and branch-line integrals in each dimensionality the grids
//! need; only the 1-D (z) form exists so far. Knows nothing of grids or particles.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Below |Δz| = this × w the branch line integral is taken as the midpoint value: the erf
/// difference quotient then loses ~eps/(|Δz|/w) ≈ 2·10⁻¹¹ relative, the midpoint rule errs by
/// (Δz/w)²/24 · |φ''/φ| ≲ 10⁻⁹ inside the support; both far below any physical resolution.
const LINE_MIDPOINT_BELOW: f64 = 1e-5;

/// A truncated Gaussian kernel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Kernel {
    /// Width w (m): the standard deviation of the Gaussian.
    pub width_m: f64,
    /// Cutoff in widths, c: φ = 0 beyond c·w (the papers use 4, where e^{−c²/2} ≈ 3·10⁻⁴).
    pub cutoff_widths: f64,
}

impl Kernel {
    /// A kernel of width `width_m` (m) cut at `cutoff_widths` widths.
    pub fn new(width_m: f64, cutoff_widths: f64) -> Self {
        Self {
            width_m,
            cutoff_widths,
        }
    }

    /// Cutoff distance c·w (m).
    pub fn cutoff_m(&self) -> f64 {
        self.width_m * self.cutoff_widths
    }

    /// The kernel in one dimension, with its constants precomputed.
    pub fn one_d(&self) -> Kernel1d {
        let w = self.width_m;
        let erf_c = libm::erf(self.cutoff_widths / std::f64::consts::SQRT_2);
        Kernel1d {
            cutoff: self.cutoff_m(),
            inv_two_w2: 1.0 / (2.0 * w * w),
            inv_sqrt2_w: 1.0 / (std::f64::consts::SQRT_2 * w),
            // ∫_{−cw}^{cw} e^{−u²/2w²} du = w √(2π) erf(c/√2).
            inv_norm: 1.0 / (w * (2.0 * std::f64::consts::PI).sqrt() * erf_c),
            inv_two_erf_c: 1.0 / (2.0 * erf_c),
            midpoint_below: LINE_MIDPOINT_BELOW * w,
        }
    }
}

/// The 1-D kernel φ(u) = e^{−u²/2w²}/N for |u| ≤ c·w, else 0, with ∫φ du = 1 exactly.
#[derive(Clone, Copy, Debug)]
pub struct Kernel1d {
    cutoff: f64,
    inv_two_w2: f64,
    inv_sqrt2_w: f64,
    inv_norm: f64,
    inv_two_erf_c: f64,
    midpoint_below: f64,
}

impl Kernel1d {
    /// Cutoff distance (m).
    pub fn cutoff_m(&self) -> f64 {
        self.cutoff
    }

    /// φ(u) (1/m).
    pub fn value(&self, u: f64) -> f64 {
        if u.abs() > self.cutoff {
            0.0
        } else {
            (-u * u * self.inv_two_w2).exp() * self.inv_norm
        }
    }

    /// ∫_a^b φ(u) du (negative when b < a).
    pub fn integral(&self, a: f64, b: f64) -> f64 {
        let clamp = |u: f64| u.clamp(-self.cutoff, self.cutoff) * self.inv_sqrt2_w;
        erf_difference(clamp(a), clamp(b)) * self.inv_two_erf_c
    }

    /// ψ = ∫_0^1 φ(u0 + s h) ds (1/m): the kernel averaged along a branch that starts at offset
    /// u0 from the evaluation point and spans h.
    ///
    /// Substituting u = u0 + s h gives (Φ(u0 + h) − Φ(u0))/h with Φ the kernel's integral; for
    /// |h| → 0 that quotient cancels, and ψ → φ(u0 + h/2).
    pub fn line(&self, u0: f64, h: f64) -> f64 {
        if h.abs() < self.midpoint_below {
            self.value(u0 + 0.5 * h)
        } else {
            self.integral(u0, u0 + h) / h
        }
    }
}

/// erf(b) − erf(a), through erfc when both are on the same side: there erf ≈ ±1 and the plain
/// difference would cancel.
pub(super) fn erf_difference(a: f64, b: f64) -> f64 {
    if a >= 0.0 && b >= 0.0 {
        libm::erfc(a) - libm::erfc(b)
    } else if a <= 0.0 && b <= 0.0 {
        libm::erfc(-b) - libm::erfc(-a)
    } else {
        libm::erf(b) - libm::erf(a)
    }
}
