//! Chute flow of spherocylinders (Hernández-Delfín, Weinhart & Hidalgo, Soft Matter 18, 3335,
//! 2022): a box periodic in x and y over a rough base of fixed random spheres of radius L/2,
//! gravity g (sin α, 0, −cos α), a linear spring–dashpot law with k_n = 2·10⁵ m_p g / ℓ and
//! k_t = 2/7 k_n. Particles are poured in as a loose random gas and flow from rest, or start as
//! a dense bed moving with a Bagnold profile (`initial_state`, `chute_warm_start.rs`); the job
//! waits for the steady state and then measures.
//!
//! Choices the paper leaves open, each a parameter recorded with the job:
//! - ℓ in k_n: the paper writes "m_p g / l" with l the cylinder length, which is 0 for ξ = 1 and
//!   tiny for ξ = 1.01 (k_n would diverge); the default is the total length L (`stiffness_length`
//!   = "total_length"), the same for every ξ since L is fixed; "cylinder_length" reads the paper
//!   literally (refused for ξ = 1), "diameter" is Weinhart et al.'s sphere convention.
//! - e_n is not given; 0.88 (as in Weinhart et al., Phys. Fluids 25, 070605, 2013 — the paper's
//!   ref. 30 setup) is the default.
//! - The base: a random monolayer of spheres (centres at z = 0) at area fraction 0.5, over a
//!   plane that catches any particle slipping through a gap: at z = −L/2 by default, at the
//!   centres with `catch_plane_height_lengths` = 0 (thin rods wedge under a sphere otherwise).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::engine::contact::{contact_time, ContactLaw, ContactPair, NormalModel};
use crate::engine::shape::Spherocylinder;

use super::blame::{time_step_problems, Reset, TimeStepInputs};
use super::silo::FieldError;

/// Fewest batch means `steady_batches` may ask for: the stationarity test's own minimum
/// (`observe::stationarity::MIN_BATCHES`, which a test there keeps equal to this).
pub const MIN_STEADY_BATCHES: usize = 4;

/// Smallest periodic box side, in particle lengths L, a campaign may ask for.
pub const MIN_BOX_LENGTHS: f64 = 4.0;

/// How a chute job's flowing particles start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum InitialState {
    /// A loose random gas at rest, poured onto the base (the paper's protocol).
    #[default]
    Pour,
    /// A dense lattice bed moving with a Bagnold velocity profile.
    Bagnold,
}

impl InitialState {
    /// Serde's skip test: the default is left out of a job's parameters (its hash).
    pub fn is_pour(&self) -> bool {
        *self == InitialState::Pour
    }
}

/// Default inertial number of the Bagnold guess: a dense flow well above the stopping angle
/// (spheres with μ = 0.5 flow at I ≈ 0.05–0.3 between the two critical angles).
pub const DEFAULT_WARM_INERTIAL_NUMBER: f64 = 0.1;

/// Serde's skip test for `warm_inertial_number` (left out at its default, older hashes kept).
pub fn default_warm_inertial_number(i: &f64) -> bool {
    *i == DEFAULT_WARM_INERTIAL_NUMBER
}

/// Which length sets k_n = factor · m_p g / ℓ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StiffnessLength {
    /// ℓ = L = l + d (fixed across ξ).
    TotalLength,
    /// ℓ = l, the paper's text read literally (undefined for ξ = 1).
    CylinderLength,
    /// ℓ = d.
    Diameter,
}

