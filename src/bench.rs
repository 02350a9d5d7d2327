//! Benchmark scenes for `sweep bench` and `cargo bench`: throughput in particle-steps per second
//! with N, dt, backend, precision and thread count, plus a state checksum so that a fast wrong
//! answer is visible.
//! - `silo-bed`: Hertz–Mindlin spheres with tangential history (d = 5.8 mm, Y = 30 MPa,
//!   G = Y/30, e = 0.9, μ = 0.5, dt = t_c/50) packed in a closed cylinder under gravity.
//! - `chute-bed`: linear spring–dashpot spheres (ξ = 1, L = d = 2/16 m, k_n = 2·10⁵ m g / L,
//!   k_t = 2/7 k_n, e_n = 0.88, μ = 0.5, dt = t_c/50) flowing down a 24° incline, periodic in x
//!   and y, on a rough base of fixed spheres of radius L/2.
//! - `chute-rods`: the chute scene's spherocylinders (ξ = 1.5, its law, dt and walls), about 20
//!   layers of rods aligned with the flow, compressed by 0.05 % of L and d (contacts from the
//!   first step, as `chute-bed`), on its rough base at 28°.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest, Sha256};

use crate::engine::contact::{contact_time, ContactLaw, ContactPair, Elasticity, NormalModel};
use crate::engine::real::V3;
use crate::engine::walls::{Wall, WallShape};
use crate::engine::{EngineConfig, State};

/// A benchmark scene: configuration and initial state.
pub struct BenchScene {
    pub config: EngineConfig,
    pub state: State<f64>,
}

/// Builds a bench scene by name with about `n` mobile particles.
///
/// # Errors
/// Unknown scene name.
pub fn scene(name: &str, n: usize, seed: u64) -> anyhow::Result<BenchScene> {
    match name {
        "silo-bed" => Ok(silo_bed(n, seed)),
        "chute-bed" => Ok(chute_bed(n, seed)),
        "chute-rods" => Ok(chute_rods(n, seed)),
        _ => anyhow::bail!(
            "unknown bench scene {name:?}; expected silo-bed, chute-bed or chute-rods"
        ),
    }
}

fn silo_bed(n: usize, seed: u64) -> BenchScene {
    let d = 0.0058;
    let rho = 2655.0;
    let y = 3.0e7;
    let law = ContactLaw {
        normal: NormalModel::Hertz(Elasticity::YoungShear {
            youngs_modulus_pa: y,
            shear_modulus_pa: y / 30.0,
        }),
        restitution: 0.9,
        tangential_restitution: 0.9,
        friction: 0.5,
    };
    let m = rho * std::f64::consts::PI / 6.0 * d * d * d;
    let tc = contact_time(
        &law,
        ContactPair {
            r_eff: d / 4.0,
            m_eff: m / 2.0,
        },
        1.0,
    );
    // A cylinder whose height is about twice its diameter, holding n particles at φ ≈ 0.5.
    let rc = ((n as f64 * d * d * d) / (2.0 * std::f64::consts::PI))
        .cbrt()
        .max(5.0 * d);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut s = State::new(true, crate::engine::history::HISTORY_SLOTS);
    // A simple cubic bed compressed by 0.05 % of d: every inner particle has six contacts, about
    // the coordination of a settled random bed, with contact forces of the order of the weight.
    let a = 0.9995 * d;
    let k = ((rc - 0.5 * d) / a).floor() as i64;
    let mut z = 0.4998 * d;
    let mut id = 0u32;
    'fill: loop {
        for ix in -k..=k {
            for iy in -k..=k {
                let (x, yy) = (ix as f64 * a, iy as f64 * a);
                if (x * x + yy * yy).sqrt() > rc - 0.52 * d {
                    continue;
                }
                let j = 0.005 * d;
                let p = [
                    x + j * (rng.random::<f64>() - 0.5),
                    yy + j * (rng.random::<f64>() - 0.5),
                    z,
                ];
                s.push_sphere(id, p, [0.0; 3], 0.5 * d, rho, false);
                id += 1;
                if id as usize >= n {
                    break 'fill;
                }
            }
        }
        z += a;
    }
    let walls = vec![
        Wall {
            shape: WallShape::Cylinder {
                axis_xy: [0.0, 0.0],
                radius: rc,
                z_min: 0.0,
                z_max: 10.0,
            },
            rotation: None,
        },
        Wall {
            shape: WallShape::OrificePlate {
                z: 0.0,
                center_xy: [0.0, 0.0],
                orifice_radius: 0.0,
            },
            rotation: None,
        },
    ];
    let config = EngineConfig {
        dt_s: tc / 50.0,
        gravity: [0.0, 0.0, -9.81],
        particle_law: law,
        wall_law: law,
        walls,
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.2 * d,
    };
    BenchScene { config, state: s }
}

