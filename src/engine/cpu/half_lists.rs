//! The sphere half lists' build (re-sort, pair slots, near walls) and the contact history's
//! trips between the pair slots and the state's table (with the history-full check).

use rayon::prelude::*;

use super::kinematics;
use super::pair_pass::PairSlot;
use super::particle::{Props, Status};
use super::passes::{block_bounds, scaled, split_blocks};
use super::{CpuEngine, MIN_LEN};
use crate::engine::backend::EngineError;
use crate::engine::grid;
use crate::engine::history::{wall_key, History, EMPTY};
use crate::engine::real::{Real, V3};

impl<R: Real> CpuEngine<R> {
    /// Writes the contact history held by the pair slots and wall springs into a `History`
    /// table (row of particle k: its own pairs, the pairs where it is the partner with the spring
    /// negated, then its walls; only touching contacts with a non-zero spring). `slots` = None
    /// sizes the rows to the fullest particle (a carrier across a mid-chunk re-sort); Some(k)
    /// is the state's format, and a particle with more contacts than k is an error (its id).
    fn pairs_to_history(&self, slots: Option<usize>) -> Result<History<R>, u32> {
        let n = self.state.len();
        let nw = self.walls.len();
        let (half, ps, ws, id) = (
            &self.half,
            &self.pair_slots,
            &self.wall_springs,
            &self.state.id,
        );
        let zero = V3::zero();
        // Every stored (partner key, spring) of particle k, in row order.
        let row = |k: usize, put: &mut dyn FnMut(u32, V3<R>)| {
            for e in half.start[k] as usize..half.start[k + 1] as usize {
                let sl = &ps[e];
                if sl.touching() && sl.spring != zero {
                    put(id[half.nbr[e] as usize], sl.spring);
                }
            }
            for r in half.rstart[k] as usize..half.rstart[k + 1] as usize {
                let sl = &ps[half.rslot[r] as usize];
                if sl.touching() && sl.spring != zero {
                    put(id[half.rowner[r] as usize], -sl.spring);
                }
            }
            for w in 0..nw {
                let s = ws[k * nw + w];
                if s != zero {
                    put(wall_key(w), s);
                }
            }
        };
        let counts: Vec<u32> = self.pool.install(|| {
            (0..n)
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|k| {
                    let mut c = 0u32;
                    row(k, &mut |_, _| c += 1);
                    c
                })
                .collect()
        });
        let fullest = counts.iter().copied().max().unwrap_or(0) as usize;
        let width = match slots {
            Some(k) => {
                if let Some(k_over) = (0..n).find(|&k_| counts[k_] as usize > k) {
                    return Err(id[k_over]);
                }
                k
            }
            None => fullest.max(1),
        };
        let mut h = History::new(width);
        h.partner = vec![EMPTY; n * width];
        h.spring = vec![V3::zero(); n * width];
        self.pool.install(|| {
            h.partner
                .par_chunks_mut(width)
                .zip(h.spring.par_chunks_mut(width))
                .enumerate()
                .with_min_len(MIN_LEN)
                .for_each(|(k, (p, s))| {
                    let mut m = 0;
                    row(k, &mut |key, v| {
                        p[m] = key;
                        s[m] = v;
                        m += 1;
                    });
                });
        });
        Ok(h)
    }

    /// Re-sorts the spheres by cell and rebuilds the half lists, carrying the springs over by
    /// partner id through a `History` table that the sort permutes with the particles. With
    /// `from_pairs` the springs come from the current slots (a rebuild inside a chunk);
    /// otherwise from the state's table (a chunk's start), which is then taken out of the state.
    pub(super) fn rebuild_half(&mut self, from_pairs: bool) {
        if from_pairs {
            kinematics::scatter_to(&self.kin, &mut self.state);
            let carrier = self
                .pairs_to_history(None)
                .expect("unsized history rows cannot overflow");
            self.state.history = carrier;
        }
        self.compact();
        let (periodic, skin) = (self.periodic, self.skin);
        let state = &mut self.state;
        let half = &mut self.half;
        self.pool
            .install(|| grid::build_half(state, &periodic, skin, half));
        let n = self.state.len();
        self.alive = vec![Status::Alive; n];
        let s = &self.state;
        self.props = (0..n)
            .map(|i| Props {
                inv_m: s.inv_mass[i],
                inv_i: if s.rotation {
                    s.inv_inertia[i]
                } else {
                    R::zero()
                },
                inv_d: R::one() / (s.radius[i] * R::from_f64(2.0)),
            })
            .collect();
        let nw = self.walls.len();
        self.pair_slots.clear();
        self.pair_slots.resize(self.half.len(), PairSlot::default());
        self.wall_springs.clear();
        self.wall_springs.resize(n * nw, V3::zero());
        let hist = std::mem::take(&mut self.state.history);
        {
            let (half, id) = (&self.half, &self.state.id);
            let bounds = block_bounds(&half.start, n);
            let blocks = split_blocks(&mut self.pair_slots, &bounds.1);
            let wblocks = split_blocks(&mut self.wall_springs, &scaled(&bounds.0, nw));
            let hist = &hist;
            self.pool.install(|| {
                blocks
                    .into_par_iter()
                    .zip(wblocks)
                    .enumerate()
                    .for_each(|(b, (slots, wsp))| {
                        let first = bounds.0[b];
                        let mut e0 = half.start[first] as usize;
                        for i in first..bounds.0[b + 1] {
                            let e1 = half.start[i + 1] as usize;
                            for e in e0..e1 {
                                let j = half.nbr[e] as usize;
                                let sl = &mut slots[e - bounds.1[b]];
                                *sl = PairSlot::default();
                                if hist.slots > 0 {
                                    let sp = hist.spring_of(i, id[j]);
                                    sl.spring = sp;
                                    // A stored spring marks a contact that existed: keep it.
                                    if sp != V3::zero() {
                                        sl.h = R::zero();
                                    }
                                }
                            }
                            e0 = e1;
                            if hist.slots > 0 {
                                for w in 0..nw {
                                    wsp[(i - first) * nw + w] = hist.spring_of(i, wall_key(w));
                                }
                            }
                        }
                    });
            });
        }
        // The table stays out of the state while the chunk runs (the slots hold the history).
        self.state.history = History::new(0);
        kinematics::gather_from(&mut self.kin, &self.state, |_| true);
        // Each sphere's walls: those within its radius plus the skin (it moves less than half
        // the skin before the next build), and any it has a spring with.
        let (s, walls, wsp) = (&self.state, &self.walls, &self.wall_springs);
        let skin = self.skin;
        self.near_walls = self.pool.install(|| {
            (0..n)
                .into_par_iter()
                .with_min_len(MIN_LEN)
                .map(|i| {
                    (0..nw.min(32))
                        .filter(|&w| {
                            walls[w].may_touch(s.pos[i], s.radius[i], skin)
                                || wsp[i * nw + w] != V3::zero()
                        })
                        .fold(0u32, |mask, w| mask | 1 << w)
                })
                .collect()
        });
        let (near, props) = (&self.near_walls, &self.props);
        self.wall_list.clear();
        self.wall_list.extend(
            (0..n as u32).filter(|&i| {
                near[i as usize] != 0 || nw > 32 || props[i as usize].inv_m == R::zero()
            }),
        );
    }

    /// The history held by the slots as a table (`pairs_to_history`, `rods_to_history`).
    fn history_from_slots(&self, slots: Option<usize>) -> Result<History<R>, u32> {
        if self.state.oriented {
            self.rods_to_history(slots)
        } else {
            self.pairs_to_history(slots)
        }
    }

    /// Puts the history back into the state in its format (`slots` per particle).
    pub(super) fn store_history(&mut self) -> Result<(), EngineError> {
        if self.slots == 0 || self.state.history.slots == self.slots {
            return Ok(());
        }
        match self.history_from_slots(Some(self.slots)) {
            Ok(h) => {
                self.state.history = h;
                Ok(())
            }
            Err(id) => {
                // Keep what fits, so the state stays readable; the run reports the overflow.
                let mut h = self.history_from_slots(None).expect("unsized rows");
                let k = self.slots;
                let w = h.slots;
                let n = self.state.len();
                let (mut p, mut s) = (Vec::with_capacity(n * k), Vec::with_capacity(n * k));
                for i in 0..n {
                    p.extend_from_slice(&h.partner[i * w..i * w + k.min(w)]);
                    s.extend_from_slice(&h.spring[i * w..i * w + k.min(w)]);
                    for _ in w..k {
                        p.push(EMPTY);
                        s.push(V3::zero());
                    }
                }
                h.slots = k;
                h.partner = p;
                h.spring = s;
                self.state.history = h;
                Err(EngineError::HistoryFull {
                    id,
                    slots: k,
                    step: self.state.step,
                })
            }
        }
    }
}
