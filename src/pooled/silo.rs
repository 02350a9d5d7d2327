//! The silo results a figure reads: discharge summaries of a campaign's done jobs, M(t) series,
//! and replicas of one (D, f) combined into one flow rate with its 95 % confidence interval.
//! The queries live in `store::silo_reads`. Read-only; no plotting here.

pub use crate::store::silo_reads::{
    done_discharge_rows, drawable_discharge_rows, mass_series, DischargeRow,
};

use crate::observe::fits::{mean_ci95, pool, t_975};

/// Where a combined point's confidence interval comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CiSource {
    /// Student t on the spread of ≥ 2 replicas' Q (rows that do not say their block count).
    ReplicaSpread,
    /// The single job's own q_ci95_kg_per_s (over its flowing intervals).
    SingleJob,
    /// Every replica's blocks pooled (`fits::pool`); from 3 replicas on, the wider of that and
    /// their spread, which `pooled` says.
    Pooled(crate::observe::fits::PooledFrom),
}

impl CiSource {
    /// How the table names it.
    pub fn name(self) -> &'static str {
        match self {
            CiSource::ReplicaSpread => "replicas",
            CiSource::SingleJob => "job",
            CiSource::Pooled(f) => f.name(),
        }
    }
}

/// Q at one (D, f), combined over the replicas that measured it.
#[derive(Debug, Clone)]
pub struct FlowPoint {
    /// Orifice diameter D, m.
    pub d_m: f64,
    /// Rotation frequency f, Hz.
    pub f_hz: f64,
    /// Particle diameter d, m.
    pub particle_d_m: f64,
    /// Bulk density ρ_b, kg/m³.
    pub bulk_density_kg_per_m3: f64,
    /// Q over the replicas (pooled: weighted by their blocks; else their mean), kg/s.
    pub q: f64,
    /// Half-width of the 95 % CI of `q`, kg/s; None when unknown.
    pub ci: Option<f64>,
    /// Replicas with a Q (replicas without one, e.g. clogged for good, are not counted).
    pub replicas: usize,
    /// How `ci` was obtained.
    pub ci_source: CiSource,
    /// Standard error of `q` behind `ci`, kg/s, and its degrees of freedom (infinite for a
    /// single job that does not say its block count: its CI is taken as normal); None with `ci`.
    pub se: Option<f64>,
    pub dof: f64,
    /// Replicas of this point that have no Q (clogged): not in `q`, named in the tables.
    pub clogged_replicas: usize,
    /// The Q of each replica with one, kg/s (what a bootstrap over replicas redraws).
    pub replica_q: Vec<f64>,
}

/// A (D, f) at which no replica has a flow rate: every run clogged before Q could be measured.
/// Figures mark it (a cross on the axis, legend "clogged"); it is never drawn as a value.
#[derive(Debug, Clone)]
pub struct CloggedPoint {
    /// Orifice diameter D, m.
    pub d_m: f64,
    /// Rotation frequency f, Hz.
    pub f_hz: f64,
    /// Particle diameter d, m.
    pub particle_d_m: f64,
    /// Runs at this point (all without Q).
    pub runs: usize,
}

impl FlowPoint {
    /// D / d, dimensionless.
    pub fn d_over_particle(&self) -> f64 {
        self.d_m / self.particle_d_m
    }
}

/// Whether two swept values are the same setting. Values come from the same campaign JSON, so
/// equal settings are bit-identical; the tolerance only absorbs a text round trip.
pub fn same_value(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-12)
}

/// The rows grouped into points: rows whose parameters are equal except the replica index
/// (`campaign::point_key`), sorted by D, f; two points at one (D, f) that differ in another
/// parameter stay two points.
fn points_of(rows: &[DischargeRow]) -> Vec<Vec<&DischargeRow>> {
    let mut keyed: Vec<(&DischargeRow, String)> = rows
        .iter()
        .map(|r| (r, crate::campaign::point_key(&r.params_json)))
        .collect();
    keyed.sort_by(|(a, ka), (b, kb)| {
        a.orifice_diameter_m
            .total_cmp(&b.orifice_diameter_m)
            .then(a.rotation_frequency_hz.total_cmp(&b.rotation_frequency_hz))
            .then(ka.cmp(kb))
    });
    let mut out = Vec::new();
    let mut rest = keyed.as_slice();
    while let Some((first, key)) = rest.first() {
        let n = rest
            .iter()
            .take_while(|(r, k)| {
                same_value(r.orifice_diameter_m, first.orifice_diameter_m)
                    && same_value(r.rotation_frequency_hz, first.rotation_frequency_hz)
                    && k == key
            })
            .count();
        let (group, tail) = rest.split_at(n);
        rest = tail;
        out.push(group.iter().map(|(r, _)| *r).collect());
    }
    out
}

