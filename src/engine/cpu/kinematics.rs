//! The sphere step's working copy of the particles' motion: position, velocity and angular
//! velocity of each sphere packed in one record. The pair pass reads a partner at a random
//! place in memory; from three arrays (and the alive flags) that costs four cache lines, from
//! one record one or two. While a chunk of sphere steps runs, the records are the truth and
//! the state's arrays are stale; `CpuEngine` copies them back before anything else reads the
//! state (a re-sort, the chunk's end, an error report).

#[cfg(target_arch = "x86_64")]
use super::simd::{self, F32x4};
use crate::engine::grid::Image;
use crate::engine::position;
use crate::engine::real::{Real, V3};
use crate::engine::state::State;

/// One sphere's motion, and the two constants the pair pass needs of a partner. Radius, mass
/// and a pad fill the fourth place of the three 4-vectors (48 bytes in f32), so that a list
/// entry need not keep its pair's constants (the list's slots shrank from 36 to 16 bytes, which
/// the pair pass reads and writes every step), the distance test finds position and radius in
/// one 16-byte piece, and the kick updates each vector with its fourth place in one 4-wide
/// operation (`kick.rs`). A particle that no longer interacts (it fell through the sink) has a
/// NaN radius: every distance test with it is false (a comparison with NaN is), so the test
/// reads no flag and takes no branch on one. The fourth 4-vector holds the rest of the position
/// where `Real::SPLIT_POSITIONS` (zero otherwise): 64 bytes in f32, one cache line.
#[repr(C, align(64))]
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
    /// The rest of the position below the precision of `pos` (`position.rs`).
    pub(super) lo: V3<R>,
    /// Zero: the fourth place of `lo`'s 4-vector (the drift adds it to r's place).
    _pad_lo: R,
}

impl<R: Real> Kin<R> {
    /// Takes the particle out of every distance test (it fell through the sink).
    #[inline(always)]
    pub(super) fn bury(&mut self) {
        self.r = R::from_f64(f64::NAN);
    }
}

/// The distance test's geometry, prepared once per pass: the minimum image as 4-vectors for
/// `separation` (the fourth place and z never folded).
#[derive(Clone, Copy)]
pub(super) struct Separation<R: Real> {
    image: Image<R>,
    half: [R; 4],
    neg_half: [R; 4],
    len: [R; 4],
}

impl<R: Real> Separation<R> {
    pub(super) fn new(image: Image<R>) -> Self {
        let (len, half) = image.lengths();
        let inf = R::from_f64(f64::INFINITY);
        Self {
            image,
            half: [half[0], half[1], inf, inf],
            neg_half: [-half[0], -half[1], -inf, -inf],
            len: [len[0], len[1], R::zero(), R::zero()],
        }
    }

    /// The separation d from j to i (minimum image when `PERIODIC`) and |d|², each component
    /// and the sum as `position::separation`, `Image::fold` and `V3::norm2` compute them (the
    /// same bits). In f32 on x86-64 from the records' first and fourth 4-vectors (position and
    /// r, the position's rest) in 4-wide SSE operations.
    #[inline(always)]
    pub(super) fn of<const PERIODIC: bool>(&self, ki: &Kin<R>, kj: &Kin<R>) -> (V3<R>, R) {
        #[cfg(target_arch = "x86_64")]
        if simd::is_f32::<R>() {
            // SAFETY: R is f32.
            let (s, ki, kj) = unsafe {
                (
                    &*(self as *const Self).cast::<Separation<f32>>(),
                    &*(ki as *const Kin<R>).cast::<Kin<f32>>(),
                    &*(kj as *const Kin<R>).cast::<Kin<f32>>(),
                )
            };
            let (d, d2) = s.of_f32::<PERIODIC>(ki, kj);
            // SAFETY: R is f32.
            return unsafe { (std::mem::transmute_copy(&d), std::mem::transmute_copy(&d2)) };
        }
        let d = position::separation(kj.pos, kj.lo, ki.pos, ki.lo);
        let d = if PERIODIC { self.image.fold(d) } else { d };
        (d, d.norm2())
    }
}

#[cfg(target_arch = "x86_64")]
impl Separation<f32> {
    #[inline(always)]
    fn of_f32<const PERIODIC: bool>(&self, ki: &Kin<f32>, kj: &Kin<f32>) -> (V3<f32>, f32) {
        // SAFETY: a `Kin<f32>` is 16-byte aligned and starts with its position and r (16
        // bytes).
        // The rests' fourth places are zero: d's is ri − rj, unused.
        let (pi, pj) = unsafe { (F32x4::load(ki.quad(0)), F32x4::load(kj.quad(0))) };
        let (li, lj) = unsafe { (F32x4::load(ki.quad(3)), F32x4::load(kj.quad(3))) };
        let mut d = (pi - pj) + (li - lj);
        if PERIODIC {
            // As `Image::delta`: d − (up − down), up = l where d > l/2, down = l where
            // d < −l/2 (z and the fourth place: never, d − 0 is d).
            let len = F32x4::from_array(&self.len);
            let up = d.gt(F32x4::from_array(&self.half)) & len;
            let down = d.lt(F32x4::from_array(&self.neg_half)) & len;
            d = d - (up - down);
        }
        // (x² + y²) + z², as `V3::norm2`.
        (d.xyz(), (d * d).sum_xyz())
    }
}

#[cfg(target_arch = "x86_64")]
impl Kin<f32> {
    /// The record's `k`-th 4-vector (0: position and r, 1: velocity and m, 2: angular
    /// velocity and the pad, 3: the position's rest and a zero), 16-byte aligned
    /// (`F32x4::load`, `F32x4::store`).
    #[inline(always)]
    pub(super) fn quad(&self, k: usize) -> *const f32 {
        debug_assert!(k < 4);
        (self as *const Self).cast::<f32>().wrapping_add(4 * k)
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
            lo: s.pos_lo.get(i).copied().unwrap_or_default(),
            _pad: R::zero(),
            _pad_lo: R::zero(),
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
    if R::SPLIT_POSITIONS {
        s.pos_lo.clear();
        s.pos_lo.extend(kin.iter().map(|k| k.lo));
    }
    if s.rotation {
        for (k, w) in kin.iter().zip(s.omega.iter_mut()) {
            *w = k.omega;
        }
    }
}
