//! The silo's field observer: at every `sample_interval_s` (a chunk boundary) it deposits the
//! downloaded particles (and contacts, when asked) on the (r, z) grid, adds the snapshot to the
//! averages whose window contains the time, and records ⟨p^k⟩ in the orifice cylinder and the
//! mass flux through z = 0. Its whole state serialises into the job's checkpoint, so a resumed
//! run gives identical fields.

use serde::{Deserialize, Serialize};

use super::settings::SiloFieldSettings;
use crate::engine::contact::ContactRecord;
use crate::engine::State;
use crate::observe::coarse_grain::{FieldGrid, GridAverage, GridFields, Kernel};
use crate::scene::silo::SiloParams;

/// Name of the per-sample ⟨p^k⟩ series (Pa): tr σᵏ averaged over r ≤ R, |z| ≤ R/2, R = D/2
/// (the paper's cylinder of radius and height R centred on the orifice, fig11).
pub const ORIFICE_KINETIC_PRESSURE: &str = "orifice_kinetic_pressure";
/// Name of the per-sample mass flux through the orifice plane, −∫ P_z 2πr dr at z = 0
/// (kg/s; the paper's Q = ∫ P·dA, a check on Q from the counted particles).
pub const ORIFICE_MASS_FLUX: &str = "orifice_mass_flux";

/// One map: a time-window average around `time_s`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapAverage {
    pub time_s: f64,
    pub average: GridAverage,
}

/// The observer (checkpointed inside the silo job's progress record).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SiloFieldObserver {
    pub settings: SiloFieldSettings,
    pub kernel: Kernel,
    /// Discharge chunks per sample.
    pub every_chunks: u64,
    /// Half a chunk (s): sample times are whole chunks of a whole number of steps, so 0.1 s may
    /// come out as 0.09999; window bounds are widened by this much.
    pub slack_s: f64,
    pub particle_density_kg_per_m3: f64,
    pub orifice_radius_m: f64,
    pub maps: Vec<MapAverage>,
    pub mean: GridAverage,
    /// The mean over flowing samples only (fig9, fig10: the paper averages "during flowing
    /// states"); None in a checkpoint of an older sweep, which did not keep it.
    #[serde(default)]
    pub mean_flowing: Option<GridAverage>,
    /// Samples of the mean whose flowing state is not known yet (the gap of exits around them
    /// is still open): held until [`SiloFieldObserver::settle`] decides. A few at most: a gap
    /// is decided once it closes or outlasts the clog time.
    #[serde(default)]
    pub pending: Vec<(f64, GridFields)>,
    pub mean_xyz: Option<GridAverage>,
    /// (t (s), value) per sample from `mean_start_s`.
    pub orifice_kinetic_pressure: Vec<(f64, f64)>,
    pub orifice_mass_flux: Vec<(f64, f64)>,
}

impl SiloFieldObserver {
    /// The observer for `silo` with discharge chunks of `chunk_dt` (s).
    pub fn new(settings: &SiloFieldSettings, silo: &SiloParams, chunk_dt: f64) -> Self {
        let w = settings.width_m(silo);
        let h = settings.spacing_for(silo);
        let z_lo = settings.z_min_m.unwrap_or(-silo.orifice_diameter_m);
        let z_lo = (z_lo / h).floor() * h;
        let z_hi = settings.z_max_m.unwrap_or(silo.cylinder_height_m);
        let grid = FieldGrid::rz(silo.cylinder_radius_m, z_lo, z_hi, h, h);
        let mean_xyz = settings.cartesian_spacing_m.map(|hc| {
            let rc = silo.cylinder_radius_m;
            GridAverage::new(FieldGrid::xyz([-rc, -rc, z_lo], [rc, rc, z_hi], hc))
        });
        Self {
            settings: settings.clone(),
            kernel: Kernel::new(w, settings.cutoff_widths),
            every_chunks: (settings.sample_interval_s / chunk_dt).round().max(1.0) as u64,
            slack_s: 0.5 * chunk_dt,
            particle_density_kg_per_m3: silo.particle_density_kg_per_m3,
            orifice_radius_m: 0.5 * silo.orifice_diameter_m,
            maps: settings
                .map_times_s
                .iter()
                .map(|&t| MapAverage {
                    time_s: t,
                    average: GridAverage::new(grid),
                })
                .collect(),
            mean: GridAverage::new(grid),
            mean_flowing: Some(GridAverage::new(grid)),
            pending: Vec::new(),
            mean_xyz,
            orifice_kinetic_pressure: Vec::new(),
            orifice_mass_flux: Vec::new(),
        }
    }

