//! Opening the database: WAL mode, a busy timeout (several launchers share it), and the schema
//! created or migrated according to `PRAGMA user_version`.

use std::path::Path;

use anyhow::Context;
use rusqlite::Connection;

/// Current schema version.
pub const SCHEMA_VERSION: i64 = 1;

/// Opens (creating if needed) the store at `path`.
///
/// # Errors
/// The file cannot be opened, or was written by a newer sweep.
pub fn open(path: &Path) -> anyhow::Result<Connection> {
    let conn = Connection::open(path)
        .with_context(|| format!("{}: cannot open the database", path.display()))?;
    conn.busy_timeout(std::time::Duration::from_secs(30))?;
    conn.pragma_update(None, "journal_mode", "WAL")?;
    conn.pragma_update(None, "foreign_keys", "ON")?;
    conn.pragma_update(None, "synchronous", "NORMAL")?;
    let v: i64 = conn.query_row("PRAGMA user_version", [], |r| r.get(0))?;
    if v > SCHEMA_VERSION {
        anyhow::bail!(
            "{}: schema version {v} is newer than this sweep's ({SCHEMA_VERSION}); upgrade sweep",
            path.display()
        );
    }
    if v < SCHEMA_VERSION {
        // Version 0 → 1: the initial schema. Later versions add ALTER/CREATE steps here, each in
        // its own transaction, so an interrupted migration leaves a consistent version.
        let tx = conn.unchecked_transaction()?;
        tx.execute_batch(include_str!("../../schema.sql"))?;
        tx.pragma_update(None, "user_version", SCHEMA_VERSION)?;
        tx.commit()?;
    }
    Ok(conn)
}
