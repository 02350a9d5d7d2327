//! The sphere step's working copy of the particles' motion: position, velocity and angular
//! velocity of each sphere packed in one record. The pair pass reads a partner at a random
//! place in memory; from three arrays (and the alive flags) that costs four cache lines, from
//! one record one or two. While a chunk of sphere steps runs, the records are the truth and
//! the state's arrays are stale; `CpuEngine` copies them back before anything else reads the
//! state (a re-sort, the chunk's end, an error report).

use super::real::{Real, V3};
use super::state::State;

/// One sphere's motion, and the two constants the pair pass needs of a partner. Radius, mass
/// and a pad fill the fourth place of the three 4-vectors (48 bytes in f32), so that a list
/// entry need not keep its pair's constants (the list's slots shrank from 36 to 16 bytes, which
/// the pair pass reads and writes every step), the distance test finds position and radius in
/// one 16-byte piece, and the kick updates each vector with its fourth place in one 4-wide
/// operation (`kick.rs`). A particle that no longer interacts (it fell through the sink) has a
/// NaN radius: every distance test with it is false (a comparison with NaN is), so the test
/// reads no flag and takes no branch on one.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Kin<R: Real> {
    pub(super) pos: V3<R>,
    /// NaN for a particle that does not interact.
    pub(super) r: R,
    pub(super) vel: V3<R>,
    /// Zero for a fixed particle, which acts as infinitely heavy (see `pair_lanes`).
    pub(super) m: R,
    pub(super) omega: V3<R>,
    /// Unused: the fourth place of `omega`'s 4-vector.
    _pad: R,
}

impl<R: Real> Kin<R> {
    /// Takes the particle out of every distance test (it fell through the sink).
    #[inline(always)]
    pub(super) fn bury(&mut self) {
        self.r = R::from_f64(f64::NAN);
    }
}

/// Fills `kin` from the state (`live[i]`: whether particle i interacts; zero angular velocity
/// when the state has no rotation).
pub(super) fn gather_from<R: Real>(
    kin: &mut Vec<Kin<R>>,
    s: &State<R>,
    live: impl Fn(usize) -> bool,
) {
    kin.clear();
    kin.extend((0..s.len()).map(|i| {
        let mut k = Kin {
            pos: s.pos[i],
            _pad: R::zero(),
            vel: s.vel[i],
            omega: if s.rotation { s.omega[i] } else { V3::zero() },
            r: s.radius[i],
            m: if s.inv_mass[i] == R::zero() {
                R::zero()
            } else {
                s.mass[i]
            },
        };
        if !live(i) {
            k.bury();
        }
        k
    }));
}

/// Writes the records' positions and velocities back into the state.
pub(super) fn scatter_to<R: Real>(kin: &[Kin<R>], s: &mut State<R>) {
    debug_assert_eq!(kin.len(), s.len());
    for (k, (p, v)) in kin.iter().zip(s.pos.iter_mut().zip(s.vel.iter_mut())) {
        *p = k.pos;
        *v = k.vel;
    }
    if s.rotation {
        for (k, w) in kin.iter().zip(s.omega.iter_mut()) {
            *w = k.omega;
        }
    }
}
