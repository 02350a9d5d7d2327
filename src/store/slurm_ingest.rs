//! Ingesting a finished Slurm task's job-local result store into the main one: the job's rows of
//! every result table (every table with a `job_id` column but the campaign links and
//! `slurm_tasks`, so tables added later come along) and its end state, in one transaction.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context;
use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};

use super::now;

/// Tables that hold no results even though they have a `job_id` column.
const NOT_RESULTS: [&str; 2] = ["campaign_jobs", "slurm_tasks"];

/// Tables holding a job's results (every table with a `job_id` column, but the campaign links
/// and this table), sorted. Tasks count their rows with it and collect copies them.
///
/// # Errors
/// Database errors.
pub fn result_tables(conn: &Connection, schema: &str) -> anyhow::Result<Vec<String>> {
    let mut q = conn.prepare(&format!(
        "SELECT name FROM {schema}.sqlite_master WHERE type = 'table' ORDER BY name"
    ))?;
    let names = q
        .query_map([], |r| r.get::<_, String>(0))?
        .collect::<Result<Vec<_>, _>>()?;
    let mut out = Vec::new();
    for t in names {
        if NOT_RESULTS.contains(&t.as_str()) || t == "jobs" {
            continue;
        }
        if columns(conn, schema, &t)?.iter().any(|c| c == "job_id") {
            out.push(t);
        }
    }
    Ok(out)
}

fn columns(conn: &Connection, schema: &str, table: &str) -> anyhow::Result<Vec<String>> {
    let mut q = conn.prepare(&format!("PRAGMA {schema}.table_info(\"{table}\")"))?;
    let cols = q
        .query_map([], |r| r.get::<_, String>(1))?
        .collect::<Result<Vec<_>, _>>()?;
    Ok(cols)
}

/// Rows per result table for `job_id` (tables without rows included, with 0).
///
/// # Errors
/// Database errors.
pub fn count_results(
    conn: &Connection,
    schema: &str,
    job_id: i64,
) -> anyhow::Result<BTreeMap<String, i64>> {
    let mut out = BTreeMap::new();
    for t in result_tables(conn, schema)? {
        let n: i64 = conn.query_row(
            &format!("SELECT COUNT(*) FROM {schema}.\"{t}\" WHERE job_id = ?1"),
            [job_id],
            |r| r.get(0),
        )?;
        out.insert(t, n);
    }
    Ok(out)
}

/// How an ingestion ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Ingested {
    /// The results are in, the job is done.
    Done,
    /// The job was already done here: nothing was written.
    AlreadyDone,
}

/// Copies `job_id`'s results from the job-local store at `result_db` (a finished task's) into
/// this store and marks the job done, in one transaction. `rows` is what the task counted: a
/// table whose copied rows differ from it aborts the ingestion.
///
/// # Errors
/// Database errors, a result store without the job done in it, or a row-count mismatch.
pub fn ingest(
    conn: &mut Connection,
    job_id: i64,
    job_hash: &str,
    result_db: &Path,
    rows: &BTreeMap<String, i64>,
) -> anyhow::Result<Ingested> {
    // NOTE: ATTACH is refused inside a transaction: attach first, detach after.
    conn.execute(
        "ATTACH DATABASE ?1 AS job_result",
        [readonly_uri(result_db)],
    )
    .with_context(|| format!("{}: cannot attach", result_db.display()))?;
    let r = ingest_attached(conn, job_id, job_hash, rows);
    let d = conn.execute("DETACH DATABASE job_result", []);
    let out = r.with_context(|| format!("ingesting {}", result_db.display()))?;
    d?;
    Ok(out)
}

