//! Checks of a silo job's parameters before it runs: ranges, the geometry (d < D < 2 R_c − 2 d,
//! the settled bed inside the cylinder) and a usable time step, each problem naming its field.

use super::blame::{time_step_problems, Reset, TimeStepInputs};
use super::placement_checks::{gravity_problem, origin_problem};
use super::silo::{FieldError, SiloParams, RANDOM_CLOSE_PACKING};

/// The widest size distribution accepted: diameters d (1 ± p).
pub const MAX_POLYDISPERSITY: f64 = 0.5;

/// A length rounded to the nanometre, for messages (0.0484, not 0.048400000000000006).
fn metres(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

/// " (millimetres? …)" when `v` / 1000 would pass `ok`: a length typed in millimetres.
fn millimetres_hint(v: f64, ok: impl Fn(f64) -> bool) -> String {
    if ok(v / 1000.0) {
        format!(
            " (a length in millimetres? lengths are in metres: {} m would fit)",
            v / 1000.0
        )
    } else {
        String::new()
    }
}

impl SiloParams {
    /// Checks ranges and combinations; returns every problem found.
    pub fn validate(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let mut pos = |field: &str, v: f64, what: &str| {
            if !(v > 0.0 && v.is_finite()) {
                e.push(FieldError {
                    field: field.into(),
                    message: format!("expected {what} > 0, got {v}"),
                });
            }
        };
        pos("cylinder_radius_m", self.cylinder_radius_m, "metres");
        pos("cylinder_height_m", self.cylinder_height_m, "metres");
        pos("particle_diameter_m", self.particle_diameter_m, "metres");
        pos(
            "particle_density_kg_per_m3",
            self.particle_density_kg_per_m3,
            "kg/m³",
        );
        pos("youngs_modulus_pa", self.youngs_modulus_pa, "pascals");
        pos("orifice_diameter_m", self.orifice_diameter_m, "metres");
        pos("impact_speed_m_per_s", self.impact_speed_m_per_s, "m/s");
        pos("discharge_time_s", self.discharge_time_s, "seconds");
        pos("sink_depth_m", self.sink_depth_m, "metres");
        pos("skin_ratio", self.skin_ratio, "a fraction of d");
        let mut err = |field: &str, message: String| {
            e.push(FieldError {
                field: field.into(),
                message,
            })
        };
        if self.particle_count == 0 {
            err(
                "particle_count",
                "expected at least 1 particle, got 0".into(),
            );
        }
        if !(0.0..=MAX_POLYDISPERSITY).contains(&self.diameter_polydispersity) {
            err(
                "diameter_polydispersity",
                format!(
                    "expected 0 ≤ p ≤ {MAX_POLYDISPERSITY} (diameters d (1 ± p); the smallest set the time step and the neighbour grid), got {}",
                    self.diameter_polydispersity
                ),
            );
        }
        if !(self.restitution > 0.0 && self.restitution <= 1.0) {
            err(
                "restitution",
                format!("expected 0 < e_n ≤ 1, got {}", self.restitution),
            );
        }
        for (f, v) in [
            ("friction_particle", self.friction_particle),
            ("friction_wall", self.friction_wall),
            ("rotation_frequency_hz", self.rotation_frequency_hz),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                err(f, format!("expected a value ≥ 0, got {v}"));
            }
        }
        // The bottom drags particles at up to its rim speed: the time step resolves collisions
        // at `impact_speed_m_per_s`, so a faster rim needs that raised with it.
        let rim = 2.0 * std::f64::consts::PI * self.rotation_frequency_hz * self.cylinder_radius_m;
        if self.rotation_frequency_hz.is_finite() && rim > self.impact_speed_m_per_s {
            err(
                "rotation_frequency_hz",
                format!(
                    "expected the bottom's rim speed 2π f R_c ≤ impact_speed_m_per_s = {} m/s (the collision speed the time step resolves), i.e. f ≤ {:.3} Hz; got f = {} Hz (raise impact_speed_m_per_s for a faster bottom)",
                    self.impact_speed_m_per_s,
                    self.impact_speed_m_per_s / (2.0 * std::f64::consts::PI * self.cylinder_radius_m),
                    self.rotation_frequency_hz
                ),
            );
        }
        e.extend(origin_problem(self.origin_m));
        e.extend(gravity_problem(self.gravity_m_per_s2));
        let mut err = |field: &str, message: String| {
            e.push(FieldError {
                field: field.into(),
                message,
            })
        };
        match (self.shear_modulus_pa, self.poisson_ratio) {
            (Some(_), Some(_)) => err(
                "poisson_ratio",
                "give either shear_modulus_pa or poisson_ratio, not both (set the other to null)"
                    .into(),
            ),
            (None, None) => err(
                "shear_modulus_pa",
                "expected shear_modulus_pa or poisson_ratio".into(),
            ),
            (Some(g), None) if !(g > 0.0) => {
                err("shear_modulus_pa", format!("expected pascals > 0, got {g}"))
            }
            (None, Some(nu)) if !(-1.0 < nu && nu < 0.5) => {
                err("poisson_ratio", format!("expected −1 < ν < 0.5, got {nu}"))
            }
            _ => {}
        }
        match (self.dt_s, self.contact_steps) {
            (Some(_), Some(_)) => err(
                "contact_steps",
                "give either dt_s or contact_steps, not both (set the other to null)".into(),
            ),
            (None, None) => err("dt_s", "expected dt_s or contact_steps".into()),
            (Some(dt), None) if !(dt > 0.0) => {
                err("dt_s", format!("expected seconds > 0, got {dt}"))
            }
            (None, Some(nc)) if !(nc >= 5.0) => err(
                "contact_steps",
                format!("expected n_c ≥ 5 (dt ≤ t_c/5), got {nc}"),
            ),
            _ => {}
        }
        if !(self.settle_max_time_s >= 0.0) {
            err(
                "settle_max_time_s",
                format!("expected seconds ≥ 0, got {}", self.settle_max_time_s),
            );
        }
        if e.is_empty() {
            e.extend(self.geometry_problems());
        }
        if e.is_empty() {
            e.extend(self.time_step_problems());
        }
        e
    }

    /// The container against the particles (every length already checked > 0): d < D < 2 R_c −
    /// 2 d (an orifice wider than a particle, with at least a particle's width of bottom on
    /// either side of it), and a settled bed lower than the cylinder.
    fn geometry_problems(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let (d, dd, rc, h) = (
            self.particle_diameter_m,
            self.orifice_diameter_m,
            self.cylinder_radius_m,
            self.cylinder_height_m,
        );
        if 3.0 * d >= 2.0 * rc {
            e.push(FieldError {
                field: "particle_diameter_m".into(),
                message: format!(
                    "expected d < 2 R_c / 3 = {} m (cylinder_radius_m = {rc} m), so that an orifice \
                     fits with d < D < 2 R_c − 2 d; got d = {d} m{}",
                    metres(2.0 * rc / 3.0),
                    millimetres_hint(d, |v| 3.0 * v < 2.0 * rc)
                ),
            });
        } else if !(d < dd && dd < 2.0 * rc - 2.0 * d) {
            let upper = metres(2.0 * rc - 2.0 * d);
            e.push(FieldError {
                field: "orifice_diameter_m".into(),
                message: format!(
                    "expected d < D < 2 R_c − 2 d, i.e. {d} m < D < {upper} m \
                     (particle_diameter_m = {d} m, cylinder_radius_m = {rc} m), got D = {dd} m{}",
                    millimetres_hint(dd, |v| d < v && v < upper)
                ),
            });
        }
        let bed = self.settled_bed_height_estimate();
        if bed > h {
            let fit = (self.particle_count as f64 * h / bed).floor();
            e.push(FieldError {
                field: "particle_count".into(),
                message: format!(
                    "expected the settled bed to fit in the cylinder: N = {} particles of d = {d} m \
                     at random close packing (solid fraction {RANDOM_CLOSE_PACKING}) stand about \
                     {bed:.3} m high in a cylinder of radius {rc} m, taller than cylinder_height_m \
                     = {h} m; at most about {fit} particles fit",
                    self.particle_count
                ),
            });
        }
        e
    }

    /// Height of the settled bed (m) estimated from the particle count: the particles' volume
    /// (mean d³ of the uniform size distribution: d³ (1 + p²)) at random close packing over the
    /// cylinder's cross-section.
    pub fn settled_bed_height_estimate(&self) -> f64 {
        let d = self.particle_diameter_m;
        let volume = self.particle_count as f64
            * std::f64::consts::PI
            * d.powi(3)
            * (1.0 + self.diameter_polydispersity.powi(2))
            / 6.0;
        volume
            / (RANDOM_CLOSE_PACKING
                * std::f64::consts::PI
                * self.cylinder_radius_m
                * self.cylinder_radius_m)
    }

    /// The time step the job will use: t_c finite and > 0, dt finite, > 0 and ≤ t_c / 5, and
    /// the fill and discharge times whole step counts that fit in a u64. Each problem names the
    /// field(s) whose paper value would cure it (`blame::culprits`).
    fn time_step_problems(&self) -> Vec<FieldError> {
        let tc_fields: [Reset<SiloParams>; 7] = [
            ("youngs_modulus_pa", |q| {
                q.youngs_modulus_pa = SiloParams::default().youngs_modulus_pa
            }),
            ("shear_modulus_pa", |q| {
                if q.shear_modulus_pa.is_some() {
                    q.shear_modulus_pa = SiloParams::default().shear_modulus_pa
                }
            }),
            ("poisson_ratio", |q| {
                if q.poisson_ratio.is_some() {
                    q.poisson_ratio = Some(0.3)
                }
            }),
            ("particle_diameter_m", |q| {
                q.particle_diameter_m = SiloParams::default().particle_diameter_m
            }),
            ("particle_density_kg_per_m3", |q| {
                q.particle_density_kg_per_m3 = SiloParams::default().particle_density_kg_per_m3
            }),
            ("impact_speed_m_per_s", |q| {
                q.impact_speed_m_per_s = SiloParams::default().impact_speed_m_per_s
            }),
            ("diameter_polydispersity", |q| {
                q.diameter_polydispersity = SiloParams::default().diameter_polydispersity
            }),
        ];
        let step_fields: [Reset<SiloParams>; 2] = [
            ("dt_s", |q| {
                if q.dt_s.is_some() {
                    q.dt_s = SiloParams::default().dt_s
                }
            }),
            ("contact_steps", |q| {
                if q.contact_steps.is_some() {
                    q.contact_steps = Some(50.0)
                }
            }),
        ];
        let discharge: [Reset<SiloParams>; 1] = [("discharge_time_s", |q| {
            q.discharge_time_s = SiloParams::default().discharge_time_s
        })];
        let settle: [Reset<SiloParams>; 1] = [("settle_max_time_s", |q| {
            q.settle_max_time_s = SiloParams::default().settle_max_time_s
        })];
        time_step_problems(
            self,
            &TimeStepInputs {
                contact_fields: &tc_fields,
                step_fields: &step_fields,
                step_field: if self.dt_s.is_some() {
                    "dt_s"
                } else {
                    "contact_steps"
                },
                durations: &[
                    ("discharge_time_s", &discharge, |q| q.discharge_time_s),
                    ("settle_max_time_s", &settle, |q| q.settle_max_time_s),
                ],
                contact_time: SiloParams::contact_time,
                time_step: SiloParams::time_step,
                contact_words: "gives a Hertz contact time t_c".into(),
                contact_inputs: "youngs_modulus_pa, shear_modulus_pa or poisson_ratio, \
                                 particle_diameter_m, particle_density_kg_per_m3 and \
                                 impact_speed_m_per_s",
                dt_words: "dt",
            },
        )
    }
}
