//! The spherocylinder: a segment of length l along the body z axis swept by a ball of radius
//! d/2, total length L = l + d, aspect ratio ξ = L/d (ξ = 1 is a sphere). Owns its mass and
//! inertia and its contacts with another spherocylinder, a sphere (the chute's rough base) and a
//! plane wall, as pure functions of the geometry; not the force law (`contact::hertz_mindlin`), the
//! neighbour search or the state arrays.
//!
//! Contacts follow the sphere convention of the CPU engine, so ξ = 1 gives the sphere result bit
//! for bit: the normal points from j to i, the overlap is δ = ri + rj − |p − q| for the closest
//! axis points p (on i) and q (on j), and the contact point sits in the middle of the overlap,
//! p − n (ri − δ/2) = q + n (rj − δ/2). The force on i is the gradient of a potential of δ, and
//! δ depends on the orientations only through the closest points, so the lever arm to them is the
//! conservative one; where the closest points are not unique (parallel axes, an axis parallel to
//! a plane) the middle of the touching part is taken, the mean of the one-sided gradients, with a
//! linear ramp to the exact points over θc < sin θ < 2θc (`segment::PARALLEL_SIN`) so that the
//! contact point never jumps.
//!
//! Inputs are the centre-to-centre vector ci − cj (the caller applies the minimum image) and unit
//! axes (`Quat::axis_z` of the orientations); outputs are lever arms from each centre. The pair
//! result is not bitwise antisymmetric under swapping i and j: the engine should evaluate each
//! pair in one canonical order (e.g. lower id first) and negate for the partner.

use super::segment::{closest_points, PARALLEL_SIN};
use crate::engine::real::{Real, V3};

/// The shape parameters of a spherocylinder (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spherocylinder<R> {
    /// l/2: half the length of the axis segment (0 for a sphere).
    pub half_length: R,
    /// d/2: the radius of the caps and the cylinder.
    pub radius: R,
}

/// A contact between particle i (a spherocylinder) and a partner j.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairContact<R> {
    /// Unit normal pointing from j to i.
    pub normal: V3<R>,
    /// Overlap δ > 0 (m).
    pub overlap: R,
    /// Contact point minus the centre of i (m): the lever arm of the force on i.
    pub arm_i: V3<R>,
    /// Contact point minus the centre of j (m).
    pub arm_j: V3<R>,
}

/// A contact between a spherocylinder and a plane wall.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneContact<R> {
    /// The wall's unit normal (from the wall to the particle).
    pub normal: V3<R>,
    /// Overlap δ > 0 (m).
    pub overlap: R,
    /// Contact point minus the particle's centre (m).
    pub arm: V3<R>,
}

impl<R: Real> Spherocylinder<R> {
    /// From the cylinder length l and the diameter d (m).
    pub fn new(cylinder_length: R, diameter: R) -> Self {
        let half = R::from_f64(0.5);
        Self {
            half_length: cylinder_length * half,
            radius: diameter * half,
        }
    }

    /// From the total length L = l + d (m) and the aspect ratio ξ = L/d: d = L/ξ, l = L − d (the
    /// paper fixes L and varies ξ). `None` unless L > 0 and ξ ≥ 1, both finite.
    pub fn from_aspect_ratio(total_length: R, aspect_ratio: R) -> Option<Self> {
        let ok = total_length.is_finite()
            && aspect_ratio.is_finite()
            && total_length > R::zero()
            && aspect_ratio >= R::one();
        if !ok {
            return None;
        }
        let d = total_length / aspect_ratio;
        Some(Self::new((total_length - d).max(R::zero()), d))
    }

    /// A sphere of radius `radius` (l = 0).
    pub fn sphere(radius: R) -> Self {
        Self {
            half_length: R::zero(),
            radius,
        }
    }

    /// l (m).
    pub fn cylinder_length(&self) -> R {
        self.half_length * R::from_f64(2.0)
    }

    /// d (m).
    pub fn diameter(&self) -> R {
        self.radius * R::from_f64(2.0)
    }

    /// L = l + d (m).
    pub fn total_length(&self) -> R {
        self.cylinder_length() + self.diameter()
    }

    /// ξ = L/d.
    pub fn aspect_ratio(&self) -> R {
        self.total_length() / self.diameter()
    }

    /// L/2 (m): the radius of the smallest ball around the particle (sizes the grid cells).
    pub fn bounding_radius(&self) -> R {
        self.half_length + self.radius
    }

