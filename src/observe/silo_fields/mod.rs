//! Coarse-grained fields of a silo job (the silo paper's Sec. III.B): settings, the observer
//! that samples them during the discharge, and its results as plain field sets and series
//! (`store::fields::save_silo_fields` writes them).

mod observer;
mod results;
mod settings;

pub use observer::{MapAverage, SiloFieldObserver, ORIFICE_KINETIC_PRESSURE, ORIFICE_MASS_FLUX};
pub use results::{NamedSeries, MEAN_FLOWING};
pub use settings::SiloFieldSettings;
