//! Forgetting jobs and campaigns: every row that names a forgotten job goes, in one transaction.
//! (Their work directories are the caller's: the store knows no files.)

use anyhow::bail;
use rusqlite::{params, Connection, TransactionBehavior};

/// What forgetting a selection removes.
#[derive(Debug, Default)]
pub struct ForgetPlan {
    /// Campaign versions removed (ids).
    pub campaigns: Vec<i64>,
    /// Jobs removed with all their rows: (id, hash, label, status).
    pub jobs: Vec<(i64, String, String, String)>,
    /// Jobs of the campaigns that other campaigns share: unlinked, kept.
    pub kept_shared: usize,
}

/// The plan for forgetting one job (and its links to campaigns).
///
/// # Errors
/// No such job, or database errors.
pub fn plan_job(conn: &Connection, id: i64) -> anyhow::Result<ForgetPlan> {
    let mut q = conn.prepare(
        "SELECT j.id, j.hash, COALESCE((SELECT label FROM campaign_jobs WHERE job_id = j.id LIMIT 1), ''), j.status
         FROM jobs j WHERE j.id = ?1",
    )?;
    let jobs: Vec<(i64, String, String, String)> = q
        .query_map([id], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))?
        .collect::<Result<_, _>>()?;
    if jobs.is_empty() {
        bail!("no job {id} in the database");
    }
    Ok(ForgetPlan {
        jobs,
        ..ForgetPlan::default()
    })
}

/// The plan for forgetting campaign `name` (every version, or only `version`): its jobs that no
/// other campaign has.
///
/// # Errors
/// No such campaign, or database errors.
pub fn plan_campaign(
    conn: &Connection,
    name: &str,
    version: Option<i64>,
) -> anyhow::Result<ForgetPlan> {
    let campaigns: Vec<i64> = conn
        .prepare("SELECT id FROM campaigns WHERE name = ?1 AND (?2 IS NULL OR version = ?2)")?
        .query_map(params![name, version], |r| r.get(0))?
        .collect::<Result<_, _>>()?;
    if campaigns.is_empty() {
        bail!(
            "no campaign named '{name}'{} in the database",
            version.map_or(String::new(), |v| format!(" with version {v}"))
        );
    }
    let ids = campaigns
        .iter()
        .map(i64::to_string)
        .collect::<Vec<_>>()
        .join(",");
    // Only ids from the database are spliced into the query.
    let mut q = conn.prepare(&format!(
        "SELECT DISTINCT j.id, j.hash, cj.label, j.status,
                EXISTS (SELECT 1 FROM campaign_jobs o WHERE o.job_id = j.id AND o.campaign_id NOT IN ({ids}))
         FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id
         WHERE cj.campaign_id IN ({ids}) GROUP BY j.id ORDER BY j.id"
    ))?;
    let mut plan = ForgetPlan {
        campaigns,
        ..ForgetPlan::default()
    };
    let rows = q.query_map([], |r| {
        Ok((
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?),
            r.get::<_, bool>(4)?,
        ))
    })?;
    for row in rows {
        let (job, shared) = row?;
        if shared {
            plan.kept_shared += 1;
        } else {
            plan.jobs.push(job);
        }
    }
    Ok(plan)
}

/// Carries out `plan` in one transaction: every row of every table that names a removed job
/// (results, series, fields, Slurm tasks, links), the jobs, and the campaign versions.
///
/// # Errors
/// Database errors (nothing is removed then).
pub fn forget(conn: &mut Connection, plan: &ForgetPlan) -> anyhow::Result<()> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    // Every table with a job_id column, found in the schema so a new results table is not missed.
    let tables: Vec<String> = tx
        .prepare(
            "SELECT m.name FROM sqlite_master m, pragma_table_info(m.name) c
             WHERE m.type = 'table' AND c.name = 'job_id' ORDER BY m.name",
        )?
        .query_map([], |r| r.get(0))?
        .collect::<Result<_, _>>()?;
    for (id, ..) in &plan.jobs {
        tx.execute(
            "DELETE FROM field_arrays WHERE set_id IN (SELECT id FROM field_sets WHERE job_id = ?1)",
            [id],
        )?;
        for t in &tables {
            tx.execute(&format!("DELETE FROM {t} WHERE job_id = ?1"), [id])?;
        }
        tx.execute("DELETE FROM jobs WHERE id = ?1", [id])?;
    }
    for c in &plan.campaigns {
        tx.execute("DELETE FROM campaign_jobs WHERE campaign_id = ?1", [c])?;
        tx.execute(
            "UPDATE slurm_tasks SET campaign_id = NULL WHERE campaign_id = ?1",
            [c],
        )?;
        tx.execute("DELETE FROM campaigns WHERE id = ?1", [c])?;
    }
    tx.commit()?;
    Ok(())
}
