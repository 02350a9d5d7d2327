//! The silo with a rotating bottom (Hernández-Delfín et al., PRE 102, 042902, 2020): a vertical
//! cylinder, a flat bottom with a centred orifice (closed while filling), Hertz–Mindlin spheres.
//! Filling settles under gravity with the bottom still; then the orifice opens and the bottom
//! rotates at f while the side wall stays still. Particles that fall `sink_depth_m` below the
//! orifice are removed and counted.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::engine::contact::{contact_time, ContactLaw, ContactPair, Elasticity, NormalModel};
use crate::engine::walls::{Wall, WallRotation, WallShape};
use crate::engine::{EngineConfig, State};

/// Solid fraction of a settled bed of spheres (random close packing), for the bed-height
/// estimate that campaign validation checks against the cylinder.
pub const RANDOM_CLOSE_PACKING: f64 = 0.64;

/// Every physical and numerical parameter of a silo job. Defaults are the paper's values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SiloParams {
    /// Cylinder radius R_c (m). Paper: 0.095.
    pub cylinder_radius_m: f64,
    /// Cylinder height h (m). Paper: 0.40.
    pub cylinder_height_m: f64,
    /// Number of particles N. Paper: 30 144.
    pub particle_count: usize,
    /// Particle diameter d (m). Paper: 5.8 mm.
    pub particle_diameter_m: f64,
    /// Relative half-width of a uniform diameter distribution, d (1 ± p). Paper: 0 (monodisperse).
    pub diameter_polydispersity: f64,
    /// Particle density ρ_p (kg/m³). Paper: 2655.
    pub particle_density_kg_per_m3: f64,
    /// Young's modulus Y (Pa). Paper: 3 GPa.
    pub youngs_modulus_pa: f64,
    /// Shear modulus G (Pa), used as given (paper form, G = Y/30). Give this or `poisson_ratio`.
    pub shear_modulus_pa: Option<f64>,
    /// Poisson's ratio ν (material form, Y* = Y/2(1−ν²)). Give this or `shear_modulus_pa`.
    pub poisson_ratio: Option<f64>,
    /// Normal restitution e_n (particle–particle and particle–wall). Paper: 0.9.
    pub restitution: f64,
    /// Particle–particle friction μ. Paper: 0.5.
    pub friction_particle: f64,
    /// Particle–wall friction μ_w. Paper: 0.5.
    pub friction_wall: f64,
    /// Time step (s). Paper: 1e-6. Give this or `contact_steps`.
    pub dt_s: Option<f64>,
    /// n_c = t_c / dt, with t_c the Hertz contact time at `impact_speed_m_per_s`.
    pub contact_steps: Option<f64>,
    /// Impact speed at which t_c is evaluated (m/s): the fastest impacts in the bed, ~√(2 g d)…1.
    pub impact_speed_m_per_s: f64,
    /// Orifice diameter D (m).
    pub orifice_diameter_m: f64,
    /// Bottom rotation frequency f (Hz).
    pub rotation_frequency_hz: f64,
    /// Gravitational acceleration (m/s², acting along −z).
    pub gravity_m_per_s2: f64,
    /// Depth below the orifice at which particles are removed and counted (m).
    pub sink_depth_m: f64,
    /// Re-insert removed particles at the top (longer steady windows) instead of the paper's
    /// plain discharge.
    pub reinsert: bool,
    /// Filling ends when the kinetic energy per particle falls below this fraction of m g d.
    pub settle_kinetic_energy_ratio: f64,
    /// Filling gives up (and says so) after this much simulated time (s).
    pub settle_max_time_s: f64,
    /// Simulated discharge time after the orifice opens (s).
    pub discharge_time_s: f64,
    /// Stop early when fewer than this fraction of the particles remain (no re-insertion):
    /// a nearly empty silo no longer discharges at the steady rate.
    pub stop_remaining_fraction: f64,
    /// Verlet skin as a fraction of d.
    pub skin_ratio: f64,
    /// Replica index: different replicas get different seeds, hence different packings.
    pub replica: u32,
    /// Moves the whole scene by this vector in the lab frame (m; default the origin). Nothing
    /// physical changes and the seed ignores it: a check that results do not depend on where
    /// the scene sits (the engine's rounding). The shared fill stage runs at the origin.
    #[serde(skip_serializing_if = "crate::scene::at_origin")]
    pub origin_m: [f64; 3],
}

