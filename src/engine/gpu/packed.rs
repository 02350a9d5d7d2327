//! The particles of a `State<f64>` in the kernels' f32 records (`Packed`): position with
//! radius, velocity with 1/m, ω, constants with the alive flag, force and torque, history slots,
//! and for oriented runs only the rotational state `RodGpu`. `pack` and `unpack` convert from
//! and to the exchange format, so a checkpoint moves between backends; `concat` and `block` lay
//! a batch's jobs out in blocks of slots and take one back.
//!
//! Velocities and spins are kept like positions, each with its rest below f32's spacing
//! (`kick_split` in common.wgsl): `vel_im` and `omega` hold n records then n rests.

use super::layout::{Info, Load, RodGpu, Slot};
use crate::engine::history::History;
use crate::engine::position::split_v3;
use crate::engine::real::V3;
use crate::engine::shape::Quat;
use crate::engine::state::State;

/// The particles of a State, in the kernels' f32 records.
#[derive(Clone, Debug, Default)]
pub struct Packed {
    pub pos_r: Vec<[f32; 4]>,
    /// The rest of each position below f32's spacing at it (`position.rs`), fourth place zero.
    pub pos_lo: Vec<[f32; 4]>,
    pub vel_im: Vec<[f32; 4]>,
    /// The rest of each velocity (`kick_split` in common.wgsl), fourth place zero.
    pub vel_lo: Vec<[f32; 4]>,
    pub omega: Vec<[f32; 4]>,
    /// The rest of each integrated spin: ω of spheres, L of oriented particles.
    pub spin_lo: Vec<[f32; 4]>,
    pub info: Vec<Info>,
    pub load: Vec<Load>,
    /// Slot-major: slot s of particle i at s n + i.
    pub hist: Vec<Slot>,
    /// Orientation, angular momentum, inverse body inertia and l/2; empty unless oriented.
    pub rod: Vec<RodGpu>,
}

impl Packed {
    /// Whether the particles carry orientations (the state was oriented).
    pub fn oriented(&self) -> bool {
        !self.rod.is_empty()
    }

    /// The shape records the contact kernel reads (unit axis, l/2), derived from the
    /// orientations with the CPU engine's f32 `Quat::axis_z`, as `kick_rotate` derives them.
    pub(super) fn shapes(&self) -> Vec<[f32; 4]> {
        self.rod
            .iter()
            .map(|r| {
                let [x, y, z, w] = r.q;
                let u = Quat::<f32> { x, y, z, w }.axis_z();
                [u.x, u.y, u.z, r.inv_inertia_h[3]]
            })
            .collect()
    }
}

