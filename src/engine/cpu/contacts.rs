//! Contacts for observers: the list of contact records and the elastic energy stored in the
//! contacts (full lists, or the sphere half lists), computed only when asked.

use rayon::prelude::*;

use super::force_gather::ForceContext;
use super::particle::Status;
use super::{CpuEngine, MIN_LEN};
use crate::engine::contact::{elastic_energy, ContactRecord};
use crate::engine::history::Rows;
use crate::engine::real::{Real, V3};

impl<R: Real> CpuEngine<R> {
    /// A gather over the current lists that reads forces without advancing any spring (dt = 0):
    /// what contact records and the elastic energy need.
    fn reading_context(&self) -> ForceContext<'_, R> {
        ForceContext {
            s: &self.state,
            list: &self.list,
            alive: &self.alive,
            law_pp: &self.law_pp,
            law_pw: &self.law_pw,
            walls: &self.walls,
            periodic: &self.periodic,
            dt: R::zero(),
        }
    }

    /// Every contact of the current state, each once, with the force of the last step (the
    /// stored springs, not advanced: dt = 0), for stress observers. Runs only when asked.
    pub fn contact_records(&mut self) -> Vec<ContactRecord> {
        self.rebuild();
        let n = self.state.len();
        let slots = self.state.history.slots;
        let mut hist = self.state.history.clone();
        let ctx = self.reading_context();
        let mut out = Vec::new();
        for i in 0..n {
            let mut rows = (slots > 0).then(|| {
                Rows::open(
                    &mut hist.partner[i * slots..(i + 1) * slots],
                    &mut hist.spring[i * slots..(i + 1) * slots],
                )
            });
            if self.state.oriented {
                ctx.oriented(i).particle::<true>(i, rows.as_mut(), &mut out);
            } else {
                ctx.particle::<true>(i, rows.as_mut(), &mut out);
            }
        }
        out
    }

    /// Elastic energy stored in the contacts of the current state (J): normal springs plus
    /// tangential springs as stored (`contact::elastic_energy`). Runs only when asked.
    pub fn elastic_energy(&mut self) -> f64 {
        self.rebuild();
        self.sum_elastic_energy()
    }

    /// `elastic_energy` from the current (fresh) lists. Summed in particle order, so the same
    /// for any thread count.
    pub(super) fn sum_elastic_energy(&self) -> f64 {
        let ctx = self.reading_context();
        let oriented = self.state.oriented;
        let per: Vec<f64> = self.pool.install(|| {
            (0..self.state.len())
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|i| {
                    if oriented {
                        ctx.oriented(i).elastic_energy(i)
                    } else {
                        ctx.elastic_energy(i)
                    }
                })
                .collect()
        });
        per.iter().sum()
    }

    /// Elastic energy of the contacts from the half lists and slots (each pair once), summed in
    /// particle order in f64 (the same for any thread count). Needs fresh lists.
    pub(super) fn pair_elastic_energy(&self) -> f64 {
        let s = &self.state;
        let (half, ps, props) = (&self.half, &self.pair_slots, &self.props);
        let nw = self.walls.len();
        let per: Vec<f64> = self.pool.install(|| {
            (0..s.len())
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|i| {
                    if self.alive[i] != Status::Alive {
                        return 0.0;
                    }
                    let (pi, ri) = (s.pos[i], s.radius[i]);
                    let mut e = 0.0;
                    let entries = half.start[i] as usize..half.start[i + 1] as usize;
                    for (&j, slot) in half.nbr[entries.clone()].iter().zip(&ps[entries]) {
                        let j = j as usize;
                        if self.alive[j] != Status::Alive {
                            continue;
                        }
                        let rj = s.radius[j];
                        let sum = ri + rj;
                        let dist2 = s.separation(&self.periodic, j, i).norm2();
                        if dist2 >= sum * sum {
                            continue;
                        }
                        let sp = if slot.touching() {
                            slot.spring
                        } else {
                            V3::zero()
                        };
                        e += elastic_energy(&self.law_pp, sum - dist2.sqrt(), ri * rj / sum, sp)
                            .to_f64();
                    }
                    if props[i].inv_m != R::zero() {
                        for (w, wall) in self.walls.iter().enumerate() {
                            if let Some(wc) = wall.touch_split(
                                pi,
                                s.pos_lo.get(i).copied().unwrap_or_default(),
                                ri,
                            ) {
                                let sp = self.wall_springs[i * nw + w];
                                e += elastic_energy(&self.law_pw, wc.overlap, ri, sp).to_f64();
                            }
                        }
                    }
                    e
                })
                .collect()
        });
        per.iter().sum()
    }
}
