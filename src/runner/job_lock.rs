//! Whether the process running a job still lives: it holds an exclusive OS lock (`flock`) on a
//! file in the job's directory from the moment it claims the job until it has recorded how the
//! job ended, through every stage (the shared fill included). The kernel drops the lock when the
//! process dies, however it dies, so `resume` and `status` know at once that a local job's owner
//! is gone; they need not wait for a heartbeat to age. The heartbeat (`Heartbeat`) still beats
//! for as long as the lock is held: it is what a job on another host is judged by.
//!
//! The same lock guards a shared stage (one process fills, the others wait).

use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use super::job::job_dir;
use super::owner_process::{owner_process, OwnerProcess};
use crate::store::jobs::{owner_place, Liveness, OpenJob, OwnerPlace};

/// The lock file of a job's (or a stage's) directory.
pub fn lock_path(dir: &Path) -> PathBuf {
    dir.join("run.lock")
}

/// An exclusive lock held on `dir/run.lock` until dropped (or the process dies).
#[derive(Debug)]
pub struct DirLock {
    _file: File,
}

impl DirLock {
    /// Takes the lock without waiting; `None` when another process (or another claim in this
    /// one) holds it. The holder's pid is written into the file for people reading it.
    ///
    /// # Errors
    /// The directory or the file cannot be created, or the lock call itself fails.
    pub fn try_take(dir: &Path) -> std::io::Result<Option<DirLock>> {
        std::fs::create_dir_all(dir)?;
        let mut file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(lock_path(dir))?;
        match file.try_lock() {
            Ok(()) => {
                file.set_len(0)?;
                writeln!(file, "{}", std::process::id())?;
                Ok(Some(DirLock { _file: file }))
            }
            Err(TryLockError::WouldBlock) => Ok(None),
            Err(TryLockError::Error(e)) => Err(e),
        }
    }
}

/// What the lock of a directory says about its holder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Holder {
    /// A live process holds the lock.
    Alive,
    /// The lock is free: whoever took it is gone.
    Gone,
    /// No lock file: the job was never locked here (a store written by an older sweep).
    NeverLocked,
}

/// Probes the lock of `dir` without keeping it.
///
/// # Errors
/// The lock file exists but cannot be opened or locked.
pub fn holder(dir: &Path) -> std::io::Result<Holder> {
    let path = lock_path(dir);
    let file = match OpenOptions::new().write(true).open(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Holder::NeverLocked),
        Err(e) => return Err(e),
    };
    match file.try_lock() {
        // Taken and dropped at once: the holder had died.
        Ok(()) => Ok(Holder::Gone),
        Err(TryLockError::WouldBlock) => Ok(Holder::Alive),
        Err(TryLockError::Error(e)) => Err(e),
    }
}

/// Seconds between two heartbeats of a held job (far below `resume --stale-after`).
pub const BEAT: Duration = Duration::from_secs(2);

/// A thread that renews a job's heartbeat every `BEAT` until dropped, whatever the job is doing
/// (filling, waiting for a shared stage, writing a checkpoint).
pub struct Heartbeat {
    stop: Option<mpsc::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Heartbeat {
    /// Starts beating for `job` as `owner` in the store at `db`.
    pub fn start(db: &Path, job: i64, owner: &str) -> Self {
        let (tx, rx) = mpsc::channel::<()>();
        let db = db.to_path_buf();
        let owner = owner.to_string();
        let thread = std::thread::spawn(move || {
            let Ok(conn) = crate::store::open(&db) else {
                return;
            };
            while let Err(mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(BEAT) {
                // A busy store only delays a beat; the next one comes BEAT later.
                let _ = crate::store::jobs::beat(&conn, job, &owner);
            }
        });
        Heartbeat {
            stop: Some(tx),
            thread: Some(thread),
        }
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Whether the owner of a running job lives: a process of this machine by its OS lock in the
/// job's directory under `work_dir`, and where that lock is free or gone, by the process
/// itself (`/proc`: the pid runs and started before it took the job); one of another machine
/// (or of an older sweep, which took no lock) by its heartbeat, taken as dead when older than
/// `stale_after_s`.
pub fn liveness(work_dir: &Path, job: &OpenJob, stale_after_s: f64) -> Liveness {
    let beat = job.heartbeat_age_s.unwrap_or(f64::INFINITY);
    let by_heartbeat = |who: String| {
        if beat < stale_after_s {
            Liveness::Alive(format!(
                "running in {who}, heartbeat {beat:.0} s ago (younger than --stale-after {stale_after_s} s)"
            ))
        } else {
            Liveness::Gone(format!(
                "{who} stopped beating {beat:.0} s ago (--stale-after {stale_after_s} s)"
            ))
        }
    };
    match owner_place(job.lease_owner.as_deref()) {
        OwnerPlace::ThisHost { pid, since } => {
            let dir = job_dir(work_dir, &job.hash);
            let free = match holder(&dir) {
                Ok(Holder::Alive) => {
                    return Liveness::Alive(format!(
                        "running in process {pid}, which holds its lock"
                    ))
                }
                Ok(Holder::Gone) => "its lock is free".to_string(),
                Ok(Holder::NeverLocked) => format!("no lock in {}", dir.display()),
                Err(e) => format!("its lock cannot be read: {e}"),
            };
            // A lock file can be deleted with its directory while its holder runs on: the
            // process itself decides.
            match owner_process(pid, since) {
                OwnerProcess::Running => Liveness::Alive(format!(
                    "running in process {pid} ({free}, but the process that took the job lives)"
                )),
                OwnerProcess::Gone => Liveness::Gone(format!("its process {pid} is gone ({free})")),
                OwnerProcess::Unknown => by_heartbeat(format!("process {pid} ({free})")),
            }
        }
        OwnerPlace::OtherHost { host, pid } => by_heartbeat(format!("process {pid} on {host}")),
        OwnerPlace::Slurm | OwnerPlace::Unknown => {
            by_heartbeat("a process of an older sweep".into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_lock_is_seen_alive_and_a_dropped_one_gone() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(holder(dir.path()).unwrap(), Holder::NeverLocked);
        let lock = DirLock::try_take(dir.path()).unwrap().expect("free");
        assert_eq!(holder(dir.path()).unwrap(), Holder::Alive);
        assert!(
            DirLock::try_take(dir.path()).unwrap().is_none(),
            "a second take fails while held"
        );
        drop(lock);
        assert_eq!(holder(dir.path()).unwrap(), Holder::Gone);
        assert!(DirLock::try_take(dir.path()).unwrap().is_some());
    }
}
