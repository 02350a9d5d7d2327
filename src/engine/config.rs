//! Engine configuration: everything the physics needs besides the particles, in SI units and f64
//! (each run compiles it to its own precision).

use serde::{Deserialize, Serialize};

use super::contact::ContactLaw;
use super::walls::Wall;

/// Physics and numerics of one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EngineConfig {
    /// Time step (s); the scene derives it as t_c / n_c.
    pub dt_s: f64,
    /// Gravitational acceleration (m/s²).
    pub gravity: [f64; 3],
    /// Particle–particle contact law.
    pub particle_law: ContactLaw,
    /// Particle–wall contact law (the silo paper uses the same parameters as particle–particle).
    pub wall_law: ContactLaw,
    pub walls: Vec<Wall>,
    /// Periodic box extent along x, [lo, hi) (m).
    pub periodic_x: Option<[f64; 2]>,
    /// Periodic box extent along y (m).
    pub periodic_y: Option<[f64; 2]>,
    /// Particles whose centre falls below this height are removed and reported (m).
    pub sink_z: Option<f64>,
    /// Verlet skin (m): neighbour lists hold pairs closer than r_i + r_j + skin and are rebuilt
    /// when some particle has moved more than skin/2. Larger skin: fewer rebuilds, longer lists.
    pub skin_m: f64,
}
