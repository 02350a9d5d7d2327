//! The CPU engine's path for oriented particles (spherocylinders, with spheres among them as
//! l = 0, such as the chute's rough base): the full-list contact gather with segment geometry
//! (contact records and the elastic energy of observers; the step itself runs on half lists,
//! `rod_pass.rs`, with the same operations per pair and the same order of each sum) and the
//! rotational half of the integrator. Sphere runs never enter this file.
//!
//! Each pair is evaluated in one canonical order, the lower id as "a", by both of its particles
//! from identical inputs, so both compute the same force bit for bit and apply ±F: the pair
//! geometry (`shape::contact_spherocylinders`) is not bitwise antisymmetric under a swap, and the
//! gather must not depend on which particle asks. Both copies of the tangential spring therefore
//! hold the same canonical value (a's view), unlike the sphere path's mirrored copies.
//!
//! Rotation is kick–rotate–kick on the lab angular momentum L with the exact free rotor of a
//! symmetric top (`shape::rigid`); ω = R I⁻¹ Rᵀ L is refreshed after every change of q or L, and is
//! what contacts read.

use super::kept_spring::gathered_force;
use super::particle::Status;
use super::rod_pass::inertial;
use crate::engine::contact::{
    elastic_energy, pair_effective_mass, wall_effective_mass, ContactInput, ContactRecord,
};
use crate::engine::history::{wall_key, Rows};
use crate::engine::real::{Real, V3};
use crate::engine::shape::{
    angular_velocity, contact_spherocylinders, rotate_free, Spherocylinder,
};
use crate::engine::state::State;

/// Per-particle output of the gather: force, torque, largest overlap ratio, contacts, table full.
pub(super) type Gathered<R> = (V3<R>, V3<R>, R, u32, bool);

/// One oriented particle's rotational kick and free rotation: L += τ kick; q ← free rotation over
/// `dt`; ω refreshed. Returns how far its ends moved off the list's reference axis (m).
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn kick_rotate<R: Real>(
    q: &mut crate::engine::shape::Quat<R>,
    l: &mut V3<R>,
    w: &mut V3<R>,
    torque: V3<R>,
    inv_inertia: V3<R>,
    half_length: R,
    ref_axis: Option<V3<R>>,
    kick: R,
    dt: R,
) -> R {
    if inv_inertia.x == R::zero() {
        // A fixed particle neither turns nor moves.
        return R::zero();
    }
    *l += torque * kick;
    *q = rotate_free(*q, *l, inv_inertia, dt);
    *w = angular_velocity(*q, inv_inertia, *l);
    match ref_axis {
        Some(u0) if half_length > R::zero() => (q.axis_z() - u0).norm() * half_length,
        _ => R::zero(),
    }
}

/// The closing rotational half kick of a chunk.
pub(super) fn close_kick<R: Real>(s: &mut State<R>, half: R) {
    use rayon::prelude::*;
    (
        s.ang_mom.par_iter_mut(),
        s.omega.par_iter_mut(),
        s.orientation.par_iter(),
        s.torque.par_iter(),
        s.inv_inertia_body.par_iter(),
    )
        .into_par_iter()
        .with_min_len(512)
        .for_each(|(l, w, &q, &t, &ii)| {
            if ii.x != R::zero() {
                *l += t * half;
                *w = angular_velocity(q, ii, *l);
            }
        });
}

/// What the gather of an oriented particle reads.
pub(super) struct OrientedContext<'a, R: Real> {
    pub s: &'a State<R>,
    /// The neighbours in ascending order, in one or two pieces (a full list's row; or a half
    /// list's earlier partners, then the later ones).
    pub neighbours: [&'a [u32]; 2],
    pub alive: &'a [Status],
    pub law_pp: &'a crate::engine::contact::LawKernel<R>,
    pub law_pw: &'a crate::engine::contact::LawKernel<R>,
    pub walls: &'a [crate::engine::walls::WallKernel<R>],
    pub periodic: &'a crate::engine::grid::Periodic<R>,
    pub dt: R,
}

