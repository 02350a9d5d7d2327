//! Neighbour search: a uniform cell grid filled by a counting sort (O(N)), which also reorders the
//! particles by cell so that neighbours sit close in memory, then either half lists (spheres'
//! step and the rods': each pair once, `HalfList`) or full lists (contact records). Both are
//! built in a fixed order, so they do not depend on the thread count. Periodic axes use the
//! minimum image.

use rayon::prelude::*;

pub use super::periodic::{Image, Periodic};
use super::real::{Real, V3};
use super::state::State;

/// Full neighbour lists with a fixed stride per particle.
#[derive(Clone, Debug, Default)]
pub struct NeighbourList<R: Real> {
    pub stride: usize,
    pub count: Vec<u32>,
    pub index: Vec<u32>,
    /// Positions when the list was built (for the skin criterion).
    pub ref_pos: Vec<V3<R>>,
    /// Axes when the list was built (oriented particles: a turn moves the ends too).
    pub ref_axis: Vec<V3<R>>,
    pub builds: u64,
}

struct Axis<R: Real> {
    lo: R,
    width: R,
    n: usize,
    periodic: bool,
}

impl<R: Real> Axis<R> {
    fn cell(&self, x: R) -> usize {
        let c = ((x - self.lo) / self.width).floor().to_f64();
        if self.periodic {
            (c as i64).rem_euclid(self.n as i64) as usize
        } else {
            c.clamp(0.0, (self.n - 1) as f64) as usize
        }
    }
    /// Neighbouring cell indices of `c` (deduplicated when a periodic axis has < 3 cells).
    fn around(&self, c: usize, out: &mut [usize; 3]) -> usize {
        let mut k = 0;
        for d in [-1i64, 0, 1] {
            let cc = c as i64 + d;
            let cc = if self.periodic {
                cc.rem_euclid(self.n as i64)
            } else if cc < 0 || cc >= self.n as i64 {
                continue;
            } else {
                cc
            };
            let cc = cc as usize;
            if !out[..k].contains(&cc) {
                out[k] = cc;
                k += 1;
            }
        }
        k
    }
}

fn axis<R: Real>(lo: f64, hi: f64, cell: f64, periodic: bool) -> Axis<R> {
    let extent = (hi - lo).max(cell);
    let n = ((extent / cell).floor() as usize).max(1);
    Axis {
        lo: R::from_f64(lo),
        width: R::from_f64(extent / n as f64),
        n,
        periodic,
    }
}

/// The cell grid of one rebuild, over the particles as sorted by `sort_by_cell`.
struct Grid<R: Real> {
    ax: [Axis<R>; 3],
    /// Cell c holds the particles start[c]..start[c + 1].
    start: Vec<u32>,
    /// Reach of each (sorted) particle: its radius, plus l/2 for a spherocylinder.
    reach: Vec<R>,
}

impl<R: Real> Grid<R> {
    /// Calls `f(j)` for every particle j in the 27 cells around `p` (each cell once).
    #[inline]
    fn around(&self, p: V3<R>, f: impl FnMut(usize)) {
        self.around_from(p, 0, f);
    }

    /// `around` for the particles j ≥ `from` only. The particles are sorted by cell, so for
    /// a half list (`from` = i + 1) a cell before i's holds none of them and is skipped whole:
    /// the build visits about half the candidates.
    #[inline]
    fn around_from(&self, p: V3<R>, from: u32, mut f: impl FnMut(usize)) {
        let ax = &self.ax;
        let (cx, cy, cz) = (ax[0].cell(p.x), ax[1].cell(p.y), ax[2].cell(p.z));
        let (mut nx, mut ny, mut nz) = ([0; 3], [0; 3], [0; 3]);
        let kx = ax[0].around(cx, &mut nx);
        let ky = ax[1].around(cy, &mut ny);
        let kz = ax[2].around(cz, &mut nz);
        for &z in &nz[..kz] {
            for &y in &ny[..ky] {
                for &x in &nx[..kx] {
                    let c = (z * ax[1].n + y) * ax[0].n + x;
                    for j in self.start[c].max(from)..self.start[c + 1] {
                        f(j as usize);
                    }
                }
            }
        }
    }
}

