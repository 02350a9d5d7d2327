//! A campaign's points as its target sees them: each point's replicas combined exactly as the
//! figures combine them (`evaluate`), and the registration of a round's work (`register_work`).
//! The rounds of a Q or D target (`adaptive`) and of a claims target (`claim_rounds`) both
//! start from here.

use std::collections::{BTreeMap, BTreeSet};

use anyhow::{Context, Result};
use rusqlite::Connection;

use crate::campaign::adaptive::{Decision, PointState, RunState, Work};
use crate::campaign::{label_without_replica, point_key, CampaignFile, JobSpec, SceneKind, Target};
use crate::observe::fits::{Pooled, PooledFrom};
use crate::pooled::silo::{combine_replicas, CiSource, DischargeRow};
use crate::scene::silo::SiloScene;
use crate::store::looks;
use crate::store::silo_reads::done_discharge_rows;
use crate::store::targets::{self, PointRow, TargetJob, WorkRow};

/// A point of the campaign: its key, its jobs (by id), and its label without a replica.
struct Point<'a> {
    key: String,
    label: String,
    jobs: Vec<&'a TargetJob>,
}

fn points_of(jobs: &[TargetJob]) -> Vec<Point<'_>> {
    let mut out: Vec<Point> = Vec::new();
    for j in jobs {
        let key = point_key(&j.params_json);
        match out.iter_mut().find(|p| p.key == key) {
            Some(p) => p.jobs.push(j),
            None => out.push(Point {
                key,
                label: label_without_replica(&j.label),
                jobs: vec![j],
            }),
        }
    }
    out
}

fn spec_of(j: &TargetJob) -> Result<JobSpec> {
    let mut s: JobSpec = serde_json::from_str(&j.params_json)
        .with_context(|| format!("job {}: stored parameters unreadable", j.job_id))?;
    s.label = j.label.clone();
    Ok(s)
}

/// The point's state for the decision, and its stored row (without status and rounds).
fn silo_point(
    p: &Point,
    rows: &BTreeMap<i64, &DischargeRow>,
    filled: &BTreeSet<String>,
    observable: &str,
) -> Result<(PointState, PointRow, JobSpec)> {
    let spec = spec_of(p.jobs[0])?;
    let sp = spec.silo();
    let scene = SiloScene::new(sp.clone()).map_err(|e| anyhow::anyhow!(e))?;
    let d = &spec.observers.discharge;
    let steps_per_s = sp.particle_count as f64 / scene.dt;
    let done: Vec<DischargeRow> = p
        .jobs
        .iter()
        .filter_map(|j| rows.get(&j.job_id).map(|r| (*r).clone()))
        .collect();
    let combined = combine_replicas(&done);
    let estimate = combined.first().and_then(|fp| {
        let ci = fp.ci?;
        let from = match fp.ci_source {
            CiSource::Pooled(f) => f,
            _ => PooledFrom::Blocks,
        };
        Some(Pooled {
            mean: fp.q,
            ci95: ci,
            se: f64::NAN,
            dof: f64::NAN,
            replicas: fp.replicas,
            from,
        })
    });
    let blocks_of = |r: &DischargeRow| {
        r.q_blocks.map_or_else(
            || {
                ((r.sim_time_s - d.skip_initial_s) / d.block_s)
                    .floor()
                    .max(0.0)
            },
            |n| n as f64,
        )
    };
    let weight: f64 = done
        .iter()
        .filter(|r| r.q_kg_per_s.is_some())
        .map(blocks_of)
        .sum();
    let chunk_s = d.sample_interval_s;
    let runs: Vec<RunState> = p
        .jobs
        .iter()
        .map(|j| {
            let end_s = j.target_time_s.max(sp.discharge_time_s);
            let not_extendable = match rows.get(&j.job_id) {
                None => Some(format!("job {} {}", j.job_id, j.status)),
                Some(r) if r.permanently_clogged => {
                    Some(format!("job {} clogged for good", j.job_id))
                }
                Some(_) if !sp.reinsert && j.sim_time_s < end_s - 1.5 * chunk_s => Some(format!(
                    "job {} emptied the silo (stop_remaining_fraction)",
                    j.job_id
                )),
                // Q's window stopped where the block rates drift: more time adds no blocks.
                Some(r)
                    if r.q_window_end_s().is_some_and(|t| {
                        t < 0.8 * j.sim_time_s && t < j.sim_time_s - 3.0 * d.block_s
                    }) =>
                {
                    Some(format!(
                        "job {}: Q's window ends at {:.2} s of {:.2} s (M(t) not linear after)",
                        j.job_id,
                        r.q_window_end_s().unwrap_or(0.0),
                        j.sim_time_s
                    ))
                }
                Some(_) => None,
            };
            RunState {
                job_id: j.job_id,
                end_s,
                not_extendable,
            }
        })
        .collect();
    // A new replica's fill is shared with the points that already filled that replica index.
    let next = spec.replica(next_replica(p)?);
    let fill = if filled.contains(&next.fill_key().0) {
        0.0
    } else {
        sp.particle_count as f64 * sp.settle_max_time_s.min(1.0) / scene.dt
    };
    // A new replica runs as long as the point's longest run: a short one pooled with long
    // ones would widen the replicas' interval, not narrow it.
    let length_s = runs
        .iter()
        .map(|r| r.end_s)
        .fold(sp.discharge_time_s, f64::max);
    let state = PointState {
        label: p.label.clone(),
        estimate,
        weight,
        weight_per_s: 1.0 / d.block_s,
        runs,
        steps_per_s,
        replica_cost: fill + steps_per_s * length_s,
        replica_weight: ((length_s - d.skip_initial_s) / d.block_s).floor().max(0.0),
        replica_end_s: length_s,
        quantum_s: d.block_s,
    };
    let row = point_row(
        p,
        observable,
        estimate,
        combined.first().map(|fp| fp.ci_source.name().to_string()),
        combined.first().map_or(0, |fp| fp.replicas),
    );
    Ok((state, row, spec))
}

