//! Replicas of one chute point (jobs whose parameters differ only in `replica`:
//! `campaign::point_key` and the label without `replica=K`) combined per block of height L:
//! D pooled from each replica's D and its standard error over the measurement's
//! `msd_error_windows` time windows (`fits::pool`, weighted by the measurement's length), the
//! other block profiles (γ̇, V_x, φ, skewness of v_z) and the coarse-grained γ̇(z) as the mean
//! over replicas with a Student-t interval from 2 replicas on. Only steady replicas are pooled:
//! the figures draw what `drawable_chute_jobs` gives them (the done jobs, and while a round runs
//! the earlier end of the jobs it runs on), and a point that has steady replicas pools those
//! only. [`pooled_points`] gives a campaign loop the same statistics as the figures.

use anyhow::Result;
use rusqlite::Connection;

use crate::campaign::point_key;
use crate::observe::chute::ChuteObserverSettings;
use crate::observe::fits::{mean_ci95, pool, t_975, Pooled, PooledFrom, ReplicaEstimate};
use crate::pooled::chute_jobs::{
    blocks, done_campaign_jobs, done_chute_jobs, shear_profile, BlockRow, ChuteJob,
};
use crate::pooled::silo::{label_without_replica, same_value};

/// The bulk of the bed, as fractions of the bed height H: blocks with centre 0.2 H < z < 0.8 H,
/// as the accuracy map compares them.
pub const BULK_BED: (f64, f64) = (0.2, 0.8);

/// The central part of the bed, as fractions of the bed height H: blocks with centre
/// 0.3 H < z < 0.7 H. For the paper's H = 20 L this is its 6 L < z < 14 L, where its Figs. 3, 4
/// and 6 read D and γ̇: what Fig. 6 and the chute claims use.
pub const CENTRAL_BED: (f64, f64) = (0.3, 0.7);

/// A value over replicas: their mean and, from 2 on, a Student-t interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OverReplicas {
    pub mean: f64,
    /// Half-width of the 95 % CI of `mean` over the replicas; None for one replica.
    pub ci95: Option<f64>,
    /// Replicas with a finite value.
    pub replicas: usize,
}

impl OverReplicas {
    /// The finite `values` combined; None when there is none.
    pub fn of(values: &[f64]) -> Option<Self> {
        let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        let first = *v.first()?;
        let (mean, ci95) = match mean_ci95(&v) {
            Some((m, c)) => (m, Some(c)),
            None => (first, None),
        };
        Some(Self {
            mean,
            ci95,
            replicas: v.len(),
        })
    }
}

/// One block of a point over its pooled replicas.
#[derive(Debug, Clone)]
pub struct PointBlock {
    /// Block index k (heights in [k L, (k + 1) L)).
    pub block: i64,
    /// Block centre, mean over the replicas, m.
    pub z_m: f64,
    /// D_z over the replicas with a D here, m²/s (see [`pool_diffusion`]); None when none has.
    pub diffusion: Option<Pooled>,
    /// dV_x/dz, 1/s.
    pub shear_rate: OverReplicas,
    /// V_x, m/s.
    pub velocity_x: OverReplicas,
    /// Solid fraction φ.
    pub solid_fraction: OverReplicas,
    /// Skewness of v_z; None when no replica has one.
    pub vz_skewness: Option<OverReplicas>,
    /// D_y over the replicas with a D_y here, pooled as D_z (see [`pool_diffusion_y`]).
    pub diffusion_y: Option<Pooled>,
    /// Nematic order S2; None when no replica has one (spheres; rows before schema 13).
    pub nematic_order: Option<OverReplicas>,
    /// ⟨|cos θ|⟩ to the flow direction; None as `nematic_order`.
    pub mean_abs_cos_flow: Option<OverReplicas>,
}