/// Every physical and numerical parameter of a chute job. Defaults are the paper's values where
/// it gives them (module doc for the rest).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ChuteParams {
    /// Aspect ratio ξ = L/d. Paper: 1.00, 1.01, 1.30, 1.50, 2.00, 2.50, 3.00.
    pub aspect_ratio: f64,
    /// Total particle length L = l + d (m). Paper: 2/16.
    pub particle_length_m: f64,
    /// Inclination α (degrees), between α_c1(ξ) and α_c2(ξ) for steady flow.
    pub inclination_deg: f64,
    /// Box length along the flow, in L. Paper: 16.
    pub box_x_lengths: f64,
    /// Box width, in L. Paper: 16.
    pub box_y_lengths: f64,
    /// Target bed thickness ΔZ in L (paper: about 20): sets the particle count through
    /// `flowing_solid_fraction`, unless `particle_count` is given.
    pub bed_height_lengths: f64,
    /// Solid fraction assumed to turn the bed height into a particle count.
    pub flowing_solid_fraction: f64,
    /// Number of flowing particles; overrides `bed_height_lengths`.
    pub particle_count: Option<usize>,
    /// Particle density ρ_p (kg/m³). Paper: 2600.
    pub particle_density_kg_per_m3: f64,
    /// |g| (m/s²). Paper: 1.
    pub gravity_m_per_s2: f64,
    /// k_n = this · m_p g / ℓ. Paper: 2·10⁵.
    pub stiffness_factor: f64,
    /// ℓ in k_n (module doc). Default: the total length L.
    pub stiffness_length: StiffnessLength,
    /// k_t / k_n. Paper: 2/7.
    pub tangential_stiffness_ratio: f64,
    /// Normal restitution e_n (also used for the tangential damping, as the paper does).
    /// Not given in the paper; default 0.88.
    pub restitution: f64,
    /// Tangential restitution e_t setting the tangential damping γ_t; null (default) uses e_n
    /// as the paper does, 1 gives γ_t = 0 (LAMMPS `gran/hooke/history … dampflag 0`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tangential_restitution: Option<f64>,
    /// Particle–particle friction μ (and particle–base). Paper: 0.5.
    pub friction: f64,
    /// n_c = t_c / dt. Paper: 50.
    pub contact_steps: f64,
    /// Base sphere radius, in L. Paper: 1/2.
    pub base_radius_lengths: f64,
    /// Area fraction of the base monolayer (random sequential addition jams near 0.547).
    pub base_coverage: f64,
    /// Height of the catch plane under the base, in L above the base spheres' centres; default
    /// (null) −base_radius_lengths, the spheres' bottoms. There, a thin rod that slips through a
    /// gap can be wedged between the plane and a fixed sphere until the overlap watchdog stops
    /// the run; at 0 (the centres) the plane meets each sphere at its equator and leaves no
    /// wedge. Left out of the job's parameters at its default, so older jobs keep their hashes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub catch_plane_height_lengths: Option<f64>,
    /// Steady state is not looked for before this time (s).
    pub steady_min_time_s: f64,
    /// Measurement starts at this time at the latest, steady or not (the job then records that
    /// the criteria did not hold).
    pub steady_max_time_s: f64,
    /// Trailing window over which the steady criteria must hold (s).
    pub steady_window_s: f64,
    /// Largest relative change |trend| · window / mean of the kinetic energy (the trend must
    /// also be within its own batch-means error, `observe::stationarity`).
    pub steady_kinetic_tolerance: f64,
    /// The same for the bed's mean V_x.
    pub steady_velocity_tolerance: f64,
    /// Largest relative deviation of the bulk σ_xz/σ_zz from tan α.
    pub steady_stress_tolerance: f64,
    /// Batch means per window for the trends' standard errors (≥ 4).
    pub steady_batches: usize,
    /// The bed is "not flowing" when its mean V_x is below this times √(g L): no D(z) then.
    pub min_flow_velocity_ratio: f64,
    /// Measure a flow that was not steady by `steady_max_time_s` anyway (recorded as not steady);
    /// by default such a job measures nothing.
    pub measure_unsteady: bool,
    /// Simulated measurement time after the steady state (s).
    pub measure_time_s: f64,
    /// Verlet skin as a fraction of d.
    pub skin_ratio: f64,
    /// Replica index (seed).
    pub replica: u32,
    /// How the flowing particles start: "pour" (a loose gas at rest, the default) or "bagnold"
    /// (a dense lattice bed moving with a Bagnold profile; `chute_warm_start.rs`). Left out of
    /// the job's parameters at its default, so older jobs keep their hashes.
    #[serde(skip_serializing_if = "InitialState::is_pour")]
    pub initial_state: InitialState,
    /// Bagnold warm start: the inertial number I of the guess
    /// V_x(z) = 2/3 (I/d) √(φ g cos α) (h^{3/2} − (h − z)^{3/2}). Default 0.1.
    #[serde(skip_serializing_if = "default_warm_inertial_number")]
    pub warm_inertial_number: f64,
    /// Bagnold warm start: V_x at the bed's surface (m/s), instead of the amplitude from
    /// `warm_inertial_number`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warm_surface_velocity_m_per_s: Option<f64>,
    /// Moves the whole scene by this vector in the lab frame (m; default the origin). Nothing
    /// physical changes and the seed ignores it: a check that results do not depend on where
    /// the scene sits (the engine's rounding). The shared fill stage runs at the origin.
    #[serde(skip_serializing_if = "crate::scene::at_origin")]
    pub origin_m: [f64; 3],
}

