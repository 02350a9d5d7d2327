//! A campaign's claim verdicts, one row per claim and look (`claim_verdicts`), and what its
//! jobs have cost (particle-steps, wall time, core-hours) for the claims' budget.

use anyhow::Result;
use rusqlite::{params, Connection};

/// One claim at one look.
#[derive(Clone, Debug, PartialEq)]
pub struct VerdictRow {
    pub round: u32,
    pub claim_id: String,
    pub statement: String,
    pub paper: String,
    pub paper_value: String,
    pub test: String,
    pub what: String,
    pub verdict: String,
    pub value: Option<f64>,
    pub lo: Option<f64>,
    pub hi: Option<f64>,
    pub level: f64,
    pub bound: String,
    pub points: String,
    pub note: String,
    pub particle_steps: f64,
    pub wall_s: f64,
    pub forecast_particle_steps: Option<f64>,
    pub forecast_wall_s: Option<f64>,
}

fn finite(v: Option<f64>) -> Option<f64> {
    v.filter(|x| x.is_finite())
}

/// A row's number as the notes write it (4 decimals, "-" when unknown).
fn num(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{x:.4}"))
}

/// Stores the verdicts of look `round` (replacing that look's earlier rows, which a look
/// evaluated again after an interruption keeps: `recorded`).
///
/// # Errors
/// Database errors.
pub fn save_verdicts(conn: &Connection, campaign_id: i64, rows: &[VerdictRow]) -> Result<()> {
    let mut q = conn.prepare(
        "INSERT OR REPLACE INTO claim_verdicts (campaign_id, round, claim_id, statement, paper,
            paper_value, test, what, verdict, value, lo, hi, level, bound, points, note,
            particle_steps, wall_s, forecast_particle_steps, forecast_wall_s)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20)",
    )?;
    for r in rows {
        q.execute(params![
            campaign_id,
            r.round,
            r.claim_id,
            r.statement,
            r.paper,
            r.paper_value,
            r.test,
            r.what,
            r.verdict,
            finite(r.value),
            finite(r.lo),
            finite(r.hi),
            r.level,
            r.bound,
            r.points,
            r.note,
            r.particle_steps,
            r.wall_s,
            finite(r.forecast_particle_steps),
            finite(r.forecast_wall_s)
        ])?;
    }
    Ok(())
}

const ROW_COLUMNS: &str = "round, claim_id, statement, paper, paper_value, test, what, verdict,
    value, lo, hi, level, bound, points, note, particle_steps, wall_s, forecast_particle_steps,
    forecast_wall_s";

fn verdict_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<VerdictRow> {
    Ok(VerdictRow {
        round: r.get(0)?,
        claim_id: r.get(1)?,
        statement: r.get(2)?,
        paper: r.get(3)?,
        paper_value: r.get(4)?,
        test: r.get(5)?,
        what: r.get(6)?,
        verdict: r.get(7)?,
        value: r.get(8)?,
        lo: r.get(9)?,
        hi: r.get(10)?,
        level: r.get(11)?,
        bound: r.get(12)?,
        points: r.get(13)?,
        note: r.get(14)?,
        particle_steps: r.get(15)?,
        wall_s: r.get(16)?,
        forecast_particle_steps: r.get(17)?,
        forecast_wall_s: r.get(18)?,
    })
}

/// Each claim's first decision (supported or contradicted) at a look before `before_round`,
/// by claim id, each claim's in order of looks. An earlier version's looks count: a new version is the same study looked at
/// again, and its looks go on from the earlier ones' numbers (`store::looks`). A caller keeps
/// such a decision only for the same test of the claim (`standing`).
///
/// # Errors
/// Database errors.
pub fn first_decisions(
    conn: &Connection,
    campaign_id: i64,
    before_round: u32,
) -> Result<std::collections::BTreeMap<String, Vec<VerdictRow>>> {
    let mut q = conn.prepare(&format!(
        "SELECT {ROW_COLUMNS} FROM claim_verdicts
         WHERE campaign_id IN (SELECT e.id FROM campaigns e JOIN campaigns c
                                 ON e.name = c.name AND e.version <= c.version
                               WHERE c.id = ?1)
           AND round < ?2 AND verdict IN ('supported', 'contradicted')
         ORDER BY round"
    ))?;
    let rows = q
        .query_map(params![campaign_id, before_round], verdict_row)?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    // Each claim's decisions by round: `standing` takes the first of the claim's present test.
    let mut by_claim = std::collections::BTreeMap::<String, Vec<VerdictRow>>::new();
    for r in rows {
        by_claim.entry(r.claim_id.clone()).or_default().push(r);
    }
    Ok(by_claim)
}