/// One point's replicas combined.
#[derive(Debug, Clone)]
pub struct PointProfiles<'a> {
    /// The pooled replicas: the steady ones, or every one given when none is steady (drawn with
    /// `--include-unsteady`), by job id.
    pub pooled: Vec<&'a ChuteJob>,
    /// The point's other jobs given (not steady, drawn with `--include-unsteady`): not pooled.
    pub not_pooled: Vec<&'a ChuteJob>,
    /// Particle length L of the first pooled replica, m.
    pub total_length_m: f64,
    /// Bed height H, mean over the pooled replicas, m.
    pub bed_height_m: f64,
    /// d_⊥, mean over the pooled replicas, m.
    pub d_perp_m: f64,
    /// The blocks any pooled replica has, by index.
    pub blocks: Vec<PointBlock>,
    /// γ̇(z) of `chute_fields` for 0 ≤ z ≤ H of each pooled replica, combined at each z, as
    /// (z in m, γ̇ in 1/s); empty when no replica has field rows.
    pub shear_field: Vec<(f64, OverReplicas)>,
}

impl PointProfiles<'_> {
    /// The point's label: its first pooled job's without `replica=K`.
    pub fn label(&self) -> String {
        label_without_replica(&self.pooled[0].label)
    }

    /// Whether the pooled replicas were steady (false only with `--include-unsteady`).
    pub fn steady(&self) -> bool {
        self.pooled.iter().all(|j| j.steady)
    }
}

/// The jobs of `jobs` that are replicas of `job`'s point (`job` among them), by job id.
pub fn replicas_of<'a>(jobs: &'a [ChuteJob], job: &ChuteJob) -> Vec<&'a ChuteJob> {
    let id = point_id(&job.label, &job.params_json);
    jobs.iter()
        .filter(|j| point_id(&j.label, &j.params_json) == id)
        .collect()
}

/// What makes jobs replicas of one point: their point key and their label without replica.
fn point_id(label: &str, params_json: &str) -> (String, String) {
    (point_key(params_json), label_without_replica(label))
}

/// `jobs` grouped into points, replicas together, in the order of each point's first job.
pub fn group_points(jobs: &[ChuteJob]) -> Vec<Vec<&ChuteJob>> {
    let mut out: Vec<((String, String), Vec<&ChuteJob>)> = Vec::new();
    for j in jobs {
        let id = point_id(&j.label, &j.params_json);
        match out.iter_mut().find(|(k, _)| *k == id) {
            Some((_, g)) => g.push(j),
            None => out.push((id, vec![j])),
        }
    }
    out.into_iter().map(|(_, g)| g).collect()
}

/// The time windows of D's standard error (`msd_error_windows`, found at any depth of the
/// job's parameters; the observer's default when absent).
pub(crate) fn error_windows(params_json: &str) -> f64 {
    fn find(v: &serde_json::Value) -> Option<u64> {
        let serde_json::Value::Object(map) = v else {
            return None;
        };
        map.get("msd_error_windows")
            .and_then(serde_json::Value::as_u64)
            .or_else(|| map.values().find_map(find))
    }
    serde_json::from_str::<serde_json::Value>(params_json)
        .ok()
        .as_ref()
        .and_then(find)
        .map_or(
            f64::from(ChuteObserverSettings::default().msd_error_windows),
            |m| m as f64,
        )
}

/// D_z of one block over the replicas that have one, m²/s. When each of them has its standard
/// error (from M time windows: M − 1 degrees of freedom, weighted by the measurement's length),
/// they are pooled (`fits::pool`; from 3 replicas on the wider of that and their spread);
/// otherwise, from 2 replicas on, their mean with a Student-t interval over them
/// (`PooledFrom::ReplicaSpread`); a single replica without its error has an infinite `ci95`
/// (unknown: no target on D's interval is met by it). None when no replica has a D.
pub fn pool_diffusion(replicas: &[(&ChuteJob, &BlockRow)]) -> Option<Pooled> {
    pool_estimates(replicas, |r| {
        (r.diffusion_m2_per_s, r.diffusion_stderr_m2_per_s)
    })
}

/// D_y of one block over the replicas that have one, m²/s, pooled exactly as
/// [`pool_diffusion`] pools D_z (its error comes from the same time windows).
pub fn pool_diffusion_y(replicas: &[(&ChuteJob, &BlockRow)]) -> Option<Pooled> {
    pool_estimates(replicas, |r| {
        (r.diffusion_y_m2_per_s, r.diffusion_y_stderr_m2_per_s)
    })
}