/// A chute point: D pooled over its steady replicas, block by block in the bulk, as the chute
/// figures pool it (weighted by measured time); its interval is the widest bulk block's. A
/// steady run can measure on; an unsteady one cannot.
fn chute_point(
    p: &Point,
    pooled: &[crate::pooled::chute::ChutePoint],
    observable: &str,
) -> Result<(PointState, PointRow, JobSpec)> {
    let spec = spec_of(p.jobs[0])?;
    let cp = spec.chute();
    let scene = crate::scene::ChuteScene::new(cp.clone()).map_err(|e| anyhow::anyhow!(e))?;
    let steps_per_s = cp.count() as f64 / scene.dt;
    let found = pooled.iter().find(|c| c.point == p.key);
    let widest = found.and_then(|c| {
        c.bulk_d
            .iter()
            .map(|(_, d)| *d)
            .max_by(|a, b| a.ci95_rel().total_cmp(&b.ci95_rel()))
    });
    let steady_jobs: &[i64] = found.map_or(&[], |c| c.steady_jobs.as_slice());
    let steady = steady_jobs.len();
    // A run's own time is its measurement: its end minus the longest wait for steady flow.
    let measured = |j: &TargetJob| (j.target_time_s - cp.steady_max_time_s).max(cp.measure_time_s);
    let runs: Vec<RunState> = p
        .jobs
        .iter()
        .map(|j| RunState {
            job_id: j.job_id,
            end_s: measured(j),
            not_extendable: (!steady_jobs.contains(&j.job_id))
                .then(|| format!("job {} was not steady: nothing to run on", j.job_id)),
        })
        .collect();
    // A replica waits for its steady state as the point's steady runs did, then measures.
    let waits: Vec<f64> = p
        .jobs
        .iter()
        .filter(|j| steady_jobs.contains(&j.job_id))
        .map(|j| (j.sim_time_s - measured(j)).max(0.0))
        .collect();
    let wait = if waits.is_empty() {
        cp.steady_max_time_s
    } else {
        waits.iter().sum::<f64>() / waits.len() as f64
    };
    // A new replica measures as long as the point's longest run, as a silo replica does.
    let length_s = runs
        .iter()
        .map(|r| r.end_s)
        .fold(cp.measure_time_s, f64::max);
    let state = PointState {
        label: p.label.clone(),
        estimate: widest.filter(|_| steady > 0),
        weight: p
            .jobs
            .iter()
            .filter(|j| steady_jobs.contains(&j.job_id))
            .map(|j| measured(j))
            .sum(),
        weight_per_s: 1.0,
        runs,
        steps_per_s,
        replica_cost: steps_per_s * (wait + length_s),
        replica_weight: length_s,
        replica_end_s: length_s,
        quantum_s: 1.0,
    };
    let row = point_row(
        p,
        observable,
        state.estimate,
        state.estimate.map(|e| e.from.name().to_string()),
        steady,
    );
    Ok((state, row, spec))
}