impl ChuteParams {
    /// Parameters left out of a job's serialised parameters at their defaults (so that older
    /// jobs keep their hashes): a campaign may still name them.
    pub const OMITTED_AT_DEFAULT: [&'static str; 5] = [
        "tangential_restitution",
        "catch_plane_height_lengths",
        "initial_state",
        "warm_inertial_number",
        "warm_surface_velocity_m_per_s",
    ];
}

impl Default for ChuteParams {
    fn default() -> Self {
        Self {
            aspect_ratio: 1.5,
            particle_length_m: 0.125,
            inclination_deg: 28.0,
            box_x_lengths: 16.0,
            box_y_lengths: 16.0,
            bed_height_lengths: 20.0,
            flowing_solid_fraction: 0.55,
            particle_count: None,
            particle_density_kg_per_m3: 2600.0,
            gravity_m_per_s2: 1.0,
            stiffness_factor: 2.0e5,
            stiffness_length: StiffnessLength::TotalLength,
            tangential_stiffness_ratio: 2.0 / 7.0,
            restitution: 0.88,
            tangential_restitution: None,
            friction: 0.5,
            contact_steps: 50.0,
            base_radius_lengths: 0.5,
            base_coverage: 0.5,
            catch_plane_height_lengths: None,
            steady_min_time_s: 20.0,
            steady_max_time_s: 200.0,
            steady_window_s: 20.0,
            steady_kinetic_tolerance: 0.02,
            steady_velocity_tolerance: 0.02,
            steady_stress_tolerance: 0.05,
            steady_batches: 8,
            min_flow_velocity_ratio: 0.05,
            measure_unsteady: false,
            measure_time_s: 50.0,
            skin_ratio: 0.2,
            replica: 0,
            initial_state: InitialState::Pour,
            warm_inertial_number: DEFAULT_WARM_INERTIAL_NUMBER,
            warm_surface_velocity_m_per_s: None,
            origin_m: [0.0; 3],
        }
    }
}

impl ChuteParams {
    /// Checks ranges; returns every problem found.
    pub fn validate(&self) -> Vec<FieldError> {
        let mut e = self.positive_problems();
        e.extend(super::placement_checks::origin_problem(self.origin_m));
        e.extend(super::placement_checks::gravity_problem(
            self.gravity_m_per_s2,
        ));
        e.extend(self.range_problems());
        e.extend(self.steady_problems());
        e.extend(self.box_problems());
        e.extend(self.warm_start_problems());
        if e.is_empty() {
            e.extend(self.time_step_problems());
        }
        e
    }

