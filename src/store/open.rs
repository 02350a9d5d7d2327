//! Opening the database: WAL mode, a busy timeout (several launchers share it), and the schema
//! created or migrated according to `PRAGMA user_version`; in-memory stores for dry runs and for
//! Slurm tasks.

use std::path::Path;

use anyhow::Context;
use rusqlite::Connection;

/// Current schema version.
pub const SCHEMA_VERSION: i64 = 15;

/// Opens (creating if needed) the store at `path`.
///
/// # Errors
/// The file cannot be opened, or was written by a newer sweep.
pub fn open(path: &Path) -> anyhow::Result<Connection> {
    let mut conn = Connection::open(path)
        .with_context(|| format!("{}: cannot open the database", path.display()))?;
    conn.busy_timeout(std::time::Duration::from_secs(30))?;
    // Switching to WAL needs an exclusive lock and does not wait on the busy handler: retry while
    // another process is setting the same database up.
    let mut tries = 0;
    loop {
        match conn.pragma_update_and_check(None, "journal_mode", "WAL", |r| r.get::<_, String>(0)) {
            Ok(_) => break,
            Err(e) if tries < 300 && is_busy(&e) => {
                tries += 1;
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            Err(e) => {
                let e = anyhow::Error::from(e);
                if is_read_only(&e) {
                    anyhow::bail!("{}", read_only(&path.display().to_string()));
                }
                return Err(e)
                    .with_context(|| format!("{}: cannot switch to WAL mode", path.display()));
            }
        }
    }
    conn.pragma_update(None, "synchronous", "NORMAL")?;
    // The log is reset after each checkpoint of it; this also shrinks its file back, so a
    // registration of 10⁶ jobs leaves no gigabyte of log behind.
    conn.pragma_update(None, "journal_size_limit", 64 * 1024 * 1024)?;
    migrate(&mut conn, &path.display().to_string())?;
    conn.pragma_update(None, "foreign_keys", "ON")?;
    Ok(conn)
}

/// [`open`] for a command that writes results (`launch`, `resume`): first SQLite's
/// `quick_check` of every page, so that damage (a flipped byte on disk, a copy cut short) is
/// found before results are added to it, with what to do about it.
///
/// # Errors
/// As [`open`], or the check finds damage.
pub fn open_checked(path: &Path) -> anyhow::Result<Connection> {
    let conn = open(path)?;
    let mut q = conn.prepare("PRAGMA quick_check(5)")?;
    let found: Vec<String> = q.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
    drop(q);
    if found.len() != 1 || found[0] != "ok" {
        let d = path.display();
        anyhow::bail!(
            "{d}: the database is damaged (SQLite's quick_check: {}); nothing was run or changed. Keep a copy of it, then recover what it holds: `sqlite3 {d} .recover | sqlite3 recovered.db`, and go on with `--db recovered.db` (jobs whose results were lost run again)",
            found.join("; ")
        );
    }
    Ok(conn)
}

/// An in-memory store with the current schema: empty, or a copy of the store at `copy_of`.
/// A dry run registers its jobs there (the real store is left as it was); a Slurm task keeps
/// its job-local store there, so SQLite is never written on shared storage.
///
/// # Errors
/// `copy_of` cannot be read, or was written by a newer sweep.
pub fn open_in_memory(copy_of: Option<&Path>) -> anyhow::Result<Connection> {
    let mut conn = Connection::open_in_memory()?;
    if let Some(path) = copy_of {
        conn.restore(
            rusqlite::MAIN_DB,
            path,
            None::<fn(rusqlite::backup::Progress)>,
        )
        .with_context(|| format!("{}: cannot copy the database", path.display()))?;
    }
    migrate(
        &mut conn,
        &copy_of.map_or_else(|| "(memory)".into(), |p| p.display().to_string()),
    )?;
    conn.pragma_update(None, "foreign_keys", "ON")?;
    Ok(conn)
}

/// Creates or upgrades the schema according to `PRAGMA user_version`; `name` names the store in
/// errors. Runs with foreign keys off (the campaigns table is rebuilt under its referrers).
fn migrate(conn: &mut Connection, name: &str) -> anyhow::Result<()> {
    migrate_tx(conn, name).map_err(|e| {
        if is_read_only(&e) {
            anyhow::anyhow!("{}", read_only(name))
        } else {
            e.context(format!("{name}: cannot set up the database"))
        }
    })
}

fn migrate_tx(conn: &mut Connection, name: &str) -> anyhow::Result<()> {
    // NOTE: the version check and the migration run in one IMMEDIATE transaction, so two processes
    // opening a new database do not both create it (a deferred transaction would fail with "locked"
    // when upgrading its read lock).
    let tx = conn.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
    let v: i64 = tx.query_row("PRAGMA user_version", [], |r| r.get(0))?;
    if v > SCHEMA_VERSION {
        anyhow::bail!(
            "{name}: schema version {v} is newer than this sweep's ({SCHEMA_VERSION}); upgrade sweep"
        );
    }
    if v < SCHEMA_VERSION {
        // 0 → 1 created the silo tables, 1 → 2 adds the chute tables, 2 → 3 the Slurm executor's
        // `slurm_tasks`, 3 → 4 the coarse-grained fields (`field_sets`, `field_arrays`,
        // `silo_field_series`): schema.sql is idempotent, so every step is running it again.
        tx.execute_batch(include_str!("../../schema.sql"))?;
        // 13 → 14 adds `claim_looks` (what a campaign had spent at each look) the same way.
        // 4 → 5: campaign versions (the name is no longer unique alone, which SQLite can only
        // change by rebuilding the table, ids kept), and the jobs' attempt limit and stage.
        if !has_column(&tx, "campaigns", "version")? {
            tx.execute_batch(
                "CREATE TABLE campaigns_v5 (
                    id INTEGER PRIMARY KEY, name TEXT NOT NULL, version INTEGER NOT NULL DEFAULT 1,
                    file TEXT NOT NULL, scene TEXT NOT NULL, spec_json TEXT NOT NULL,
                    created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
                    UNIQUE (name, version));
                 INSERT INTO campaigns_v5 (id, name, version, file, scene, spec_json, created_at)
                    SELECT id, name, 1, file, scene, spec_json, created_at FROM campaigns;
                 DROP TABLE campaigns;
                 ALTER TABLE campaigns_v5 RENAME TO campaigns;",
            )?;
        }
        if !has_column(&tx, "jobs", "max_attempts")? {
            tx.execute_batch(
                "ALTER TABLE jobs ADD COLUMN max_attempts INTEGER NOT NULL DEFAULT 3;
                 ALTER TABLE jobs ADD COLUMN stage TEXT;",
            )?;
        }
        // 5 → 6: whether the silo was flowing at each field-series sample (NULL for older rows).
        if !has_column(&tx, "silo_field_series", "flowing")? {
            tx.execute_batch("ALTER TABLE silo_field_series ADD COLUMN flowing INTEGER;")?;
        }
        // 6 → 7: the chute's bulk mean V_x series (the flow verdict's tables are new ones).
        if !has_column(&tx, "chute_series", "mean_vx_m_per_s")? {
            tx.execute_batch("ALTER TABLE chute_series ADD COLUMN mean_vx_m_per_s REAL;")?;
        }
        // 7 → 8: campaign targets: Q's block count, jobs run on past their own end (the
        // target's extensions), jobs a target added to a campaign (`target_*` tables are new).
        for (table, column, kind) in [
            ("discharge_summary", "q_blocks", "INTEGER"),
            ("jobs", "extended_to_s", "REAL"),
            ("campaign_jobs", "origin", "TEXT"),
            // 8 → 9: what was said about a job's backend (why `--backend auto` took the CPU).
            ("jobs", "backend_note", "TEXT"),
            // 9 → 10: the threads a job ran with (a claims target's core-hours); the
            // claims' verdicts are a new table.
            ("jobs", "threads", "INTEGER"),
            // 10 → 11: indexes for the job lookups of a campaign of 10⁶ jobs (schema.sql), and
            // whether a campaign's registration (chunk by chunk) is complete.
            ("campaigns", "registered", "INTEGER NOT NULL DEFAULT 1"),
            // 11 → 12: the looks and α a campaign's earlier versions spent on its claims.
            ("campaigns", "looks_carried", "INTEGER NOT NULL DEFAULT 0"),
            ("campaigns", "alpha_carried", "REAL NOT NULL DEFAULT 0"),
            // 12 → 13: the chute's per-block orientation (rods) and D_y; older rows get NULL.
            ("chute_blocks", "nematic_order_s2", "REAL"),
            ("chute_blocks", "mean_abs_cos_flow", "REAL"),
            ("chute_blocks", "diffusion_y_m2_per_s", "REAL"),
            ("chute_blocks", "diffusion_y_stderr_m2_per_s", "REAL"),
            // 14 → 15: the CPU time a job's threads ran (NULL for jobs that ran before).
            ("jobs", "cpu_time_s", "REAL"),
        ] {
            if !has_column(&tx, table, column)? {
                tx.execute_batch(&format!("ALTER TABLE {table} ADD COLUMN {column} {kind};"))?;
            }
        }
        tx.pragma_update(None, "user_version", SCHEMA_VERSION)?;
    }
    tx.commit()?;
    Ok(())
}

