//! The spherocylinder test scene's units, shape and stiffness: L = 0.125 m rods, ρ = 2600 kg/m³,
//! g = 1 m/s², k_n = 2·10⁵ m g / L (the law itself is `common::linear_law`).

use sweep::engine::shape::Spherocylinder;

pub const L: f64 = 0.125;
pub const RHO: f64 = 2600.0;
pub const G: f64 = 1.0;

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