/// A point's stored row before its decision (status and rounds are filled in after).
fn point_row(
    p: &Point,
    observable: &str,
    estimate: Option<Pooled>,
    ci_from: Option<String>,
    replicas: usize,
) -> PointRow {
    PointRow {
        point: p.label.clone(),
        observable: observable.into(),
        mean: estimate.map(|e| e.mean),
        ci95_rel: estimate.map(|e| e.ci95_rel()),
        ci_from,
        replicas,
        runs: p.jobs.len(),
        measured_s: p.jobs.iter().map(|j| j.sim_time_s).sum(),
        particle_steps: p.jobs.iter().map(|j| j.particle_steps).sum(),
        met: false,
        status: String::new(),
        rounds: 0,
    }
}

/// The next replica index of a point: one past the largest it has.
fn next_replica(p: &Point) -> Result<u32> {
    let mut top = 0;
    for j in &p.jobs {
        let s = spec_of(j)?;
        let r = s
            .silo
            .as_ref()
            .map(|x| x.replica)
            .or(s.chute.as_ref().map(|x| x.replica))
            .unwrap_or(0);
        top = top.max(r);
    }
    Ok(top + 1)
}

/// A campaign's points as its target sees them, without changing anything.
pub struct Evaluation {
    pub file: CampaignFile,
    pub target: Target,
    /// Jobs of the campaign not ended (pending, running, paused).
    pub open: usize,
    /// Rounds of work added so far.
    pub rounds_done: u32,
    /// The claims' looks and α the campaign's earlier versions spent.
    pub carried: looks::Carried,
    pub points: Vec<EvaluatedPoint>,
}

impl Evaluation {
    /// The claims' look this evaluation is: the earlier versions' looks, then one per round.
    pub fn look(&self) -> u32 {
        self.carried.looks + self.rounds_done
    }

    /// How many looks the claims may have in all, the earlier versions' included.
    pub fn looks(&self) -> u32 {
        self.carried.looks + self.target.looks()
    }
}

/// One point: the decision's input, its stored row, the replica it would add, and the
/// throughput its jobs ran at (particle-steps per wall second; None before any ran).
pub struct EvaluatedPoint {
    pub state: PointState,
    pub row: PointRow,
    pub next: JobSpec,
    pub rate: Option<f64>,
    /// Its jobs that are done: a steady share counts only these, so that a forecast taken
    /// while replicas still run does not read them as unsteady, nor a crash as a drift.
    pub done: usize,
}

/// Reads campaign `campaign_id` and combines each point's replicas.
///
/// # Errors
/// Database errors, unreadable stored parameters, or a campaign without a target.
pub fn evaluate(conn: &Connection, campaign_id: i64) -> Result<Evaluation> {
    evaluate_for(conn, campaign_id, None)
}