/// Combines the replicas of each point. When every replica with Q says its block count
/// (`DischargeRow::q_blocks`), their blocks are pooled (`fits::pool`: weighted by blocks, and
/// from 3 replicas on the wider of that and their spread); otherwise the mean of their Q with,
/// from 2 replicas on, a Student-t CI over them; one replica keeps its own CI. Replicas without Q
/// are counted in `clogged_replicas`; a point where no replica has Q is not here but in
/// [`clogged_points`].
pub fn combine_replicas(rows: &[DischargeRow]) -> Vec<FlowPoint> {
    points_of(rows)
        .iter()
        .filter_map(|g| combine_group(g))
        .collect()
}

/// One point's replicas combined (see [`combine_replicas`]); None when none has Q.
fn combine_group(group: &[&DischargeRow]) -> Option<FlowPoint> {
    let with_q: Vec<&DischargeRow> = group
        .iter()
        .copied()
        .filter(|r| r.q_kg_per_s.is_some())
        .collect();
    let first = with_q.first()?;
    let qs: Vec<f64> = with_q.iter().filter_map(|r| r.q_kg_per_s).collect();
    let estimates: Option<Vec<_>> = with_q.iter().map(|r| r.q_estimate()).collect();
    let pooled = estimates.as_deref().and_then(pool);
    let (q, ci, ci_source, se, dof) = match (pooled, mean_ci95(&qs)) {
        (Some(p), _) => (
            p.mean,
            Some(p.ci95),
            CiSource::Pooled(p.from),
            Some(p.se),
            p.dof,
        ),
        (None, Some((mean, hw))) => {
            let dof = (qs.len() - 1) as f64;
            (
                mean,
                Some(hw),
                CiSource::ReplicaSpread,
                Some(hw / t_975(dof)),
                dof,
            )
        }
        (None, None) => {
            let ci = first.q_ci95_kg_per_s;
            (
                qs[0],
                ci,
                CiSource::SingleJob,
                ci.map(|c| c / 1.959_964),
                f64::INFINITY,
            )
        }
    };
    Some(FlowPoint {
        d_m: first.orifice_diameter_m,
        f_hz: first.rotation_frequency_hz,
        particle_d_m: first.particle_diameter_m,
        bulk_density_kg_per_m3: first.bulk_density_kg_per_m3,
        q,
        ci,
        replicas: qs.len(),
        ci_source,
        se,
        dof,
        clogged_replicas: group.len() - qs.len(),
        replica_q: qs,
    })
}

/// One silo point as [`pooled_q_points`] gives it: (point key, label without `replica=K`, the
/// point's done jobs, its combined Q).
pub type QPoint = (String, String, Vec<i64>, Option<FlowPoint>);

/// Every point of the campaign's done silo jobs with the flow rate Fig. 3–5 draw for it, as
/// (point key (`campaign::point_key`), its label without `replica=K`, the point's done jobs
/// (with or without Q), its combined Q (None when no replica has Q)): the
/// same rows (`done_discharge_rows`), the same grouping and the same [`combine_replicas`]
/// statistics, so a campaign loop that stops on a point's CI stops on the figure's CI (the loop
/// looks when every job has ended; while a round runs, a figure also draws the earlier end of the
/// jobs it runs on, `drawable_discharge_rows`). Sorted by D, f, point key.
///
/// # Errors
/// On a database error.
pub fn pooled_q_points(
    conn: &rusqlite::Connection,
    campaign_id: i64,
) -> anyhow::Result<Vec<QPoint>> {
    let rows = done_discharge_rows(conn, campaign_id)?;
    Ok(points_of(&rows)
        .iter()
        .map(|g| {
            (
                crate::campaign::point_key(&g[0].params_json),
                label_without_replica(&g[0].label),
                g.iter().map(|r| r.job_id).collect(),
                combine_group(g),
            )
        })
        .collect())
}

