//! Contact laws: parameters (`law`), the force of one contact as a pure function (`hertz_mindlin`: Hertz–Mindlin, or a linear
//! normal spring as LAMMPS' `gran/hooke/history`), and
//! the contact duration that sets the time step (`duration`).

mod duration;
mod hertz_mindlin;
mod law;
mod record;

pub use duration::{contact_time, ContactPair};
pub use hertz_mindlin::{contact_force, elastic_energy, ContactInput};
pub use law::{beta, ContactLaw, Elasticity, LawKernel, NormalModel};
pub use record::ContactRecord;
