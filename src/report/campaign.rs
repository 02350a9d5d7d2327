//! Which campaign a report is about: by name, or the most recent one (of a scene). Read-only.

use anyhow::{bail, Result};
use rusqlite::{params, Connection, OptionalExtension};

/// A campaign row, as much of it as a report needs.
#[derive(Debug, Clone)]
pub struct CampaignRef {
    /// campaigns.id
    pub id: i64,
    /// campaigns.name
    pub name: String,
    /// campaigns.scene, e.g. "silo"
    pub scene: String,
}

/// "NAME@vK" as (NAME, Some(K)); a plain name (or one whose suffix is not a version) as
/// (name, None), which means its latest version.
pub fn split_version(name: &str) -> (&str, Option<i64>) {
    match name.rsplit_once("@v") {
        Some((n, k)) if !n.is_empty() => match k.parse() {
            Ok(k) => (n, Some(k)),
            Err(_) => (name, None),
        },
        _ => (name, None),
    }
}

/// The campaign named `name` (its latest version; "NAME@vK" for version K), or when None the most recent campaign of `scene` (of any scene
/// when `scene` is None). A named campaign must belong to `scene` when one is given.
///
/// # Errors
/// When no campaign matches, when the named one belongs to another scene, or on a database error.
pub fn find_campaign(
    conn: &Connection,
    name: Option<&str>,
    scene: Option<&str>,
) -> Result<CampaignRef> {
    let row = |r: &rusqlite::Row<'_>| {
        Ok(CampaignRef {
            id: r.get(0)?,
            name: r.get(1)?,
            scene: r.get(2)?,
        })
    };
    let Some(name) = name else {
        let found = conn
            .query_row(
                "SELECT id, name, scene FROM campaigns WHERE ?1 IS NULL OR scene = ?1 \
                 ORDER BY created_at DESC, id DESC LIMIT 1",
                params![scene],
                row,
            )
            .optional()?;
        return match (found, scene) {
            (Some(c), _) => Ok(c),
            (None, Some(scene)) => {
                bail!("no campaign with scene '{scene}' in the database: launch one first")
            }
            (None, None) => bail!("no campaign in the database: launch one first"),
        };
    };
    let (name, version) = split_version(name);
    let found = conn
        .query_row(
            "SELECT id, name, scene FROM campaigns WHERE name = ?1 AND (?2 IS NULL OR version = ?2)
             ORDER BY version DESC LIMIT 1",
            params![name, version],
            row,
        )
        .optional()?;
    match (found, scene) {
        (Some(c), Some(scene)) if c.scene != scene => bail!(
            "campaign '{}' is a '{}' campaign; this figure needs a '{scene}' campaign",
            c.name,
            c.scene
        ),
        (Some(c), _) => Ok(c),
        (None, _) => {
            let mut stmt = conn.prepare(
                "SELECT name || CASE WHEN version > 1 THEN '@v' || version ELSE '' END
                 FROM campaigns ORDER BY name, version",
            )?;
            let names = stmt
                .query_map([], |r| r.get::<_, String>(0))?
                .collect::<rusqlite::Result<Vec<_>>>()?;
            if names.is_empty() {
                bail!("no campaign named '{name}': the database has no campaigns")
            }
            bail!(
                "no campaign named '{name}': known campaigns are {}",
                names.join(", ")
            )
        }
    }
}