impl Default for SiloParams {
    fn default() -> Self {
        Self {
            cylinder_radius_m: 0.095,
            cylinder_height_m: 0.40,
            particle_count: 30_144,
            particle_diameter_m: 0.0058,
            diameter_polydispersity: 0.0,
            particle_density_kg_per_m3: 2655.0,
            youngs_modulus_pa: 3.0e9,
            shear_modulus_pa: Some(1.0e8),
            poisson_ratio: None,
            restitution: 0.9,
            friction_particle: 0.5,
            friction_wall: 0.5,
            dt_s: Some(1.0e-6),
            contact_steps: None,
            impact_speed_m_per_s: 1.0,
            orifice_diameter_m: 0.036,
            rotation_frequency_hz: 0.0,
            gravity_m_per_s2: 9.81,
            sink_depth_m: 0.05,
            reinsert: false,
            settle_kinetic_energy_ratio: 1.0e-4,
            settle_max_time_s: 3.0,
            discharge_time_s: 10.0,
            stop_remaining_fraction: 0.15,
            skin_ratio: 0.2,
            replica: 0,
            origin_m: [0.0; 3],
        }
    }
}

/// A validation problem: the field and what was expected.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldError {
    pub field: String,
    pub message: String,
}

impl FieldError {
    pub fn new(field: &str, message: String) -> Self {
        FieldError {
            field: field.into(),
            message,
        }
    }
}

impl SiloParams {
    fn elasticity(&self) -> Elasticity {
        match (self.shear_modulus_pa, self.poisson_ratio) {
            (_, Some(nu)) => Elasticity::YoungPoisson {
                youngs_modulus_pa: self.youngs_modulus_pa,
                poisson_ratio: nu,
            },
            (Some(g), None) => Elasticity::YoungShear {
                youngs_modulus_pa: self.youngs_modulus_pa,
                shear_modulus_pa: g,
            },
            (None, None) => Elasticity::YoungShear {
                youngs_modulus_pa: self.youngs_modulus_pa,
                shear_modulus_pa: self.youngs_modulus_pa / 30.0,
            },
        }
    }

    fn law(&self, friction: f64) -> ContactLaw {
        ContactLaw {
            normal: NormalModel::Hertz(self.elasticity()),
            restitution: self.restitution,
            tangential_restitution: self.restitution,
            friction,
        }
    }

    /// Mass of a particle of diameter d (kg).
    pub fn particle_mass(&self) -> f64 {
        self.particle_density_kg_per_m3 * std::f64::consts::PI / 6.0
            * self.particle_diameter_m.powi(3)
    }

    /// Shortest Hertz contact time (s): the smallest particles against a wall and each other.
    pub fn contact_time(&self) -> f64 {
        let d_min = self.particle_diameter_m * (1.0 - self.diameter_polydispersity);
        let m_min = self.particle_density_kg_per_m3 * std::f64::consts::PI / 6.0 * d_min.powi(3);
        let pp = ContactPair {
            r_eff: d_min / 4.0,
            m_eff: m_min / 2.0,
        };
        let pw = ContactPair {
            r_eff: d_min / 2.0,
            m_eff: m_min,
        };
        let law = self.law(self.friction_particle);
        contact_time(&law, pp, self.impact_speed_m_per_s).min(contact_time(
            &law,
            pw,
            self.impact_speed_m_per_s,
        ))
    }

    /// The time step, refusing dt > t_c / 5.
    pub fn time_step(&self) -> Result<f64, String> {
        let tc = self.contact_time();
        let dt = match (self.dt_s, self.contact_steps) {
            (Some(dt), _) => dt,
            (None, Some(nc)) => tc / nc,
            (None, None) => return Err("expected dt_s or contact_steps".into()),
        };
        if dt > tc / 5.0 {
            return Err(format!("dt = {dt:.3e} s exceeds t_c/5 = {:.3e} s (t_c = {tc:.3e} s at {} m/s): the contact would be resolved in fewer than 5 steps", tc / 5.0, self.impact_speed_m_per_s));
        }
        Ok(dt)
    }

    /// The parameters the filling stage reads; jobs that agree on these share one fill.
    pub fn fill_stage(&self) -> SiloParams {
        SiloParams {
            orifice_diameter_m: 0.0,
            rotation_frequency_hz: 0.0,
            sink_depth_m: 0.0,
            reinsert: false,
            discharge_time_s: 0.0,
            stop_remaining_fraction: 0.0,
            origin_m: [0.0; 3],
            ..self.clone()
        }
    }
}

/// Solid fraction of the random gas the fill pours (random sequential addition stays cheap
/// well below its jamming limit of about 0.38).
const INSERT_SOLID_FRACTION: f64 = 0.3;

/// Which stage of a silo job.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SiloPhase {
    /// Orifice closed, bottom still.
    Fill,
    /// Orifice open, bottom rotating.
    Discharge,
}

/// A silo job's scene: parameters plus what derives from them.
#[derive(Clone, Debug)]
pub struct SiloScene {
    pub p: SiloParams,
    pub dt: f64,
}

impl SiloScene {
    /// # Errors
    /// The first validation problem, as text (campaign validation reports them all earlier).
    pub fn new(p: SiloParams) -> Result<Self, String> {
        if let Some(e) = p.validate().into_iter().next() {
            return Err(format!("{}: {}", e.field, e.message));
        }
        let dt = p.time_step()?;
        Ok(Self { p, dt })
    }

