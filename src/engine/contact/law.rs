//! Contact-law parameters, composed as normal model × damping × friction (MercuryDPM's species,
//! without one type per combination), and their compiled per-precision form.

use serde::{Deserialize, Serialize};

use crate::engine::real::Real;

/// How elastic constants are given for Hertz–Mindlin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Elasticity {
    /// The silo paper's form: k_n = 4/3 Y √(R δ), k_t = 8 G √(R δ) with Y and G used as given
    /// (its G = Y/30 corresponds to no physical Poisson ratio).
    YoungShear {
        youngs_modulus_pa: f64,
        shear_modulus_pa: f64,
    },
    /// Material constants of identical bodies: Y* = Y / (2(1 − ν²)), G = Y / (2(1 + ν)),
    /// G* = G / (2(2 − ν)) (the usual Hertz–Mindlin mixing, as in LIGGGHTS).
    YoungPoisson {
        youngs_modulus_pa: f64,
        poisson_ratio: f64,
    },
}

impl Elasticity {
    /// Effective (Y*, G*) entering k_n = 4/3 Y* √(Rδ), k_t = 8 G* √(Rδ).
    pub fn effective(&self) -> (f64, f64) {
        match *self {
            Elasticity::YoungShear {
                youngs_modulus_pa,
                shear_modulus_pa,
            } => (youngs_modulus_pa, shear_modulus_pa),
            Elasticity::YoungPoisson {
                youngs_modulus_pa: y,
                poisson_ratio: nu,
            } => {
                let g = y / (2.0 * (1.0 + nu));
                (y / (2.0 * (1.0 - nu * nu)), g / (2.0 * (2.0 - nu)))
            }
        }
    }
}

/// Normal (and matching tangential-stiffness) model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum NormalModel {
    /// Hertz–Mindlin (silo paper).
    Hertz(Elasticity),
    /// Linear spring–dashpot (chute paper): constant k_n and k_t (N/m).
    Linear { kn_n_per_m: f64, kt_n_per_m: f64 },
}

/// A complete contact law between two species (or a species and a wall).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactLaw {
    pub normal: NormalModel,
    /// Normal restitution coefficient e_n ∈ (0, 1]; sets the normal damping through
    /// β = ln e / √(ln² e + π²).
    pub restitution: f64,
    /// Tangential restitution used for the tangential damping (the papers use e_n for both).
    pub tangential_restitution: f64,
    /// Coulomb friction coefficient μ; 0 switches tangential forces (and history) off.
    pub friction: f64,
}

/// β = ln e / √(ln² e + π²) (≤ 0); e = 1 gives 0.
pub fn beta(e: f64) -> f64 {
    if e >= 1.0 {
        0.0
    } else {
        let l = e.ln();
        l / (l * l + std::f64::consts::PI.powi(2)).sqrt()
    }
}

/// The law compiled for the kernels of one precision.
#[derive(Clone, Copy, Debug)]
pub struct LawKernel<R: Real> {
    pub hertz: bool,
    /// Hertz: 4/3 Y*; linear: k_n.
    pub kn_coef: R,
    /// Hertz: 8 G*; linear: k_t.
    pub kt_coef: R,
    /// Hertz: 2 √(5/6) |β_n| (γ_n = this · √(S_n m*), S_n = 2 Y* √(Rδ));
    /// linear: 2 |β_n| (γ_n = this · √(k_n m*)).
    pub damp_n: R,
    pub damp_t: R,
    pub mu: R,
    pub tangential: bool,
}

impl ContactLaw {
    pub fn kernel<R: Real>(&self) -> LawKernel<R> {
        let bn = beta(self.restitution).abs();
        let bt = beta(self.tangential_restitution).abs();
        let tangential = self.friction > 0.0;
        match self.normal {
            NormalModel::Hertz(el) => {
                let (y, g) = el.effective();
                let c = 2.0 * (5.0f64 / 6.0).sqrt();
                LawKernel {
                    hertz: true,
                    kn_coef: R::from_f64(4.0 / 3.0 * y),
                    kt_coef: R::from_f64(8.0 * g),
                    damp_n: R::from_f64(c * bn),
                    damp_t: R::from_f64(c * bt),
                    mu: R::from_f64(self.friction),
                    tangential,
                }
            }
            NormalModel::Linear {
                kn_n_per_m,
                kt_n_per_m,
            } => LawKernel {
                hertz: false,
                kn_coef: R::from_f64(kn_n_per_m),
                kt_coef: R::from_f64(kt_n_per_m),
                damp_n: R::from_f64(2.0 * bn),
                damp_t: R::from_f64(2.0 * bt),
                mu: R::from_f64(self.friction),
                tangential,
            },
        }
    }
}
