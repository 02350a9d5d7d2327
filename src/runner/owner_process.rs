//! Whether the process that took a job's lease still runs, asked of the kernel (`/proc`), not
//! of a file the user can delete. A pid alone is not enough: the kernel reuses pids, so the
//! process must also have started before it took the lease.

/// What `/proc` says of process `pid`, which took a lease at unix time `since`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OwnerProcess {
    /// It runs, and started before the lease: the lease's owner.
    Running,
    /// No such process, a zombie, or a process started after the lease (a reused pid).
    Gone,
    /// `/proc` cannot tell (not Linux, or unreadable).
    Unknown,
}

/// Asks `/proc` about `pid`.
pub fn owner_process(pid: u32, since: f64) -> OwnerProcess {
    if !std::path::Path::new("/proc/self/stat").exists() {
        return OwnerProcess::Unknown;
    }
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return OwnerProcess::Gone;
    };
    // Fields after the command name (in parentheses, which may hold spaces): state is the
    // 3rd field of the line, starttime (clock ticks after boot) the 22nd.
    let Some(rest) = stat.rfind(')').map(|i| &stat[i + 1..]) else {
        return OwnerProcess::Unknown;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    if matches!(fields.first(), Some(&"Z") | Some(&"X")) {
        return OwnerProcess::Gone;
    }
    let (Some(start_ticks), Some(boot)) = (
        fields.get(19).and_then(|s| s.parse::<f64>().ok()),
        boot_time(),
    ) else {
        return OwnerProcess::Unknown;
    };
    if !since.is_finite() {
        return OwnerProcess::Running;
    }
    // SAFETY: sysconf has no preconditions.
    let ticks = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    let started = boot + start_ticks / ticks.max(1) as f64;
    // A second of slack: boot time is whole seconds.
    if started <= since + 1.0 {
        OwnerProcess::Running
    } else {
        OwnerProcess::Gone
    }
}

/// The machine's boot time, unix seconds (`btime` of `/proc/stat`).
fn boot_time() -> Option<f64> {
    std::fs::read_to_string("/proc/stat")
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix("btime "))
        .and_then(|s| s.trim().parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_process_runs_and_a_reused_pid_does_not_count() {
        let me = std::process::id();
        let now = crate::store::now();
        assert_eq!(owner_process(me, now), OwnerProcess::Running);
        // A lease taken a day before this process started was another process's.
        assert_eq!(
            owner_process(me, now - 86_400.0 * 365.0),
            OwnerProcess::Gone
        );
    }

    #[test]
    fn an_ended_process_is_gone() {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        assert_eq!(owner_process(pid, crate::store::now()), OwnerProcess::Gone);
    }
}
