//! Contact laws: parameters (`law`), the force of one contact as a pure function (`force`), and
//! the contact duration that sets the time step (`duration`).

mod duration;
mod force;
mod law;
mod record;

pub use duration::{contact_time, ContactPair};
pub use force::{contact_force, elastic_energy, ContactInput};
pub use law::{beta, ContactLaw, Elasticity, LawKernel, NormalModel};
pub use record::ContactRecord;
