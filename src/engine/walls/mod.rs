//! Walls: infinite plane, the inside of a vertical finite cylinder, and a horizontal plate with a
//! circular orifice whose rim is a real edge. A wall may rotate rigidly about its own symmetry
//! axis: the geometry is unchanged, only its surface velocity enters the contact, so friction
//! drags particles along (the silo's rotating bottom).

mod cylinder;
mod orifice_plate;
mod plane;

use serde::{Deserialize, Serialize};

use super::contact::ContactInput;
use super::position;
use super::real::{Real, V3};
use super::shape::{contact_plane, PlaneContact, Spherocylinder};

/// Geometry of a wall (SI units).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum WallShape {
    /// Particles live on the side `normal` points to.
    Plane { point: [f64; 3], normal: [f64; 3] },
    /// Inside of a cylinder with vertical axis through (x, y), between z_min and z_max.
    Cylinder {
        axis_xy: [f64; 2],
        radius: f64,
        z_min: f64,
        z_max: f64,
    },
    /// Zero-thickness horizontal plate at height z with a circular hole of radius
    /// `orifice_radius` centred at (x, y); radius 0 is a closed plate.
    OrificePlate {
        z: f64,
        center_xy: [f64; 2],
        orifice_radius: f64,
    },
}

/// Rigid rotation of a wall about a vertical axis through `axis_xy` (rad/s, right-handed about +z).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallRotation {
    pub axis_xy: [f64; 2],
    pub omega_rad_per_s: f64,
}

/// A wall and its motion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    pub shape: WallShape,
    pub rotation: Option<WallRotation>,
}

/// A contact found with a wall, seen from the particle.
#[derive(Clone, Copy, Debug)]
pub struct WallContact<R: Real> {
    /// Unit normal from the wall to the particle centre.
    pub normal: V3<R>,
    pub overlap: R,
    /// Velocity of the wall's surface at the contact point.
    pub wall_velocity: V3<R>,
}

impl<R: Real> WallContact<R> {
    /// The lever from the centre of a sphere (radius `r`, mass `m`, velocity `v`, angular
    /// velocity `w`) to the contact point, and the contact law's input for this contact (a wall
    /// acts as infinitely heavy and flat: R* = r, m* = m).
    #[inline(always)]
    pub fn sphere_input(&self, r: R, m: R, v: V3<R>, w: V3<R>) -> (V3<R>, ContactInput<R>) {
        let n = self.normal;
        let lever = -(n * (r - self.overlap * R::from_f64(0.5)));
        let input = ContactInput {
            overlap: self.overlap,
            normal: n,
            v_rel: v + w.cross(lever) - self.wall_velocity,
            r_eff: r,
            m_eff: m,
        };
        (lever, input)
    }
}

/// A wall in the run's precision.
#[derive(Clone, Copy, Debug)]
pub struct WallKernel<R: Real> {
    kind: u8,
    /// The anchor that centre offsets are taken from: a point of a plane, the cylinder's axis
    /// at z = 0, the orifice's centre.
    a: V3<R>,
    b: V3<R>,
    r: R,
    z0: R,
    z1: R,
    rot_center: V3<R>,
    omega: R,
}