fn has_column(conn: &Connection, table: &str, column: &str) -> rusqlite::Result<bool> {
    let mut q = conn.prepare(&format!("PRAGMA table_info({table})"))?;
    let names = q.query_map([], |r| r.get::<_, String>(1))?;
    for n in names {
        if n? == column {
            return Ok(true);
        }
    }
    Ok(false)
}

fn read_only(name: &str) -> String {
    format!(
        "{name}: the database is read-only (the file's or its directory's permissions, or a \
         read-only filesystem): sweep writes it, and its -wal and -shm files beside it"
    )
}

/// A write refused because the file (or its directory, for the WAL files) is read-only.
fn is_read_only(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        matches!(c.downcast_ref::<rusqlite::Error>(),
            Some(rusqlite::Error::SqliteFailure(f, _)) if f.code == rusqlite::ErrorCode::ReadOnly
                || f.code == rusqlite::ErrorCode::CannotOpen)
    })
}

fn is_busy(e: &rusqlite::Error) -> bool {
    matches!(e, rusqlite::Error::SqliteFailure(f, _) if f.code == rusqlite::ErrorCode::DatabaseBusy || f.code == rusqlite::ErrorCode::DatabaseLocked)
}

/// Writes a compacted copy of the store on `conn` to the new file `path` (`VACUUM INTO`).
///
/// # Errors
/// Database errors, among them `path` already existing.
pub fn copy_to(conn: &Connection, path: &Path) -> anyhow::Result<()> {
    conn.execute("VACUUM INTO ?1", [path.display().to_string()])?;
    Ok(())
}
