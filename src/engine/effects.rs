//! The physics a run switches on, decided once from its configuration. Only the kernels of enabled
//! effects run and only the arrays they need exist: spheres without friction carry no angular
//! velocity and no contact history; no orientation array exists for spheres at all.

use serde::{Deserialize, Serialize};

use super::config::EngineConfig;
use super::contact::NormalModel;
use super::walls::WallShape;

/// What one run simulates. Printed by `sweep plan` and recorded with each job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Effects {
    /// Particle shape: "sphere", or "spherocylinder" (orientations and the oriented contact
    /// path; spheres among them, such as a rough base, have l = 0).
    pub shape: String,
    /// "hertz_mindlin" or "linear_spring_dashpot".
    pub contact_law: String,
    /// Tangential springs with Coulomb truncation (friction > 0 somewhere).
    pub tangential_history: bool,
    /// Angular velocities and torques (needed exactly when there is friction, for spheres).
    pub rotation: bool,
    /// Wall kinds present.
    pub walls: Vec<String>,
    /// A wall moves (its surface velocity enters contacts).
    pub wall_motion: bool,
    /// Periodic axes (x, y).
    pub periodic: [bool; 2],
    /// Fixed particles exist (rough base).
    pub fixed_particles: bool,
    /// Particles below a plane are removed and reported.
    pub sink: bool,
}

impl Effects {
    /// Effects of a configuration; `fixed_particles` and `oriented` come from the scene's
    /// initial state.
    pub fn of(config: &EngineConfig, fixed_particles: bool, oriented: bool) -> Self {
        let law = match config.particle_law.normal {
            NormalModel::Hertz(_) => "hertz_mindlin",
            NormalModel::Linear { .. } => "linear_spring_dashpot",
        };
        let tangential = config.particle_law.friction > 0.0
            || (!config.walls.is_empty() && config.wall_law.friction > 0.0);
        let mut walls: Vec<String> = config
            .walls
            .iter()
            .map(|w| {
                match w.shape {
                    WallShape::Plane { .. } => "plane",
                    WallShape::Cylinder { .. } => "cylinder",
                    WallShape::OrificePlate { orifice_radius, .. } if orifice_radius > 0.0 => {
                        "orifice_plate"
                    }
                    WallShape::OrificePlate { .. } => "closed_plate",
                }
                .to_string()
            })
            .collect();
        walls.dedup();
        Effects {
            shape: if oriented { "spherocylinder" } else { "sphere" }.into(),
            contact_law: law.into(),
            tangential_history: tangential,
            // Rods turn under any off-centre normal force; spheres only under friction.
            rotation: tangential || oriented,
            walls,
            wall_motion: config
                .walls
                .iter()
                .any(|w| w.rotation.is_some_and(|r| r.omega_rad_per_s != 0.0)),
            periodic: [config.periodic_x.is_some(), config.periodic_y.is_some()],
            fixed_particles,
            sink: config.sink_z.is_some(),
        }
    }
}