pub use crate::campaign::label_without_replica;

/// The text a figure writes beside a point that combines `replicas` runs: "n=3"; None for one.
pub fn replica_label(replicas: usize) -> Option<String> {
    (replicas > 1).then(|| format!("n={replicas}"))
}

/// The figure note that explains [`replica_label`]'s texts.
/// A campaign target's outcome in one line ("target ±3.0 % (95 % CI of Q): 6 of 6 points
/// met, …"), for the figures that show Q; None for a campaign without target points.
pub fn target_note(
    conn: &rusqlite::Connection,
    campaign_id: i64,
) -> anyhow::Result<Option<String>> {
    let points = crate::store::targets::points(conn, campaign_id)?;
    if points.is_empty() {
        return Ok(None);
    }
    let Some(t) = crate::store::targets::campaign_file(conn, campaign_id)?.and_then(|f| f.target)
    else {
        return Ok(None);
    };
    let work = crate::store::targets::work(conn, campaign_id)?;
    let met = points.iter().filter(|p| p.met).count();
    let short: Vec<String> = points
        .iter()
        .filter(|p| !p.met)
        .map(|p| format!("{} ({})", p.point, p.status))
        .collect();
    Ok(Some(format!(
        "target ±{:.1} % (95 % CI of Q): {met} of {} points met after {} extension(s), {} added replica(s){}",
        100.0 * t.ci95_rel(),
        points.len(),
        work.iter().filter(|w| w.action == "extend").count(),
        work.iter().filter(|w| w.action == "replica").count(),
        if short.is_empty() {
            String::new()
        } else {
            format!("; not met: {}", short.join("; "))
        }
    )))
}

pub const REPLICA_NOTE: &str = "n=K beside a point: K replicas combined; bars: their 95 % CI";

/// The points at which every run clogged before Q could be measured (no replica has Q).
pub fn clogged_points(rows: &[DischargeRow]) -> Vec<CloggedPoint> {
    points_of(rows)
        .into_iter()
        .filter(|g| g.iter().all(|r| r.q_kg_per_s.is_none()))
        .map(|g| CloggedPoint {
            d_m: g[0].orifice_diameter_m,
            f_hz: g[0].rotation_frequency_hz,
            particle_d_m: g[0].particle_diameter_m,
            runs: g.len(),
        })
        .collect()
}

/// The distinct values of `values`, sorted ascending.
pub fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| same_value(*a, *b));
    v
}

/// Up to `k` elements of `v` spread evenly over it, always including both ends.
pub fn spread<T: Copy>(v: &[T], k: usize) -> Vec<T> {
    if v.len() <= k {
        return v.to_vec();
    }
    match k {
        0 => Vec::new(),
        1 => vec![v[0]],
        _ => (0..k)
            .map(|i| v[(i * (v.len() - 1) + (k - 1) / 2) / (k - 1)])
            .collect(),
    }
}