    /// Lengths, densities, stiffness and times that must be finite and positive.
    fn positive_problems(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let mut pos = |field: &str, v: f64, what: &str| {
            if !(v > 0.0 && v.is_finite()) {
                e.push(FieldError {
                    field: field.into(),
                    message: format!("expected {what} > 0, got {v}"),
                });
            }
        };
        pos("particle_length_m", self.particle_length_m, "metres");
        pos("box_x_lengths", self.box_x_lengths, "a multiple of L");
        pos("box_y_lengths", self.box_y_lengths, "a multiple of L");
        pos(
            "bed_height_lengths",
            self.bed_height_lengths,
            "a multiple of L",
        );
        pos(
            "particle_density_kg_per_m3",
            self.particle_density_kg_per_m3,
            "kg/m³",
        );
        pos("stiffness_factor", self.stiffness_factor, "a number");
        pos(
            "tangential_stiffness_ratio",
            self.tangential_stiffness_ratio,
            "a ratio",
        );
        pos("contact_steps", self.contact_steps, "steps");
        pos(
            "base_radius_lengths",
            self.base_radius_lengths,
            "a multiple of L",
        );
        pos("steady_window_s", self.steady_window_s, "seconds");
        pos("measure_time_s", self.measure_time_s, "seconds");
        pos("skin_ratio", self.skin_ratio, "a fraction of d");
        e
    }

    /// The particle, the incline and the contact law's parameters in their ranges.
    fn range_problems(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let mut err = |field: &str, message: String| e.push(FieldError::new(field, message));
        if !(self.aspect_ratio >= 1.0 && self.aspect_ratio.is_finite()) {
            err(
                "aspect_ratio",
                format!("expected ξ = L/d ≥ 1, got {}", self.aspect_ratio),
            );
        }
        if !(self.inclination_deg > 0.0 && self.inclination_deg < 90.0) {
            err(
                "inclination_deg",
                format!("expected 0 < α < 90 degrees, got {}", self.inclination_deg),
            );
        }
        if !(self.flowing_solid_fraction > 0.0 && self.flowing_solid_fraction < 0.8) {
            err(
                "flowing_solid_fraction",
                format!("expected 0 < φ < 0.8, got {}", self.flowing_solid_fraction),
            );
        }
        if !(self.restitution > 0.0 && self.restitution <= 1.0) {
            err(
                "restitution",
                format!("expected 0 < e_n ≤ 1, got {}", self.restitution),
            );
        }
        if let Some(et) = self.tangential_restitution {
            if !(et > 0.0 && et <= 1.0) {
                err(
                    "tangential_restitution",
                    format!("expected 0 < e_t ≤ 1 (1: no tangential damping) or null, got {et}"),
                );
            }
        }
        if !(self.friction >= 0.0 && self.friction.is_finite()) {
            err("friction", format!("expected μ ≥ 0, got {}", self.friction));
        }
        if !(self.base_coverage > 0.0 && self.base_coverage <= 0.547) {
            err(
                "base_coverage",
                format!(
                    "expected an area fraction in (0, 0.547] (random disks jam at 0.547), got {}",
                    self.base_coverage
                ),
            );
        }
        if let Some(h) = self.catch_plane_height_lengths {
            if !(h >= -self.base_radius_lengths && h <= 0.0) {
                err(
                    "catch_plane_height_lengths",
                    format!(
                        "expected a height in L between the base spheres' bottoms (−base_radius_lengths = {}) and their centres (0), or null, got {h}",
                        -self.base_radius_lengths
                    ),
                );
            }
        }
        if self.particle_count == Some(0) {
            err("particle_count", "expected at least one particle".into());
        }
        if self.stiffness_length == StiffnessLength::CylinderLength && self.aspect_ratio <= 1.0 {
            err(
                "stiffness_length",
                "\"cylinder_length\" is undefined for ξ = 1 (l = 0): use \"total_length\"".into(),
            );
        }
        e
    }

