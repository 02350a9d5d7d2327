//! Opening the database: WAL mode, a busy timeout (several launchers share it), and the schema
//! created or migrated according to `PRAGMA user_version`; in-memory stores for dry runs and for
//! Slurm tasks.

use std::path::Path;

use anyhow::Context;
use rusqlite::Connection;

/// Current schema version.
pub const SCHEMA_VERSION: i64 = 4;

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
                return Err(e)
                    .with_context(|| format!("{}: cannot switch to WAL mode", path.display()))
            }
        }
    }
    conn.pragma_update(None, "foreign_keys", "ON")?;
    conn.pragma_update(None, "synchronous", "NORMAL")?;
    migrate(&mut conn, &path.display().to_string())?;
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
    conn.pragma_update(None, "foreign_keys", "ON")?;
    migrate(
        &mut conn,
        &copy_of.map_or_else(|| "(memory)".into(), |p| p.display().to_string()),
    )?;
    Ok(conn)
}

/// Creates or upgrades the schema according to `PRAGMA user_version`; `name` names the store in
/// errors.
fn migrate(conn: &mut Connection, name: &str) -> anyhow::Result<()> {
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
        tx.pragma_update(None, "user_version", SCHEMA_VERSION)?;
    }
    tx.commit()?;
    Ok(())
}

fn is_busy(e: &rusqlite::Error) -> bool {
    matches!(e, rusqlite::Error::SqliteFailure(f, _) if f.code == rusqlite::ErrorCode::DatabaseBusy || f.code == rusqlite::ErrorCode::DatabaseLocked)
}
