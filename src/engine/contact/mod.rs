//! Contact laws: parameters (`law`), the force of one contact as a pure function (`hertz_mindlin`: Hertz–Mindlin, or a linear
//! normal spring as LAMMPS' `gran/hooke/history`), and
//! the contact duration that sets the time step (`duration`), and the effective mass of a
//! contact, rotation included (`effective_mass`).

mod duration;
mod effective_mass;
mod hertz_mindlin;
mod law;
mod record;

pub use duration::{contact_time, ContactPair};
pub use effective_mass::{pair_effective_mass, wall_effective_mass, Inertial};
pub use hertz_mindlin::{contact_force, contact_force_in, elastic_energy, ContactInput};
pub use law::{beta, ContactLaw, Elasticity, LawKernel, NormalModel};
pub use record::ContactRecord;