    /// Engine configuration of a phase.
    pub fn engine_config(&self, phase: SiloPhase) -> EngineConfig {
        let p = &self.p;
        let open = phase == SiloPhase::Discharge;
        let omega = if open {
            2.0 * std::f64::consts::PI * p.rotation_frequency_hz
        } else {
            0.0
        };
        let walls = vec![
            Wall {
                shape: WallShape::Cylinder {
                    axis_xy: [0.0, 0.0],
                    radius: p.cylinder_radius_m,
                    z_min: 0.0,
                    // While filling, the poured gas may stand taller than the silo: the wall
                    // holds it until it settles (the settled bed is checked against h).
                    z_max: if open { p.cylinder_height_m } else { f64::MAX },
                },
                rotation: None,
            },
            Wall {
                shape: WallShape::OrificePlate {
                    z: 0.0,
                    center_xy: [0.0, 0.0],
                    orifice_radius: if open {
                        0.5 * p.orifice_diameter_m
                    } else {
                        0.0
                    },
                },
                rotation: if omega != 0.0 {
                    Some(WallRotation {
                        axis_xy: [0.0, 0.0],
                        omega_rad_per_s: omega,
                    })
                } else {
                    None
                },
            },
        ];
        EngineConfig {
            dt_s: self.dt,
            gravity: [0.0, 0.0, -p.gravity_m_per_s2],
            particle_law: p.law(p.friction_particle),
            wall_law: p.law(p.friction_wall),
            walls,
            periodic_x: None,
            periodic_y: None,
            sink_z: if open { Some(-p.sink_depth_m) } else { None },
            skin_m: p.skin_ratio * p.particle_diameter_m,
        }
    }

    /// The particles inserted without overlap, before settling.
    pub fn initial_state(&self, seed: u64) -> State<f64> {
        self.initial_state_until(seed, &|| false)
            .expect("never stopped")
    }

    /// [`SiloScene::initial_state`], or `None` as soon as `stop` says so (asked every few
    /// thousand insertions).
    pub fn initial_state_until(&self, seed: u64, stop: &dyn Fn() -> bool) -> Option<State<f64>> {
        let p = &self.p;
        let rotation = p.friction_particle > 0.0 || p.friction_wall > 0.0;
        let mut s = State::new(
            rotation,
            if rotation {
                crate::engine::history::HISTORY_SLOTS
            } else {
                0
            },
        );
        let spots = super::fill::cylinder_random_until(
            p.particle_count,
            p.cylinder_radius_m,
            0.0,
            p.particle_diameter_m,
            p.diameter_polydispersity,
            INSERT_SOLID_FRACTION,
            seed,
            stop,
        )?;
        for (k, (x, r)) in spots.into_iter().enumerate() {
            s.push_sphere(
                k as u32,
                x,
                [0.0, 0.0, 0.0],
                r,
                p.particle_density_kg_per_m3,
                false,
            );
        }
        Some(s)
    }

    /// Whether the bed has settled (kinetic energy per particle below the threshold).
    pub fn settled(&self, s: &State<f64>) -> bool {
        let p = &self.p;
        let scale = s.len().max(1) as f64
            * self.p.particle_mass()
            * p.gravity_m_per_s2
            * p.particle_diameter_m;
        s.kinetic_energy() < p.settle_kinetic_energy_ratio * scale
    }

    /// Height of the settled bed (m): the mean top of the highest 2 % of particles.
    pub fn bed_height(&self, s: &State<f64>) -> f64 {
        let mut z: Vec<f64> = s.pos.iter().zip(&s.radius).map(|(p, r)| p.z + r).collect();
        if z.is_empty() {
            return 0.0;
        }
        z.sort_by(|a, b| b.total_cmp(a));
        let k = (z.len() / 50).max(1);
        z[..k].iter().sum::<f64>() / k as f64
    }

    /// Bulk density ρ_b (kg/m³) of the settled bed, measured in a core away from the walls, the
    /// bottom and the free surface (two diameters from each).
    pub fn bulk_density(&self, s: &State<f64>) -> f64 {
        let d = self.p.particle_diameter_m;
        let r_core = self.p.cylinder_radius_m - 2.0 * d;
        let (z0, z1) = (2.0 * d, self.bed_height(s) - 2.0 * d);
        if z1 <= z0 || r_core <= 0.0 {
            return 0.0;
        }
        let mut m = 0.0;
        for i in 0..s.len() {
            let p = s.pos[i];
            if (p.x * p.x + p.y * p.y).sqrt() < r_core && p.z > z0 && p.z < z1 {
                m += s.mass[i];
            }
        }
        m / (std::f64::consts::PI * r_core * r_core * (z1 - z0))
    }
}
