//! Which campaign a report is about: by name, or the most recent one (of a scene). Read-only.

use anyhow::{bail, Result};
use rusqlite::Connection;

pub use crate::store::campaign_reads::CampaignRef;
use crate::store::campaign_reads::{campaign_named, campaign_names, newest_campaign};

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
    let Some(name) = name else {
        let found = newest_campaign(conn, scene)?;
        return match (found, scene) {
            (Some(c), _) => Ok(c),
            (None, Some(scene)) => {
                bail!("no campaign with scene '{scene}' in the database: launch one first")
            }
            (None, None) => bail!("no campaign in the database: launch one first"),
        };
    };
    let (name, version) = split_version(name);
    let found = campaign_named(conn, name, version)?;
    match (found, scene) {
        (Some(c), Some(scene)) if c.scene != scene => bail!(
            "campaign '{}' is a '{}' campaign; this figure needs a '{scene}' campaign",
            c.name,
            c.scene
        ),
        (Some(c), _) => Ok(c),
        (None, _) => {
            let names = campaign_names(conn)?;
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