    /// Whether chunk `chunk` (counted from the opening) ends with a sample.
    pub fn samples_at(&self, chunk: u64) -> bool {
        chunk.is_multiple_of(self.every_chunks)
    }

    /// Whether a sample needs the engine's contact list.
    pub fn needs_contacts(&self) -> bool {
        self.settings.contact_stress
    }

    /// Whether a sample at `t_s` would be used by any average or series.
    pub fn wanted_at(&self, t_s: f64) -> bool {
        self.in_mean(t_s) || self.maps.iter().any(|m| self.in_window(m, t_s))
    }

    fn in_window(&self, m: &MapAverage, t_s: f64) -> bool {
        (t_s - m.time_s).abs() <= 0.5 * self.settings.map_window_s + self.slack_s
    }

    fn in_mean(&self, t_s: f64) -> bool {
        t_s >= self.settings.mean_start_s - self.slack_s
    }

    /// Deposits the snapshot `s` taken `t_s` after opening (with `contacts` when the observer
    /// asks for them) and adds it where its time belongs.
    pub fn sample(&mut self, t_s: f64, s: &State<f64>, contacts: Option<&[ContactRecord]>) {
        if !self.wanted_at(t_s) {
            return;
        }
        let (mut pos, mut vel, mut mass) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..s.len() {
            if s.inv_mass[i] == 0.0 {
                continue;
            }
            pos.push([s.pos[i].x, s.pos[i].y, s.pos[i].z]);
            vel.push([s.vel[i].x, s.vel[i].y, s.vel[i].z]);
            mass.push(s.mass[i]);
        }
        let mut f = GridFields::new(self.mean.grid);
        f.deposit_particles(&self.kernel, &pos, &vel, &mass);
        if let Some(c) = contacts {
            f.deposit_contacts(&self.kernel, c);
        }
        if self.in_mean(t_s) {
            self.mean.add(&f, t_s);
            if self.mean_flowing.is_some() {
                self.pending.push((t_s, f.clone()));
            }
            // No grid point in the cylinder: no value, rather than a 0 that reads as "at rest".
            if let Some(pk) = self.cylinder_kinetic_pressure(&f) {
                self.orifice_kinetic_pressure.push((t_s, pk));
            }
            self.orifice_mass_flux.push((t_s, orifice_flux(&f)));
            if let Some(avg) = &mut self.mean_xyz {
                let mut fx = GridFields::new(avg.grid);
                fx.deposit_particles(&self.kernel, &pos, &vel, &mass);
                if let Some(c) = contacts {
                    fx.deposit_contacts(&self.kernel, c);
                }
                avg.add(&fx, t_s);
            }
        }
        let window = 0.5 * self.settings.map_window_s + self.slack_s;
        for m in &mut self.maps {
            if (t_s - m.time_s).abs() <= window {
                m.average.add(&f, t_s);
            }
        }
    }

    /// Adds the pending samples that `flowing` now decides (Some(true)) to the flowing mean and
    /// drops those inside a clog (Some(false)); undecided ones (None) stay pending.
    pub fn settle(&mut self, flowing: impl Fn(f64) -> Option<bool>) {
        let Some(avg) = self.mean_flowing.as_mut() else {
            return;
        };
        self.pending.retain(|(t, f)| match flowing(*t) {
            Some(true) => {
                avg.add(f, *t);
                false
            }
            Some(false) => false,
            None => true,
        });
    }

