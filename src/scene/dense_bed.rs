//! A disordered dense bed of particles aligned with x (spheres, or spherocylinders lying along
//! the flow) in a box periodic in x and y between a floor and a ceiling: random positions at the
//! target solid fraction, then overlap relaxation (each overlapping pair pushed apart along its
//! separation, all pairs at once, until the largest overlap is below a tolerance). A lattice
//! would start the chute as a crystal that slides as a plug on a sheared bottom layer; a random
//! bed flows like a poured one. Deterministic for a seed.

use std::collections::HashMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The packing problem: `count` particles of radius `radius` and axis half-length `half_length`
/// (along x) in [0, lx) × [0, ly), centres between `z_lo` and `z_hi`.
#[derive(Clone, Copy, Debug)]
pub struct DenseBed {
    pub count: usize,
    pub radius: f64,
    pub half_length: f64,
    pub lx: f64,
    pub ly: f64,
    pub z_lo: f64,
    pub z_hi: f64,
}

/// The relaxed bed.
#[derive(Clone, Debug)]
pub struct Packed {
    pub pos: Vec<[f64; 3]>,
    /// The largest remaining overlap (m).
    pub max_overlap: f64,
    /// Relaxation sweeps used.
    pub sweeps: usize,
}

/// Push apart a little more than the overlap: the bed then settles into small gaps instead of
/// creeping towards zero overlap.
const OVER_RELAX: f64 = 1.2;

/// Most relaxation sweeps (a bed at φ ≲ 0.58 needs a few hundred).
const MAX_SWEEPS: usize = 20_000;

impl DenseBed {
    /// The vector between the closest points of particles at `a` and `b` (b to a, minimum
    /// image): for parallel segments along x, the x gap beyond the segments' overlap.
    fn closest(&self, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        let mut d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        d[0] -= self.lx * (d[0] / self.lx).round();
        d[1] -= self.ly * (d[1] / self.ly).round();
        let along = (d[0].abs() - 2.0 * self.half_length).max(0.0);
        [along.copysign(d[0]), d[1], d[2]]
    }

    /// Random positions relaxed until no overlap exceeds `tolerance` (m) or `MAX_SWEEPS`.
    pub fn pack(&self, tolerance: f64, seed: u64) -> Packed {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (zl, zh) = (self.z_lo, self.z_hi.max(self.z_lo));
        let mut pos: Vec<[f64; 3]> = (0..self.count)
            .map(|_| {
                [
                    self.lx * rng.random::<f64>(),
                    self.ly * rng.random::<f64>(),
                    zl + (zh - zl) * rng.random::<f64>(),
                ]
            })
            .collect();
        let reach = 2.0 * (self.radius + self.half_length);
        let d = 2.0 * self.radius;
        let (nx, ny) = (
            ((self.lx / reach).floor() as i64).max(1),
            ((self.ly / (2.0 * self.radius)).floor() as i64).max(1),
        );
        let cell = |p: &[f64; 3]| {
            (
                ((p[0] / self.lx * nx as f64).floor() as i64).rem_euclid(nx),
                ((p[1] / self.ly * ny as f64).floor() as i64).rem_euclid(ny),
                ((p[2] - zl) / d).floor() as i64,
            )
        };
        let mut max_overlap = f64::INFINITY;
        let mut sweeps = 0;
        let mut push = vec![[0.0f64; 3]; self.count];
        while sweeps < MAX_SWEEPS {
            let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
            for (i, p) in pos.iter().enumerate() {
                grid.entry(cell(p)).or_default().push(i);
            }
            push.iter_mut().for_each(|v| *v = [0.0; 3]);
            max_overlap = 0.0;
            for (i, p) in pos.iter().enumerate() {
                let (cx, cy, cz) = cell(p);
                // Cells along x span a whole particle; along y and z one diameter.
                for (ox, oy, oz) in neighbours(nx, ny) {
                    let key = ((cx + ox).rem_euclid(nx), (cy + oy).rem_euclid(ny), cz + oz);
                    let Some(others) = grid.get(&key) else {
                        continue;
                    };
                    for &j in others {
                        if j <= i {
                            continue;
                        }
                        let c = self.closest(*p, pos[j]);
                        let dist = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                        let overlap = d - dist;
                        if overlap <= 0.0 {
                            continue;
                        }
                        max_overlap = max_overlap.max(overlap);
                        // Coincident axes: apart along y (any direction would do).
                        let n = if dist > 1e-12 * d {
                            [c[0] / dist, c[1] / dist, c[2] / dist]
                        } else {
                            [0.0, 1.0, 0.0]
                        };
                        let s = 0.5 * OVER_RELAX * overlap;
                        for (k, nk) in n.iter().enumerate() {
                            push[i][k] += s * nk;
                            push[j][k] -= s * nk;
                        }
                    }
                }
            }
            if max_overlap <= tolerance {
                break;
            }
            for (p, v) in pos.iter_mut().zip(&push) {
                p[0] = (p[0] + v[0]).rem_euclid(self.lx);
                p[1] = (p[1] + v[1]).rem_euclid(self.ly);
                p[2] = (p[2] + v[2]).clamp(zl, zh);
            }
            sweeps += 1;
        }
        Packed {
            pos,
            max_overlap,
            sweeps,
        }
    }
}

/// Neighbour cell offsets, each periodic neighbour once even in a box of one or two cells.
fn neighbours(nx: i64, ny: i64) -> Vec<(i64, i64, i64)> {
    let span = |n: i64| -> Vec<i64> {
        match n {
            1 => vec![0],
            2 => vec![0, 1],
            _ => vec![-1, 0, 1],
        }
    };
    let mut out = Vec::new();
    for ox in span(nx) {
        for oy in span(ny) {
            for oz in [-1, 0, 1] {
                out.push((ox, oy, oz));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spheres at φ = 0.55 and rods at 0.5 relax below the tolerance, inside the box's z range.
    #[test]
    fn beds_relax_below_the_tolerance() {
        for (half_length, count) in [(0.0, 1000), (0.5, 400)] {
            let (lx, ly) = (6.0, 6.0);
            let v = std::f64::consts::PI * (0.25 * 2.0 * half_length + 1.0 / 6.0);
            let phi = if half_length == 0.0 { 0.55 } else { 0.5 };
            let h = count as f64 * v / (lx * ly * phi);
            let bed = DenseBed {
                count,
                radius: 0.5,
                half_length,
                lx,
                ly,
                z_lo: 0.5,
                z_hi: h - 0.5,
            };
            let p = bed.pack(1e-4, 3);
            assert!(
                p.max_overlap <= 1e-4 && p.sweeps < MAX_SWEEPS,
                "{half_length}: {p:?}"
            );
            assert!(p.pos.iter().all(|r| r[2] >= 0.5 && r[2] <= h - 0.5));
            for (i, a) in p.pos.iter().enumerate() {
                for b in &p.pos[i + 1..] {
                    let c = bed.closest(*a, *b);
                    let dist = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                    assert!(dist >= 1.0 - 1e-4 - 1e-12);
                }
            }
        }
    }
}
