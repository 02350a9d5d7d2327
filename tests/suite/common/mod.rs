//! Helpers shared by the integration tests. Each test crate uses only some of them.
#![allow(dead_code)]

pub mod backends;
pub mod cli;
pub mod collision;
pub mod fit;
pub mod gpu;
pub mod rods;
pub mod silo;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweep::engine::contact::{ContactLaw, Elasticity, NormalModel};
use sweep::engine::walls::{Wall, WallShape};

/// The chute paper's linear spring–dashpot law: k_t = 2/7 k_n, the same restitution normal and
/// tangential, friction `mu`.
pub fn linear_law(kn: f64, e: f64, mu: f64) -> ContactLaw {
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

/// Hertz–Mindlin with Young's modulus `y` and Poisson's ratio 0.25.
pub fn hertz_law(y: f64, e: f64, mu: f64) -> ContactLaw {
    ContactLaw {
        normal: NormalModel::Hertz(Elasticity::YoungPoisson {
            youngs_modulus_pa: y,
            poisson_ratio: 0.25,
        }),
        restitution: e,
        tangential_restitution: e,
        friction: mu,
    }
}

/// The paper form of Hertz–Mindlin, shear modulus G = Y/30, friction `mu`.
pub fn hertz_shear_law(y: f64, e: f64, mu: f64) -> ContactLaw {
    ContactLaw {
        normal: NormalModel::Hertz(Elasticity::YoungShear {
            youngs_modulus_pa: y,
            shear_modulus_pa: y / 30.0,
        }),
        restitution: e,
        tangential_restitution: e,
        friction: mu,
    }
}

/// A fixed plane through `point` with inward normal `normal`.
pub fn plane(point: [f64; 3], normal: [f64; 3]) -> Wall {
    Wall {
        shape: WallShape::Plane { point, normal },
        rotation: None,
    }
}

/// Seeded uniform numbers in [−1, 1), so test scenes are random but reproducible.
pub struct Noise(ChaCha8Rng);

impl Noise {
    pub fn new(seed: u64) -> Self {
        Self(ChaCha8Rng::seed_from_u64(seed))
    }

    pub fn next(&mut self) -> f64 {
        self.0.random_range(-1.0..1.0)
    }
}
