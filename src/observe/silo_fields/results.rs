//! The silo field observer's results, handed to the store as plain values: each average becomes a field set (the maps
//! `map_t<time>`, the whole-run `mean`, the flowing-only `mean_flowing`, and `mean_xyz` when
//! asked), each series rows of
//! `silo_field_series`. Fields stored per set: phi, density, momentum, velocity,
//! kinetic_stress, kinetic_pressure (and contact_stress); (r, z) sets carry vector and tensor
//! components in the cylindrical basis (r, θ, z), Cartesian sets in (x, y, z).

use super::observer::{SiloFieldObserver, ORIFICE_KINETIC_PRESSURE, ORIFICE_MASS_FLUX};

/// Name of the field set averaging the flowing samples only (from `mean_start_s`, clogged
/// intervals left out); `mean` averages every sample from `mean_start_s`.
pub const MEAN_FLOWING: &str = "mean_flowing";
use crate::observe::coarse_grain::{FieldArray, FieldSet, GridAverage};

/// One time series of a scalar: its name, SI units and (t (s), value) samples.
#[derive(Clone, Copy, Debug)]
pub struct NamedSeries<'a> {
    pub name: &'static str,
    pub units: &'static str,
    pub samples: &'a [(f64, f64)],
}

impl SiloFieldObserver {
    /// Every field set with at least one sample, with its arrays.
    pub fn field_sets(&self) -> Vec<(FieldSet, Vec<FieldArray>)> {
        let mut out = Vec::new();
        for m in &self.maps {
            out.push((format!("map_t{:.3}", m.time_s), &m.average));
        }
        out.push(("mean".to_string(), &self.mean));
        if let Some(m) = &self.mean_flowing {
            out.push((MEAN_FLOWING.to_string(), m));
        }
        if let Some(x) = &self.mean_xyz {
            out.push(("mean_xyz".to_string(), x));
        }
        out.into_iter()
            .filter(|(_, a)| a.samples > 0)
            .map(|(name, a)| (self.describe(name, a), self.arrays(a)))
            .collect()
    }

    fn describe(&self, name: String, a: &GridAverage) -> FieldSet {
        FieldSet {
            id: 0,
            job_id: 0,
            name,
            grid_kind: a.grid.kind.name().into(),
            origin_m: a.grid.origin_m,
            spacing_m: a.grid.spacing_m,
            shape: a.grid.shape,
            kernel_width_m: self.kernel.width_m,
            cutoff_widths: self.kernel.cutoff_widths,
            t_start_s: a.t_first_s,
            t_end_s: a.t_last_s,
            samples: a.samples as i64,
        }
    }

    fn arrays(&self, a: &GridAverage) -> Vec<FieldArray> {
        let rho = a.density();
        let arr = |field: &str, units: &str, components: usize, data: Vec<f64>| FieldArray {
            field: field.into(),
            units: units.into(),
            components,
            data,
        };
        let mut v = vec![
            arr(
                "phi",
                "1",
                1,
                rho.iter()
                    .map(|r| r / self.particle_density_kg_per_m3)
                    .collect(),
            ),
            arr("density", "kg/m^3", 1, rho),
            arr("momentum", "kg/(m^2 s)", 3, a.momentum()),
            arr("velocity", "m/s", 3, a.velocity()),
            arr("kinetic_stress", "Pa", 9, a.kinetic_stress()),
            arr("kinetic_pressure", "Pa", 1, a.kinetic_pressure()),
        ];
        if let Some(c) = a.contact_stress() {
            v.push(arr("contact_stress", "Pa", 9, c));
        }
        v
    }

    /// The orifice series, named as the store keeps them.
    pub fn series(&self) -> [NamedSeries<'_>; 2] {
        [
            NamedSeries {
                name: ORIFICE_KINETIC_PRESSURE,
                units: "Pa",
                samples: &self.orifice_kinetic_pressure,
            },
            NamedSeries {
                name: ORIFICE_MASS_FLUX,
                units: "kg/s",
                samples: &self.orifice_mass_flux,
            },
        ]
    }
}
