//! Export for ParaView and OVITO: VTK XML writers for particle frames (`vtu`), coarse-grained
//! field sets (`vti`) and time series (`pvd`), built from one `<DataArray>` writer
//! (`data_array`); `chute_profiles` reads the chute's z profiles as a field set; `job` exports
//! one job's frames and fields into a directory.

mod chute_profiles;
mod data_array;
mod error;
mod job;
mod pvd;
mod vti;
mod vtu;

pub use chute_profiles::chute_profile_set;
pub use data_array::Encoding;
pub use error::ExportError;
pub use job::{export_job, ExportOptions, ExportReport};
pub use pvd::{collection, PvdEntry};
pub use vti::{array_name, field_set_to_vti, image_geometry};
pub use vtu::frame_to_vtu;