/// [`pool_diffusion`] of the (value, standard error) that `of` reads from each row.
fn pool_estimates(
    replicas: &[(&ChuteJob, &BlockRow)],
    of: impl Fn(&BlockRow) -> (Option<f64>, Option<f64>),
) -> Option<Pooled> {
    let with_d: Vec<(&ChuteJob, f64, Option<f64>)> = replicas
        .iter()
        .filter_map(|(j, r)| {
            let (d, se) = of(r);
            let d = d.filter(|d| d.is_finite())?;
            Some((*j, d, se.filter(|s| s.is_finite())))
        })
        .collect();
    let estimates: Option<Vec<ReplicaEstimate>> = with_d
        .iter()
        .map(|&(j, d, se)| {
            Some(ReplicaEstimate {
                mean: d,
                se: se?,
                dof: (error_windows(&j.params_json) - 1.0).max(1.0),
                weight: if j.measure_s.is_finite() && j.measure_s > 0.0 {
                    j.measure_s
                } else {
                    1.0
                },
            })
        })
        .collect();
    if let Some(p) = estimates.as_deref().and_then(pool) {
        return Some(p);
    }
    let ds: Vec<f64> = with_d.iter().map(|w| w.1).collect();
    let n = ds.len();
    match mean_ci95(&ds) {
        Some((mean, ci95)) => Some(Pooled {
            mean,
            ci95,
            se: ci95 / t_975((n - 1) as f64),
            dof: (n - 1) as f64,
            replicas: n,
            from: PooledFrom::ReplicaSpread,
        }),
        None => ds.first().map(|&mean| Pooled {
            mean,
            ci95: f64::INFINITY,
            se: f64::INFINITY,
            dof: 0.0,
            replicas: 1,
            from: PooledFrom::Blocks,
        }),
    }
}

/// Combines the replicas of one point (`replicas`: jobs of one group of [`group_points`], not
/// empty): the steady ones when there are any, else all of them.
///
/// # Errors
/// On a database error.
///
/// # Panics
/// When `replicas` is empty.
pub fn combine_point<'a>(
    conn: &Connection,
    replicas: &[&'a ChuteJob],
) -> Result<PointProfiles<'a>> {
    assert!(!replicas.is_empty(), "a point has at least one job");
    let steady: Vec<&ChuteJob> = replicas.iter().copied().filter(|j| j.steady).collect();
    let (mut pooled, not_pooled) = if steady.is_empty() {
        (replicas.to_vec(), Vec::new())
    } else {
        let others = replicas.iter().copied().filter(|j| !j.steady).collect();
        (steady, others)
    };
    pooled.sort_by_key(|j| j.job_id);
    let rows: Vec<Vec<BlockRow>> = pooled
        .iter()
        .map(|j| blocks(conn, j.job_id))
        .collect::<Result<_>>()?;
    let mut ids: Vec<i64> = rows.iter().flatten().map(|r| r.block).collect();
    ids.sort_unstable();
    ids.dedup();
    let mut out_blocks = Vec::new();
    for k in ids {
        let at: Vec<(&ChuteJob, &BlockRow)> = pooled
            .iter()
            .zip(&rows)
            .filter_map(|(j, rs)| rs.iter().find(|r| r.block == k).map(|r| (*j, r)))
            .collect();
        let values = |f: &dyn Fn(&BlockRow) -> Option<f64>| {
            OverReplicas::of(&at.iter().filter_map(|(_, r)| f(r)).collect::<Vec<f64>>())
        };
        let nan = OverReplicas {
            mean: f64::NAN,
            ci95: None,
            replicas: 0,
        };
        out_blocks.push(PointBlock {
            block: k,
            z_m: at.iter().map(|(_, r)| r.z_m).sum::<f64>() / at.len() as f64,
            diffusion: pool_diffusion(&at),
            shear_rate: values(&|r| Some(r.shear_rate_per_s)).unwrap_or(nan),
            velocity_x: values(&|r| Some(r.velocity_x_m_per_s)).unwrap_or(nan),
            solid_fraction: values(&|r| Some(r.solid_fraction)).unwrap_or(nan),
            vz_skewness: values(&|r| r.vz_skewness),
            diffusion_y: pool_diffusion_y(&at),
            nematic_order: values(&|r| r.nematic_order),
            mean_abs_cos_flow: values(&|r| r.mean_abs_cos_flow),
        });
    }
    let mut field: Vec<(f64, f64)> = Vec::new();
    for j in &pooled {
        field.extend(shear_profile(conn, j.job_id, j.bed_height_m)?);
    }
    field.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut shear_field = Vec::new();
    let mut rest = field.as_slice();
    while let Some(&(z, _)) = rest.first() {
        let n = rest.iter().take_while(|p| same_value(p.0, z)).count();
        let (here, tail) = rest.split_at(n);
        rest = tail;
        let g: Vec<f64> = here.iter().map(|p| p.1).collect();
        if let Some(v) = OverReplicas::of(&g) {
            shear_field.push((z, v));
        }
    }
    let n = pooled.len() as f64;
    Ok(PointProfiles {
        total_length_m: pooled[0].total_length_m,
        bed_height_m: pooled.iter().map(|j| j.bed_height_m).sum::<f64>() / n,
        d_perp_m: pooled.iter().map(|j| j.d_perp_m).sum::<f64>() / n,
        pooled,
        not_pooled,
        blocks: out_blocks,
        shear_field,
    })
}