    /// The steady-flow test's tolerances, batches and time window.
    fn steady_problems(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let mut err = |field: &str, message: String| e.push(FieldError::new(field, message));
        for (field, tol) in [
            ("steady_kinetic_tolerance", self.steady_kinetic_tolerance),
            ("steady_velocity_tolerance", self.steady_velocity_tolerance),
            ("steady_stress_tolerance", self.steady_stress_tolerance),
        ] {
            if !(tol > 0.0 && tol < 1.0) {
                err(
                    field,
                    format!("expected a relative tolerance in (0, 1), got {tol}"),
                );
            }
        }
        if self.steady_batches < MIN_STEADY_BATCHES {
            err(
                "steady_batches",
                format!(
                    "expected at least {MIN_STEADY_BATCHES} batch means, got {}",
                    self.steady_batches
                ),
            );
        }
        if !(self.min_flow_velocity_ratio >= 0.0 && self.min_flow_velocity_ratio.is_finite()) {
            err(
                "min_flow_velocity_ratio",
                format!(
                    "expected a multiple of √(g L) ≥ 0, got {}",
                    self.min_flow_velocity_ratio
                ),
            );
        }
        if !(self.steady_min_time_s >= 0.0 && self.steady_max_time_s >= self.steady_min_time_s) {
            err(
                "steady_max_time_s",
                format!(
                    "expected 0 ≤ steady_min_time_s ≤ steady_max_time_s, got {} and {}",
                    self.steady_min_time_s, self.steady_max_time_s
                ),
            );
        }
        e
    }

    /// A periodic box wide enough that no particle meets its own image.
    fn box_problems(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let mut err = |field: &str, message: String| e.push(FieldError::new(field, message));
        for (field, v) in [
            ("box_x_lengths", self.box_x_lengths),
            ("box_y_lengths", self.box_y_lengths),
        ] {
            if v.is_finite() && v > 0.0 && v < MIN_BOX_LENGTHS {
                err(
                    field,
                    format!(
                        "expected a periodic box side ≥ {MIN_BOX_LENGTHS} L (in units of the particle \
                         length L), got {v} L: a particle would meet its own periodic image"
                    ),
                );
            }
        }
        e
    }

    /// The time step the job will use: t_c finite and > 0, dt = t_c / n_c finite and > 0, and
    /// the longest run (`max_time_s`) a step count that fits in a u64. Each problem names the
    /// field(s) whose paper value would cure it (`blame::culprits`).
    fn time_step_problems(&self) -> Vec<FieldError> {
        let tc_fields: [Reset<ChuteParams>; 7] = [
            ("stiffness_factor", |q| {
                q.stiffness_factor = ChuteParams::default().stiffness_factor
            }),
            ("particle_length_m", |q| {
                q.particle_length_m = ChuteParams::default().particle_length_m
            }),
            ("aspect_ratio", |q| {
                q.aspect_ratio = ChuteParams::default().aspect_ratio
            }),
            ("particle_density_kg_per_m3", |q| {
                q.particle_density_kg_per_m3 = ChuteParams::default().particle_density_kg_per_m3
            }),
            ("gravity_m_per_s2", |q| {
                q.gravity_m_per_s2 = ChuteParams::default().gravity_m_per_s2
            }),
            ("stiffness_length", |q| {
                q.stiffness_length = ChuteParams::default().stiffness_length
            }),
            ("restitution", |q| {
                q.restitution = ChuteParams::default().restitution
            }),
        ];
        let step_fields: [Reset<ChuteParams>; 1] = [("contact_steps", |q| {
            q.contact_steps = ChuteParams::default().contact_steps
        })];
        let run: [Reset<ChuteParams>; 2] = [
            ("steady_max_time_s", |q| {
                q.steady_max_time_s = ChuteParams::default().steady_max_time_s
            }),
            ("measure_time_s", |q| {
                q.measure_time_s = ChuteParams::default().measure_time_s
            }),
        ];
        time_step_problems(
            self,
            &TimeStepInputs {
                contact_fields: &tc_fields,
                step_fields: &step_fields,
                step_field: "contact_steps",
                durations: &[(
                    "(steady_max_time_s + measure_time_s)",
                    &run,
                    ChuteParams::max_time_s,
                )],
                contact_time: ChuteParams::contact_time,
                time_step: ChuteParams::time_step,
                contact_words: format!(
                    "gives a contact time t_c (k_n = {:e} N/m)",
                    self.normal_stiffness()
                ),
                contact_inputs: "stiffness_factor, stiffness_length, particle_length_m, \
                                 aspect_ratio, particle_density_kg_per_m3, gravity_m_per_s2 and \
                                 restitution",
                dt_words: "dt = t_c / contact_steps",
            },
        )
    }