impl Wall {
    pub fn kernel<R: Real>(&self) -> WallKernel<R> {
        let (rot_center, omega) = match self.rotation {
            Some(r) => (
                V3::from_f64([r.axis_xy[0], r.axis_xy[1], 0.0]),
                R::from_f64(r.omega_rad_per_s),
            ),
            None => (V3::zero(), R::zero()),
        };
        match self.shape {
            WallShape::Plane { point, normal } => {
                let l = (normal[0].powi(2) + normal[1].powi(2) + normal[2].powi(2)).sqrt();
                let n = [normal[0] / l, normal[1] / l, normal[2] / l];
                WallKernel {
                    kind: 0,
                    a: V3::from_f64(point),
                    b: V3::from_f64(n),
                    r: R::zero(),
                    z0: R::zero(),
                    z1: R::zero(),
                    rot_center,
                    omega,
                }
            }
            WallShape::Cylinder {
                axis_xy,
                radius,
                z_min,
                z_max,
            } => WallKernel {
                kind: 1,
                a: V3::from_f64([axis_xy[0], axis_xy[1], 0.0]),
                b: V3::zero(),
                r: R::from_f64(radius),
                z0: R::from_f64(z_min),
                z1: R::from_f64(z_max),
                rot_center,
                omega,
            },
            WallShape::OrificePlate {
                z,
                center_xy,
                orifice_radius,
            } => WallKernel {
                kind: 2,
                a: V3::from_f64([center_xy[0], center_xy[1], z]),
                b: V3::zero(),
                r: R::from_f64(orifice_radius),
                z0: R::from_f64(z),
                z1: R::zero(),
                rot_center,
                omega,
            },
        }
    }
}

impl<R: Real> WallKernel<R> {
    /// Whether a sphere of radius `rad` whose centre stays within `m` of `p` may touch this
    /// wall: false only when a lower bound on its distance from the wall exceeds the radius,
    /// so that `touch` gives nothing anywhere within `m`. Walls do not move (a rotating wall
    /// only gives its surface a velocity), so a particle's walls can be picked once per list
    /// build (with `m` the skin) and the others skipped until the next.
    pub fn may_touch(&self, p: V3<R>, rad: R, m: R) -> bool {
        let reach = rad + m;
        match self.kind {
            0 => (p - self.a).dot(self.b) < reach,
            1 => {
                if p.z < self.z0 - m || p.z > self.z1 + m {
                    return false;
                }
                let (dx, dy) = (p.x - self.a.x, p.y - self.a.y);
                self.r - (dx * dx + dy * dy).sqrt() < reach
            }
            // The plate's face or its rim, both in the plane z = z0.
            _ => (p.z - self.z0).abs() < reach,
        }
    }

    /// The contact of a sphere (centre `p`, radius `rad`) with this wall, if they overlap.
    #[inline]
    pub fn touch(&self, p: V3<R>, rad: R) -> Option<WallContact<R>> {
        self.touch_split(p, V3::zero(), rad)
    }

    /// `touch` for a split position (`p` + `lo`: `position.rs`): the centre's offset from the
    /// wall's anchor is formed as precisely as a separation of two particles.
    #[inline]
    pub(crate) fn touch_split(&self, p: V3<R>, lo: V3<R>, rad: R) -> Option<WallContact<R>> {
        let rel = position::relative(p, lo, self.a);
        let (normal, dist, point) = match self.kind {
            0 => plane::touch(self, rel, p, rad)?,
            1 => cylinder::touch(self, rel, p, rad)?,
            _ => orifice_plate::touch(self, rel, p, rad)?,
        };
        let wall_velocity = if self.omega != R::zero() {
            // v = Ω ẑ × (q − c)
            let rel = point - self.rot_center;
            V3::new(-self.omega * rel.y, self.omega * rel.x, R::zero())
        } else {
            V3::zero()
        };
        Some(WallContact {
            normal,
            overlap: rad - dist,
            wall_velocity,
        })
    }

