//! Facts about the store itself (`store_meta`): where its work directory is.

use std::path::{Path, PathBuf};

use rusqlite::{Connection, OptionalExtension};

/// Where a database's work directory goes by default: `sweep-work/<stem>` beside the file.
pub fn default_work_dir(db: &Path) -> PathBuf {
    let stem = db
        .file_stem()
        .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned());
    db.parent()
        .unwrap_or(Path::new("."))
        .join("sweep-work")
        .join(stem)
}

/// The work directory (checkpoints, shared stages, Slurm files) of the store at `db`.
///
/// The store records its absolute path when first asked, so a renamed or copied database still
/// reaches the checkpoints it made. When the recorded directory is gone but the default one
/// beside the database exists (the database moved together with its `sweep-work/`), that one is
/// used and recorded. A read-only store is only read.
///
/// # Errors
/// Database errors, or the current directory cannot be read.
pub fn work_dir(conn: &Connection, db: &Path) -> anyhow::Result<PathBuf> {
    let beside = std::path::absolute(default_work_dir(db))?;
    let recorded: Option<String> = conn
        .query_row(
            "SELECT value FROM store_meta WHERE key = 'work_dir'",
            [],
            |r| r.get(0),
        )
        .optional()?;
    let chosen = match recorded.map(PathBuf::from) {
        Some(r) if r.is_dir() || !beside.is_dir() => return Ok(r),
        _ => beside,
    };
    if !conn.is_readonly(rusqlite::MAIN_DB)? {
        conn.execute(
            "INSERT INTO store_meta (key, value) VALUES ('work_dir', ?1)
             ON CONFLICT(key) DO UPDATE SET value = excluded.value",
            [chosen.to_string_lossy()],
        )?;
    }
    Ok(chosen)
}
