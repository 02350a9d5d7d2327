//! A scene moved in the lab frame: the engine runs every particle, wall, periodic box and sink
//! `origin_m` away from where the scene put them, and everything outside the engine (observers,
//! checkpoints, insertion) sees the scene's own frame. Nothing physical changes, so a result that
//! moves with `origin_m` measures the engine's rounding (`position.rs`), which is what the
//! parameter is for.

use super::backend::{Backend, BackendInfo, ChunkReport, EngineError};
use super::config::EngineConfig;
use super::contact::ContactRecord;
use super::state::State;
use super::walls::{Wall, WallShape};

/// `inner`, which runs the scene moved by `origin`.
pub struct Translated {
    inner: Box<dyn Backend>,
    origin: [f64; 3],
}

impl Translated {
    /// Wraps a backend built from `config(…, origin)` and `state(…, origin)`.
    pub fn new(inner: Box<dyn Backend>, origin: [f64; 3]) -> Self {
        Self { inner, origin }
    }
}

/// The engine configuration of the scene moved by `o`.
pub fn config(c: &EngineConfig, o: [f64; 3]) -> EngineConfig {
    let shift = |b: Option<[f64; 2]>, k: usize| b.map(|[lo, hi]| [lo + o[k], hi + o[k]]);
    EngineConfig {
        walls: c.walls.iter().map(|w| wall(w, o)).collect(),
        periodic_x: shift(c.periodic_x, 0),
        periodic_y: shift(c.periodic_y, 1),
        sink_z: c.sink_z.map(|z| z + o[2]),
        ..c.clone()
    }
}

fn wall(w: &Wall, o: [f64; 3]) -> Wall {
    let xy = |p: [f64; 2]| [p[0] + o[0], p[1] + o[1]];
    let shape = match w.shape {
        WallShape::Plane { point, normal } => WallShape::Plane {
            point: [point[0] + o[0], point[1] + o[1], point[2] + o[2]],
            normal,
        },
        WallShape::Cylinder {
            axis_xy,
            radius,
            z_min,
            z_max,
        } => WallShape::Cylinder {
            axis_xy: xy(axis_xy),
            radius,
            z_min: z_min + o[2],
            z_max: z_max + o[2],
        },
        WallShape::OrificePlate {
            z,
            center_xy,
            orifice_radius,
        } => WallShape::OrificePlate {
            z: z + o[2],
            center_xy: xy(center_xy),
            orifice_radius,
        },
    };
    let mut rotation = w.rotation;
    if let Some(r) = &mut rotation {
        r.axis_xy = xy(r.axis_xy);
    }
    Wall { shape, rotation }
}

/// The state moved by `o` (a negative `o` moves it back).
pub fn state(s: &State<f64>, o: [f64; 3]) -> State<f64> {
    let mut out = s.clone();
    for p in &mut out.pos {
        p.x += o[0];
        p.y += o[1];
        p.z += o[2];
    }
    out
}

fn back(o: [f64; 3]) -> [f64; 3] {
    [-o[0], -o[1], -o[2]]
}

impl Backend for Translated {
    fn advance(&mut self, steps: u64) -> Result<ChunkReport, EngineError> {
        self.inner.advance(steps)
    }

    fn download(&mut self) -> State<f64> {
        state(&self.inner.download(), back(self.origin))
    }

    fn try_download(&mut self) -> Result<State<f64>, EngineError> {
        Ok(state(&self.inner.try_download()?, back(self.origin)))
    }

    fn kinetic_energy(&mut self) -> Result<f64, EngineError> {
        self.inner.kinetic_energy()
    }

    fn upload(&mut self, s: &State<f64>) {
        self.inner.upload(&state(s, self.origin));
    }

    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError> {
        let mut c = self.inner.contacts()?;
        for r in &mut c {
            for k in 0..3 {
                r.pos_i[k] -= self.origin[k];
            }
        }
        Ok(c)
    }

    fn describe(&self) -> BackendInfo {
        self.inner.describe()
    }

    fn workers_cpu_s(&self) -> Option<f64> {
        self.inner.workers_cpu_s()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::walls::WallRotation;

    /// Every coordinate a scene sets moves by the origin; nothing else does.
    #[test]
    fn the_configuration_moves_every_coordinate_and_nothing_else() {
        let law = crate::engine::contact::ContactLaw {
            normal: crate::engine::contact::NormalModel::Linear {
                kn_n_per_m: 1e4,
                kt_n_per_m: 2e3,
            },
            restitution: 0.5,
            tangential_restitution: 0.5,
            friction: 0.5,
        };
        let c = EngineConfig {
            dt_s: 1e-6,
            gravity: [0.0, 0.0, -9.81],
            particle_law: law,
            wall_law: law,
            walls: vec![
                Wall {
                    shape: WallShape::OrificePlate {
                        z: 0.0,
                        center_xy: [0.0, 0.0],
                        orifice_radius: 0.01,
                    },
                    rotation: Some(WallRotation {
                        axis_xy: [0.0, 0.0],
                        omega_rad_per_s: 1.0,
                    }),
                },
                Wall {
                    shape: WallShape::Cylinder {
                        axis_xy: [0.0, 0.0],
                        radius: 0.05,
                        z_min: 0.0,
                        z_max: 0.2,
                    },
                    rotation: None,
                },
            ],
            periodic_x: Some([-0.1, 0.1]),
            periodic_y: None,
            sink_z: Some(-0.05),
            skin_m: 1e-4,
        };
        let o = [1.0, 2.0, 100.0];
        let m = config(&c, o);
        assert_eq!(m.sink_z, Some(99.95));
        assert_eq!(m.periodic_x, Some([0.9, 1.1]));
        assert_eq!(
            m.walls[0].shape,
            WallShape::OrificePlate {
                z: 100.0,
                center_xy: [1.0, 2.0],
                orifice_radius: 0.01
            }
        );
        assert_eq!(m.walls[0].rotation.unwrap().axis_xy, [1.0, 2.0]);
        assert_eq!(
            m.walls[1].shape,
            WallShape::Cylinder {
                axis_xy: [1.0, 2.0],
                radius: 0.05,
                z_min: 100.0,
                z_max: 100.2
            }
        );
        assert_eq!((m.dt_s, m.gravity, m.skin_m), (c.dt_s, c.gravity, c.skin_m));
    }
}
