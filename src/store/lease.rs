//! Who holds a job: a lease's owner (`local:HOST:PID:T`, or a Slurm task) and where it runs.

use super::now;

/// The owner of a claimed job: `local:HOST:PID:T` (T tells two claims of one process apart).
#[derive(Clone, Debug)]
pub struct Lease {
    pub owner: String,
}

impl Lease {
    pub fn new() -> Self {
        Self {
            owner: format!("local:{}:{}:{}", this_host(), std::process::id(), now()),
        }
    }
}

impl Default for Lease {
    fn default() -> Self {
        Self::new()
    }
}

/// This machine's name, as local leases record it.
pub fn this_host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "localhost".into())
}

/// Where a lease's owner runs, as far as this machine can tell.
#[derive(Clone, Debug, PartialEq)]
pub enum OwnerPlace {
    /// A process of this machine (`pid`, which took the lease at unix time `since`): its OS
    /// lock says whether it lives, or the process itself when the lock file is gone.
    ThisHost { pid: u32, since: f64 },
    /// A process of another machine sharing the store: judged by its heartbeat.
    OtherHost { host: String, pid: u32 },
    /// A Slurm task: `sweep collect` decides when it ended.
    Slurm,
    /// A lease written by an older sweep (`PID:T`), or none: judged by its heartbeat.
    Unknown,
}

/// Parses a lease owner.
pub fn owner_place(owner: Option<&str>) -> OwnerPlace {
    let Some(o) = owner else {
        return OwnerPlace::Unknown;
    };
    if o.starts_with("slurm:") {
        return OwnerPlace::Slurm;
    }
    let parts: Vec<&str> = o.split(':').collect();
    match parts.as_slice() {
        ["local", host, pid, since] => match pid.parse() {
            Ok(pid) if *host == this_host() => OwnerPlace::ThisHost {
                pid,
                since: since.parse().unwrap_or(f64::NAN),
            },
            Ok(pid) => OwnerPlace::OtherHost {
                host: host.to_string(),
                pid,
            },
            Err(_) => OwnerPlace::Unknown,
        },
        _ => OwnerPlace::Unknown,
    }
}