/// Wraps positions into the periodic box (so that one shift is the minimum image), sorts
/// `state` by cell (a stable counting sort: deterministic) and returns the grid.
fn sort_by_cell<R: Real>(state: &mut State<R>, periodic: &Periodic<R>, skin: R) -> Grid<R> {
    let n = state.len();
    for p in &mut state.pos {
        periodic.wrap(p);
    }
    // The reach of a particle from its centre: its radius, plus l/2 for a spherocylinder. Cells
    // are sized from the longest particle.
    let reach: Vec<R> = if state.oriented {
        state
            .radius
            .iter()
            .zip(&state.half_length)
            .map(|(&r, &h)| r + h)
            .collect()
    } else {
        state.radius.clone()
    };
    let r_max = reach.iter().fold(R::zero(), |a, &b| a.max(b)).to_f64();
    let mut cell = 2.0 * r_max + skin.to_f64();
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    for p in &state.pos {
        let p = p.to_f64();
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if let Some((a, b)) = periodic.x {
        lo[0] = a.to_f64();
        hi[0] = b.to_f64();
    }
    if let Some((a, b)) = periodic.y {
        lo[1] = a.to_f64();
        hi[1] = b.to_f64();
    }
    // A stray particle far away must not blow up the cell count: coarsen until cells ≤ 8N + 4096.
    let cells_for = |c: f64| -> f64 {
        (0..3)
            .map(|k| ((hi[k] - lo[k]) / c).floor().max(1.0))
            .product()
    };
    while cells_for(cell) > (8 * n + 4096) as f64 {
        cell *= 1.5;
    }
    let ax: [Axis<R>; 3] = [
        axis(lo[0], hi[0], cell, periodic.x.is_some()),
        axis(lo[1], hi[1], cell, periodic.y.is_some()),
        axis(lo[2], hi[2], cell, false),
    ];
    let ncell = ax[0].n * ax[1].n * ax[2].n;
    let cell_of = |p: V3<R>| -> usize {
        (ax[2].cell(p.z) * ax[1].n + ax[1].cell(p.y)) * ax[0].n + ax[0].cell(p.x)
    };

    // Counting sort by cell (stable: ties keep their previous order, so it is deterministic).
    let cells: Vec<u32> = state.pos.iter().map(|&p| cell_of(p) as u32).collect();
    let mut start = vec![0u32; ncell + 1];
    for &c in &cells {
        start[c as usize + 1] += 1;
    }
    for c in 0..ncell {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut order = vec![0u32; n];
    for (i, &c) in cells.iter().enumerate() {
        order[fill[c as usize] as usize] = i as u32;
        fill[c as usize] += 1;
    }
    state.permute(&order);
    let reach: Vec<R> = order.iter().map(|&o| reach[o as usize]).collect();
    Grid { ax, start, reach }
}

/// Sorts `state` by cell and rebuilds `list` with cutoff r_i + r_j + skin (r the reach: the
/// radius, plus l/2 for a spherocylinder).
pub fn build<R: Real>(
    state: &mut State<R>,
    periodic: &Periodic<R>,
    skin: R,
    list: &mut NeighbourList<R>,
) {
    let n = state.len();
    list.builds += 1;
    if n == 0 {
        list.count.clear();
        list.index.clear();
        list.ref_pos.clear();
        return;
    }
    let grid = sort_by_cell(state, periodic, skin);
    if list.stride == 0 {
        list.stride = 32;
    }
    let pos = &state.pos;
    let rad = &grid.reach;
    loop {
        let stride = list.stride;
        list.count.resize(n, 0);
        list.index.resize(n * stride, 0);
        let overflow = list
            .index
            .par_chunks_mut(stride)
            .zip(list.count.par_iter_mut())
            .enumerate()
            .map(|(i, (row, count))| {
                let p = pos[i];
                let mut k = 0usize;
                let mut over = false;
                grid.around(p, |j| {
                    if j == i {
                        return;
                    }
                    let d = periodic.delta(p, pos[j]);
                    let cut = rad[i] + rad[j] + skin;
                    if d.norm2() < cut * cut {
                        if k < stride {
                            row[k] = j as u32;
                        } else {
                            over = true;
                        }
                        k += 1;
                    }
                });
                // Cells are visited in a fixed order, but sort so the sum order does not depend
                // on how the cells of a periodic axis wrap.
                let m = k.min(stride);
                row[..m].sort_unstable();
                *count = m as u32;
                over
            })
            .reduce(|| false, |a, b| a || b);
        if !overflow {
            break;
        }
        list.stride *= 2;
    }
    list.ref_pos.clear();
    list.ref_pos.extend_from_slice(&state.pos);
    list.ref_axis.clear();
    if state.oriented {
        list.ref_axis
            .extend(state.orientation.iter().map(|q| q.axis_z()));
    }
}

/// Particles per rayon task when building half lists (rows are gathered per block, then
/// concatenated in block order: the list does not depend on the thread count).
const HALF_BLOCK: usize = 2048;

/// Half neighbour lists in CSR form: particle i's partners j > i (sorted order) within
/// r_i + r_j + skin (r the reach: the radius, plus l/2 for a rod), pairs of two fixed particles
/// left out. Each pair appears once, so its force
/// is computed once (Newton's third law) and its tangential spring lives in its entry. The
/// transposed index (`rstart`, `rslot`: the entries in which a particle is the partner j, in
/// entry order) lets each particle sum its forces in a fixed order without atomics.
///
#[derive(Clone, Debug, Default)]
pub struct HalfList<R: Real> {
    /// Particle i's entries are start[i]..start[i + 1].
    pub start: Vec<u32>,
    /// Partner j of each entry.
    pub nbr: Vec<u32>,
    /// Owner i of each entry (the pair pass walks a block's entries in one flat loop: a loop
    /// per particle, of 0 to a dozen entries, would mispredict its exit once per particle).
    pub owner: Vec<u32>,
    /// Entries in which particle j is the partner: rslot[rstart[j]..rstart[j + 1]].
    pub rstart: Vec<u32>,
    pub rslot: Vec<u32>,
    /// The particle i owning each entry of `rslot`.
    pub rowner: Vec<u32>,
    /// Positions when the list was built (for the skin criterion).
    pub ref_pos: Vec<V3<R>>,
    pub builds: u64,
}

impl<R: Real> HalfList<R> {
    pub fn len(&self) -> usize {
        self.nbr.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nbr.is_empty()
    }
}

/// Sorts `state` by cell and rebuilds the half list `list`; `fixed` pairs (both
/// inverse masses zero) are left out.
pub fn build_half<R: Real>(
    state: &mut State<R>,
    periodic: &Periodic<R>,
    skin: R,
    list: &mut HalfList<R>,
) {
    let n = state.len();
    list.builds += 1;
    list.start.clear();
    list.nbr.clear();
    list.owner.clear();
    list.rstart.clear();
    list.rslot.clear();
    list.rowner.clear();
    list.ref_pos.clear();
    if n == 0 {
        list.start.push(0);
        list.rstart.push(0);
        return;
    }
    let grid = sort_by_cell(state, periodic, skin);
    // Every candidate j the cells hand out lies in 0..n: the cells' starts ascend to n. Checked
    // once per build (with the fullest cell's count, in the same pass), so that the candidate
    // loop reads the particles' data unchecked (the bounds checks and the box lengths,
    // recomputed per candidate, were half of the loop).
    let fullest = grid
        .start
        .windows(2)
        .try_fold(0u32, |m, w| w[1].checked_sub(w[0]).map(|c| m.max(c)));
    assert!(grid.start.last() == Some(&(n as u32)) && fullest.is_some());
    let (pos, rad, inv_mass) = (&state.pos[..n], &grid.reach[..n], &state.inv_mass[..n]);
    let image = periodic.image();
    // The most candidates one particle can have: 27 cells of the fullest cell's count, and
    // fewer than N. (A row that grows instead pays a test per candidate.)
    let most = (27 * fullest.unwrap_or(0) as usize).min(n);
    let blocks: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(HALF_BLOCK))
        .into_par_iter()
        .map(|b| {
            let range = b * HALF_BLOCK..((b + 1) * HALF_BLOCK).min(n);
            let mut counts = Vec::with_capacity(range.len());
            let mut nbr = Vec::with_capacity(range.len() * 8);
            let mut row = vec![0u32; most];
            for i in range {
                let (p, ri) = (pos[i], rad[i]);
                let fixed_i = inv_mass[i] == R::zero();
                let mut k = 0;
                grid.around_from(p, i as u32 + 1, |j| {
                    debug_assert!(j < n);
                    // SAFETY: j < n (the assertion on the cells' starts above).
                    let (pj, rj, mj) = unsafe {
                        (
                            *pos.get_unchecked(j),
                            *rad.get_unchecked(j),
                            *inv_mass.get_unchecked(j),
                        )
                    };
                    // Fixed pairs never interact: they would only cost a distance test a step.
                    let both_fixed = fixed_i & (mj == R::zero());
                    let d = image.delta(p, pj);
                    let cut = ri + rj + skin;
                    // Every candidate is written and the place advances only for a partner:
                    // whether one is within reach is a coin flip the branch predictor loses.
                    row[k] = j as u32;
                    k += usize::from(d.norm2() < cut * cut && !both_fixed);
                });
                // Ascending partners: a fixed order, and the partners' data read in memory order.
                let row = &mut row[..k];
                row.sort_unstable();
                nbr.extend_from_slice(row);
                counts.push(k as u32);
            }
            (counts, nbr)
        })
        .collect();
    list.start.reserve(n + 1);
    list.start.push(0);
    let mut total = 0u32;
    list.owner
        .reserve(blocks.iter().map(|(_, nbr)| nbr.len()).sum());
    for (counts, nbr) in &blocks {
        for &c in counts {
            let i = list.start.len() as u32 - 1;
            list.owner.extend(std::iter::repeat_n(i, c as usize));
            total += c;
            list.start.push(total);
        }
        list.nbr.extend_from_slice(nbr);
    }
    // Transpose: a counting sort of the entries by partner, in entry order (deterministic).
    list.rstart.resize(n + 1, 0);
    for &j in &list.nbr {
        list.rstart[j as usize + 1] += 1;
    }
    for j in 0..n {
        list.rstart[j + 1] += list.rstart[j];
    }
    let mut fill = list.rstart.clone();
    list.rslot.resize(list.nbr.len(), 0);
    list.rowner.resize(list.nbr.len(), 0);
    for i in 0..n {
        for e in list.start[i]..list.start[i + 1] {
            let j = list.nbr[e as usize] as usize;
            let r = fill[j] as usize;
            list.rslot[r] = e;
            list.rowner[r] = i as u32;
            fill[j] += 1;
        }
    }
    list.ref_pos.extend_from_slice(&state.pos);
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::{build_half, HalfList, Periodic};
    use crate::engine::state::State;

    /// Every pair within reach (r_i + r_j + skin, minimum image) is one entry, owned by the
    /// earlier particle, each row ascending; the transpose lists each partner's entries in
    /// entry order.
    #[test]
    fn half_list_holds_each_pair_within_reach_once() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut s = State::<f64>::new(true, 8);
        for id in 0..3000u32 {
            let p = [0.0, 1.0, 2.0].map(|_| rng.random::<f64>() * 0.3);
            s.push_sphere(id, p, [0.0; 3], 0.01, 1000.0, false);
        }
        let periodic = Periodic {
            x: Some((0.0, 0.3)),
            y: None,
        };
        let skin = 0.004;
        let mut list = HalfList::default();
        build_half(&mut s, &periodic, skin, &mut list);
        let n = s.len();
        let mut expected = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let cut = s.radius[i] + s.radius[j] + skin;
                if periodic.delta(s.pos[i], s.pos[j]).norm2() < cut * cut {
                    expected.push((i as u32, j as u32));
                }
            }
        }
        let entries: Vec<(u32, u32)> = list.owner.iter().copied().zip(list.nbr.clone()).collect();
        assert_eq!(entries, expected);
        assert!(
            expected
                .iter()
                .any(|&(i, j)| s.pos[i as usize].x - s.pos[j as usize].x > 0.15),
            "the test needs pairs across the periodic seam"
        );
        for j in 0..n {
            let (a, b) = (list.rstart[j] as usize, list.rstart[j + 1] as usize);
            let mut prev = None;
            for r in a..b {
                let e = list.rslot[r];
                assert_eq!(list.nbr[e as usize] as usize, j);
                assert_eq!(list.rowner[r], list.owner[e as usize]);
                assert!(prev < Some(e), "partner {j}: entries in order");
                prev = Some(e);
            }
        }
        assert_eq!(list.rstart[n] as usize, list.nbr.len());
    }
}
