//! A conservative estimate of the host memory a CPU run takes per particle, so a campaign can be
//! refused up front (`sweep launch`, `sweep plan`) instead of aborting on an allocation mid-run.
//!
//! It counts, per particle, in the run's precision (`real_bytes` = 4 or 8):
//! - the state (`state.rs`): id, position, velocity, force, radius, mass, 1/m, angular velocity,
//!   torque, 1/I (spheres) or orientation, angular momentum, body 1/I and half length (oriented
//!   particles), and the contact-history table of `history::HISTORY_SLOTS` (partner id, spring);
//! - the CPU engine's scratch (`cpu/`, `grid.rs`): spheres: the packed kinematics (16 reals),
//!   constants, new force and torque, flags, the wall springs of up to `WALLS` walls, the half
//!   list (start, reference position, and per entry partner, owner, reverse slot and owner, pair
//!   slot and near reference) with `HALF_ENTRIES` entries, and the history carrier a rebuild
//!   builds (as wide as the table); oriented particles: the full neighbour list at a stride of
//!   `FULL_STRIDE` with its reference positions and axes, new force and torque, flags;
//! - copies: one of the state while it is re-sorted by cell (`State::permute` builds each array
//!   anew), and two f64 copies when a checkpoint is written (the converted state and its bytes).
//!
//! The real neighbour counts are lower (a settled bed of spheres has about 5 half-list entries
//! per particle at the default skin; a dense flow of ξ = 1.5 rods fits in the list's first
//! stride of 32), so the estimate errs high by design. Observers' own per-particle memory (the
//! chute's MSD rings) is added by the caller; GPU memory is not counted here.

use super::history::HISTORY_SLOTS;

/// Half-list entries per sphere assumed (the real count is about 5 in a settled bed).
pub const HALF_ENTRIES: u64 = 8;
/// Full-list entries per oriented particle assumed (the list doubles its stride of 32 once).
pub const FULL_STRIDE: u64 = 64;
/// Walls whose springs each sphere keeps (the silo has 2, the chute 1).
pub const WALLS: u64 = 2;

/// Bytes of the state arrays of one particle.
pub fn state_bytes_per_particle(real_bytes: usize, oriented: bool) -> u64 {
    let r = real_bytes as u64;
    let core = 4 + 9 * r + 3 * r; // id; pos, vel, force; radius, mass, 1/m
    let rotation = if oriented {
        6 * r + 4 * r + 3 * r + 3 * r + r // ω, torque; q, L, body 1/I, l/2
    } else {
        6 * r + r // ω, torque; 1/I
    };
    let history = HISTORY_SLOTS as u64 * (4 + 3 * r);
    core + rotation + history
}

/// Conservative host bytes per particle of a CPU run (module doc for what it counts).
pub fn bytes_per_particle(real_bytes: usize, oriented: bool) -> u64 {
    let r = real_bytes as u64;
    let state = state_bytes_per_particle(real_bytes, oriented);
    let engine = if oriented {
        4 + FULL_STRIDE * 4 + 6 * r // count, index; ref_pos, ref_axis
            + 6 * r + 13 // new force and torque; flags and counts
    } else {
        16 * r + 3 * r + 6 * r + 13 // kinematics, constants, new force and torque, flags
            + WALLS * 3 * r // wall springs
            + 8 + 3 * r // half-list start and reverse start, reference position
            + HALF_ENTRIES * (16 + 4 * r + 3 * r) // entry indices, pair slot, near reference
            + HISTORY_SLOTS as u64 * (4 + 3 * r) // history carrier of a rebuild
    };
    let copies = state + 2 * state_bytes_per_particle(8, oriented);
    state + engine + copies
}

/// `RLIMIT_AS` (`ulimit -v`) in bytes; None when unlimited or unreadable. Both the campaign's
/// memory check and the CPU engine's thread check hold their needs against it.
pub fn address_space_limit() -> Option<u64> {
    let mut r = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes only the struct it is given.
    let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut r) } == 0;
    (ok && r.rlim_cur != libc::RLIM_INFINITY).then_some(r.rlim_cur)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimate_covers_the_state_and_grows_with_precision() {
        for oriented in [false, true] {
            let f32_ = bytes_per_particle(4, oriented);
            let f64_ = bytes_per_particle(8, oriented);
            assert!(f32_ < f64_);
            assert!(f32_ > 3 * state_bytes_per_particle(4, oriented));
        }
        // A silo of 30 144 spheres in f64 stays well under a gigabyte.
        assert!(30_144 * bytes_per_particle(8, false) < 1 << 30);
    }
}
