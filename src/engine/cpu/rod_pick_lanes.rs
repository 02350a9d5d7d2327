//! The rods' near-pair pick, `LANES` list entries at once: the squared distance between two
//! rods' axes (as `shape::contact_spherocylinders` measures it, through `closest_points_in` with
//! selects) against the pick's cut, one array per component, so that the compiler turns the loop into SIMD
//! instructions (as `rod_lanes.rs` does for the pair kernel). Each lane performs the scalar
//! code's operations in its order, so the pick keeps the same entries.

use multiversion::multiversion;

use super::rod_lanes::LANES;
use crate::engine::choice::Select;
use crate::engine::real::{Real, V3};
use crate::engine::shape::closest_points_in;

type Col<R> = [R; LANES];

/// A group's entries: centre gap, the two half-axes (u · l/2) and the squared cut.
#[derive(Clone, Copy, Default)]
pub(super) struct PickLanes<R: Real> {
    d: [Col<R>; 3],
    hi: [Col<R>; 3],
    hj: [Col<R>; 3],
    cut2: Col<R>,
}

impl<R: Real> PickLanes<R> {
    /// Lane `l`: the pair whose centres are `d` apart (c_i − c_j) with half-axes `hi`, `hj`,
    /// near when its axes lie closer than √`cut2`.
    #[inline(always)]
    pub(super) fn set(&mut self, l: usize, d: V3<R>, hi: V3<R>, hj: V3<R>, cut2: R) {
        for (k, (a, b, c)) in [(d.x, hi.x, hj.x), (d.y, hi.y, hj.y), (d.z, hi.z, hj.z)]
            .into_iter()
            .enumerate()
        {
            self.d[k][l] = a;
            self.hi[k][l] = b;
            self.hj[k][l] = c;
        }
        self.cut2[l] = cut2;
    }
}

/// Which of the group's lanes are near. Compiled also for AVX2 and AVX-512 and chosen at run
/// time; Rust never fuses a multiply and an add, so every clone computes the same bits.
#[multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2+avx"))]
pub(super) fn near<R: Real>(inp: &PickLanes<R>, out: &mut [bool; LANES]) {
    for (l, near) in out.iter_mut().enumerate() {
        let get = |a: &[Col<R>; 3]| V3::new(a[0][l], a[1][l], a[2][l]);
        let (d, hi, hj) = (get(&inp.d), get(&inp.hi), get(&inp.hj));
        let dist2 = closest_points_in::<R, Select>(d - hi, hi + hi, -hj, hj + hj).dist2;
        *near = dist2 < inp.cut2[l];
    }
}
