//! Registering a campaign's jobs: a new campaign (or version) and its jobs, shared with other
//! campaigns where their resolved parameters are equal. A campaign of 10⁶ jobs is registered in
//! chunks, each its own transaction, so that the write-ahead log stays small and a SIGTERM
//! stops between two chunks; the campaign is marked registered once every chunk is in, and a
//! launch of the same file finishes a registration cut short.

use rayon::prelude::*;
use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};

use crate::campaign::{CampaignFile, Identity, JobSpec, Jobs};

/// Jobs registered per transaction: a few MB of log each.
const CHUNK: usize = 20_000;

/// How a launch was registered.
#[derive(Debug)]
pub enum Registration {
    /// The campaign's jobs are registered under `version` (a new one, or the latest when the
    /// file still expands to the same jobs); `added` of them are new to the store.
    Registered {
        campaign_id: i64,
        version: i64,
        added: usize,
    },
    /// The file differs from the latest launched version `version` in the jobs it makes:
    /// nothing was registered. `changes` lists the fields that differ ("path: old -> new").
    Changed { version: i64, changes: Vec<String> },
    /// `stop` said stop between two chunks: `added` jobs are registered, the campaign is not
    /// yet; the same launch again finishes it.
    Interrupted { campaign_id: i64, added: usize },
}

/// Registers a campaign and its jobs. Launching the same file twice adds nothing (replicas its
/// target added are the campaign's own, not the file's, and do not count as a change). A file whose
/// jobs or claims differ from the latest version launched under its name is refused (`Changed`, with the
/// fields that differ) unless `new_version`, which registers it as the next version with its
/// own jobs; jobs are shared between versions only where their resolved parameters are equal.
/// A new version carries over the claims' looks and spent α of the one before, and the jobs
/// its target added at the points the new one keeps (`store::looks`).
///
/// # Errors
/// Database errors.
pub fn register(
    conn: &mut Connection,
    file: &str,
    c: &CampaignFile,
    jobs: &Jobs,
    new_version: bool,
) -> anyhow::Result<Registration> {
    register_until(conn, file, c, jobs, new_version, &|| false)
}

/// [`register`], asking `stop` between chunks.
///
/// # Errors
/// Database errors.
pub fn register_until(
    conn: &mut Connection,
    file: &str,
    c: &CampaignFile,
    jobs: &Jobs,
    new_version: bool,
    stop: &(dyn Fn() -> bool + Sync),
) -> anyhow::Result<Registration> {
    let spec = serde_json::to_string(c)?;
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let latest: Option<(i64, i64, String, bool)> = tx
        .query_row(
            "SELECT id, version, spec_json, registered FROM campaigns WHERE name = ?1
             ORDER BY version DESC LIMIT 1",
            [&c.name],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
        )
        .optional()?;
    let (cid, version) = match latest {
        // A registration cut short of the same file: finish it.
        Some((cid, version, old_spec, false)) if old_spec == spec => (cid, version),
        Some((cid, version, old_spec, complete)) => {
            let unchanged = complete && same_jobs(&tx, cid, jobs, &old_spec, &spec)?;
            if unchanged {
                // Same jobs: settings that change no result (checkpoint interval, executor,
                // description) follow the file.
                tx.execute(
                    "UPDATE campaigns SET file = ?2, spec_json = ?3 WHERE id = ?1",
                    params![cid, file, spec],
                )?;
                tx.commit()?;
                return Ok(Registration::Registered {
                    campaign_id: cid,
                    version,
                    added: 0,
                });
            } else if new_version {
                tx.execute(
                    "INSERT INTO campaigns (name, version, file, scene, spec_json, registered)
                     VALUES (?1, ?2, ?3, ?4, ?5, 0)",
                    params![c.name, version + 1, file, c.scene.name(), spec],
                )?;
                (tx.last_insert_rowid(), version + 1)
            } else {
                let old: serde_json::Value = serde_json::from_str(&old_spec)?;
                let new: serde_json::Value = serde_json::from_str(&spec)?;
                let mut changes = crate::campaign::diff_fields(&old, &new);
                if !complete {
                    changes.push(format!(
                        "(version {version}'s registration was cut short; launching its own file again finishes it)"
                    ));
                }
                if changes.is_empty() {
                    changes.push(
                        "(no field differs, but the jobs do: this sweep resolves parameters differently from the one that launched it)".into(),
                    );
                }
                return Ok(Registration::Changed { version, changes });
            }
        }
        None => {
            tx.execute(
                "INSERT INTO campaigns (name, version, file, scene, spec_json, registered)
                 VALUES (?1, 1, ?2, ?3, ?4, 0)",
                params![c.name, file, c.scene.name(), spec],
            )?;
            (tx.last_insert_rowid(), 1)
        }
    };
    tx.commit()?;
    // Jobs are made and hashed (a serialisation and a hash each) on the other cores while the
    // previous chunk is written: the writing is serial, the hashing is not. Only two chunks are
    // held at a time.
    let made = |chunk: usize| -> Option<Vec<(JobSpec, Identity)>> {
        let start = chunk * CHUNK;
        (start < jobs.len()).then(|| {
            (start..jobs.len().min(start + CHUNK))
                .into_par_iter()
                .map(|k| {
                    let j = jobs.get(k);
                    let id = j.identity();
                    (j, id)
                })
                .collect()
        })
    };
    // The hash index of 10⁶ jobs takes random inserts: a page cache that holds it (SQLite's
    // default is 2 MB) saves a read and a write of a page per job.
    conn.pragma_update(None, "cache_size", -128 * 1024)?;
    let mut added = 0;
    let mut ready = made(0);
    let mut k = 0;
    while let Some(chunk) = ready.take() {
        let (written, next) = rayon::join(|| insert_chunk(conn, cid, c, &chunk), || made(k + 1));
        added += written?;
        ready = next;
        k += 1;
        if ready.is_some() && stop() {
            return Ok(Registration::Interrupted {
                campaign_id: cid,
                added,
            });
        }
    }
    if let Some(previous) = super::looks::previous_version(conn, cid)? {
        let points = jobs
            .points()
            .par_iter()
            .map(|p| crate::campaign::point_key(&p.identity().resolved_json))
            .collect();
        super::looks::carry(conn, previous, cid, &points)?;
    }
    conn.execute("UPDATE campaigns SET registered = 1 WHERE id = ?1", [cid])?;
    Ok(Registration::Registered {
        campaign_id: cid,
        version,
        added,
    })
}

