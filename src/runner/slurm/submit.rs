//! Handing pending jobs to Slurm: one job file per job, one sbatch script per array (a campaign
//! larger than the cluster's MaxArraySize becomes several arrays), `sbatch --parsable`, and the
//! array and task ids recorded per job. Jobs are taken (running, lease `slurm:submitting`)
//! before `sbatch` runs and given back, pending, if it refuses; so a local launcher never runs a
//! job that Slurm may run too.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use rusqlite::Connection;
use serde::{Deserialize, Serialize};

use super::error::SlurmError;
use super::files::{self, TaskSpec};
use super::query;
use super::script::{script, ScriptInput};
use crate::campaign::{CampaignFile, ExecutorKind, SlurmSettings};
use crate::checkpoint::write_atomic;
use crate::runner::backend::{BackendChoice, GpuSelect};
use crate::store::{pending, slurm_tasks};

/// How one submission runs its jobs; stored with each task so that `sweep resume` resubmits a
/// job as it was first submitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SubmitSettings {
    pub slurm: SlurmSettings,
    pub backend: BackendChoice,
    /// Which GPU adapter (`--gpu N`, `--allow-software-gpu`; absent from older submissions).
    #[serde(default)]
    pub gpu: GpuSelect,
    /// Engine threads per job (0: the task's cores).
    pub threads: usize,
    pub checkpoint_interval_s: f64,
}

/// Where and what to submit.
pub struct SubmitOptions<'a> {
    /// Absolute work directory, on storage the compute nodes share.
    pub work_dir: &'a Path,
    pub campaign_id: Option<i64>,
    pub campaign_name: &'a str,
    pub settings: &'a SubmitSettings,
    /// The sweep binary as the compute nodes reach it.
    pub sweep_bin: &'a Path,
    /// Build the scripts, submit nothing, write nothing.
    pub dry_run: bool,
}

/// One array: its script and (unless a dry run) Slurm's id for it.
#[derive(Clone, Debug)]
pub struct Submitted {
    pub script: PathBuf,
    pub text: String,
    pub array_job_id: Option<String>,
    /// Task `k` runs `jobs[k]`.
    pub jobs: Vec<i64>,
}

/// Hands the pending ones of `job_ids` to Slurm.
///
/// # Errors
/// Unusable settings, no `sbatch`, a work directory Slurm cannot be told about, `sbatch`
/// refusing a script (the jobs of that array and of those not yet submitted are given back,
/// pending), database and I/O errors.
pub fn submit(
    conn: &mut Connection,
    job_ids: &[i64],
    o: &SubmitOptions<'_>,
) -> anyhow::Result<Vec<Submitted>> {
    let problems = o.settings.slurm.problems();
    if !problems.is_empty() {
        return Err(SlurmError::Settings { problems }.into());
    }
    if !o.dry_run && query::which("sbatch").is_none() {
        return Err(SlurmError::NotInstalled { command: "sbatch" }.into());
    }
    let work = o.work_dir.display().to_string();
    if !o.work_dir.is_absolute() || work.contains(char::is_whitespace) {
        return Err(SlurmError::Settings {
            problems: vec![format!(
                "work directory {work:?}: expected an absolute path without spaces (it goes into #SBATCH lines); put the database elsewhere"
            )],
        }
        .into());
    }
    let specs = pending_specs(conn, job_ids, o.settings.checkpoint_interval_s)?;
    let ids: Vec<i64> = specs.iter().map(|s| s.job_id).collect();
    let ids = if o.dry_run {
        ids
    } else {
        slurm_tasks::take_for_submission(conn, &ids)?
    };
    if ids.is_empty() {
        return Ok(Vec::new());
    }
    let by_id: BTreeMap<i64, &TaskSpec> = specs.iter().map(|s| (s.job_id, s)).collect();
    let chunk = query::max_array_size().max(1);
    let parts: Vec<&[i64]> = ids.chunks(chunk).collect();
    let stamp = crate::store::stamp(conn)?;
    let settings_json = serde_json::to_string(o.settings)?;
    let dir = files::slurm_dir(o.work_dir);
    let mut out = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        let text = script(&ScriptInput {
            campaign: o.campaign_name,
            work_dir: o.work_dir,
            sweep_bin: o.sweep_bin,
            jobs: part,
            settings: &o.settings.slurm,
            backend: o.settings.backend,
            gpu: o.settings.gpu,
            threads: o.settings.threads,
            part: (k + 1, parts.len()),
        });
        let name = super::script::job_name(o.campaign_name);
        // Scripts are kept: a second submission within the same second gets its own name.
        let mut path = dir.join(format!("{name}-{stamp}-{}.sbatch", k + 1));
        let mut n = 1;
        while path.exists() {
            n += 1;
            path = dir.join(format!("{name}-{stamp}-{}-{n}.sbatch", k + 1));
        }
        if o.dry_run {
            out.push(Submitted {
                script: path,
                text,
                array_job_id: None,
                jobs: part.to_vec(),
            });
            continue;
        }
        let rest: Vec<i64> = parts[k..].iter().flat_map(|p| p.iter().copied()).collect();
        match write_and_submit(o.work_dir, &path, &text, part, &by_id) {
            Ok(array) => {
                slurm_tasks::record(conn, o.campaign_id, &array, part, &path, &settings_json)?;
                out.push(Submitted {
                    script: path,
                    text,
                    array_job_id: Some(array),
                    jobs: part.to_vec(),
                });
            }
            Err(e) => {
                slurm_tasks::give_back(conn, &rest, &format!("{e:#}"))?;
                return Err(e);
            }
        }
    }
    Ok(out)
}