impl<R: Real> OrientedContext<'_, R> {
    #[inline(always)]
    fn shape(&self, k: usize) -> Spherocylinder<R> {
        Spherocylinder {
            half_length: self.s.half_length[k],
            radius: self.s.radius[k],
        }
    }

    /// Elastic energy of oriented particle i's contacts (J): half of each pair's (both
    /// particles evaluate the pair in canonical order), all of each wall's, with the springs as
    /// stored. The watchdog's, once per chunk.
    pub fn elastic_energy(&self, i: usize) -> f64 {
        let s = self.s;
        if self.alive[i] != Status::Alive {
            return 0.0;
        }
        let fixed_i = s.inv_mass[i] == R::zero();
        let mut e = 0.0;
        for &j in self.neighbours[0].iter().chain(self.neighbours[1]) {
            let j = j as usize;
            if self.alive[j] != Status::Alive || (fixed_i && s.inv_mass[j] == R::zero()) {
                continue;
            }
            let (a, b) = if s.id[i] < s.id[j] { (i, j) } else { (j, i) };
            let (sa, sb) = (self.shape(a), self.shape(b));
            let Some(pc) = contact_spherocylinders(
                s.separation(self.periodic, b, a),
                s.orientation[a].axis_z(),
                &sa,
                s.orientation[b].axis_z(),
                &sb,
            ) else {
                continue;
            };
            let r_eff = sa.radius * sb.radius / (sa.radius + sb.radius);
            let spring = s.history.spring_of(i, s.id[j]);
            e += 0.5 * elastic_energy(self.law_pp, pc.overlap, r_eff, spring).to_f64();
        }
        if !fixed_i {
            let shape = self.shape(i);
            let axis = s.orientation[i].axis_z();
            for (w, wall) in self.walls.iter().enumerate() {
                if let Some((pc, _)) = wall.touch_oriented(s.pos[i], s.lo(i), axis, &shape) {
                    let spring = s.history.spring_of(i, wall_key(w));
                    e += elastic_energy(self.law_pw, pc.overlap, shape.radius, spring).to_f64();
                }
            }
        }
        e
    }

    /// Force, torque, largest overlap ratio, contact count and "history full" of particle i.
    /// With `RECORD`, also appends each contact once (pairs from the side of the lower id, or of
    /// the mobile particle when the partner is fixed) to `records`.
    #[inline]
    pub fn particle<const RECORD: bool>(
        &self,
        i: usize,
        mut rows: Option<&mut Rows<'_, R>>,
        records: &mut Vec<ContactRecord>,
    ) -> Gathered<R> {
        let s = self.s;
        let mut f = V3::zero();
        let mut t = V3::zero();
        let mut max_ov = R::zero();
        let mut nc = 0u32;
        let mut full = false;
        if self.alive[i] != Status::Alive {
            return (f, t, max_ov, nc, full);
        }
        let fixed_i = s.inv_mass[i] == R::zero();
        let two = R::from_f64(2.0);
        for &j in self.neighbours[0].iter().chain(self.neighbours[1]) {
            let j = j as usize;
            if self.alive[j] != Status::Alive {
                continue;
            }
            let fixed_j = s.inv_mass[j] == R::zero();
            if fixed_i && fixed_j {
                continue;
            }
            // Canonical order: a has the lower id.
            let i_is_a = s.id[i] < s.id[j];
            let (a, b) = if i_is_a { (i, j) } else { (j, i) };
            let d = s.separation(self.periodic, b, a); // c_a − c_b
            let (sa, sb) = (self.shape(a), self.shape(b));
            let Some(pc) = contact_spherocylinders(
                d,
                s.orientation[a].axis_z(),
                &sa,
                s.orientation[b].axis_z(),
                &sb,
            ) else {
                continue;
            };
            let v_rel =
                (s.vel[a] + s.omega[a].cross(pc.arm_i)) - (s.vel[b] + s.omega[b].cross(pc.arm_j));
            let m_eff = pair_effective_mass(
                inertial(s, a),
                inertial(s, b),
                pc.arm_i,
                pc.arm_j,
                pc.normal,
            );
            let c = ContactInput {
                overlap: pc.overlap,
                normal: pc.normal,
                v_rel,
                r_eff: sa.radius * sb.radius / (sa.radius + sb.radius),
                m_eff,
            };
            let key = s.id[j];
            let fc = gathered_force(
                self.law_pp,
                &c,
                rows.as_deref_mut(),
                key,
                self.dt,
                &mut full,
            );
            let (force_i, arm_i) = if i_is_a {
                (fc, pc.arm_i)
            } else {
                (-fc, pc.arm_j)
            };
            f += force_i;
            t += arm_i.cross(force_i);
            max_ov = max_ov.max(pc.overlap / (sa.radius.min(sb.radius) * two));
            nc += 1;
            if RECORD && !fixed_i && (fixed_j || i_is_a) {
                let branch = if i_is_a { d } else { -d };
                records.push(ContactRecord {
                    i: s.id[i],
                    j: Some(s.id[j]),
                    pos_i: s.pos[i].to_f64(),
                    branch: branch.to_f64(),
                    force_on_i: force_i.to_f64(),
                    j_fixed: fixed_j,
                });
            }
        }
        if !fixed_i {
            let shape = self.shape(i);
            let axis = s.orientation[i].axis_z();
            for (w, wall) in self.walls.iter().enumerate() {
                let Some((pc, wall_velocity)) =
                    wall.touch_oriented(s.pos[i], s.lo(i), axis, &shape)
                else {
                    continue;
                };
                let v_rel = s.vel[i] + s.omega[i].cross(pc.arm) - wall_velocity;
                let c = ContactInput {
                    overlap: pc.overlap,
                    normal: pc.normal,
                    v_rel,
                    r_eff: shape.radius,
                    m_eff: wall_effective_mass(inertial(s, i), pc.arm, pc.normal),
                };
                let key = wall_key(w);
                let fc = gathered_force(
                    self.law_pw,
                    &c,
                    rows.as_deref_mut(),
                    key,
                    self.dt,
                    &mut full,
                );
                f += fc;
                t += pc.arm.cross(fc);
                max_ov = max_ov.max(pc.overlap / (shape.radius * two));
                nc += 1;
                if RECORD {
                    records.push(ContactRecord {
                        i: s.id[i],
                        j: None,
                        pos_i: s.pos[i].to_f64(),
                        branch: (-pc.arm).to_f64(),
                        force_on_i: fc.to_f64(),
                        j_fixed: true,
                    });
                }
            }
        }
        if fixed_i {
            f = V3::zero();
            t = V3::zero();
        }
        (f, t, max_ov, nc, full)
    }
}