    /// The particle shape.
    pub fn shape(&self) -> Spherocylinder<f64> {
        Spherocylinder::from_aspect_ratio(self.particle_length_m, self.aspect_ratio)
            .expect("validated aspect ratio")
    }

    /// Whether the particles are spheres (ξ = 1): they then run on the sphere engine (half
    /// lists, no orientations), which simulates only what spheres need.
    pub fn spheres(&self) -> bool {
        self.shape().half_length == 0.0
    }

    /// Particle mass m_p (kg).
    pub fn particle_mass(&self) -> f64 {
        self.shape().mass(self.particle_density_kg_per_m3)
    }

    /// Box extents (m).
    pub fn box_size(&self) -> (f64, f64) {
        (
            self.box_x_lengths * self.particle_length_m,
            self.box_y_lengths * self.particle_length_m,
        )
    }

    /// Number of flowing particles.
    pub fn count(&self) -> usize {
        self.particle_count.unwrap_or_else(|| {
            let (lx, ly) = self.box_size();
            let h = self.bed_height_lengths * self.particle_length_m;
            (self.flowing_solid_fraction * lx * ly * h / self.shape().volume()).round() as usize
        })
    }

    /// The length ℓ in k_n (m).
    pub fn stiffness_length_m(&self) -> f64 {
        let s = self.shape();
        match self.stiffness_length {
            StiffnessLength::TotalLength => self.particle_length_m,
            StiffnessLength::CylinderLength => 2.0 * s.half_length,
            StiffnessLength::Diameter => 2.0 * s.radius,
        }
    }

    /// k_n (N/m).
    pub fn normal_stiffness(&self) -> f64 {
        self.stiffness_factor * self.particle_mass() * self.gravity_m_per_s2
            / self.stiffness_length_m()
    }

    /// The contact law (particle–particle, particle–base and the catch plane).
    pub fn law(&self) -> ContactLaw {
        let kn = self.normal_stiffness();
        ContactLaw {
            normal: NormalModel::Linear {
                kn_n_per_m: kn,
                kt_n_per_m: self.tangential_stiffness_ratio * kn,
            },
            restitution: self.restitution,
            tangential_restitution: self.tangential_restitution.unwrap_or(self.restitution),
            friction: self.friction,
        }
    }

    /// t_c of the lightest pair: two rods struck across their axes at their tips, where rotation
    /// makes each respond as its `tip_mass` (m* = m_tip/2; m_p/2 for spheres, the paper's t_c;
    /// against the fixed base m* is twice that), so that `contact_steps` resolves every contact.
    pub fn contact_time(&self) -> f64 {
        let shape = self.shape();
        let m_tip = shape.tip_mass(self.particle_density_kg_per_m3);
        contact_time(
            &self.law(),
            ContactPair {
                r_eff: shape.radius / 2.0,
                m_eff: m_tip / 2.0,
            },
            1.0,
        )
    }

    /// dt = t_c / n_c, refusing n_c < 5.
    pub fn time_step(&self) -> Result<f64, String> {
        if self.contact_steps < 5.0 {
            return Err(format!(
                "contact_steps = {} resolves a contact in fewer than 5 steps (dt > t_c/5)",
                self.contact_steps
            ));
        }
        Ok(self.contact_time() / self.contact_steps)
    }

    /// The flowing threshold on the bed's mean V_x (m/s).
    pub fn min_flow_velocity_m_per_s(&self) -> f64 {
        self.min_flow_velocity_ratio * (self.gravity_m_per_s2 * self.particle_length_m).sqrt()
    }

    /// Total simulated time the job may take (s): the longest wait for steady state plus the
    /// measurement.
    pub fn max_time_s(&self) -> f64 {
        self.steady_max_time_s + self.measure_time_s
    }
}
