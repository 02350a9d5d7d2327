//! Non-overlapping insertion of spheres into a vertical cylinder: a jittered hexagonal-free square
//! lattice, layer by layer from the bottom, with seeded jitter and small random velocities so the
//! packing that forms is random but reproducible.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Positions and radii of `count` spheres in a cylinder of radius `cyl_radius` centred on the z
/// axis, starting at `z0`. Diameters are d (1 ± poly) uniformly; the lattice spacing leaves a gap
/// so nothing overlaps.
pub fn cylinder_lattice(
    count: usize,
    cyl_radius: f64,
    z0: f64,
    d: f64,
    poly: f64,
    seed: u64,
) -> Vec<([f64; 3], f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d_max = d * (1.0 + poly);
    let spacing = 1.1 * d_max;
    let jitter = 0.04 * d_max;
    let usable = cyl_radius - 0.5 * d_max - jitter - 0.02 * d;
    let n = (usable / spacing).floor() as i64;
    let mut out = Vec::with_capacity(count);
    let mut layer = 0;
    while out.len() < count {
        let z = z0 + 0.5 * d_max + jitter + layer as f64 * spacing;
        // Alternate layers are shifted by half a spacing to break the columns.
        let shift = if layer % 2 == 1 { 0.5 * spacing } else { 0.0 };
        'layer: for ix in -n - 1..=n {
            for iy in -n - 1..=n {
                let x = ix as f64 * spacing + shift;
                let y = iy as f64 * spacing + shift;
                if (x * x + y * y).sqrt() > usable {
                    continue;
                }
                let r = 0.5 * d * (1.0 + poly * (2.0 * rng.random::<f64>() - 1.0));
                let jx = jitter * (2.0 * rng.random::<f64>() - 1.0);
                let jy = jitter * (2.0 * rng.random::<f64>() - 1.0);
                let jz = jitter * (2.0 * rng.random::<f64>() - 1.0);
                let (px, py) = (x + jx, y + jy);
                if (px * px + py * py).sqrt() + r > cyl_radius {
                    continue;
                }
                out.push(([px, py, z + jz], r));
                if out.len() == count {
                    break 'layer;
                }
            }
        }
        layer += 1;
    }
    out
}