    /// tr σᵏ averaged (by volume) over the grid points with r ≤ R and |z| ≤ R/2 (Pa); None when
    /// no grid point lies inside the orifice cylinder (an orifice narrower than the grid
    /// spacing): there is nothing to average, and 0 would read as a bed at rest.
    pub fn cylinder_kinetic_pressure(&self, f: &GridFields) -> Option<f64> {
        let g = &f.grid;
        let r = self.orifice_radius_m;
        let (mut sum, mut vol) = (0.0, 0.0);
        for j in g.range(1, -0.5 * r, 0.5 * r) {
            for i in g.range(0, 0.0, r) {
                let p = g.index(i, j, 0);
                let s = f.kinetic_stress(p);
                let v = g.volume(p);
                sum += (s[0] + s[4] + s[8]) * v;
                vol += v;
            }
        }
        (vol > 0.0).then(|| sum / vol)
    }
}

/// −∫ P_z 2πr dr on the row z = 0 (kg/s), positive for outflow; 0 without such a row.
fn orifice_flux(f: &GridFields) -> f64 {
    let g = &f.grid;
    let row = g.range(1, -1e-9 * g.spacing_m[1], 1e-9 * g.spacing_m[1]);
    let Some(j) = row.clone().next() else {
        return 0.0;
    };
    (0..g.shape[0])
        .map(|i| {
            let p = g.index(i, j, 0);
            let r = g.coord(0, i);
            -f.momentum[3 * p + 2] * std::f64::consts::TAU * r * g.spacing_m[0]
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observer(orifice_m: f64, spacing_m: f64) -> SiloFieldObserver {
        let silo = SiloParams {
            orifice_diameter_m: orifice_m,
            ..SiloParams::default()
        };
        let settings = SiloFieldSettings {
            spacing_m: Some(spacing_m),
            ..SiloFieldSettings::default()
        };
        SiloFieldObserver::new(&settings, &silo, 0.01)
    }

    #[test]
    fn an_orifice_cylinder_without_grid_points_has_no_pressure_not_zero() {
        // r points sit at (i + 1/2) h: with R = 5 mm < h/2 = 6 mm none is inside.
        let coarse = observer(0.010, 0.012);
        let empty = GridFields::new(coarse.mean.grid);
        assert_eq!(coarse.cylinder_kinetic_pressure(&empty), None);
        let fine = observer(0.010, 0.002);
        let empty = GridFields::new(fine.mean.grid);
        assert_eq!(fine.cylinder_kinetic_pressure(&empty), Some(0.0));
    }
}

#[cfg(test)]
mod flowing_tests {
    use super::*;

    #[test]
    fn pending_samples_join_the_flowing_mean_only_when_decided_flowing() {
        let silo = SiloParams::default();
        let mut obs = SiloFieldObserver::new(&SiloFieldSettings::default(), &silo, 0.01);
        let grid = obs.mean.grid;
        for t in [1.0, 1.05, 1.1, 1.15] {
            obs.pending.push((t, GridFields::new(grid)));
        }
        // 1.0 flowing, 1.05 in a clog, the rest undecided.
        obs.settle(|t| match t {
            t if t < 1.01 => Some(true),
            t if t < 1.06 => Some(false),
            _ => None,
        });
        let mean = obs.mean_flowing.as_ref().expect("kept");
        assert_eq!((mean.samples, mean.t_first_s), (1, 1.0));
        let left: Vec<f64> = obs.pending.iter().map(|p| p.0).collect();
        assert_eq!(left, vec![1.1, 1.15]);
        obs.settle(|_| Some(true));
        assert_eq!(obs.mean_flowing.as_ref().map(|m| m.samples), Some(3));
        assert!(obs.pending.is_empty());
    }
}
