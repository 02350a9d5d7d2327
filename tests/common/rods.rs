//! The spherocylinder test scene's units and contact law: L = 0.125 m rods, ρ = 2600 kg/m³,
//! g = 1 m/s², the chute paper's linear law (k_t = 2/7 k_n).

use sweep::engine::contact::{ContactLaw, NormalModel};
use sweep::engine::shape::Spherocylinder;

pub const L: f64 = 0.125;
pub const RHO: f64 = 2600.0;
pub const G: f64 = 1.0;

pub fn law(kn: f64, e: f64, mu: f64) -> ContactLaw {
    ContactLaw {
        normal: NormalModel::Linear {
            kn_n_per_m: kn,
            kt_n_per_m: 2.0 / 7.0 * kn,
        },
        restitution: e,
        tangential_restitution: e,
        friction: mu,
    }
}

pub fn shape(xi: f64) -> Spherocylinder<f64> {
    Spherocylinder::from_aspect_ratio(L, xi).unwrap()
}

/// k_n = 2e5 m g / L (the chute's) and dt = t_c/50 with m* = m/2.
pub fn stiffness(xi: f64) -> (f64, f64) {
    let m = shape(xi).mass(RHO);
    let kn = 2e5 * m * G / L;
    let tc = std::f64::consts::PI * (0.5 * m / kn).sqrt();
    (kn, tc / 50.0)
}
