//! The files through which the submitting host and the array tasks talk, on shared storage.
//! Every one is written whole and atomically (temporary file, fsync, rename), so a reader sees
//! the old file or the new one, never half of one; no SQLite file is ever written there.
//!
//! ```text
//! <work>/slurm/<campaign>-<time>-<k>.sbatch   the submitted scripts (kept for provenance)
//! <work>/slurm/jobs/<id>.json                 what a task needs to know about its job (TaskSpec)
//! <work>/slurm/logs/<array>_<task>.out        each task's stdout and stderr (appended on requeue)
//! <work>/jobs/<hash16>/ckpt-*.bin             checkpoints, as with the local executor
//! <work>/jobs/<hash16>/progress.json          the task's progress, rewritten every second
//! <work>/jobs/<hash16>/result.db              the job-local store of a finished job (results)
//! <work>/jobs/<hash16>/result.json            its marker: checksum and row counts, written last
//! <work>/jobs/<hash16>/failed.json            the error of a failed job
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rusqlite::{Connection, OpenFlags};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::error::SlurmError;
use crate::checkpoint::write_atomic;
use crate::store::jobs::{job_state, JobState};
use crate::store::slurm_ingest::count_results;

/// Version of the files' JSON; a task refuses a job file of another version.
pub const FORMAT: u32 = 1;

/// What a task knows about its job: the job's database row, written at submission.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaskSpec {
    pub format: u32,
    pub job_id: i64,
    pub hash: String,
    pub scene: String,
    pub params_json: String,
    pub seed: i64,
    pub label: String,
    pub target_time_s: f64,
    pub sim_time_s: f64,
    /// Simulated seconds between checkpoints (the campaign's `run.checkpoint_interval_s`).
    pub checkpoint_interval_s: f64,
}

/// A task's last word on its progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProgressFile {
    pub job_id: i64,
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub particle_steps_per_s: f64,
    /// Wall time of this task run so far (s).
    pub wall_time_s: f64,
    pub slurm_job: Option<String>,
}

/// The marker of a finished job: written after `result.db`, so its presence means the store is
/// complete, and its checksum and row counts let `collect` verify that store before ingesting it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResultMarker {
    pub format: u32,
    pub job_id: i64,
    pub hash: String,
    /// The store's file name, beside the marker.
    pub db_file: String,
    pub db_sha256: String,
    pub db_bytes: u64,
    /// Rows of the job in each result table.
    pub rows: BTreeMap<String, i64>,
    /// Slurm's id of the task that finished it (`array_task`), and where it ran.
    pub slurm_job: Option<String>,
    pub host: Option<String>,
}

/// The error of a failed job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailedMarker {
    pub job_id: i64,
    pub hash: String,
    pub error: String,
    pub slurm_job: Option<String>,
}

/// `<work>/slurm`.
pub fn slurm_dir(work: &Path) -> PathBuf {
    work.join("slurm")
}

/// `<work>/slurm/jobs/<id>.json`.
pub fn spec_path(work: &Path, job_id: i64) -> PathBuf {
    slurm_dir(work).join("jobs").join(format!("{job_id}.json"))
}

/// A job's own directory (the local executor's too).
pub fn job_dir(work: &Path, hash: &str) -> PathBuf {
    crate::runner::job::job_dir(work, hash)
}

/// Writes a JSON file atomically.
///
/// # Errors
/// I/O failures.
pub fn write_json<T: Serialize>(path: &Path, v: &T) -> Result<(), SlurmError> {
    let text = serde_json::to_string_pretty(v).expect("serializable");
    write_atomic(path, text.as_bytes()).map_err(SlurmError::io(path))
}

