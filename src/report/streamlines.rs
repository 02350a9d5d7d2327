//! Streamlines of a 2-D velocity field on a regular (r, z) grid, for the silo's |V| maps (fig7):
//! each line follows the direction of (V_r, V_z), traced from seeds on a coarse lattice both
//! downstream and upstream with the midpoint rule on the bilinear interpolant, and stops where
//! the field is undefined (no material), where it stalls, or at the grid's edge.

/// A velocity field sampled at r_i = r0 + i dr, z_j = z0 + j dz (point index j·nr + i); NaN where
/// undefined.
pub struct Field2d<'a> {
    pub r0: f64,
    pub dr: f64,
    pub nr: usize,
    pub z0: f64,
    pub dz: f64,
    pub nz: usize,
    pub ur: &'a [f64],
    pub uz: &'a [f64],
}

impl Field2d<'_> {
    /// Bilinear (u_r, u_z) at (r, z); None outside the grid or next to an undefined point.
    fn at(&self, r: f64, z: f64) -> Option<(f64, f64)> {
        let x = (r - self.r0) / self.dr;
        let y = (z - self.z0) / self.dz;
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (i, j) = (x.floor() as usize, y.floor() as usize);
        if i + 1 >= self.nr || j + 1 >= self.nz {
            return None;
        }
        let (fx, fy) = (x - i as f64, y - j as f64);
        let mut out = (0.0, 0.0);
        for (dj, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (di, wx) in [(0, 1.0 - fx), (1, fx)] {
                let k = (j + dj) * self.nr + i + di;
                let (a, b) = (self.ur[k], self.uz[k]);
                if !(a.is_finite() && b.is_finite()) {
                    return None;
                }
                out.0 += wx * wy * a;
                out.1 += wx * wy * b;
            }
        }
        Some(out)
    }

    /// Unit direction of the flow at (r, z), `sign` = −1 for upstream; None where it is
    /// undefined or slower than `stall` (m/s).
    fn direction(&self, r: f64, z: f64, sign: f64, stall: f64) -> Option<(f64, f64)> {
        let (a, b) = self.at(r, z)?;
        let s = a.hypot(b);
        (s > stall).then(|| (sign * a / s, sign * b / s))
    }

    /// Streamlines from seeds every `every` grid points in r and z, each traced at most
    /// `max_steps` half-cell steps each way; lines shorter than 3 points are dropped. `stall` is
    /// the speed below which the flow counts as at rest (m/s).
    pub fn streamlines(&self, every: usize, max_steps: usize, stall: f64) -> Vec<Vec<(f64, f64)>> {
        let h = 0.5 * self.dr.min(self.dz);
        let mut lines = Vec::new();
        let every = every.max(1);
        for j in (every / 2..self.nz).step_by(every) {
            for i in (every / 2..self.nr).step_by(every) {
                let seed = (self.r0 + i as f64 * self.dr, self.z0 + j as f64 * self.dz);
                let mut halves = [Vec::new(), Vec::new()];
                for (half, sign) in halves.iter_mut().zip([1.0, -1.0]) {
                    let mut p = seed;
                    for _ in 0..max_steps {
                        let Some(d1) = self.direction(p.0, p.1, sign, stall) else {
                            break;
                        };
                        let mid = (p.0 + 0.5 * h * d1.0, p.1 + 0.5 * h * d1.1);
                        let Some(d2) = self.direction(mid.0, mid.1, sign, stall) else {
                            break;
                        };
                        p = (p.0 + h * d2.0, p.1 + h * d2.1);
                        if p.0 < self.r0 {
                            break; // crossed the axis
                        }
                        half.push(p);
                    }
                }
                let [down, up] = halves;
                let mut line: Vec<(f64, f64)> = up.into_iter().rev().collect();
                line.push(seed);
                line.extend(down);
                if line.len() >= 3 {
                    lines.push(line);
                }
            }
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(f: impl Fn(f64, f64) -> (f64, f64)) -> (Vec<f64>, Vec<f64>) {
        let (mut ur, mut uz) = (Vec::new(), Vec::new());
        for j in 0..41 {
            for i in 0..41 {
                let (a, b) = f(i as f64 * 0.05, -1.0 + j as f64 * 0.05);
                ur.push(a);
                uz.push(b);
            }
        }
        (ur, uz)
    }

    /// The test grid of `grid`'s fields.
    fn field<'a>(ur: &'a [f64], uz: &'a [f64]) -> Field2d<'a> {
        Field2d {
            r0: 0.0,
            dr: 0.05,
            nr: 41,
            z0: -1.0,
            dz: 0.05,
            nz: 41,
            ur,
            uz,
        }
    }

    #[test]
    fn lines_follow_uniform_and_circular_flows() {
        // Uniform downward flow: every line is vertical (r constant to rounding).
        let (ur, uz) = grid(|_, _| (0.0, -1.0));
        let f = field(&ur, &uz);
        let lines = f.streamlines(10, 200, 1e-9);
        assert!(!lines.is_empty());
        for l in &lines {
            assert!(l.iter().all(|p| (p.0 - l[0].0).abs() < 1e-12), "{l:?}");
            assert!(
                l.windows(2).all(|w| w[1].1 < w[0].1),
                "downstream goes down"
            );
        }
        // Rotation about (1, 0): u = (−(z − 0), r − 1); lines stay on circles within 1 %.
        let (ur, uz) = grid(|r, z| (-z, r - 1.0));
        let f = field(&ur, &uz);
        for l in f.streamlines(8, 100, 1e-9) {
            let rad = |p: &(f64, f64)| (p.0 - 1.0).hypot(p.1);
            let r0 = rad(&l[0]);
            if r0 < 0.2 {
                continue;
            }
            for p in &l {
                assert!((rad(p) / r0 - 1.0).abs() < 0.01, "{} vs {r0}", rad(p));
            }
        }
        // Undefined points stop a line.
        let (mut ur, uz) = grid(|_, _| (0.0, -1.0));
        for i in 0..41 {
            ur[20 * 41 + i] = f64::NAN;
        }
        let f = field(&ur, &uz);
        for l in f.streamlines(10, 200, 1e-9) {
            let above = l.iter().any(|p| p.1 > 0.05);
            let below = l.iter().any(|p| p.1 < -0.05);
            assert!(!(above && below), "crossed the undefined row: {l:?}");
        }
    }
}
