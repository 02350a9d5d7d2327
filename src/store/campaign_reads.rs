//! What reports read about campaigns: which campaign (by name and version, or the newest of a
//! scene), the names to suggest when none matches, and its jobs' labels and states.

use anyhow::Result;
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

fn campaign_ref(r: &rusqlite::Row<'_>) -> rusqlite::Result<CampaignRef> {
    Ok(CampaignRef {
        id: r.get(0)?,
        name: r.get(1)?,
        scene: r.get(2)?,
    })
}

/// The most recently created campaign of `scene` (of any scene when None), or None.
///
/// # Errors
/// On a database error.
pub fn newest_campaign(conn: &Connection, scene: Option<&str>) -> Result<Option<CampaignRef>> {
    Ok(conn
        .query_row(
            "SELECT id, name, scene FROM campaigns WHERE ?1 IS NULL OR scene = ?1 \
             ORDER BY created_at DESC, id DESC LIMIT 1",
            params![scene],
            campaign_ref,
        )
        .optional()?)
}

/// Version `version` of the campaign named `name` (its latest when None), or None.
///
/// # Errors
/// On a database error.
pub fn campaign_named(
    conn: &Connection,
    name: &str,
    version: Option<i64>,
) -> Result<Option<CampaignRef>> {
    Ok(conn
        .query_row(
            "SELECT id, name, scene FROM campaigns WHERE name = ?1 AND (?2 IS NULL OR version = ?2)
             ORDER BY version DESC LIMIT 1",
            params![name, version],
            campaign_ref,
        )
        .optional()?)
}

/// Every campaign version as a report names it ("NAME", or "NAME@vK" for K > 1), by name and
/// version.
///
/// # Errors
/// On a database error.
pub fn campaign_names(conn: &Connection) -> Result<Vec<String>> {
    let mut stmt = conn.prepare(
        "SELECT name || CASE WHEN version > 1 THEN '@v' || version ELSE '' END
         FROM campaigns ORDER BY name, version",
    )?;
    let names = stmt
        .query_map([], |r| r.get::<_, String>(0))?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(names)
}

/// One job of a campaign: its label there and its status.
#[derive(Debug, Clone)]
pub struct LabelledStatus {
    /// campaign_jobs.label
    pub label: String,
    /// jobs.status
    pub status: String,
}

/// The labels and statuses of a campaign's jobs, by label.
///
/// # Errors
/// On a database error.
pub fn campaign_job_statuses(conn: &Connection, campaign_id: i64) -> Result<Vec<LabelledStatus>> {
    let mut stmt = conn.prepare(
        "SELECT cj.label, j.status FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id \
         WHERE cj.campaign_id = ?1 ORDER BY cj.label",
    )?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            Ok(LabelledStatus {
                label: r.get(0)?,
                status: r.get(1)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}