fn f4(v: &V3<f64>, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// A vector split as the kernels keep it (`position::split`): the nearest f32 with `w`, and
/// the rest with a zero fourth place.
fn split4(v: &V3<f64>, w: f64) -> ([f32; 4], [f32; 4]) {
    let (hi, lo) = split_v3::<f32>(v.to_f64());
    ([hi.x, hi.y, hi.z, w as f32], [lo.x, lo.y, lo.z, 0.0])
}

/// hi + lo in f64, exact for a pair the kernels wrote (`f64_rest` in common.wgsl); a zero rest
/// leaves hi as it is (its sign included), as `split` gives it back.
fn join(hi: &[f32; 4], lo: Option<&[f32; 4]>) -> V3<f64> {
    let lo = lo.copied().unwrap_or_default();
    let one = |h: f32, l: f32| {
        if l == 0.0 {
            h as f64
        } else {
            h as f64 + l as f64
        }
    };
    V3::new(one(hi[0], lo[0]), one(hi[1], lo[1]), one(hi[2], lo[2]))
}

/// The history of `s`, slot s of particle i at s n + i (the kernels' slot-major order).
fn slot_major(s: &State<f64>) -> Vec<Slot> {
    let (n, k) = (s.len(), s.history.slots);
    let mut out = vec![Slot::default(); n * k];
    for i in 0..n {
        for q in 0..k {
            let sp = s.history.spring[i * k + q];
            out[q * n + i] = Slot {
                spring: [sp.x as f32, sp.y as f32, sp.z as f32],
                key: s.history.partner[i * k + q],
            };
        }
    }
    out
}

/// Packs `s` (every particle alive); each history row keeps its slot order.
pub fn pack(s: &State<f64>) -> Packed {
    let n = s.len();
    let zero = V3::zero();
    Packed {
        pos_r: (0..n)
            .map(|i| {
                let (hi, _) = split_v3::<f32>(s.pos[i].to_f64());
                [hi.x, hi.y, hi.z, s.radius[i] as f32]
            })
            .collect(),
        pos_lo: (0..n)
            .map(|i| {
                let (_, lo) = split_v3::<f32>(s.pos[i].to_f64());
                [lo.x, lo.y, lo.z, 0.0]
            })
            .collect(),
        vel_im: (0..n).map(|i| split4(&s.vel[i], s.inv_mass[i]).0).collect(),
        vel_lo: (0..n).map(|i| split4(&s.vel[i], 0.0).1).collect(),
        // Oriented: ω is derived from L (whose rest this is).
        omega: (0..n)
            .map(|i| split4(s.omega.get(i).unwrap_or(&zero), 0.0).0)
            .collect(),
        spin_lo: (0..n)
            .map(|i| {
                let spin = if s.oriented { &s.ang_mom } else { &s.omega };
                split4(spin.get(i).unwrap_or(&zero), 0.0).1
            })
            .collect(),
        info: (0..n)
            .map(|i| Info {
                id: s.id[i],
                alive: 1,
                mass: s.mass[i] as f32,
                // Oriented runs: 1/I⊥, which the rods' effective mass reads (the rotation
                // reads the rod records).
                inv_inertia: if s.oriented {
                    s.inv_inertia_body[i].x as f32
                } else {
                    s.inv_inertia.get(i).copied().unwrap_or(0.0) as f32
                },
            })
            .collect(),
        load: (0..n)
            .map(|i| Load {
                force: f4(&s.force[i], 0.0),
                torque: f4(s.torque.get(i).unwrap_or(&zero), 0.0),
            })
            .collect(),
        hist: slot_major(s),
        rod: if s.oriented {
            (0..n)
                .map(|i| {
                    let [x, y, z, w] = s.orientation[i].to_f64();
                    RodGpu {
                        q: [x as f32, y as f32, z as f32, w as f32],
                        ang_mom: split4(&s.ang_mom[i], 0.0).0,
                        inv_inertia_h: f4(&s.inv_inertia_body[i], s.half_length[i]),
                    }
                })
                .collect()
        } else {
            Vec::new()
        },
    }
}

/// The live particles of `p` as a State (removed ones dropped, order kept); oriented when `p`
/// carries orientations (then `rotation` is implied).
pub fn unpack(p: &Packed, slots: usize, rotation: bool, time: f64, step: u64) -> State<f64> {
    let oriented = p.oriented();
    let mut s = if oriented {
        State::new_oriented(slots)
    } else {
        State::new(rotation, slots)
    };
    s.time = time;
    s.step = step;
    let v = |a: &[f32; 4]| V3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let mut history = History::new(slots);
    let n = p.info.len();
    for (i, info) in p.info.iter().enumerate() {
        if info.alive == 0 {
            continue;
        }
        s.id.push(info.id);
        s.pos.push(join(&p.pos_r[i], p.pos_lo.get(i)));
        s.radius.push(p.pos_r[i][3] as f64);
        s.vel.push(join(&p.vel_im[i], p.vel_lo.get(i)));
        s.inv_mass.push(p.vel_im[i][3] as f64);
        s.mass.push(info.mass as f64);
        s.force.push(v(&p.load[i].force));
        if oriented {
            let r = &p.rod[i];
            s.omega.push(v(&p.omega[i]));
            s.torque.push(v(&p.load[i].torque));
            let q = r.q.map(|c| c as f64);
            s.orientation.push(Quat::from_f64(q));
            s.ang_mom.push(join(&r.ang_mom, p.spin_lo.get(i)));
            s.inv_inertia_body.push(v(&r.inv_inertia_h));
            s.half_length.push(r.inv_inertia_h[3] as f64);
        } else if rotation {
            s.omega.push(join(&p.omega[i], p.spin_lo.get(i)));
            s.torque.push(v(&p.load[i].torque));
            s.inv_inertia.push(info.inv_inertia as f64);
        }
        for slot in (0..slots).map(|q| &p.hist[q * n + i]) {
            history.partner.push(slot.key);
            history.spring.push(V3::new(
                slot.spring[0] as f64,
                slot.spring[1] as f64,
                slot.spring[2] as f64,
            ));
        }
    }
    s.history = history;
    // By id: the slots' order is the device's business (it may reorder them).
    if s.id.windows(2).any(|w| w[0] > w[1]) {
        let mut order: Vec<u32> = (0..s.len() as u32).collect();
        order.sort_unstable_by_key(|&k| s.id[k as usize]);
        s.permute(&order);
    }
    s
}

impl Packed {
    /// A slot that holds no particle (a batch's padding): dead, massless, with empty history.
    pub(super) fn pad_to(&mut self, n: usize, slots: usize) {
        let k = self.info.len();
        let oriented = self.oriented();
        self.pos_r.resize(n, [0.0; 4]);
        self.pos_lo.resize(n, [0.0; 4]);
        self.vel_im.resize(n, [0.0; 4]);
        self.vel_lo.resize(n, [0.0; 4]);
        self.omega.resize(n, [0.0; 4]);
        self.spin_lo.resize(n, [0.0; 4]);
        self.info.resize(n, Info::default());
        self.load.resize(n, Load::default());
        if oriented {
            self.rod.resize(n, RodGpu::default());
        }
        // Slot-major rows: row q of the k particles becomes row q of n.
        let mut hist = vec![Slot::default(); n * slots];
        for q in 0..slots {
            hist[q * n..q * n + k].copy_from_slice(&self.hist[q * k..(q + 1) * k]);
        }
        self.hist = hist;
    }
}

/// The jobs of a batch as one upload: job j's particles in slots j·n_job.., each block padded
/// with empty slots to `n_job`.
pub fn concat(jobs: Vec<Packed>, n_job: usize, slots: usize) -> Packed {
    let total = jobs.len() * n_job;
    let mut out = Packed::default();
    let mut hist = vec![Slot::default(); total * slots];
    for (j, mut p) in jobs.into_iter().enumerate() {
        p.pad_to(n_job, slots);
        out.pos_r.extend(p.pos_r);
        out.pos_lo.extend(p.pos_lo);
        out.vel_im.extend(p.vel_im);
        out.vel_lo.extend(p.vel_lo);
        out.omega.extend(p.omega);
        out.spin_lo.extend(p.spin_lo);
        out.info.extend(p.info);
        out.load.extend(p.load);
        out.rod.extend(p.rod);
        for q in 0..slots {
            let at = q * total + j * n_job;
            hist[at..at + n_job].copy_from_slice(&p.hist[q * n_job..(q + 1) * n_job]);
        }
    }
    out.hist = hist;
    out
}

/// Job j's block of a batch's download (padding included; `unpack` drops it with the dead).
pub fn block(p: &Packed, j: usize, n_job: usize, slots: usize) -> Packed {
    let total = p.info.len();
    let r = j * n_job..(j + 1) * n_job;
    let mut hist = Vec::with_capacity(n_job * slots);
    for q in 0..slots {
        hist.extend_from_slice(&p.hist[q * total + r.start..q * total + r.end]);
    }
    Packed {
        pos_r: p.pos_r[r.clone()].to_vec(),
        pos_lo: p.pos_lo[r.clone()].to_vec(),
        vel_im: p.vel_im[r.clone()].to_vec(),
        vel_lo: p.vel_lo[r.clone()].to_vec(),
        omega: p.omega[r.clone()].to_vec(),
        spin_lo: p.spin_lo[r.clone()].to_vec(),
        info: p.info[r.clone()].to_vec(),
        load: p.load[r.clone()].to_vec(),
        hist,
        rod: if p.rod.is_empty() {
            Vec::new()
        } else {
            p.rod[r].to_vec()
        },
    }
}
