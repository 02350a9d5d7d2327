//! What the overlap watchdog names when it stops a run: the deepest contact of the state, found
//! by a scan of the half list's pairs and of every particle against every wall (run once, after
//! the run has already failed), so that a user can tell a wedged rod from a collision at speed
//! or a particle under the base. The list holds every touching pair: the watchdog found the
//! overlap through it.

use super::particle::Status;
use super::CpuEngine;
use crate::engine::real::{Real, V3};
use crate::engine::shape::{contact_spherocylinders, Spherocylinder};

/// The deepest contact found, as a fraction of the smaller diameter.
struct Deepest {
    ratio: f64,
    what: String,
}

impl<R: Real> CpuEngine<R> {
    /// One line on the deepest contact of the current state: which particles (or wall), their
    /// heights, speeds and spins, and their approach speed along the normal.
    pub(super) fn overlap_report(&self) -> String {
        let s = &self.state;
        let mut deepest: Option<Deepest> = None;
        let shape = |k: usize| Spherocylinder {
            half_length: s.half_length.get(k).copied().unwrap_or_else(R::zero),
            radius: s.radius[k],
        };
        // A non-finite motion is the finiteness check's to report; here it would hide the rest.
        let mut keep = |ratio: f64, what: &dyn Fn() -> String| {
            if ratio.is_finite() && deepest.as_ref().is_none_or(|d| ratio > d.ratio) {
                deepest = Some(Deepest {
                    ratio,
                    what: what(),
                });
            }
        };
        let alive = |k: usize| self.alive[k] == Status::Alive;
        for i in (0..s.len()).filter(|&i| alive(i)) {
            let (ui, si) = (s.axis(i), shape(i));
            let entries = self.half.start[i] as usize..self.half.start[i + 1] as usize;
            for j in self.half.nbr[entries].iter().map(|&j| j as usize) {
                if !alive(j) || (s.inv_mass[i] == R::zero() && s.inv_mass[j] == R::zero()) {
                    continue;
                }
                let d = s.separation(&self.periodic, j, i);
                let Some(c) = contact_spherocylinders(d, ui, &si, s.axis(j), &shape(j)) else {
                    continue;
                };
                let smaller = 2.0 * Real::to_f64(s.radius[i]).min(Real::to_f64(s.radius[j]));
                let approach = (s.vel[j] - s.vel[i]).dot(c.normal).to_f64();
                keep(Real::to_f64(c.overlap) / smaller, &|| {
                    format!(
                        "between {} and {}, approaching at {approach:.3} m/s along the normal",
                        self.describe(i),
                        self.describe(j)
                    )
                });
            }
            if s.inv_mass[i] == R::zero() {
                continue;
            }
            for (w, wall) in self.walls.iter().enumerate() {
                let Some((c, _)) = wall.touch_oriented(s.pos[i], s.lo(i), ui, &si) else {
                    continue;
                };
                let approach = -s.vel[i].dot(c.normal).to_f64();
                keep(
                    Real::to_f64(c.overlap) / (2.0 * Real::to_f64(s.radius[i])),
                    &|| {
                        format!(
                            "between {} and wall {w}, approaching at {approach:.3} m/s along the normal",
                            self.describe(i)
                        )
                    },
                );
            }
        }
        match deepest {
            Some(d) => format!("deepest contact {:.3} d {}", d.ratio, d.what),
            None => "no overlapping contact left in the state".into(),
        }
    }

    /// `particle 812 (mobile, z = 0.310 m, |v| = 2.10 m/s, |ω| = 40.0 rad/s)`.
    fn describe(&self, k: usize) -> String {
        let s = &self.state;
        let speed = |v: V3<R>| v.norm().to_f64();
        let spin = if s.rotation { speed(s.omega[k]) } else { 0.0 };
        format!(
            "particle {} ({}, z = {:.4} m, |v| = {:.3} m/s, |ω| = {:.2} rad/s)",
            s.id[k],
            if s.inv_mass[k] == R::zero() {
                "fixed"
            } else {
                "mobile"
            },
            s.position_f64(k)[2],
            speed(s.vel[k]),
            spin
        )
    }
}