    /// The contact of a spherocylinder (centre `c`, unit axis `axis`) with this wall, if they
    /// overlap, and the wall's surface velocity there. Planes are exact (`shape::contact_plane`,
    /// which gives a rod lying flat its contact under the centre). Cylinder and orifice plate
    /// take the deepest of the axis' two end spheres and its centre sphere: exact for a rod
    /// touching with one end, approximate for one lying along the surface (no scene of sweep puts
    /// rods against those walls yet). `lo` is the rest of a split centre (`position.rs`).
    #[inline]
    pub fn touch_oriented(
        &self,
        c: V3<R>,
        lo: V3<R>,
        axis: V3<R>,
        shape: &Spherocylinder<R>,
    ) -> Option<(PlaneContact<R>, V3<R>)> {
        if self.kind == 0 || shape.half_length == R::zero() {
            let pc = if self.kind == 0 && R::SPLIT_POSITIONS {
                // The centre relative to the plane's point, as precise as a separation.
                let rel = position::relative(c, lo, self.a);
                contact_plane(rel, axis, shape, V3::zero(), self.b)?
            } else if self.kind == 0 {
                contact_plane(c, axis, shape, self.a, self.b)?
            } else {
                let wc = self.touch_split(c, lo, shape.radius)?;
                let arm = -(wc.normal * (shape.radius - wc.overlap * R::from_f64(0.5)));
                return Some((
                    PlaneContact {
                        normal: wc.normal,
                        overlap: wc.overlap,
                        arm,
                    },
                    wc.wall_velocity,
                ));
            };
            let v = self.surface_velocity(c + pc.arm);
            return Some((pc, v));
        }
        let h = axis * shape.half_length;
        let mut best: Option<(PlaneContact<R>, V3<R>)> = None;
        for offset in [h, -h, V3::zero()] {
            if let Some(wc) = self.touch_split(c + offset, lo, shape.radius) {
                if best.is_none_or(|(b, _)| wc.overlap > b.overlap) {
                    let arm = offset - wc.normal * (shape.radius - wc.overlap * R::from_f64(0.5));
                    best = Some((
                        PlaneContact {
                            normal: wc.normal,
                            overlap: wc.overlap,
                            arm,
                        },
                        wc.wall_velocity,
                    ));
                }
            }
        }
        best
    }

    /// Velocity of the wall's surface at `point` (zero unless the wall rotates).
    #[inline]
    fn surface_velocity(&self, point: V3<R>) -> V3<R> {
        if self.omega != R::zero() {
            let rel = point - self.rot_center;
            V3::new(-self.omega * rel.y, self.omega * rel.x, R::zero())
        } else {
            V3::zero()
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::{Wall, WallShape};
    use crate::engine::real::V3;

    /// `may_touch` never rules out a wall that a sphere moved by up to `m` touches: random
    /// centres near each kind of wall (plate face and rim, cylinder side and ends, a tilted
    /// plane), random moves of length up to m.
    #[test]
    fn may_touch_never_misses_a_contact_within_the_margin() {
        let shapes = [
            WallShape::Plane {
                point: [0.0, 0.0, -0.01],
                normal: [0.0, 0.6, 0.8],
            },
            WallShape::Cylinder {
                axis_xy: [0.01, 0.0],
                radius: 0.05,
                z_min: 0.0,
                z_max: 0.1,
            },
            WallShape::OrificePlate {
                z: 0.0,
                center_xy: [0.0, 0.0],
                orifice_radius: 0.013,
            },
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (rad, m) = (0.003, 0.0012);
        for shape in shapes {
            let wall = Wall {
                shape,
                rotation: None,
            }
            .kernel::<f64>();
            let (mut touched, mut ruled_out) = (0, 0);
            for _ in 0..200_000 {
                let p0 = V3::new(
                    rng.random_range(-0.07..0.07),
                    rng.random_range(-0.07..0.07),
                    rng.random_range(-0.03..0.13),
                );
                let may = wall.may_touch(p0, rad, m);
                ruled_out += usize::from(!may);
                let dir: V3<f64> = V3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                let p = p0 + dir * (m * rng.random::<f64>() / dir.norm().max(1e-9));
                if wall.touch(p, rad).is_some() {
                    touched += 1;
                    assert!(may, "{shape:?}: a sphere at {p0:?} moved to {p:?} touches");
                }
            }
            // The test means something only if both outcomes occur often.
            assert!(
                touched > 1000 && ruled_out > 10_000,
                "{touched} {ruled_out}"
            );
        }
    }
}
