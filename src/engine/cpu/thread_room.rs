//! Whether the address-space limit (`ulimit -v`) leaves room for the engine's threads. Checked
//! before they are spawned: a thread whose stack fits but whose signal stack does not aborts
//! the whole process inside the standard library, where no error can be returned.

use crate::engine::memory::address_space_limit;

/// Address space one engine thread takes, with margin: a rayon worker's and a team helper's
/// stack (2 MiB each, the standard library's default), their guard pages and signal stacks.
const PER_THREAD_BYTES: u64 = 2 * (2 << 20) + (1 << 20);

/// Why `threads` engine threads would not fit under this process's address-space limit, or
/// None when they fit (or no limit is set, or it cannot be read).
pub(super) fn lacking_room(threads: usize) -> Option<String> {
    let limit = address_space_limit()?;
    let used = address_space_used()?;
    let needed = threads as u64 * PER_THREAD_BYTES;
    (used.saturating_add(needed) > limit).then(|| {
        format!(
            "their stacks need about {} MB of address space, and the limit leaves {} MB",
            needed >> 20,
            limit.saturating_sub(used) >> 20
        )
    })
}

/// The process's mapped address space now (the first field of /proc/self/statm, in pages).
fn address_space_used() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().next()?.parse().ok()?;
    // SAFETY: sysconf has no preconditions.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    Some(pages * u64::try_from(page).ok()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_process_knows_its_address_space() {
        // The test process maps at least its own binary; a limit, when set, is above that.
        let used = address_space_used().expect("/proc/self/statm");
        assert!(used > 1 << 20, "{used}");
        if let Some(limit) = address_space_limit() {
            assert!(limit > used);
        }
        // Far more threads than any address space holds.
        if address_space_limit().is_some() {
            assert!(lacking_room(1 << 40).is_some());
        }
    }
}
