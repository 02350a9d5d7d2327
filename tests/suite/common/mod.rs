//! Helpers shared by the integration tests. Each test crate uses only some of them.
#![allow(dead_code)]

pub mod cli;
pub mod collision;
pub mod fit;
pub mod gpu;
pub mod rods;
pub mod silo;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweep::engine::contact::{ContactLaw, NormalModel};

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