fn chute_bed(n: usize, seed: u64) -> BenchScene {
    let l = 2.0 / 16.0;
    let d = l;
    let rho = 2600.0;
    let g = 1.0;
    let m = rho * std::f64::consts::PI / 6.0 * d * d * d;
    // ξ = 1 has no cylinder length l; the paper's k_n = 2·10⁵ m g / l then uses the total length L.
    let kn = 2.0e5 * m * g / l;
    let law = ContactLaw {
        normal: NormalModel::Linear {
            kn_n_per_m: kn,
            kt_n_per_m: 2.0 / 7.0 * kn,
        },
        restitution: 0.88,
        tangential_restitution: 0.88,
        friction: 0.5,
    };
    let tc = contact_time(
        &law,
        ContactPair {
            r_eff: d / 4.0,
            m_eff: m / 2.0,
        },
        1.0,
    );
    // Box side so that the bed is ~20 layers deep.
    // Simple cubic layers at spacing a = 0.9995 d (a dense flowing bed from the first step), k × k
    // per layer so that the bed is about 20 layers deep.
    let a = 0.9995 * d;
    let k = ((n as f64 / 20.0).sqrt().ceil() as usize).max(4);
    let side = k as f64 * a;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut s = State::new(true, crate::engine::history::HISTORY_SLOTS);
    let mut id = 0u32;
    // Rough base: fixed spheres of radius L/2 at random on z = 0, about one per L².
    let nb = ((side / d).powi(2) * 1.2) as usize;
    for _ in 0..nb {
        s.push_sphere(
            id,
            [rng.random::<f64>() * side, rng.random::<f64>() * side, 0.0],
            [0.0; 3],
            0.5 * l,
            rho,
            true,
        );
        id += 1;
    }
    let mut placed = 0;
    let mut z = 1.2 * d;
    'fill: loop {
        for ix in 0..k {
            for iy in 0..k {
                let p = [
                    (ix as f64 + 0.5) * side / k as f64,
                    (iy as f64 + 0.5) * side / k as f64,
                    z + 0.01 * d * rng.random::<f64>(),
                ];
                s.push_sphere(id, p, [0.0; 3], 0.5 * d, rho, false);
                id += 1;
                placed += 1;
                if placed >= n {
                    break 'fill;
                }
            }
        }
        z += a;
    }
    let alpha = 24f64.to_radians();
    let config = EngineConfig {
        dt_s: tc / 50.0,
        gravity: [g * alpha.sin(), 0.0, -g * alpha.cos()],
        particle_law: law,
        wall_law: law,
        walls: vec![Wall {
            shape: WallShape::Plane {
                point: [0.0, 0.0, -0.5 * l],
                normal: [0.0, 0.0, 1.0],
            },
            rotation: None,
        }],
        periodic_x: Some([0.0, side]),
        periodic_y: Some([0.0, side]),
        sink_z: None,
        skin_m: 0.2 * d,
    };
    BenchScene { config, state: s }
}