/// One chute point of a campaign with D pooled over its steady replicas, as the figures draw it.
#[derive(Debug, Clone)]
pub struct ChutePoint {
    /// `campaign::point_key` of its jobs.
    pub point: String,
    /// A job label without its `replica=K`.
    pub label: String,
    /// The point's done jobs (with or without a summary, steady or not), by id.
    pub jobs: Vec<i64>,
    /// Those whose flow was steady (with a summary): the pooled ones, by id.
    pub steady_jobs: Vec<i64>,
    /// (z in m, D_z pooled over `steady_jobs`, m²/s) per block of the bulk,
    /// 0.2 H < z < 0.8 H (H: the mean bed height of the steady replicas), by z; a block's
    /// interval is infinite when it is unknown (see [`pool_diffusion`]).
    pub bulk_d: Vec<(f64, Pooled)>,
    /// max over `bulk_d` of ci95 / |D|; None without a bulk block with D.
    pub widest_bulk_ci_rel: Option<f64>,
}

/// Every point of the campaign's done chute jobs (grouped as the figures group them), with D
/// pooled over its steady replicas in the bulk of the bed: exactly the statistics of the chute
/// figures, for a campaign loop that stops on D's interval. Points in the order of their first
/// job id.
///
/// # Errors
/// On a database error.
pub fn pooled_points(conn: &Connection, campaign_id: i64) -> Result<Vec<ChutePoint>> {
    let done = done_campaign_jobs(conn, campaign_id)?;
    let summarised = done_chute_jobs(conn, campaign_id, true)?;
    let mut groups: Vec<((String, String), Vec<i64>)> = Vec::new();
    for (id, label, params) in &done {
        let key = point_id(label, params);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, g)) => g.push(*id),
            None => groups.push((key, vec![*id])),
        }
    }
    let mut out = Vec::new();
    for ((point, label), jobs) in groups {
        let steady: Vec<&ChuteJob> = summarised
            .iter()
            .filter(|j| j.steady && jobs.contains(&j.job_id))
            .collect();
        let mut bulk_d = Vec::new();
        if !steady.is_empty() {
            let p = combine_point(conn, &steady)?;
            let (lo, hi) = (BULK_BED.0 * p.bed_height_m, BULK_BED.1 * p.bed_height_m);
            bulk_d = p
                .blocks
                .iter()
                .filter(|b| b.z_m > lo && b.z_m < hi)
                .filter_map(|b| b.diffusion.map(|d| (b.z_m, d)))
                .collect();
        }
        let widest_bulk_ci_rel = bulk_d.iter().map(|(_, d)| d.ci95_rel()).reduce(f64::max);
        let mut steady_jobs: Vec<i64> = steady.iter().map(|j| j.job_id).collect();
        steady_jobs.sort_unstable();
        out.push(ChutePoint {
            point,
            label,
            jobs,
            steady_jobs,
            bulk_d,
            widest_bulk_ci_rel,
        });
    }
    Ok(out)
}

/// "; up to K replicas per point combined, bars 95 % CI" for a caption when a point combines
/// more than one replica; empty otherwise.
pub(crate) fn replicas_caption(max_replicas: usize) -> String {
    if max_replicas > 1 {
        format!("; up to {max_replicas} replicas per point combined, bars 95 % CI")
    } else {
        String::new()
    }
}
