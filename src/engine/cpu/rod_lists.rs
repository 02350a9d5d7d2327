//! The spherocylinders' half lists: their build (re-sort, pair slots, axes) and the contact
//! history's trips between the pair slots and the state's table, in the table's rod format
//! (each row: the touching partners in ascending order with the pair's canonical spring, then
//! the touching walls; what the full-list gather of `oriented.rs` wrote).

use super::oriented::OrientedContext;
use super::pair_pass::PairSlot;
use super::particle::Status;
use super::rod_pass::RodKin;
use super::CpuEngine;
use crate::engine::grid;
use crate::engine::history::{wall_key, History, EMPTY};
use crate::engine::real::{Real, V3};

impl<R: Real> CpuEngine<R> {
    /// Re-sorts the rods by cell and rebuilds the half lists; each entry's and wall's spring
    /// comes from the state's table (which stays in the state), by partner key. With
    /// `from_pairs` the table is first written from the current slots (a rebuild inside a
    /// chunk).
    pub(super) fn rebuild_rods(&mut self, from_pairs: bool) {
        if from_pairs {
            self.state.history = self
                .rods_to_history(None)
                .expect("unsized history rows cannot overflow");
        }
        self.compact();
        let (periodic, skin) = (self.periodic, self.skin);
        let (state, half) = (&mut self.state, &mut self.half);
        self.pool
            .install(|| grid::build_half(state, &periodic, skin, half));
        let n = self.state.len();
        let nw = self.walls.len();
        self.alive = vec![Status::Alive; n];
        let s = &self.state;
        let hist = &s.history;
        // A stored row lists the contacts that touched: their springs, marked touching.
        let slot_of = |i: usize, key: u32| -> PairSlot<R> {
            let row = i * hist.slots..(i + 1) * hist.slots;
            for (&p, &sp) in hist.partner[row.clone()].iter().zip(&hist.spring[row]) {
                if p == key {
                    return PairSlot {
                        spring: sp,
                        h: R::zero(),
                    };
                }
                if p == EMPTY {
                    break;
                }
            }
            PairSlot::default()
        };
        self.pair_slots.clear();
        self.rod_walls.clear();
        if hist.slots > 0 {
            let half = &self.half;
            self.pair_slots.extend(
                (0..half.len())
                    .map(|e| slot_of(half.owner[e] as usize, s.id[half.nbr[e] as usize])),
            );
            self.rod_walls
                .extend((0..n * nw).map(|k| slot_of(k / nw, wall_key(k % nw))));
        } else {
            self.pair_slots.resize(self.half.len(), PairSlot::default());
            self.rod_walls.resize(n * nw, PairSlot::default());
        }
        self.axis.clear();
        self.axis.extend(s.orientation.iter().map(|q| q.axis_z()));
        self.rod_ref_axis.clone_from(&self.axis);
        let axis = &self.axis;
        self.rod_kin.clear();
        self.rod_kin
            .extend((0..n).map(|k| RodKin::of(&self.state, k, axis[k])));
    }

    /// Every touching contact of rod k as (partner key, spring), in row order: partners in
    /// ascending order (the entries where k is the partner, then its own), then walls.
    fn rod_row(&self, k: usize, put: &mut dyn FnMut(u32, V3<R>)) {
        let (half, ps, id) = (&self.half, &self.pair_slots, &self.state.id);
        for r in half.rstart[k] as usize..half.rstart[k + 1] as usize {
            let sl = &ps[half.rslot[r] as usize];
            if sl.touching() {
                put(id[half.rowner[r] as usize], sl.spring);
            }
        }
        for e in half.start[k] as usize..half.start[k + 1] as usize {
            let sl = &ps[e];
            if sl.touching() {
                put(id[half.nbr[e] as usize], sl.spring);
            }
        }
        let nw = self.walls.len();
        for (w, sl) in self.rod_walls[k * nw..(k + 1) * nw].iter().enumerate() {
            if sl.touching() {
                put(wall_key(w), sl.spring);
            }
        }
    }

    /// The rods' history as a table: `slots` = None sizes the rows to the fullest rod (a
    /// carrier across a re-sort); Some(k) is the state's format, and a rod with more contacts
    /// than k is an error (its id).
    pub(super) fn rods_to_history(&self, slots: Option<usize>) -> Result<History<R>, u32> {
        let n = self.state.len();
        let counts: Vec<usize> = (0..n)
            .map(|k| {
                let mut c = 0;
                self.rod_row(k, &mut |_, _| c += 1);
                c
            })
            .collect();
        let width = match slots {
            Some(w) => {
                if let Some(k) = (0..n).find(|&k| counts[k] > w) {
                    return Err(self.state.id[k]);
                }
                w
            }
            None => counts.iter().copied().max().unwrap_or(0).max(1),
        };
        let mut h = History::new(width);
        h.partner = vec![EMPTY; n * width];
        h.spring = vec![V3::zero(); n * width];
        for k in 0..n {
            let mut m = 0;
            self.rod_row(k, &mut |key, v| {
                if m < width {
                    h.partner[k * width + m] = key;
                    h.spring[k * width + m] = v;
                }
                m += 1;
            });
        }
        Ok(h)
    }

    /// Elastic energy of the rods' contacts (J) from the half lists and the state's table, as
    /// `sum_elastic_energy` computes it over full lists (the same bits).
    pub(super) fn rod_elastic_energy(&self) -> f64 {
        let half = &self.half;
        (0..self.state.len())
            .map(|i| {
                let before = &half.rowner[half.rstart[i] as usize..half.rstart[i + 1] as usize];
                let after = &half.nbr[half.start[i] as usize..half.start[i + 1] as usize];
                OrientedContext {
                    s: &self.state,
                    neighbours: [before, after],
                    alive: &self.alive,
                    law_pp: &self.law_pp,
                    law_pw: &self.law_pw,
                    walls: &self.walls,
                    periodic: &self.periodic,
                    dt: R::zero(),
                }
                .elastic_energy(i)
            })
            .sum()
    }
}
