//! A chute job's scene (`ChuteScene`): the validated parameters with their time step, and what
//! they make: the engine's configuration, the rough base and the initial particles.

use crate::engine::walls::{Wall, WallShape};
use crate::engine::{EngineConfig, State};

use super::chute::ChuteParams;

/// Solid fraction of the poured gas.
const INSERT_SOLID_FRACTION: f64 = 0.2;

/// A chute job's scene.
#[derive(Clone, Debug)]
pub struct ChuteScene {
    pub p: ChuteParams,
    pub dt: f64,
}

impl ChuteScene {
    /// # Errors
    /// The first validation problem, as text.
    pub fn new(p: ChuteParams) -> Result<Self, String> {
        if let Some(e) = p.validate().into_iter().next() {
            return Err(format!("{}: {}", e.field, e.message));
        }
        let dt = p.time_step()?;
        Ok(Self { p, dt })
    }

    /// tan α.
    pub fn tan_alpha(&self) -> f64 {
        self.p.inclination_deg.to_radians().tan()
    }

    /// Radius of the base spheres (m).
    pub fn base_radius(&self) -> f64 {
        self.p.base_radius_lengths * self.p.particle_length_m
    }

    /// Height of the catch plane under the base (m): the base spheres' bottoms by default.
    pub fn catch_plane_z(&self) -> f64 {
        self.p
            .catch_plane_height_lengths
            .map_or(-self.base_radius(), |h| h * self.p.particle_length_m)
    }

    pub fn engine_config(&self) -> EngineConfig {
        let p = &self.p;
        let a = p.inclination_deg.to_radians();
        let (lx, ly) = p.box_size();
        let law = p.law();
        EngineConfig {
            dt_s: self.dt,
            gravity: [
                p.gravity_m_per_s2 * a.sin(),
                0.0,
                -p.gravity_m_per_s2 * a.cos(),
            ],
            particle_law: law,
            wall_law: law,
            walls: vec![Wall {
                shape: WallShape::Plane {
                    point: [0.0, 0.0, self.catch_plane_z()],
                    normal: [0.0, 0.0, 1.0],
                },
                rotation: None,
            }],
            periodic_x: Some([0.0, lx]),
            periodic_y: Some([0.0, ly]),
            sink_z: None,
            skin_m: p.skin_ratio * 2.0 * p.shape().radius,
        }
    }

    /// The base spheres (fixed, ids from 0, a random monolayer of centres at z = 0) in an empty
    /// state of the right kind: the sphere engine's for ξ = 1 (rotating under friction), the
    /// oriented one otherwise.
    pub(super) fn base_state(&self, seed: u64) -> State<f64> {
        let p = &self.p;
        let (lx, ly) = p.box_size();
        let rb = self.base_radius();
        let slots = if p.friction > 0.0 {
            crate::engine::history::HISTORY_SLOTS
        } else {
            0
        };
        // Spheres (ξ = 1) need no orientations: the sphere engine, rotating under friction.
        let mut s = if p.spheres() {
            State::new(slots > 0, slots)
        } else {
            State::new_oriented(slots)
        };
        let base = super::fill_rods::base_monolayer(lx, ly, rb, 0.0, p.base_coverage, seed);
        for (k, c) in base.iter().enumerate() {
            s.push_sphere(
                k as u32,
                *c,
                [0.0; 3],
                rb,
                p.particle_density_kg_per_m3,
                true,
            );
        }
        s
    }

