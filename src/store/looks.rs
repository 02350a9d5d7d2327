//! The looks a campaign's claims have had and the error rate they spent, across its versions.
//!
//! A claims target splits α over its looks. A new version of the campaign (another orifice, a
//! longer window) is the same study looked at again: it carries over the looks and the α its
//! earlier versions spent (`campaigns.looks_carried`, `alpha_carried`), and the jobs their
//! targets added at the points it keeps. Then the verdicts of all versions together still hold
//! at 1 − α.

use std::collections::HashSet;

use anyhow::Result;
use rusqlite::{params, Connection, OptionalExtension};

use crate::campaign::point_key;

/// Looks taken and α spent before a campaign's own first look.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Carried {
    pub looks: u32,
    pub alpha: f64,
}

/// What campaign `cid`'s earlier versions took (zero for a first version).
///
/// # Errors
/// Database errors.
pub fn carried(conn: &Connection, cid: i64) -> Result<Carried> {
    let row: Option<(i64, f64)> = conn
        .query_row(
            "SELECT looks_carried, alpha_carried FROM campaigns WHERE id = ?1",
            [cid],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .optional()?;
    Ok(row.map_or(Carried::default(), |(looks, alpha)| Carried {
        looks: looks as u32,
        alpha,
    }))
}

/// The level of each of campaign `cid`'s own looks before look `look`, by look. A look stored
/// twice (evaluated again after an interruption) is one look; its lowest level counts.
///
/// # Errors
/// Database errors.
pub fn levels_before(conn: &Connection, cid: i64, look: u32) -> Result<Vec<f64>> {
    let mut q = conn.prepare(
        "SELECT MIN(level) FROM claim_verdicts WHERE campaign_id = ?1 AND round < ?2
         GROUP BY round ORDER BY round",
    )?;
    let rows = q
        .query_map(params![cid, look], |r| r.get(0))?
        .collect::<rusqlite::Result<Vec<f64>>>()?;
    Ok(rows)
}

/// The level each of campaign `cid`'s own looks before look `look` tested claim `claim_id`
/// at, by look: 1 (no α spent) at a look where the claim had no value (a result missing, so
/// it could not be decided there). A look stored twice counts once, at its lowest level.
///
/// # Errors
/// Database errors.
pub fn claim_levels_before(
    conn: &Connection,
    cid: i64,
    claim_id: &str,
    look: u32,
) -> Result<Vec<f64>> {
    let mut q = conn.prepare(
        "SELECT MIN(CASE WHEN value IS NULL THEN 1.0 ELSE level END) FROM claim_verdicts
         WHERE campaign_id = ?1 AND claim_id = ?2 AND round < ?3
         GROUP BY round ORDER BY round",
    )?;
    let rows = q
        .query_map(params![cid, claim_id, look], |r| r.get(0))?
        .collect::<rusqlite::Result<Vec<f64>>>()?;
    Ok(rows)
}

/// Everything campaign `cid` has taken: its carried looks and α, and its own looks.
///
/// # Errors
/// Database errors.
pub fn taken(conn: &Connection, cid: i64) -> Result<Carried> {
    let before = carried(conn, cid)?;
    let last: Option<i64> = conn.query_row(
        "SELECT MAX(round) FROM claim_verdicts WHERE campaign_id = ?1",
        [cid],
        |r| r.get(0),
    )?;
    let Some(last) = last else {
        return Ok(before);
    };
    let own = levels_before(conn, cid, last as u32 + 1)?;
    Ok(Carried {
        looks: before.looks.max(last as u32 + 1),
        alpha: before.alpha + own.iter().map(|l| 1.0 - l).sum::<f64>(),
    })
}

/// Carries version `from`'s looks, spent α and target-added jobs into its next version `to`:
/// only the added jobs at one of `points` (the new version's point keys) follow; jobs already
/// linked to `to` stay as they are. Running it again changes nothing. Returns the jobs linked.
///
/// # Errors
/// Database errors.
pub fn carry(conn: &Connection, from: i64, to: i64, points: &HashSet<String>) -> Result<usize> {
    let t = taken(conn, from)?;
    conn.execute(
        "UPDATE campaigns SET looks_carried = ?2, alpha_carried = ?3 WHERE id = ?1",
        params![to, t.looks, t.alpha],
    )?;
    let mut q = conn.prepare(
        "SELECT cj.job_id, cj.label, j.params_json FROM campaign_jobs cj
         JOIN jobs j ON j.id = cj.job_id WHERE cj.campaign_id = ?1 AND cj.origin = 'target'",
    )?;
    let added = q
        .query_map([from], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, String>(1)?,
                r.get::<_, String>(2)?,
            ))
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    let mut link = conn.prepare(
        "INSERT OR IGNORE INTO campaign_jobs (campaign_id, job_id, label, origin)
         VALUES (?1, ?2, ?3, 'target')",
    )?;
    let mut linked = 0;
    for (job_id, label, params) in added {
        if points.contains(&point_key(&params)) {
            linked += link.execute(params![to, job_id, label])?;
        }
    }
    Ok(linked)
}

/// The id of campaign `cid`'s previous version, if it has one.
///
/// # Errors
/// Database errors.
pub fn previous_version(conn: &Connection, cid: i64) -> Result<Option<i64>> {
    Ok(conn
        .query_row(
            "SELECT p.id FROM campaigns c JOIN campaigns p
               ON p.name = c.name AND p.version = c.version - 1
             WHERE c.id = ?1",
            [cid],
            |r| r.get(0),
        )
        .optional()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stores claim `claim` at look `round` with level `level` and `value` (None: untested).
    fn store(conn: &Connection, round: u32, claim: &str, level: f64, value: Option<f64>) {
        conn.execute(
            "INSERT INTO claim_verdicts (campaign_id, round, claim_id, statement, paper,
               paper_value, test, what, verdict, value, lo, hi, level, bound, points, note,
               particle_steps, wall_s)
             VALUES (1, ?1, ?2, '', '', '', 'trend', '', 'undecided', ?3, ?3, ?3, ?4, '> 0',
               '', '', 0, 0)",
            params![round, claim, value, level],
        )
        .unwrap();
    }

    #[test]
    fn a_look_that_could_not_test_a_claim_spends_none_of_its_alpha() {
        let conn = crate::store::open_in_memory(None).unwrap();
        conn.execute(
            "INSERT INTO campaigns (id, name, file, scene, spec_json) VALUES (1, 'c', 'c.json',
               'chute', '{}')",
            [],
        )
        .unwrap();
        // Look 0 tested `a` only; look 1 tested both; look 2 neither.
        store(&conn, 0, "a", 0.99, Some(0.3));
        store(&conn, 0, "b", 0.99, None);
        store(&conn, 1, "a", 0.99, Some(0.2));
        store(&conn, 1, "b", 0.99, Some(0.1));
        store(&conn, 2, "a", 0.99, None);
        store(&conn, 2, "b", 0.99, None);
        assert_eq!(
            claim_levels_before(&conn, 1, "a", 3).unwrap(),
            [0.99, 0.99, 1.0]
        );
        assert_eq!(
            claim_levels_before(&conn, 1, "b", 3).unwrap(),
            [1.0, 0.99, 1.0]
        );
        assert_eq!(claim_levels_before(&conn, 1, "b", 1).unwrap(), [1.0]);
        // The campaign's own looks still count every look at its level (a new version carries
        // them: conservative).
        assert_eq!(levels_before(&conn, 1, 3).unwrap(), [0.99, 0.99, 0.99]);
    }
}