/// The rows stored for look `round`, by claim id, while the look's data are those it read: no
/// job of the campaign has finished since it was recorded (a retried or extended job brings
/// new data, and the look is taken again). Such a look stands (`recorded`).
///
/// # Errors
/// Database errors.
pub fn look_rows(
    conn: &Connection,
    campaign_id: i64,
    round: u32,
) -> Result<std::collections::BTreeMap<String, VerdictRow>> {
    // Both times are strftime('%Y-%m-%dT%H:%M:%fZ'): they compare as text.
    let mut q = conn.prepare(&format!(
        "SELECT {ROW_COLUMNS} FROM claim_verdicts v WHERE campaign_id = ?1 AND round = ?2
           AND NOT EXISTS (SELECT 1 FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
                           WHERE cj.campaign_id = ?1 AND j.finished_at > v.created_at)"
    ))?;
    let rows = q
        .query_map(params![campaign_id, round], verdict_row)?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows.into_iter().map(|r| (r.claim_id.clone(), r)).collect())
}

/// A look already recorded stands as recorded: its data were fixed when it was taken, and a
/// verdict read again under a later build's rules (which replicas count, say) would be a second
/// test of the same data at the same α. Returns the recorded row, and a line saying what the
/// data read today give when that differs from the record.
pub fn recorded(stored: &VerdictRow, today: &VerdictRow) -> (VerdictRow, Option<String>) {
    let reading = |r: &VerdictRow| {
        format!(
            "{} {} [{}, {}]",
            r.verdict,
            num(r.value),
            num(r.lo),
            num(r.hi)
        )
    };
    let differs = reading(stored) != reading(today);
    let line = differs.then(|| {
        format!(
            "{}: look {} stands as recorded ({}); its data read today give {}",
            stored.claim_id,
            stored.round,
            reading(stored),
            reading(today)
        )
    });
    (stored.clone(), line)
}

/// The earlier decision that stands for `now`'s claim: one of the same test, what and bound.
/// A later version may keep a claim's id and change its test; its looks then decide afresh.
pub fn standing<'a>(
    decided: &'a std::collections::BTreeMap<String, Vec<VerdictRow>>,
    now: &VerdictRow,
) -> Option<&'a VerdictRow> {
    decided
        .get(&now.claim_id)?
        .iter()
        .find(|f| (&f.test, &f.what, &f.bound) == (&now.test, &now.what, &now.bound))
}

/// A claim decided at an earlier look stays decided, as a sequential test stops at its first
/// decision: later looks spend α on the claims still open, not on re-testing this one. The row
/// of look `now.round` keeps the deciding look's verdict, value and interval, and says what the
/// later look saw.
pub fn kept_decision(first: &VerdictRow, now: &VerdictRow) -> VerdictRow {
    let mut note = format!(
        "decided at look {}; look {} reads {} [{}, {}], {}",
        first.round,
        now.round,
        num(now.value),
        num(now.lo),
        num(now.hi),
        now.verdict
    );
    if !first.note.is_empty() {
        note = format!("{note}; {}", first.note);
    }
    VerdictRow {
        round: now.round,
        note,
        forecast_particle_steps: None,
        forecast_wall_s: None,
        ..first.clone()
    }
}

/// The verdicts of the campaign's latest look (every claim), in the file's order of first
/// storage, each claim decided at an earlier look kept as decided (`kept_decision`); empty when
/// none was stored.
///
/// # Errors
/// Database errors.
pub fn latest_verdicts(conn: &Connection, campaign_id: i64) -> Result<Vec<VerdictRow>> {
    let mut q = conn.prepare(&format!(
        "SELECT {ROW_COLUMNS} FROM claim_verdicts
         WHERE campaign_id = ?1
           AND round = (SELECT MAX(round) FROM claim_verdicts WHERE campaign_id = ?1)
         ORDER BY rowid"
    ))?;
    let rows = q
        .query_map([campaign_id], verdict_row)?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    let Some(latest) = rows.first().map(|r| r.round) else {
        return Ok(rows);
    };
    let decided = first_decisions(conn, campaign_id, latest)?;
    Ok(rows
        .into_iter()
        .map(|r| match standing(&decided, &r) {
            Some(first) => kept_decision(first, &r),
            None => r,
        })
        .collect())
}