/// Job files, the script, then `sbatch --parsable`; Slurm's id for the array.
fn write_and_submit(
    work: &Path,
    script_path: &Path,
    text: &str,
    jobs: &[i64],
    specs: &BTreeMap<i64, &TaskSpec>,
) -> anyhow::Result<String> {
    for id in jobs {
        files::write_json(&files::spec_path(work, *id), specs[id])?;
    }
    let logs = files::slurm_dir(work).join("logs");
    std::fs::create_dir_all(&logs).map_err(SlurmError::io(&logs))?;
    write_atomic(script_path, text.as_bytes()).map_err(SlurmError::io(script_path))?;
    let out = Command::new("sbatch")
        .arg("--parsable")
        .arg(script_path)
        .output()
        .map_err(SlurmError::io("sbatch"))?;
    if !out.status.success() {
        return Err(SlurmError::Rejected {
            script: script_path.to_path_buf(),
            stderr: String::from_utf8_lossy(&out.stderr)
                .trim()
                .replace('\n', "; "),
        }
        .into());
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints "jobid" or "jobid;cluster".
    let id = stdout
        .lines()
        .last()
        .unwrap_or("")
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_string();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(SlurmError::Command {
            command: format!("sbatch --parsable {}", script_path.display()),
            status: out.status.to_string(),
            stderr: format!("unexpected output {stdout:?}"),
        }
        .into());
    }
    Ok(id)
}

/// The task files of the pending ones of `ids`, in the order given.
fn pending_specs(
    conn: &Connection,
    ids: &[i64],
    checkpoint_interval_s: f64,
) -> anyhow::Result<Vec<TaskSpec>> {
    Ok(pending::pending_tasks(conn, ids)?
        .into_iter()
        .map(|t| TaskSpec {
            format: files::FORMAT,
            job_id: t.job_id,
            hash: t.hash,
            scene: t.scene,
            params_json: t.params_json,
            seed: t.seed,
            target_time_s: t.target_time_s,
            sim_time_s: t.sim_time_s,
            label: t.label,
            checkpoint_interval_s,
        })
        .collect())
}

/// Jobs that `sweep resume` submits together.
#[derive(Clone, Debug)]
pub struct ResumeGroup {
    pub campaign_id: Option<i64>,
    pub campaign_name: String,
    pub settings: SubmitSettings,
    pub jobs: Vec<i64>,
}

/// Pending jobs that `sweep resume` hands to Slurm, grouped by submission: those last submitted
/// to Slurm (with the settings of that submission), those never submitted whose first campaign
/// says `executor: "slurm"`, or with `all`, every pending job. Jobs never submitted take their
/// campaign's `run.slurm` and `fallback`'s backend and threads; `fallback`'s `--gpu N` and
/// `--allow-software-gpu`, when given, hold for every job.
///
/// # Errors
/// Database errors.
pub fn resume_groups(
    conn: &Connection,
    all: bool,
    fallback: &SubmitSettings,
) -> anyhow::Result<Vec<ResumeGroup>> {
    let latest = slurm_tasks::latest_by_job(conn, None)?;
    let pending = pending::pending_jobs(conn)?;
    let names: BTreeMap<i64, String> = pending
        .iter()
        .filter_map(|p| Some((p.campaign_id?, p.campaign_name.clone()?)))
        .collect();
    let mut groups: BTreeMap<(Option<i64>, String), Vec<i64>> = BTreeMap::new();
    for pending::PendingJob {
        id,
        campaign_id: cid,
        campaign_spec: spec,
        ..
    } in pending
    {
        let key = match latest.get(&id) {
            Some(t) => (t.campaign_id.or(cid), t.settings_json.clone()),
            None => {
                let file: Option<CampaignFile> = spec.and_then(|s| serde_json::from_str(&s).ok());
                let wants_slurm = file
                    .as_ref()
                    .is_some_and(|f| f.run.executor == ExecutorKind::Slurm);
                if !all && !wants_slurm {
                    continue;
                }
                let mut s = fallback.clone();
                if let Some(f) = file {
                    s.slurm = f.run.slurm;
                    s.checkpoint_interval_s = f.run.checkpoint_interval_s;
                }
                (cid, serde_json::to_string(&s)?)
            }
        };
        groups.entry(key).or_default().push(id);
    }
    let mut out = Vec::new();
    for ((cid, settings), ids) in groups {
        let mut s: SubmitSettings = match serde_json::from_str(&settings) {
            Ok(s) => s,
            Err(_) => fallback.clone(),
        };
        // What this command line says of the GPU adapter holds over the earlier submission's.
        s.gpu.allow_software |= fallback.gpu.allow_software;
        s.gpu.index = fallback.gpu.index.or(s.gpu.index);
        let name = cid
            .and_then(|c| names.get(&c).cloned())
            .unwrap_or_else(|| "resumed".into());
        out.push(ResumeGroup {
            campaign_id: cid,
            campaign_name: name,
            settings: s,
            jobs: ids,
        });
    }
    Ok(out)
}
