//! Non-overlapping insertion of spherocylinders into a periodic box by random sequential addition
//! (uniform positions, isotropic orientations, rejected on overlap with an earlier one), and the
//! random monolayer of fixed spheres that makes the chute's rough base.

use std::collections::HashMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::engine::real::V3;
use crate::engine::shape::{contact_spherocylinders, Quat, Spherocylinder};

/// A particle placed by the fill: centre and orientation ([x, y, z, w], body → lab).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    pub pos: [f64; 3],
    pub q: [f64; 4],
}

/// Minimum image of `d` in a box periodic in x and y.
fn min_image(mut d: [f64; 3], lx: f64, ly: f64) -> [f64; 3] {
    d[0] -= lx * (d[0] / lx).round();
    d[1] -= ly * (d[1] / ly).round();
    d
}

/// `count` spherocylinders of `shape` in the box [0, lx) × [0, ly) × [z0, z0 + height), height
/// chosen for solid fraction `phi` (≤ 0.25 keeps the rejection cheap) and grown when the gas
/// locally jams. Orientations are isotropic. Deterministic for a seed.
pub fn box_random_rods(
    count: usize,
    shape: Spherocylinder<f64>,
    lx: f64,
    ly: f64,
    z0: f64,
    phi: f64,
    seed: u64,
) -> Vec<Placed> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let reach = shape.bounding_radius();
    let mut height = count as f64 * shape.volume() / (phi * lx * ly);
    let cell = 2.0 * reach;
    let (nx, ny) = (
        ((lx / cell).floor() as i64).max(1),
        ((ly / cell).floor() as i64).max(1),
    );
    let key = |p: [f64; 3]| {
        (
            ((p[0] / lx * nx as f64).floor() as i64).rem_euclid(nx),
            ((p[1] / ly * ny as f64).floor() as i64).rem_euclid(ny),
            ((p[2] - z0) / cell).floor() as i64,
        )
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    let mut out: Vec<Placed> = Vec::with_capacity(count);
    let mut misses = 0usize;
    while out.len() < count {
        // Isotropic axis: uniform on the sphere.
        let cz: f64 = 2.0 * rng.random::<f64>() - 1.0;
        let az = std::f64::consts::TAU * rng.random::<f64>();
        let sz = (1.0 - cz * cz).sqrt();
        let axis = V3::new(sz * az.cos(), sz * az.sin(), cz);
        let q = Quat::<f64>::from_axis_z(axis);
        let p = [
            lx * rng.random::<f64>(),
            ly * rng.random::<f64>(),
            z0 + reach + height * rng.random::<f64>(),
        ];
        let c = key(p);
        let mut free = true;
        'near: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let k = (
                        (c.0 + dx).rem_euclid(nx),
                        (c.1 + dy).rem_euclid(ny),
                        c.2 + dz,
                    );
                    for &j in grid.get(&k).map_or(&[][..], |v| v.as_slice()) {
                        let o = out[j];
                        let d =
                            min_image([p[0] - o.pos[0], p[1] - o.pos[1], p[2] - o.pos[2]], lx, ly);
                        let uj = Quat::from_f64(o.q).axis_z();
                        // A 1 % margin: no pair starts in contact.
                        let grown = Spherocylinder {
                            half_length: shape.half_length,
                            radius: shape.radius * 1.01,
                        };
                        if contact_spherocylinders(V3::from_f64(d), axis, &grown, uj, &grown)
                            .is_some()
                        {
                            free = false;
                            break 'near;
                        }
                    }
                }
            }
        }
        if free {
            grid.entry(c).or_default().push(out.len());
            out.push(Placed {
                pos: p,
                q: q.to_f64(),
            });
            misses = 0;
        } else {
            misses += 1;
            if misses > 10_000 {
                height *= 1.1;
                misses = 0;
            }
        }
    }
    out
}

/// Centres of a random monolayer of spheres of radius `r` at height `z` covering the periodic
/// area [0, lx) × [0, ly) at area fraction about `coverage` (random sequential addition of
/// disks, whose jamming limit is about 0.547: above it the fill stops at what fits).
pub fn base_monolayer(lx: f64, ly: f64, r: f64, z: f64, coverage: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let target = (coverage * lx * ly / (std::f64::consts::PI * r * r)).round() as usize;
    let mut out: Vec<[f64; 3]> = Vec::with_capacity(target);
    let mut misses = 0usize;
    while out.len() < target && misses < 200_000 {
        let p = [lx * rng.random::<f64>(), ly * rng.random::<f64>(), z];
        let free = out.iter().all(|o| {
            let d = min_image([p[0] - o[0], p[1] - o[1], 0.0], lx, ly);
            d[0] * d[0] + d[1] * d[1] >= 4.0 * r * r
        });
        if free {
            out.push(p);
            misses = 0;
        } else {
            misses += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rods_do_not_overlap_across_the_seam_either() {
        let shape = Spherocylinder::from_aspect_ratio(0.125, 2.5).unwrap();
        let (lx, ly) = (0.5, 0.5);
        let rods = box_random_rods(300, shape, lx, ly, 0.1, 0.2, 7);
        for (i, a) in rods.iter().enumerate() {
            assert!(a.pos[0] >= 0.0 && a.pos[0] < lx && a.pos[1] >= 0.0 && a.pos[1] < ly);
            assert!(a.pos[2] - shape.bounding_radius() >= 0.1);
            for b in &rods[..i] {
                let d = min_image(
                    [
                        a.pos[0] - b.pos[0],
                        a.pos[1] - b.pos[1],
                        a.pos[2] - b.pos[2],
                    ],
                    lx,
                    ly,
                );
                let (ua, ub) = (Quat::from_f64(a.q).axis_z(), Quat::from_f64(b.q).axis_z());
                assert!(
                    contact_spherocylinders(V3::from_f64(d), ua, &shape, ub, &shape).is_none(),
                    "rods {i} and another overlap"
                );
            }
        }
        assert_eq!(rods, box_random_rods(300, shape, lx, ly, 0.1, 0.2, 7));
    }

    #[test]
    fn base_spheres_do_not_overlap() {
        let b = base_monolayer(1.0, 1.0, 0.0625, 0.0, 0.5, 3);
        assert!(b.len() > 30);
        for (i, p) in b.iter().enumerate() {
            for q in &b[..i] {
                let d = min_image([p[0] - q[0], p[1] - q[1], 0.0], 1.0, 1.0);
                assert!(d[0].hypot(d[1]) >= 0.125 - 1e-12);
            }
        }
    }
}