/// Every (round, claim, verdict) of the campaign, by round: how its claims were decided.
///
/// # Errors
/// Database errors.
pub fn history(conn: &Connection, campaign_id: i64) -> Result<Vec<(u32, String, String)>> {
    let mut q = conn.prepare(
        "SELECT round, claim_id, verdict FROM claim_verdicts WHERE campaign_id = ?1 ORDER BY round, rowid",
    )?;
    let rows = q
        .query_map([campaign_id], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// What the campaign's jobs have cost: (particle-steps, wall seconds, core-hours = wall time ×
/// each job's engine threads, 1 where unrecorded).
///
/// # Errors
/// Database errors.
pub fn spent(conn: &Connection, campaign_id: i64) -> Result<(f64, f64, f64)> {
    Ok(conn.query_row(
        "SELECT COALESCE(SUM(j.particle_steps), 0), COALESCE(SUM(j.wall_time_s), 0),
                COALESCE(SUM(j.wall_time_s * COALESCE(j.threads, 1)), 0) / 3600.0
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id WHERE cj.campaign_id = ?1",
        [campaign_id],
        |r| Ok((r.get::<_, f64>(0)?, r.get(1)?, r.get(2)?)),
    )?)
}

/// The CPU a campaign's jobs used against the cores they held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuUse {
    /// CPU hours of the jobs that counted theirs.
    pub cpu_hours: f64,
    /// Their core-hours (wall time × threads).
    pub core_hours: f64,
    /// Jobs that counted their CPU time, and jobs that ran at all.
    pub counted: i64,
    pub ran: i64,
}

/// The CPU hours a campaign's jobs used, beside the core-hours the same jobs held; jobs that ran
/// before sweep counted CPU time (`cpu_time_s` NULL) are left out of both and counted apart.
///
/// # Errors
/// Database errors.
pub fn cpu_use(conn: &Connection, campaign_id: i64) -> Result<CpuUse> {
    Ok(conn.query_row(
        "SELECT COALESCE(SUM(j.cpu_time_s), 0) / 3600.0,
                COALESCE(SUM(CASE WHEN j.cpu_time_s IS NOT NULL
                                  THEN j.wall_time_s * COALESCE(j.threads, 1) END), 0) / 3600.0,
                COUNT(j.cpu_time_s), COUNT(*)
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
         WHERE cj.campaign_id = ?1 AND j.wall_time_s > 0",
        [campaign_id],
        |r| {
            Ok(CpuUse {
                cpu_hours: r.get(0)?,
                core_hours: r.get(1)?,
                counted: r.get(2)?,
                ran: r.get(3)?,
            })
        },
    )?)
}

/// Stores what campaign `campaign_id` had spent at look `round` (particle-steps, wall s,
/// core-hours), before the look's verdicts are saved: only a look taken for the first time
/// records it. A look evaluated again keeps its recorded verdicts (`recorded`) and its first
/// cost, or none if a sweep before schema 14 took it (its jobs may have run on since).
///
/// # Errors
/// Database errors.
pub fn save_look_spent(
    conn: &Connection,
    campaign_id: i64,
    round: u32,
    spent: (f64, f64, f64),
) -> Result<()> {
    conn.execute(
        "INSERT OR IGNORE INTO claim_looks (campaign_id, round, particle_steps, wall_s, core_hours)
         SELECT ?1, ?2, ?3, ?4, ?5 WHERE NOT EXISTS
             (SELECT 1 FROM claim_verdicts WHERE campaign_id = ?1 AND round = ?2)",
        params![campaign_id, round, spent.0, spent.1, spent.2],
    )?;
    Ok(())
}

/// What campaign `campaign_id` had spent at look `round`; None for a look stored by a sweep
/// that did not record it.
///
/// # Errors
/// Database errors.
pub fn look_spent(
    conn: &Connection,
    campaign_id: i64,
    round: u32,
) -> Result<Option<(f64, f64, f64)>> {
    use rusqlite::OptionalExtension;
    Ok(conn
        .query_row(
            "SELECT particle_steps, wall_s, core_hours FROM claim_looks
             WHERE campaign_id = ?1 AND round = ?2",
            params![campaign_id, round],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .optional()?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::test_rows;

    fn row(round: u32, claim: &str, verdict: &str, value: f64) -> VerdictRow {
        VerdictRow {
            round,
            claim_id: claim.into(),
            statement: String::new(),
            paper: String::new(),
            paper_value: String::new(),
            test: "compare".into(),
            what: "q ratio".into(),
            verdict: verdict.into(),
            value: Some(value),
            lo: Some(value - 0.1),
            hi: Some(value + 0.1),
            level: 0.99,
            bound: "> 0".into(),
            points: String::new(),
            note: String::new(),
            particle_steps: f64::from(round),
            wall_s: 0.0,
            forecast_particle_steps: Some(1.0),
            forecast_wall_s: None,
        }
    }

    #[test]
    fn a_claim_decided_at_a_look_stays_decided_at_later_looks() {
        let conn = test_rows::empty_db();
        let c = test_rows::campaign(&conn, "c", "silo", "2026-01-01T00:00:00Z");
        let looks = [
            [
                row(0, "a", "undecided", 0.05),
                row(0, "b", "undecided", 0.0),
            ],
            [
                row(1, "a", "supported", 0.15),
                row(1, "b", "contradicted", -0.2),
            ],
            [
                row(2, "a", "undecided", 0.09),
                row(2, "b", "supported", 0.2),
            ],
        ];
        for rows in &looks {
            save_verdicts(&conn, c, rows).expect("save");
        }
        let first = first_decisions(&conn, c, 2).expect("first");
        assert_eq!(first["a"][0].round, 1);
        assert!(first_decisions(&conn, c, 1).expect("none").is_empty());
        let latest = latest_verdicts(&conn, c).expect("latest");
        assert_eq!(latest.len(), 2);
        let a = &latest[0];
        assert_eq!(
            (a.round, a.verdict.as_str(), a.value),
            (2, "supported", Some(0.15))
        );
        assert_eq!((a.lo, a.particle_steps), (Some(0.15 - 0.1), 1.0));
        assert!(
            a.note
                .starts_with("decided at look 1; look 2 reads 0.0900 [-0.0100, 0.1900], undecided"),
            "{}",
            a.note
        );
        assert_eq!(a.forecast_particle_steps, None, "nothing is still needed");
        // The first decision stands even against a later opposite one.
        let b = &latest[1];
        assert_eq!((b.verdict.as_str(), b.value), ("contradicted", Some(-0.2)));
        // A campaign without earlier decisions reads its latest look as stored.
        let d = test_rows::campaign(&conn, "d", "silo", "2026-01-01T00:00:00Z");
        save_verdicts(&conn, d, &[row(0, "a", "undecided", 0.05)]).expect("save");
        assert_eq!(
            latest_verdicts(&conn, d).expect("d"),
            vec![row(0, "a", "undecided", 0.05)]
        );
    }

    #[test]
    fn an_earlier_versions_decision_stands_for_the_same_test_only() {
        let conn = test_rows::empty_db();
        let v1 = test_rows::campaign(&conn, "c", "silo", "2026-01-01T00:00:00Z");
        conn.execute(
            "INSERT INTO campaigns (name, version, file, scene, spec_json) VALUES ('c', 2, 'c.json', 'silo', '{}')",
            [],
        )
        .expect("version 2");
        let v2 = conn.last_insert_rowid();
        // Another campaign's decision of a claim of the same id is not this study's.
        let other = test_rows::campaign(&conn, "other", "silo", "2026-01-01T00:00:00Z");
        save_verdicts(&conn, other, &[row(0, "c", "contradicted", -0.3)]).expect("other");
        save_verdicts(
            &conn,
            v1,
            &[
                row(0, "a", "supported", 0.15),
                row(0, "b", "supported", 0.2),
                row(0, "c", "undecided", 0.0),
            ],
        )
        .expect("v1");
        // Version 2 keeps `a`, tests `b` against another bound, and looks on from look 1.
        let mut b = row(1, "b", "undecided", 0.05);
        b.bound = "> 0.1".into();
        save_verdicts(
            &conn,
            v2,
            &[
                row(1, "a", "undecided", 0.05),
                b.clone(),
                row(1, "c", "undecided", 0.0),
            ],
        )
        .expect("v2");
        let latest = latest_verdicts(&conn, v2).expect("latest");
        let a = &latest[0];
        assert_eq!(
            (a.round, a.verdict.as_str(), a.value),
            (1, "supported", Some(0.15))
        );
        assert!(
            a.note.starts_with("decided at look 0; look 1 reads"),
            "{}",
            a.note
        );
        assert_eq!(latest[1], b, "a changed test is decided afresh");
        assert_eq!(latest[2], row(1, "c", "undecided", 0.0));
        // Version 2's own decision of its changed `b` stands over version 1's of the old test.
        let mut b2 = row(2, "b", "supported", 0.3);
        b2.bound = "> 0.1".into();
        save_verdicts(&conn, v2, &[b2]).expect("v2 look 2");
        let mut b3 = row(3, "b", "undecided", 0.05);
        b3.bound = "> 0.1".into();
        save_verdicts(&conn, v2, &[b3]).expect("v2 look 3");
        let b = &latest_verdicts(&conn, v2).expect("look 3")[0];
        assert_eq!((b.verdict.as_str(), b.value), ("supported", Some(0.3)));
        // A later version's decision does not reach back into an earlier one.
        save_verdicts(&conn, v2, &[row(2, "c", "supported", 0.3)]).expect("v2 look 2");
        save_verdicts(&conn, v1, &[row(3, "c", "undecided", 0.0)]).expect("v1 look 3");
        assert_eq!(
            latest_verdicts(&conn, v1).expect("v1")[0].verdict,
            "undecided"
        );
    }
}