fn chute_rods(n: usize, seed: u64) -> BenchScene {
    use crate::scene::{ChuteParams, ChuteScene};
    let p0 = ChuteParams {
        aspect_ratio: 1.5,
        inclination_deg: 28.0,
        ..ChuteParams::default()
    };
    let (l, d) = (p0.particle_length_m, p0.shape().diameter());
    // Rods along x at 0.9995 L, side by side and stacked at 0.9995 d, about 20 layers: a square
    // box of side √(n L d / 20), whole numbers of rods across it.
    let a = 0.9995;
    let side = (n as f64 * a * l * a * d / 20.0).sqrt();
    let (kx, ky) = (
        ((side / (a * l)).round() as usize).max(4),
        ((side / (a * d)).round() as usize).max(4),
    );
    let p = ChuteParams {
        box_x_lengths: kx as f64 * a,
        box_y_lengths: ky as f64 * a * d / l,
        particle_count: Some(n),
        ..p0
    };
    // Not `ChuteScene::new`: a small bench's box may be narrower than the 4 L a campaign must
    // have (`chute::MIN_BOX_LENGTHS`, a finite-size bound); the engine itself needs only more
    // than 2 (L + skin) across, which 4 rod widths of ξ = 1.5 give.
    let dt = p.time_step().expect("valid chute time step");
    let scene = ChuteScene { p, dt };
    let (lx, ly) = scene.p.box_size();
    let rb = scene.base_radius();
    let mut s = State::new_oriented(crate::engine::history::HISTORY_SLOTS);
    let base = crate::scene::fill_rods::base_monolayer(lx, ly, rb, 0.0, 0.5, seed);
    for (id, c) in base.iter().enumerate() {
        s.push_sphere(
            id as u32,
            *c,
            [0.0; 3],
            rb,
            scene.p.particle_density_kg_per_m3,
            true,
        );
    }
    let q = crate::engine::shape::Quat::<f64>::from_axis_z(crate::engine::V3::new(1.0, 0.0, 0.0));
    let mut id = base.len() as u32;
    // The bottom layer rests on the tops of the base spheres.
    let mut z = rb + 0.4998 * d;
    'fill: loop {
        for ix in 0..kx {
            for iy in 0..ky {
                let c = [
                    (ix as f64 + 0.5) * lx / kx as f64,
                    (iy as f64 + 0.5) * ly / ky as f64,
                    z,
                ];
                s.push_spherocylinder(
                    id,
                    c,
                    [0.0; 3],
                    q.to_f64(),
                    scene.p.shape(),
                    scene.p.particle_density_kg_per_m3,
                    false,
                );
                id += 1;
                if s.len() - base.len() >= n {
                    break 'fill;
                }
            }
        }
        z += a * d;
    }
    BenchScene {
        config: scene.engine_config(),
        state: s,
    }
}

/// SHA-256 (first 16 hex digits) of positions and velocities: equal runs give equal checksums.
pub fn checksum(s: &State<f64>) -> String {
    let mut h = Sha256::new();
    for (p, v) in s.pos.iter().zip(&s.vel) {
        for x in [p.x, p.y, p.z, v.x, v.y, v.z] {
            h.update(x.to_le_bytes());
        }
    }
    h.finalize()
        .iter()
        .take(8)
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// How `sweep bench --settle` brings a scene from its lattice start to a representative state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Settling {
    /// silo-bed: until the kinetic energy is below this (J).
    Rest(f64),
    /// chute-bed: this many steps of flow.
    Flow(u64),
}

/// The scene's settling: silo-bed comes to rest (`rest_energy`); chute-bed flows for 20 √(L/g)
/// (the lattice dilates and mixes into a flowing random bed; a fully developed profile would
/// take hundreds of √(L/g)). None for chute-rods.
pub fn settling(name: &str, sc: &BenchScene) -> Option<Settling> {
    match name {
        "silo-bed" => Some(Settling::Rest(rest_energy(&sc.state, sc.config.gravity))),
        "chute-bed" => {
            let g = V3::<f64>::from_f64(sc.config.gravity).norm();
            // L: the diameter of the flowing spheres (ξ = 1).
            let s = &sc.state;
            let l = 2.0
                * (0..s.len())
                    .filter(|&i| s.inv_mass[i] > 0.0)
                    .map(|i| s.radius[i])
                    .fold(0.0, f64::max);
            let tau = (l / g).sqrt();
            Some(Settling::Flow((20.0 * tau / sc.config.dt_s).ceil() as u64))
        }
        _ => None,
    }
}

/// The name results from `sweep bench --settle` are stored under (scenes that `settling`
/// knows): silo-bed's settled bed, chute-bed's flowing one.
pub fn settled_name(name: &str) -> Option<String> {
    match name {
        "silo-bed" => Some(format!("{name}/settled")),
        "chute-bed" => Some(format!("{name}/flowing")),
        _ => None,
    }
}

/// The kinetic energy below which a bed counts as settled: 10⁻⁴ m g d per mobile particle, the
/// silo study's criterion (`SiloParams::settle_kinetic_energy_ratio`).
pub fn rest_energy(s: &State<f64>, gravity: [f64; 3]) -> f64 {
    let g = V3::<f64>::from_f64(gravity).norm();
    let mgd: f64 = (0..s.len())
        .filter(|&i| s.inv_mass[i] > 0.0)
        .map(|i| s.mass[i] * g * 2.0 * s.radius[i])
        .sum();
    1e-4 * mgd
}