    /// The base spheres (fixed, ids from 0) and the poured gas of spherocylinders (spheres for
    /// ξ = 1) above them (ids after the base), at rest. Flowing particles are those with inverse
    /// mass > 0. `start_state` picks this or the warm start.
    pub fn initial_state(&self, seed: u64) -> State<f64> {
        let p = &self.p;
        let (lx, ly) = p.box_size();
        let rb = self.base_radius();
        let mut s = self.base_state(seed);
        let shape = p.shape();
        let rods = super::fill_rods::box_random_rods(
            p.count(),
            shape,
            lx,
            ly,
            rb,
            INSERT_SOLID_FRACTION,
            seed ^ 0x9E37_79B9_7F4A_7C15,
        );
        let n0 = s.len() as u32;
        for (k, r) in rods.iter().enumerate() {
            if p.spheres() {
                let rho = p.particle_density_kg_per_m3;
                s.push_sphere(n0 + k as u32, r.pos, [0.0; 3], shape.radius, rho, false);
                continue;
            }
            s.push_spherocylinder(
                n0 + k as u32,
                r.pos,
                [0.0; 3],
                r.q,
                shape,
                p.particle_density_kg_per_m3,
                false,
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_defaults_give_the_papers_time_scales() {
        let s = ChuteScene::new(ChuteParams::default()).unwrap();
        // k_n = 2e5 m g / L with m* = m/2 (spheres, the paper's t_c): t_c ≈ π √(L / (4e5 g))
        // (slightly longer with damping); rods with m* = m_tip/2, shorter by √(m_tip/m).
        let undamped = std::f64::consts::PI * (0.125f64 / 4e5).sqrt();
        let spheres = ChuteParams {
            aspect_ratio: 1.0,
            ..ChuteParams::default()
        };
        let tc = spheres.contact_time();
        assert!(tc > undamped && tc < 1.05 * undamped, "t_c = {tc}");
        let shape = s.p.shape();
        let rho = s.p.particle_density_kg_per_m3;
        let tip = (shape.tip_mass(rho) / shape.mass(rho)).sqrt();
        assert!(tip > 0.8 && tip < 0.9, "√(m_tip/m) = {tip}");
        let tc = s.p.contact_time();
        assert!(
            tc > tip * undamped && tc < 1.05 * tip * undamped,
            "t_c = {tc}"
        );
        assert!((s.dt - tc / 50.0).abs() < 1e-15);
        // 16 L × 16 L × 20 L at φ = 0.55 of ξ = 1.5 rods.
        let n = s.p.count();
        assert!(n > 9000 && n < 11000, "N = {n}");
    }

    /// e_t defaults to e_n (the paper); e_t = 1 switches the tangential damping off (LAMMPS
    /// `dampflag 0`) and leaves the normal damping alone.
    #[test]
    fn tangential_damping_follows_its_restitution() {
        let paper = ChuteParams::default().law().kernel::<f64>();
        assert!(paper.damp_t > 0.0 && paper.damp_t == paper.damp_n);
        let none = ChuteParams {
            tangential_restitution: Some(1.0),
            ..ChuteParams::default()
        };
        let k = none.law().kernel::<f64>();
        assert_eq!(k.damp_t, 0.0);
        assert_eq!(k.damp_n, paper.damp_n);
        let bad = ChuteParams {
            tangential_restitution: Some(1.5),
            ..ChuteParams::default()
        };
        assert!(bad
            .validate()
            .iter()
            .any(|e| e.field == "tangential_restitution"));
    }

    /// The catch plane sits at the base spheres' bottoms unless raised, at most to their centres.
    #[test]
    fn the_catch_plane_sits_under_the_base() {
        let plane_z = |h: Option<f64>| {
            let s = ChuteScene::new(ChuteParams {
                catch_plane_height_lengths: h,
                ..ChuteParams::default()
            })
            .unwrap();
            match s.engine_config().walls[0].shape {
                WallShape::Plane { point, .. } => point[2],
                _ => panic!("the chute's wall is a plane"),
            }
        };
        assert_eq!(plane_z(None), -0.0625);
        assert_eq!(plane_z(Some(0.0)), 0.0);
        assert_eq!(plane_z(Some(-0.25)), -0.25 * 0.125);
        let low = ChuteParams {
            catch_plane_height_lengths: Some(-0.6),
            ..ChuteParams::default()
        };
        assert!(low
            .validate()
            .iter()
            .any(|e| e.field == "catch_plane_height_lengths"));
    }

    #[test]
    fn bad_values_are_named() {
        let p = ChuteParams {
            aspect_ratio: 0.5,
            inclination_deg: 95.0,
            ..ChuteParams::default()
        };
        let e = p.validate();
        assert!(e.iter().any(|e| e.field == "aspect_ratio"));
        assert!(e.iter().any(|e| e.field == "inclination_deg"));
    }
}