fn ingest_attached(
    conn: &mut Connection,
    job_id: i64,
    job_hash: &str,
    rows: &BTreeMap<String, i64>,
) -> anyhow::Result<Ingested> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let status: String = tx.query_row("SELECT status FROM jobs WHERE id = ?1", [job_id], |r| {
        r.get(0)
    })?;
    if status == "done" {
        return Ok(Ingested::AlreadyDone);
    }
    type JobEnd = (
        String,
        String,
        f64,
        f64,
        f64,
        i64,
        Option<String>,
        Option<String>,
        Option<String>,
        Option<String>,
        Option<i64>,
        Option<String>,
    );
    let row: Option<JobEnd> = tx
        .query_row(
            "SELECT hash, status, progress, sim_time_s, wall_time_s, particle_steps, finished_at, backend, adapter,
                    precision, particles, program_version
             FROM job_result.jobs WHERE id = ?1",
            [job_id],
            |r| {
                Ok((
                    r.get(0)?,
                    r.get(1)?,
                    r.get(2)?,
                    r.get(3)?,
                    r.get(4)?,
                    r.get(5)?,
                    r.get(6)?,
                    r.get(7)?,
                    r.get(8)?,
                    r.get(9)?,
                    r.get(10)?,
                    r.get(11)?,
                ))
            },
        )
        .optional()?;
    let Some(j) = row else {
        anyhow::bail!("job {job_id} is not in the result store");
    };
    anyhow::ensure!(
        j.0 == job_hash,
        "the result store holds job {job_id} with hash {}, expected {job_hash}",
        j.0
    );
    anyhow::ensure!(
        j.1 == "done",
        "job {job_id} is '{}' in the result store, not done",
        j.1
    );
    let theirs = result_tables(&tx, "job_result")?;
    for t in result_tables(&tx, "main")? {
        if t == "field_sets" {
            // Sets carry their arrays by id, which the job-local store numbered on its own.
            let n = if theirs.contains(&t) {
                super::fields::copy_job_fields(&tx, "job_result", job_id)? as i64
            } else {
                super::fields::delete_job_fields(&tx, job_id)?;
                0
            };
            let expected = rows.get(&t).copied().unwrap_or(0);
            anyhow::ensure!(
                n == expected,
                "table {t}: copied {n} row(s), the task counted {expected}"
            );
            continue;
        }
        tx.execute(
            &format!("DELETE FROM main.\"{t}\" WHERE job_id = ?1"),
            [job_id],
        )?;
        if !theirs.contains(&t) {
            anyhow::ensure!(
                rows.get(&t).copied().unwrap_or(0) == 0,
                "table {t} is missing from the result store"
            );
            continue;
        }
        let mine = columns(&tx, "main", &t)?;
        let other = columns(&tx, "job_result", &t)?;
        let cols: Vec<String> = mine
            .iter()
            .filter(|c| other.contains(c))
            .map(|c| format!("\"{c}\""))
            .collect();
        let cols = cols.join(", ");
        let n = tx.execute(
            &format!(
                "INSERT INTO main.\"{t}\" ({cols}) SELECT {cols} FROM job_result.\"{t}\" WHERE job_id = ?1"
            ),
            [job_id],
        )?;
        let expected = rows.get(&t).copied().unwrap_or(0);
        anyhow::ensure!(
            n as i64 == expected,
            "table {t}: copied {n} row(s), the task counted {expected}"
        );
    }
    tx.execute(
        "UPDATE jobs SET status = 'done', lease_owner = NULL, last_error = NULL, heartbeat_at = ?2, progress = ?3,
                sim_time_s = ?4, wall_time_s = ?5, particle_steps = ?6,
                finished_at = COALESCE(?7, strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
                backend = ?8, adapter = ?9, precision = COALESCE(?10, precision), particles = COALESCE(?11, particles),
                program_version = COALESCE(?12, program_version)
         WHERE id = ?1",
        params![job_id, now(), j.2, j.3, j.4, j.5, j.6, j.7, j.8, j.9, j.10, j.11],
    )?;
    // The task's threads and CPU time (core-hours and CPU hours are read together); a task
    // store from before schema 15 leaves the CPU time unknown.
    let result_columns = columns(&tx, "job_result", "jobs")?;
    let cpu = if result_columns.iter().any(|c| c == "cpu_time_s") {
        "(SELECT cpu_time_s FROM job_result.jobs WHERE id = ?1)"
    } else {
        "NULL"
    };
    let threads = if result_columns.iter().any(|c| c == "threads") {
        "COALESCE((SELECT threads FROM job_result.jobs WHERE id = ?1), threads)"
    } else {
        "threads"
    };
    tx.execute(
        &format!("UPDATE jobs SET cpu_time_s = {cpu}, threads = {threads} WHERE id = ?1"),
        [job_id],
    )?;
    if result_columns.iter().any(|c| c == "backend_note") {
        tx.execute(
            "UPDATE jobs SET backend_note = (SELECT backend_note FROM job_result.jobs WHERE id = ?1) WHERE id = ?1",
            [job_id],
        )?;
    }
    tx.execute(
        "UPDATE slurm_tasks SET state = 'done' WHERE job_id = ?1 AND state IN ('active', 'ended', 'cancelled')",
        [job_id],
    )?;
    tx.commit()?;
    Ok(Ingested::Done)
}

/// A read-only SQLite URI for `path` (ATTACH takes a file name or a URI).
fn readonly_uri(path: &Path) -> String {
    let mut s = String::from("file:");
    for c in path.display().to_string().chars() {
        match c {
            '%' | '?' | '#' | ' ' => s.push_str(&format!("%{:02X}", c as u32)),
            c => s.push(c),
        }
    }
    s.push_str("?mode=ro");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uri_escapes_what_sqlite_would_read_as_syntax() {
        assert_eq!(
            readonly_uri(Path::new("/a b/c?d#e%f/r.db")),
            "file:/a%20b/c%3Fd%23e%25f/r.db?mode=ro"
        );
    }

    #[test]
    fn result_tables_are_those_with_a_job_id() {
        let conn = crate::store::open_in_memory(None).unwrap();
        let t = result_tables(&conn, "main").unwrap();
        for want in [
            "discharge_series",
            "discharge_summary",
            "clogs",
            "chute_summary",
        ] {
            assert!(t.contains(&want.to_string()), "{t:?}");
        }
        for not in ["jobs", "campaign_jobs", "slurm_tasks", "bench_runs"] {
            assert!(!t.contains(&not.to_string()), "{t:?}");
        }
    }
}