/// |g| in m/s² from a job's parameters: the first of the keys `gravity_m_per_s2`,
/// `g_m_per_s2`, `gravity` found at any depth, given as a number or a vector. None if absent.
pub fn gravity_m_per_s2(params_json: &str) -> Option<f64> {
    fn find(v: &serde_json::Value) -> Option<f64> {
        let serde_json::Value::Object(map) = v else {
            return None;
        };
        for key in ["gravity_m_per_s2", "g_m_per_s2", "gravity"] {
            match map.get(key) {
                Some(serde_json::Value::Number(n)) => return n.as_f64().map(f64::abs),
                Some(serde_json::Value::Array(a)) => {
                    let c: Option<Vec<f64>> = a.iter().map(serde_json::Value::as_f64).collect();
                    if let Some(c) = c {
                        return Some(c.iter().map(|x| x * x).sum::<f64>().sqrt());
                    }
                }
                _ => {}
            }
        }
        map.values().find_map(find)
    }
    let value: serde_json::Value = serde_json::from_str(params_json).ok()?;
    find(&value).filter(|g| g.is_finite() && *g > 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(d: f64, f: f64, q: Option<f64>, ci: Option<f64>) -> DischargeRow {
        DischargeRow {
            job_id: 0,
            label: String::new(),
            orifice_diameter_m: d,
            rotation_frequency_hz: f,
            particle_diameter_m: 0.0058,
            bulk_density_kg_per_m3: 1550.0,
            q_kg_per_s: q,
            q_ci95_kg_per_s: ci,
            params_json: "{}".into(),
            permanently_clogged: q.is_none(),
            q_blocks: None,
            sim_time_s: 2.0,
            particle_steps: 0,
            q_method: String::new(),
            running_on_to_s: None,
        }
    }

    #[test]
    fn replicas_combine_with_student_t_and_singles_keep_their_ci() {
        let rows = vec![
            row(0.03, 0.5, Some(1.0), Some(0.1)),
            row(0.02, 0.5, Some(0.5), Some(0.05)),
            row(0.03, 0.5, Some(1.2), Some(0.1)),
            row(0.03, 0.5, None, None),
            row(0.03, 1.0, None, None),
        ];
        let pts = combine_replicas(&rows);
        assert_eq!(pts.len(), 2);
        assert_eq!(
            pts[1].clogged_replicas, 1,
            "the Q-less replica at (30 mm, 0.5 Hz)"
        );
        let clogged = clogged_points(&rows);
        assert_eq!(clogged.len(), 1, "(30 mm, 1 Hz) has no Q at all");
        assert!(same_value(clogged[0].f_hz, 1.0) && clogged[0].runs == 1);
        assert!(same_value(pts[0].d_m, 0.02) && pts[0].ci == Some(0.05));
        assert_eq!(pts[0].ci_source, CiSource::SingleJob);
        let p = &pts[1];
        assert_eq!((p.replicas, p.ci_source), (2, CiSource::ReplicaSpread));
        assert!((p.q - 1.1).abs() < 1e-12);
        // s = 0.1414, t_1 = 12.706: hw = 12.706 · 0.1414 / √2 = 1.2706
        let hw = p.ci.expect("ci");
        assert!((hw - 1.270_620_473_617_470_7).abs() < 1e-9, "{hw}");
    }

    #[test]
    fn jobs_that_differ_in_another_parameter_are_not_replicas() {
        let with_n = |n: u32, replica: u32| DischargeRow {
            params_json: format!(
                r#"{{"scene":"silo","silo":{{"particle_count":{n},"replica":{replica}}}}}"#
            ),
            ..row(0.03, 0.5, Some(f64::from(n) / 1000.0), Some(0.01))
        };
        let pts = combine_replicas(&[with_n(300, 0), with_n(400, 0), with_n(300, 1)]);
        assert_eq!(pts.len(), 2, "N = 300 and N = 400 are two points");
        let replicas: Vec<usize> = pts.iter().map(|p| p.replicas).collect();
        assert!(
            replicas.contains(&2) && replicas.contains(&1),
            "{replicas:?}"
        );
    }

    #[test]
    fn spread_keeps_ends_and_count() {
        let v: Vec<usize> = (0..10).collect();
        assert_eq!(spread(&v, 4), vec![0, 3, 6, 9]);
        assert_eq!(spread(&v, 2), vec![0, 9]);
        assert_eq!(spread(&v[..3], 8), vec![0, 1, 2]);
        assert_eq!(
            distinct([0.3, 0.1, 0.3, 0.2].into_iter()),
            vec![0.1, 0.2, 0.3]
        );
    }

    #[test]
    fn gravity_found_as_number_or_vector_at_any_depth() {
        assert_eq!(
            gravity_m_per_s2(r#"{"gravity_m_per_s2": 9.81}"#),
            Some(9.81)
        );
        let g = gravity_m_per_s2(r#"{"scene": {"gravity": [0, 0, -9.81]}}"#).expect("g");
        assert!((g - 9.81).abs() < 1e-12);
        assert_eq!(gravity_m_per_s2(r#"{"dt_s": 1e-6}"#), None);
        assert_eq!(gravity_m_per_s2("not json"), None);
    }
}