    /// Volume π r² l + 4/3 π r³ (m³).
    pub fn volume(&self) -> R {
        let pi = R::from_f64(std::f64::consts::PI);
        let r2 = self.radius * self.radius;
        pi * r2 * (self.cylinder_length() + R::from_f64(4.0 / 3.0) * self.radius)
    }

    /// Mass ρ V (kg) for density `density` (kg/m³).
    pub fn mass(&self, density: R) -> R {
        density * self.volume()
    }

    /// Principal moments of inertia (I⊥, I⊥, I∥) (kg m²) about the centre, in the body frame
    /// (axis = body z), of a solid spherocylinder of density `density` (kg/m³). With the cylinder
    /// mass m_c = ρπr²l and the mass of both caps m_s = ρ 4/3 πr³:
    /// I∥ = m_c r²/2 + 2/5 m_s r²;
    /// I⊥ = m_c (l²/12 + r²/4) + m_s (2/5 r² + l²/4 + 3/8 l r),
    /// the caps' term being a hemisphere's 2/5 m r² about its face diameter, moved to its centroid
    /// 3r/8 off the face and then to the body centre l/2 + 3r/8 away.
    pub fn inertia(&self, density: R) -> V3<R> {
        let pi = R::from_f64(std::f64::consts::PI);
        let (r, l) = (self.radius, self.cylinder_length());
        let (r2, l2) = (r * r, l * l);
        let m_c = density * pi * r2 * l;
        let m_s = density * R::from_f64(4.0 / 3.0) * pi * r2 * r;
        let f = R::from_f64;
        let axial = m_c * r2 * f(0.5) + m_s * r2 * f(0.4);
        let perp = m_c * (l2 / f(12.0) + r2 * f(0.25))
            + m_s * (r2 * f(0.4) + l2 * f(0.25) + l * r * f(3.0 / 8.0));
        V3::new(perp, perp, axial)
    }

    /// The effective mass (kg) of the rod struck at the tip of its axis across the axis, its
    /// lightest contact: 1/m* = 1/m + (l/2)²/I⊥ (`contact::pair_effective_mass`; m for a
    /// sphere). Two such rods meet with half of it, which bounds the contact time from below.
    pub fn tip_mass(&self, density: R) -> R {
        let m = self.mass(density);
        let h = self.half_length;
        R::one() / (R::one() / m + h * h / self.inertia(density).x)
    }
}

/// A unit vector perpendicular to the unit vector `u`, chosen deterministically: `u` crossed with
/// the coordinate axis it is least aligned with.
fn perpendicular<R: Real>(u: V3<R>) -> V3<R> {
    let (ax, ay, az) = (u.x.abs(), u.y.abs(), u.z.abs());
    let (o, z) = (R::one(), R::zero());
    let e = if ax <= ay && ax <= az {
        V3::new(o, z, z)
    } else if ay <= az {
        V3::new(z, o, z)
    } else {
        V3::new(z, z, o)
    };
    let p = u.cross(e);
    p * (o / p.norm())
}

/// The normal for axes that touch (|p − q| = 0): along ui × uj if the axes cross, else the part
/// of the centre vector `d` across ui, else any perpendicular of ui. Deterministic; such exact
/// touching needs δ = ri + rj and never happens in a stable run.
fn touching_normal<R: Real>(d: V3<R>, ui: V3<R>, uj: V3<R>) -> V3<R> {
    let tiny = R::from_f64(1e-24);
    let c = ui.cross(uj);
    let c2 = c.norm2();
    if c2 > tiny {
        return c * (R::one() / c2.sqrt());
    }
    let across = d - ui * d.dot(ui);
    let a2 = across.norm2();
    if a2 > tiny * d.norm2() && a2 > R::zero() {
        return across * (R::one() / a2.sqrt());
    }
    perpendicular(ui)
}

