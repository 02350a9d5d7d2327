//! The per-particle force gather over full lists: contact records, elastic energy, rods.

use super::kept_spring::gathered_force;
use super::oriented::OrientedContext;
use super::particle::Status;
use crate::engine::contact::{elastic_energy, ContactInput, ContactRecord, LawKernel};
use crate::engine::grid::{NeighbourList, Periodic};
use crate::engine::history::{wall_key, Rows};
use crate::engine::real::{Real, V3};
use crate::engine::state::State;
use crate::engine::walls::WallKernel;

/// Everything the per-particle force gather reads.
pub(super) struct ForceContext<'a, R: Real> {
    pub(super) s: &'a State<R>,
    pub(super) list: &'a NeighbourList<R>,
    pub(super) alive: &'a [Status],
    pub(super) law_pp: &'a LawKernel<R>,
    pub(super) law_pw: &'a LawKernel<R>,
    pub(super) walls: &'a [WallKernel<R>],
    pub(super) periodic: &'a Periodic<R>,
    pub(super) dt: R,
}

impl<'a, R: Real> ForceContext<'a, R> {
    /// The gather of oriented particle i (`oriented.rs`).
    #[inline]
    pub(super) fn oriented(&self, i: usize) -> OrientedContext<'a, R> {
        let cnt = self.list.count[i] as usize;
        OrientedContext {
            s: self.s,
            neighbours: [
                &self.list.index[i * self.list.stride..i * self.list.stride + cnt],
                &[],
            ],
            alive: self.alive,
            law_pp: self.law_pp,
            law_pw: self.law_pw,
            walls: self.walls,
            periodic: self.periodic,
            dt: self.dt,
        }
    }

    /// Elastic energy of particle i's contacts (J): half of each pair's (both particles count
    /// it), all of each wall's, with the springs as stored. The watchdog's, once per chunk.
    pub(super) fn elastic_energy(&self, i: usize) -> f64 {
        let s = self.s;
        if self.alive[i] != Status::Alive {
            return 0.0;
        }
        let (pi, ri) = (s.pos[i], s.radius[i]);
        let fixed_i = s.inv_mass[i] == R::zero();
        let cnt = self.list.count[i] as usize;
        let row = &self.list.index[i * self.list.stride..i * self.list.stride + cnt];
        let mut e = 0.0;
        for &j in row {
            let j = j as usize;
            if self.alive[j] != Status::Alive || (fixed_i && s.inv_mass[j] == R::zero()) {
                continue;
            }
            let rj = s.radius[j];
            let sum = ri + rj;
            let dist2 = s.separation(self.periodic, j, i).norm2();
            if dist2 >= sum * sum {
                continue;
            }
            let spring = s.history.spring_of(i, s.id[j]);
            let u = elastic_energy(self.law_pp, sum - dist2.sqrt(), ri * rj / sum, spring);
            e += 0.5 * u.to_f64();
        }
        if !fixed_i {
            for (w, wall) in self.walls.iter().enumerate() {
                if let Some(wc) = wall.touch_split(pi, s.lo(i), ri) {
                    let spring = s.history.spring_of(i, wall_key(w));
                    e += elastic_energy(self.law_pw, wc.overlap, ri, spring).to_f64();
                }
            }
        }
        e
    }

    /// Force, torque, largest overlap ratio, contact count and "history full" for particle i.
    /// With `RECORD`, also appends each contact once (from the lower id, or from the mobile
    /// particle when the partner is fixed) to `records`.
    #[inline]
    pub(super) fn particle<const RECORD: bool>(
        &self,
        i: usize,
        mut rows: Option<&mut Rows<'_, R>>,
        records: &mut Vec<ContactRecord>,
    ) -> (V3<R>, V3<R>, R, u32, bool) {
        let s = self.s;
        let mut f = V3::zero();
        let mut t = V3::zero();
        let mut max_ov = R::zero();
        let mut nc = 0u32;
        let mut full = false;
        if self.alive[i] != Status::Alive {
            return (f, t, max_ov, nc, full);
        }
        let pi = s.pos[i];
        let ri = s.radius[i];
        let mi = s.mass[i];
        let vi = s.vel[i];
        let wi = if s.rotation { s.omega[i] } else { V3::zero() };
        let fixed_i = s.inv_mass[i] == R::zero();
        let cnt = self.list.count[i] as usize;
        let row = &self.list.index[i * self.list.stride..i * self.list.stride + cnt];
        for &j in row {
            let j = j as usize;
            if self.alive[j] != Status::Alive {
                continue;
            }
            // Fixed particles feel no force: skip pairs of two fixed ones entirely.
            let fixed_j = s.inv_mass[j] == R::zero();
            if fixed_i && fixed_j {
                continue;
            }
            let d = s.separation(self.periodic, j, i); // from j to i
            let rj = s.radius[j];
            let dist2 = d.norm2();
            let sum = ri + rj;
            if dist2 >= sum * sum {
                continue;
            }
            let dist = dist2.sqrt();
            let n = d * (R::one() / dist);
            let overlap = sum - dist;
            let half_ov = overlap * R::from_f64(0.5);
            let bi = -(n * (ri - half_ov));
            let bj = n * (rj - half_ov);
            let wj = if s.rotation { s.omega[j] } else { V3::zero() };
            let v_rel = (vi + wi.cross(bi)) - (s.vel[j] + wj.cross(bj));
            let mj = s.mass[j];
            // A fixed partner acts as infinitely heavy.
            let m_eff = if fixed_j {
                mi
            } else if fixed_i {
                mj
            } else {
                mi * mj / (mi + mj)
            };
            let c = ContactInput {
                overlap,
                normal: n,
                v_rel,
                r_eff: ri * rj / sum,
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
            f += fc;
            t += bi.cross(fc);
            max_ov = max_ov.max(overlap / (ri.min(rj) * R::from_f64(2.0)));
            nc += 1;
            if RECORD && !fixed_i && (fixed_j || s.id[i] < s.id[j]) {
                records.push(ContactRecord {
                    i: s.id[i],
                    j: Some(s.id[j]),
                    pos_i: pi.to_f64(),
                    branch: d.to_f64(),
                    force_on_i: fc.to_f64(),
                    j_fixed: fixed_j,
                });
            }
        }
        if !fixed_i {
            for (w, wall) in self.walls.iter().enumerate() {
                if let Some(wc) = wall.touch_split(pi, s.lo(i), ri) {
                    let (bi, c) = wc.sphere_input(ri, mi, vi, wi);
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
                    t += bi.cross(fc);
                    max_ov = max_ov.max(wc.overlap / (ri * R::from_f64(2.0)));
                    nc += 1;
                    if RECORD {
                        records.push(ContactRecord {
                            i: s.id[i],
                            j: None,
                            pos_i: pi.to_f64(),
                            branch: (-bi).to_f64(),
                            force_on_i: fc.to_f64(),
                            j_fixed: true,
                        });
                    }
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
