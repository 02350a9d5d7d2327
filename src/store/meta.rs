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
/// The default directory beside the database wins when it exists (a project copied or moved
/// with its `sweep-work/` uses its own copy); otherwise the directory the store recorded, so a
/// renamed database, or one copied alone, still reaches the checkpoints it made. The choice is
/// recorded (absolute) unless the store is read-only.
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
    let recorded = recorded.map(PathBuf::from);
    let chosen = match &recorded {
        Some(r) if !beside.is_dir() => r.clone(),
        _ => beside,
    };
    if recorded.as_ref() != Some(&chosen) && !conn.is_readonly(rusqlite::MAIN_DB)? {
        conn.execute(
            "INSERT INTO store_meta (key, value) VALUES ('work_dir', ?1)
             ON CONFLICT(key) DO UPDATE SET value = excluded.value",
            [chosen.to_string_lossy()],
        )?;
    }
    Ok(chosen)
}
