//! Neighbour search: a uniform cell grid filled by a counting sort (O(N)), which also reorders the
//! particles by cell so that neighbours sit close in memory, then a full Verlet list per particle
//! (each particle gathers its own forces: no float atomics, identical results for any thread
//! count). Periodic axes use the minimum image.

use rayon::prelude::*;

use super::real::{Real, V3};
use super::state::State;

/// Periodic extents along x and y, in the run's precision.
#[derive(Clone, Copy, Debug)]
pub struct Periodic<R: Real> {
    pub x: Option<(R, R)>,
    pub y: Option<(R, R)>,
}

impl<R: Real> Periodic<R> {
    /// Minimum-image separation b − a.
    #[inline(always)]
    pub fn delta(&self, a: V3<R>, b: V3<R>) -> V3<R> {
        let mut d = b - a;
        if let Some((lo, hi)) = self.x {
            let l = hi - lo;
            d.x -= l * (d.x / l + R::from_f64(0.5)).floor();
        }
        if let Some((lo, hi)) = self.y {
            let l = hi - lo;
            d.y -= l * (d.y / l + R::from_f64(0.5)).floor();
        }
        d
    }

    /// Wraps a position into the box.
    #[inline(always)]
    pub fn wrap(&self, p: &mut V3<R>) {
        if let Some((lo, hi)) = self.x {
            let l = hi - lo;
            p.x -= l * ((p.x - lo) / l).floor();
        }
        if let Some((lo, hi)) = self.y {
            let l = hi - lo;
            p.y -= l * ((p.y - lo) / l).floor();
        }
    }
}

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

    if list.stride == 0 {
        list.stride = 32;
    }
    let pos = &state.pos;
    let rad = &reach;
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
                let (cx, cy, cz) = (ax[0].cell(p.x), ax[1].cell(p.y), ax[2].cell(p.z));
                let (mut nx, mut ny, mut nz) = ([0; 3], [0; 3], [0; 3]);
                let kx = ax[0].around(cx, &mut nx);
                let ky = ax[1].around(cy, &mut ny);
                let kz = ax[2].around(cz, &mut nz);
                let mut k = 0usize;
                let mut over = false;
                for &z in &nz[..kz] {
                    for &y in &ny[..ky] {
                        for &x in &nx[..kx] {
                            let c = (z * ax[1].n + y) * ax[0].n + x;
                            for j in start[c]..start[c + 1] {
                                let j = j as usize;
                                if j == i {
                                    continue;
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
                            }
                        }
                    }
                }
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