/// The contact of spherocylinder i with spherocylinder j, if they overlap.
///
/// `d` = ci − cj (m, minimum image), `ui`, `uj` their unit axes. Returns the normal from j to i,
/// the overlap and the lever arms (module doc). With both half-lengths zero this is the sphere
/// contact of the CPU engine, bit for bit.
#[inline]
pub fn contact_spherocylinders<R: Real>(
    d: V3<R>,
    ui: V3<R>,
    shape_i: &Spherocylinder<R>,
    uj: V3<R>,
    shape_j: &Spherocylinder<R>,
) -> Option<PairContact<R>> {
    let hi = ui * shape_i.half_length;
    let hj = uj * shape_j.half_length;
    // In the frame of cj: axis i runs from d − hi to d + hi, axis j from −hj to hj.
    let cp = closest_points(d - hi, hi + hi, -hj, hj + hj);
    let (ri, rj) = (shape_i.radius, shape_j.radius);
    let sum = ri + rj;
    if cp.dist2 >= sum * sum {
        return None;
    }
    let dist = cp.dist2.sqrt();
    let normal = if dist > R::zero() {
        (cp.p - cp.q) * (R::one() / dist)
    } else {
        touching_normal(d, ui, uj)
    };
    let overlap = sum - dist;
    let half_ov = overlap * R::from_f64(0.5);
    // Axis points relative to their own centres: h (2s − 1) is exactly 0 for a sphere.
    let two = R::from_f64(2.0);
    let on_i = hi * (cp.s * two - R::one());
    let on_j = hj * (cp.t * two - R::one());
    Some(PairContact {
        normal,
        overlap,
        arm_i: on_i - normal * (ri - half_ov),
        arm_j: on_j + normal * (rj - half_ov),
    })
}

/// The contact of spherocylinder i with a sphere j of radius `sphere_radius` (a fixed grain of the
/// rough base), if they overlap; `d` = ci − cj (m, minimum image).
#[inline]
pub fn contact_sphere<R: Real>(
    d: V3<R>,
    ui: V3<R>,
    shape_i: &Spherocylinder<R>,
    sphere_radius: R,
) -> Option<PairContact<R>> {
    contact_spherocylinders(d, ui, shape_i, ui, &Spherocylinder::sphere(sphere_radius))
}

/// The contact of a spherocylinder (centre `centre`, unit axis `axis`) with the plane through
/// `plane_point` with unit normal `plane_normal` (particles live on the side it points to), if
/// they overlap.
///
/// The overlap is r − h_min, h_min the height of the lower axis end above the plane. The contact
/// point lies below the lower axis end once the axis is tilted by sin θ ≥ 2θc (θc =
/// [`PARALLEL_SIN`]), below the centre — the middle of the touching axis — for sin θ ≤ θc (a rod
/// lying flat gets no spurious torque), and moves linearly between the two in between, so it
/// never jumps. For a sphere (l = 0) this is the engine's plane wall, bit for bit.
#[inline]
pub fn contact_plane<R: Real>(
    centre: V3<R>,
    axis: V3<R>,
    shape: &Spherocylinder<R>,
    plane_point: V3<R>,
    plane_normal: V3<R>,
) -> Option<PlaneContact<R>> {
    let n = plane_normal;
    let r = shape.radius;
    let h = axis * shape.half_length;
    // Heights of the centre and of the lower axis end above the plane.
    let above = (centre - plane_point).dot(n);
    let lowest = above - h.dot(n).abs();
    if lowest >= r {
        return None;
    }
    let overlap = r - lowest;
    // Axial position σ ∈ [−1, 1] of the contact (point = centre + σ h): the lower end (σ = ∓1)
    // for |sin θ| ≥ 2θc, the centre for |sin θ| ≤ θc, linear in between.
    let tilt = axis.dot(n);
    let ramp = (tilt.abs() / R::from_f64(PARALLEL_SIN) - R::one())
        .max(R::zero())
        .min(R::one());
    let sigma = if tilt > R::zero() { -ramp } else { ramp };
    Some(PlaneContact {
        normal: n,
        overlap,
        arm: h * sigma - n * (r - overlap * R::from_f64(0.5)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aspect_ratio_round_trips() {
        let s = Spherocylinder::<f64>::from_aspect_ratio(0.125, 2.5).unwrap();
        assert!((s.aspect_ratio() - 2.5).abs() < 1e-14);
        assert!((s.total_length() - 0.125).abs() < 1e-16);
        assert_eq!(
            Spherocylinder::<f64>::from_aspect_ratio(0.125, 1.0)
                .unwrap()
                .half_length,
            0.0
        );
        assert!(Spherocylinder::<f64>::from_aspect_ratio(0.125, 0.9).is_none());
    }

    #[test]
    fn a_sphere_has_the_sphere_inertia() {
        let s = Spherocylinder::<f64>::sphere(0.5);
        let m = s.mass(2.0);
        let i = s.inertia(2.0);
        assert!((m - 2.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.125).abs() < 1e-15);
        for k in [i.x, i.y, i.z] {
            assert!((k - 0.4 * m * 0.25).abs() < 1e-15);
        }
    }
}
