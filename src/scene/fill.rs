//! Non-overlapping insertion of spheres into a vertical cylinder by random sequential addition:
//! uniformly random positions, rejected when they overlap an earlier sphere, at a loose solid
//! fraction. Pouring such a gas under gravity gives a random packing; a lattice start would
//! settle into crystalline layers (φ ≈ 0.70 measured with one), which changes the bulk density
//! and the flow rate.

use std::collections::HashMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Positions and radii of `count` spheres in a cylinder of radius `cyl_radius` centred on the z
/// axis, above `z0`, at solid fraction about `phi` (≤ 0.3 keeps the rejection cheap). Diameters
/// are d (1 ± poly) uniformly. Deterministic for a seed.
pub fn cylinder_random(
    count: usize,
    cyl_radius: f64,
    z0: f64,
    d: f64,
    poly: f64,
    phi: f64,
    seed: u64,
) -> Vec<([f64; 3], f64)> {
    cylinder_random_until(count, cyl_radius, z0, d, poly, phi, seed, &|| false)
        .expect("never stopped")
}

/// [`cylinder_random`], asking `stop` every few thousand tries: `None` when it says stop (a
/// bed of millions takes a minute to place, and a SIGTERM must not wait for it).
#[allow(clippy::too_many_arguments)]
pub fn cylinder_random_until(
    count: usize,
    cyl_radius: f64,
    z0: f64,
    d: f64,
    poly: f64,
    phi: f64,
    seed: u64,
    stop: &dyn Fn() -> bool,
) -> Option<Vec<([f64; 3], f64)>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d_max = d * (1.0 + poly);
    let r_in = cyl_radius - 0.5 * d_max - 0.01 * d;
    let v_mean = std::f64::consts::PI / 6.0 * d.powi(3) * (1.0 + poly * poly);
    let mut height = count as f64 * v_mean / (phi * std::f64::consts::PI * cyl_radius * cyl_radius);
    // Hash grid of cell size d_max: an overlap can only be with the 27 surrounding cells.
    let cell = |x: f64| (x / d_max).floor() as i64;
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    let mut out: Vec<([f64; 3], f64)> = Vec::with_capacity(count);
    let mut misses = 0usize;
    let mut tries = 0u32;
    while out.len() < count {
        tries = tries.wrapping_add(1);
        if tries.is_multiple_of(4096) && stop() {
            return None;
        }
        let r = 0.5 * d * (1.0 + poly * (2.0 * rng.random::<f64>() - 1.0));
        let (rho, th) = (
            r_in * rng.random::<f64>().sqrt(),
            std::f64::consts::TAU * rng.random::<f64>(),
        );
        let p = [
            rho * th.cos(),
            rho * th.sin(),
            z0 + 0.5 * d_max + 0.01 * d + height * rng.random::<f64>(),
        ];
        let c = (cell(p[0]), cell(p[1]), cell(p[2]));
        let mut free = true;
        'near: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &j in grid
                        .get(&(c.0 + dx, c.1 + dy, c.2 + dz))
                        .map_or(&[][..], |v| v.as_slice())
                    {
                        let (q, rq) = out[j];
                        let dist2 =
                            (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2);
                        if dist2 < (r + rq).powi(2) * 1.0001 {
                            free = false;
                            break 'near;
                        }
                    }
                }
            }
        }
        if free {
            grid.entry(c).or_default().push(out.len());
            out.push((p, r));
            misses = 0;
        } else {
            misses += 1;
            // Locally jammed: give the gas more room instead of looping.
            if misses > 10_000 {
                height *= 1.1;
                misses = 0;
            }
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_insertion_has_no_overlap_and_stays_inside() {
        let (rc, d) = (0.03, 0.0058);
        let spots = cylinder_random(500, rc, 0.0, d, 0.1, 0.3, 3);
        assert_eq!(spots.len(), 500);
        for (i, (p, r)) in spots.iter().enumerate() {
            assert!(
                (p[0] * p[0] + p[1] * p[1]).sqrt() + r <= rc,
                "particle {i} outside the cylinder"
            );
            assert!(p[2] - r >= 0.0, "particle {i} below the bottom");
            for (q, rq) in &spots[..i] {
                let dist =
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                assert!(dist >= r + rq, "particles overlap: {dist} < {}", r + rq);
            }
        }
        assert_eq!(
            spots,
            cylinder_random(500, rc, 0.0, d, 0.1, 0.3, 3),
            "deterministic for a seed"
        );
    }
}
