//! Replicas of one chute point (jobs whose parameters differ only in `replica`:
//! `campaign::point_key` and the label without `replica=K`) combined per block of height L:
//! D pooled from each replica's D and its standard error over the measurement's
//! `msd_error_windows` time windows (`fits::pool`, weighted by the measurement's length), the
//! other block profiles (γ̇, V_x, φ, skewness of v_z) and the coarse-grained γ̇(z) as the mean
//! over replicas with a Student-t interval from 2 replicas on. Only steady replicas are pooled:
//! the figures draw what `done_chute_jobs` gives them, and a point that has steady replicas pools
//! those only. [`pooled_points`] gives a campaign loop the same statistics as the figures.

use anyhow::Result;
use rusqlite::Connection;

use crate::campaign::point_key;
use crate::observe::chute::ChuteObserverSettings;
use crate::observe::fits::{mean_ci95, pool, t_975, Pooled, PooledFrom, ReplicaEstimate};
use crate::report::chute::data::{
    blocks, done_campaign_jobs, done_chute_jobs, shear_profile, BlockRow, ChuteJob,
};
use crate::report::silo::data::{label_without_replica, same_value};

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
fn error_windows(params_json: &str) -> f64 {
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
    let with_d: Vec<(&ChuteJob, f64, Option<f64>)> = replicas
        .iter()
        .filter_map(|(j, r)| {
            let d = r.diffusion_m2_per_s.filter(|d| d.is_finite())?;
            Some((*j, d, r.diffusion_stderr_m2_per_s.filter(|s| s.is_finite())))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::test_rows::{self, ChuteBlock, ChuteSummary};

    const L: f64 = 0.125;
    const H: f64 = 20.0 * L;
    const BLOCKS: i64 = 20;
    /// Each replica's standard error of D, relative.
    const SE_REL: f64 = 0.05;

    fn d0(z: f64) -> f64 {
        1e-4 * (1.0 - 0.9 * z / H)
    }

    /// A done job at (ξ, α) = (1.3, `alpha`), replica `replica`, whose D is `scale` × d0(z)
    /// with a relative standard error of `SE_REL` (none when `with_se` is false).
    fn add(conn: &Connection, c: i64, alpha: f64, replica: u32, scale: f64, state: &'static str) {
        let label = format!("aspect_ratio=1.3,inclination_deg={alpha},replica={replica}");
        let params = format!(
            r#"{{"scene":"chute","chute":{{"aspect_ratio":1.3,"inclination_deg":{alpha},"replica":{replica}}}}}"#
        );
        let job = test_rows::chute_job(conn, c, &label, "done", &params);
        let summary = ChuteSummary {
            aspect_ratio: 1.3,
            inclination_deg: alpha,
            total_length_m: L,
            bed_height_m: H,
            d_perp_m: 0.07,
            measure_s: 240.0,
            state,
        };
        test_rows::chute_summary(conn, job, &summary);
        for k in 0..BLOCKS {
            let z = (k as f64 + 0.5) * L;
            let d = d0(z);
            let block = ChuteBlock {
                block: k,
                z_m: z,
                d: Some(scale * d),
                d_se: Some(SE_REL * d),
                shear_rate: 0.1 * (1.0 - 0.9 * z / H) * scale,
                velocity_x: z,
                solid_fraction: 0.55,
                vz_skewness: Some(0.1 * scale),
            };
            test_rows::chute_block(conn, job, &block);
        }
        for i in 0..=80 {
            let z = f64::from(i) * L / 4.0;
            test_rows::chute_field(conn, job, z, 0.1 * (1.0 - 0.9 * z / H) * scale);
        }
    }

    /// Point α = 27°: three steady replicas at D × (1.001, 1, 0.999) and a fourth that drifted
    /// (D × 2); point α = 28°: one steady run.
    fn db() -> (Connection, i64) {
        let conn = test_rows::empty_db();
        let c = test_rows::campaign(&conn, "chute_replicas", "chute", "2025-01-01T00:00:00.000Z");
        for (r, scale) in [1.001, 1.0, 0.999].into_iter().enumerate() {
            add(&conn, c, 27.0, r as u32, scale, "steady");
        }
        add(&conn, c, 27.0, 3, 2.0, "drifted");
        add(&conn, c, 28.0, 0, 1.0, "steady");
        (conn, c)
    }

    #[test]
    fn pooled_points_pool_the_steady_replicas_of_each_point() {
        let (conn, c) = db();
        let points = pooled_points(&conn, c).expect("points");
        assert_eq!(points.len(), 2);
        let (a, b) = (&points[0], &points[1]);
        assert_eq!(a.label, "aspect_ratio=1.3,inclination_deg=27");
        assert_eq!((a.jobs.len(), a.steady_jobs.len()), (4, 3));
        assert_eq!(a.steady_jobs, a.jobs[..3].to_vec());
        assert!(!a.point.contains("replica"), "{}", a.point);
        // 0.2 H < z < 0.8 H: blocks 4 to 15.
        assert_eq!(a.bulk_d.len(), 12);
        let one = t_975(3.0) * SE_REL;
        let three = t_975(9.0) * SE_REL / 3f64.sqrt();
        for (z, d) in &a.bulk_d {
            assert!((d.mean - d0(*z)).abs() < 1e-12 * d0(*z), "{z}: {d:?}");
            assert_eq!((d.replicas, d.from), (3, PooledFrom::Blocks));
            assert!((d.dof - 9.0).abs() < 1e-9, "{z}: {d:?}");
            assert!((d.ci95_rel() - three).abs() < 1e-9, "{z}: {d:?}");
            assert!(d.ci95_rel() < one);
        }
        let widest = a.widest_bulk_ci_rel.expect("widest");
        assert!((widest - three).abs() < 1e-9, "{widest}");
        assert_eq!((b.jobs.len(), b.steady_jobs.len()), (1, 1));
        let widest = b.widest_bulk_ci_rel.expect("widest");
        assert!((widest - one).abs() < 1e-9, "{widest}");
    }

    #[test]
    fn replicas_without_their_error_fall_back_to_their_spread() {
        let (conn, c) = db();
        let jobs = done_chute_jobs(&conn, c, false).expect("jobs");
        conn.execute(
            "UPDATE chute_blocks SET diffusion_stderr_m2_per_s = NULL WHERE job_id = ?1",
            [jobs[0].job_id],
        )
        .expect("update");
        let groups = group_points(&jobs);
        assert_eq!(groups.len(), 2);
        let p = combine_point(&conn, &groups[0]).expect("point");
        let b = &p.blocks[5];
        let d = b.diffusion.expect("D");
        assert_eq!((d.replicas, d.from), (3, PooledFrom::ReplicaSpread));
        // Student t over D × (1.001, 1, 0.999): s = 0.001 D.
        let expected = t_975(2.0) * 0.001 * d0(b.z_m) / 3f64.sqrt();
        assert!((d.ci95 - expected).abs() < 1e-9 * expected, "{d:?}");
        // A single run without its error: D with an unknown (infinite) interval.
        let single = combine_point(&conn, &groups[0][..1]).expect("single");
        let d = single.blocks[5].diffusion.expect("D");
        assert!(d.ci95.is_infinite() && d.replicas == 1);
        // The other profiles: the replicas' mean with a t-interval.
        assert_eq!(b.shear_rate.replicas, 3);
        assert!(b.shear_rate.ci95.is_some());
        assert_eq!(p.shear_field.len(), 81);
        assert_eq!(p.shear_field[10].1.replicas, 3);
        assert_eq!(error_windows(&jobs[0].params_json), 4.0);
        assert_eq!(
            error_windows(r#"{"o":{"chute":{"msd_error_windows":8}}}"#),
            8.0
        );
    }

    #[test]
    fn figures_draw_the_pooled_points_with_their_count() {
        let (conn, _) = db();
        let dir = tempfile::tempdir().expect("tempdir");
        let fig3 = crate::report::render_figure(&conn, "fig3", None, dir.path()).expect("fig3");
        assert!(
            fig3.table.contains("not steady, left out")
                && fig3
                    .table
                    .contains("aspect_ratio=1.3,inclination_deg=27,replica=3"),
            "{}",
            fig3.table
        );
        let csv = std::fs::read_to_string(dir.path().join("chute_fig3.csv")).expect("csv");
        let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
        assert_eq!(header.last(), Some(&"replicas"));
        // The label is quoted (it holds a comma): the cells after it.
        let rows: Vec<Vec<&str>> = csv
            .lines()
            .skip(1)
            .filter(|l| l.contains("inclination_deg=27\"") && l.contains("D_L2_per_s"))
            .map(|l| l.rsplit_once("\",").expect("label").1.split(',').collect())
            .collect();
        assert_eq!(rows.len(), BLOCKS as usize);
        for r in &rows {
            assert_eq!(r[8], "3", "{r:?}");
            let (d, ci): (f64, f64) = (r[4].parse().expect("D"), r[6].parse().expect("ci"));
            let rel = t_975(9.0) * SE_REL / 3f64.sqrt();
            assert!((ci / d - rel).abs() < 1e-9, "{r:?}");
        }
        let svg = std::fs::read_to_string(dir.path().join("chute_fig3.svg")).expect("svg");
        assert!(svg.contains("n=3"), "no replica count in the figure");
        let fig6 = crate::report::render_figure(&conn, "fig6", None, dir.path()).expect("fig6");
        let csv = std::fs::read_to_string(dir.path().join("chute_fig6.csv")).expect("csv");
        // 0.3 H < z < 0.7 H: 8 blocks per point, not per replica.
        assert_eq!(csv.lines().count(), 1 + 2 * 8, "{}", fig6.table);
        let fig5 = crate::report::render_figure(&conn, "fig5", None, dir.path()).expect("fig5");
        assert!(
            fig5.table.contains("1 of its point's 3 replicas"),
            "{}",
            fig5.table
        );
    }
}