/// One transaction of jobs and their links to campaign `cid`; returns how many jobs were new.
fn insert_chunk(
    conn: &mut Connection,
    cid: i64,
    c: &CampaignFile,
    jobs: &[(JobSpec, Identity)],
) -> anyhow::Result<usize> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let mut added = 0;
    {
        let mut insert_job = tx.prepare_cached(
            "INSERT OR IGNORE INTO jobs (hash, scene, params_json, seed, target_time_s, particles, precision, program_version, max_attempts)
             VALUES (?1, ?8, ?2, ?3, ?4, ?5, ?6, ?7, ?9)",
        )?;
        let mut job_id = tx.prepare_cached("SELECT id FROM jobs WHERE hash = ?1")?;
        // Two points of one physics (0.0 and −0.0) are one job, linked under the first.
        let mut link = tx.prepare_cached(
            "INSERT OR IGNORE INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, ?3)",
        )?;
        for (j, id) in jobs {
            let n = insert_job.execute(params![
                id.hash,
                id.resolved_json,
                id.seed as i64,
                j.target_time_s(),
                j.particle_count() as i64,
                j.precision.name(),
                env!("CARGO_PKG_VERSION"),
                j.scene.name(),
                c.run.max_attempts
            ])?;
            added += n;
            let jid: i64 = if n == 1 {
                tx.last_insert_rowid()
            } else {
                job_id.query_row([&id.hash], |r| r.get(0))?
            };
            link.execute(params![cid, jid, j.label])?;
        }
    }
    tx.commit()?;
    Ok(added)
}

/// Whether the file's jobs and claims are those of the stored campaign `cid` (its own jobs, not
/// those its target added). The two sets of (hash, label) are compared by count and by an
/// order-free digest, streamed: neither is held.
fn same_jobs(
    tx: &Connection,
    cid: i64,
    jobs: &Jobs,
    old_spec: &str,
    spec: &str,
) -> anyhow::Result<bool> {
    // Claims are part of the file's version: a claim edited after its data were seen is
    // another study, kept apart (its jobs are shared: they are not part of identity).
    let claims_of = |s: &str| {
        serde_json::from_str::<serde_json::Value>(s)
            .ok()
            .and_then(|v| v.get("claims").cloned())
    };
    if claims_of(old_spec) != claims_of(spec) {
        return Ok(false);
    }
    let (mut stored_n, mut stored) = (0usize, 0u128);
    let mut rows = tx.prepare(
        "SELECT j.hash, cj.label FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
         WHERE cj.campaign_id = ?1 AND cj.origin IS NULL",
    )?;
    let mut rows = rows.query([cid])?;
    while let Some(r) = rows.next()? {
        stored_n += 1;
        stored = stored.wrapping_add(pair_digest(
            &r.get::<_, String>(0)?,
            &r.get::<_, String>(1)?,
        ));
    }
    // Two points of one physics (0.0 and −0.0) are one job, linked under the first: their
    // replicas are equal too, so duplicates are found among the points.
    let mut seen = std::collections::HashSet::new();
    let unique: Vec<bool> = jobs
        .points()
        .iter()
        .map(|p| seen.insert(p.hash()))
        .collect();
    let r = jobs.replicas() as usize;
    let (wanted_n, wanted) = (0..jobs.len())
        .into_par_iter()
        .filter(|k| unique[k / r])
        .map(|k| {
            let j = jobs.get(k);
            (1usize, pair_digest(&j.hash(), &j.label))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1.wrapping_add(b.1)));
    Ok(stored_n == wanted_n && stored == wanted)
}

/// A job's (hash, label) as 128 bits: summed over a set, equal sets give equal sums.
fn pair_digest(hash: &str, label: &str) -> u128 {
    use sha2::{Digest, Sha256};
    let h = Sha256::digest(format!("{hash}\n{label}").as_bytes());
    u128::from_le_bytes(h[..16].try_into().expect("16 bytes"))
}
