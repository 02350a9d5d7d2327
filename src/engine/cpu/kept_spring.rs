//! One contact's force in a per-particle gather, its tangential spring kept in the particle's
//! history rows between steps: the same for spheres and rods, partners and walls.

use crate::engine::contact::{contact_force, ContactInput, LawKernel};
use crate::engine::history::Rows;
use crate::engine::real::{Real, V3};

/// One contact's force, its tangential spring kept in the particle's history `rows` under the
/// partner's `key` (a new zero spring each step without rows); `full` is set when the rows
/// cannot hold it.
#[inline(always)]
pub(super) fn gathered_force<R: Real>(
    law: &LawKernel<R>,
    c: &ContactInput<R>,
    rows: Option<&mut Rows<'_, R>>,
    key: u32,
    dt: R,
    full: &mut bool,
) -> V3<R> {
    match rows {
        Some(rows) => {
            let mut spring = rows.get(key);
            let fc = contact_force(law, c, &mut spring, dt);
            *full |= !rows.put(key, spring);
            fc
        }
        None => {
            let mut spring = V3::zero();
            contact_force(law, c, &mut spring, dt)
        }
    }
}