/// As [`evaluate`], under `target` instead of the stored file's (`sweep plan` of an edited
/// target).
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_for(
    conn: &Connection,
    campaign_id: i64,
    target: Option<&Target>,
) -> Result<Evaluation> {
    let file: CampaignFile = targets::campaign_file(conn, campaign_id)?
        .with_context(|| format!("no campaign with id {campaign_id}"))?;
    let target: Target = match target.or(file.target.as_ref()) {
        Some(t) => t.clone(),
        // Claims are looked at once when no target adds work for them.
        None if !file.claims.is_empty() => Target::claims_looked_at_once(),
        None => anyhow::bail!("campaign '{}' has no target", file.name),
    };
    let jobs = targets::campaign_jobs(conn, campaign_id)?;
    let open = jobs
        .iter()
        .filter(|j| !matches!(j.status.as_str(), "done" | "failed"))
        .count();
    let rows = done_discharge_rows(conn, campaign_id)?;
    let by_job: BTreeMap<i64, &DischargeRow> = rows.iter().map(|r| (r.job_id, r)).collect();
    let mut filled = BTreeSet::new();
    // Silo fills are shared between jobs of one seed (a chute has no fill stage).
    for j in jobs.iter().filter(|j| j.status == "done") {
        let spec = spec_of(j)?;
        if spec.scene == SceneKind::Silo {
            filled.insert(spec.fill_key().0);
        }
    }
    let rounds_done = targets::rounds(conn, campaign_id)?;
    let mut points = Vec::new();
    let chute = if file.scene == SceneKind::Chute {
        crate::pooled::chute::pooled_points(conn, campaign_id)?
    } else {
        Vec::new()
    };
    for p in &points_of(&jobs) {
        let (state, mut row, spec) = match file.scene {
            SceneKind::Silo => silo_point(p, &by_job, &filled, "q")?,
            SceneKind::Chute => chute_point(p, &chute, "d")?,
        };
        row.rounds = rounds_done;
        let (steps, wall) = p
            .jobs
            .iter()
            .filter(|j| j.wall_time_s > 0.0)
            .fold((0.0, 0.0), |(s, w), j| {
                (s + j.particle_steps as f64, w + j.wall_time_s)
            });
        points.push(EvaluatedPoint {
            state,
            row,
            next: spec.replica(next_replica(p)?),
            rate: (wall > 0.0).then_some(steps / wall),
            done: p.jobs.iter().filter(|j| j.status == "done").count(),
        });
    }
    Ok(Evaluation {
        file,
        target,
        open,
        rounds_done,
        carried: looks::carried(conn, campaign_id)?,
        points,
    })
}

/// Registers round `round`'s work (each a decision for the point labelled so, with the replica
/// it would add) and records it in `target_work`; returns what was recorded.
///
/// # Errors
/// Database errors, or a job to run on that is no longer done.
pub(crate) fn register_work(
    tx: &rusqlite::Transaction,
    campaign_id: i64,
    file: &CampaignFile,
    round: u32,
    planned: Vec<(Decision, JobSpec, String)>,
) -> Result<Vec<WorkRow>> {
    let mut work = Vec::new();
    for (decision, next, label) in planned {
        let Decision::Work {
            work: w,
            ci_rel_before,
            ci_rel_expected,
            cost,
        } = decision
        else {
            continue;
        };
        let (job_id, action, from_s, to_s) = match w {
            Work::Extend {
                job_id,
                from_s,
                to_s,
            } => {
                // A chute job's end adds its longest wait for the steady state.
                let end_s = match next.chute.as_ref() {
                    Some(c) => c.steady_max_time_s + to_s,
                    None => to_s,
                };
                anyhow::ensure!(
                    targets::extend(tx, job_id, to_s, end_s)?,
                    "job {job_id} is not done: it cannot be run on"
                );
                (job_id, "extend", from_s, to_s)
            }
            Work::Replica { to_s } => {
                // A chute job's end adds its longest wait for the steady state, as above.
                let end_s = match next.chute.as_ref() {
                    Some(c) => c.steady_max_time_s + to_s,
                    None => to_s,
                };
                let attempts = i64::from(file.run.max_attempts);
                let id = targets::add_replica(tx, campaign_id, &next, end_s, attempts)?;
                (id, "replica", 0.0, to_s)
            }
        };
        let row = WorkRow {
            round,
            point: label,
            job_id,
            action: action.into(),
            from_s,
            to_s,
            ci95_rel_before: ci_rel_before,
            ci95_rel_expected: ci_rel_expected,
            particle_steps_expected: cost,
        };
        targets::record_work(tx, campaign_id, &row)?;
        work.push(row);
    }
    Ok(work)
}