/// Reads a JSON file; `Ok(None)` when it does not exist.
///
/// # Errors
/// Unreadable or not of the expected shape.
pub fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<Option<T>, String> {
    match std::fs::read_to_string(path) {
        Ok(t) => serde_json::from_str(&t)
            .map(Some)
            .map_err(|e| format!("{}: {e}", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// Reads a task's job file.
///
/// # Errors
/// Missing, unreadable or of another format version.
pub fn read_spec(work: &Path, job_id: i64) -> Result<TaskSpec, SlurmError> {
    let path = spec_path(work, job_id);
    match read_json::<TaskSpec>(&path) {
        Ok(Some(s)) if s.format == FORMAT && s.job_id == job_id => Ok(s),
        Ok(Some(s)) => Err(SlurmError::Io {
            path,
            source: std::io::Error::other(format!(
                "job file of format {} for job {}, expected format {FORMAT} for job {job_id}",
                s.format, s.job_id
            )),
        }),
        Ok(None) => Err(SlurmError::NoJobFile { job: job_id, path }),
        Err(e) => Err(SlurmError::Io {
            path,
            source: std::io::Error::other(e),
        }),
    }
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Writes a finished job's store (`conn`, in memory) as `<dir>/result.db`, then its marker.
///
/// # Errors
/// I/O and database failures; the marker is then not written, so nothing counts as done.
pub fn write_result(
    dir: &Path,
    conn: &Connection,
    spec: &TaskSpec,
    slurm_job: Option<String>,
    host: Option<String>,
) -> anyhow::Result<ResultMarker> {
    let db = dir.join("result.db");
    let tmp = dir.join(format!("result.db.tmp.{}", std::process::id()));
    let _ = std::fs::remove_file(&tmp);
    crate::store::copy_to(conn, &tmp)?;
    let bytes = std::fs::read(&tmp).map_err(SlurmError::io(&tmp))?;
    std::fs::File::open(&tmp)
        .and_then(|f| f.sync_all())
        .map_err(SlurmError::io(&tmp))?;
    std::fs::rename(&tmp, &db).map_err(SlurmError::io(&db))?;
    let marker = ResultMarker {
        format: FORMAT,
        job_id: spec.job_id,
        hash: spec.hash.clone(),
        db_file: "result.db".into(),
        db_sha256: sha256_hex(&bytes),
        db_bytes: bytes.len() as u64,
        rows: count_results(conn, "main", spec.job_id)?,
        slurm_job,
        host,
    };
    write_json(&dir.join("result.json"), &marker)?;
    Ok(marker)
}

/// The verified result of a job, if its directory holds one: `Ok(None)` when there is no
/// marker, `Err(why)` when there is one that does not verify (wrong job, checksum, size, the
/// job not done in the store, or row counts that differ from the marker's).
pub fn verify_result(dir: &Path, job_id: i64, hash: &str) -> Result<Option<ResultMarker>, String> {
    let Some(m) = read_json::<ResultMarker>(&dir.join("result.json"))? else {
        return Ok(None);
    };
    if m.format != FORMAT || m.job_id != job_id || m.hash != hash {
        return Err(format!(
            "result.json is for job {} ({}), format {}, expected job {job_id} ({}), format {FORMAT}",
            m.job_id,
            &m.hash[..m.hash.len().min(16)],
            m.format,
            &hash[..hash.len().min(16)]
        ));
    }
    let db = dir.join(&m.db_file);
    let bytes = std::fs::read(&db).map_err(|e| format!("{}: {e}", db.display()))?;
    if bytes.len() as u64 != m.db_bytes || sha256_hex(&bytes) != m.db_sha256 {
        return Err(format!(
            "{}: {} bytes with sha256 {}, the marker says {} bytes with sha256 {}",
            db.display(),
            bytes.len(),
            sha256_hex(&bytes),
            m.db_bytes,
            m.db_sha256
        ));
    }
    let conn = Connection::open_with_flags(&db, OpenFlags::SQLITE_OPEN_READ_ONLY)
        .map_err(|e| format!("{}: {e}", db.display()))?;
    let JobState {
        hash: h, status, ..
    } = job_state(&conn, job_id).map_err(|e| format!("{}: job {job_id}: {e}", db.display()))?;
    if h != hash || status != "done" {
        return Err(format!(
            "{}: job {job_id} is '{status}' with hash {}, expected done with {}",
            db.display(),
            &h[..h.len().min(16)],
            &hash[..hash.len().min(16)]
        ));
    }
    let rows = count_results(&conn, "main", job_id).map_err(|e| format!("{e:#}"))?;
    if rows != m.rows {
        return Err(format!(
            "{}: rows {rows:?}, the marker says {:?}",
            db.display(),
            m.rows
        ));
    }
    Ok(Some(m))
}

/// Removes a job's result files (a marker that did not verify, before the job runs again).
pub fn remove_result(dir: &Path) {
    for f in ["result.json", "result.db"] {
        let _ = std::fs::remove_file(dir.join(f));
    }
}

/// The machine this runs on (Slurm's node name when Slurm started us).
pub fn host() -> Option<String> {
    std::env::var("SLURMD_NODENAME").ok().or_else(|| {
        std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .map(|h| h.trim().to_string())
    })
}
