//! Replicas of chute points pooled (`pooled::chute`) and drawn: a synthetic campaign of steady
//! and drifted replicas with known D and errors.

use rusqlite::Connection;

use crate::observe::fits::{t_975, PooledFrom};
use crate::pooled::chute::*;
use crate::pooled::chute_jobs::done_chute_jobs;
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
fn add(
    conn: &Connection,
    c: i64,
    alpha: f64,
    replica: u32,
    scale: f64,
    state: &'static str,
) -> i64 {
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
    job
}

/// Gives every job tolerances of 10 % (kinetic energy) and 5 % (V_x).
fn tolerances(conn: &Connection) {
    conn.execute(
        "UPDATE jobs SET params_json = json_set(params_json, \
         '$.chute.steady_kinetic_tolerance', 0.1, '$.chute.steady_velocity_tolerance', 0.05)",
        [],
    )
    .expect("tolerances");
}

/// A stored measurement window of `job` whose V_x trend changes by `vx_change` with t statistic
/// `vx_t` (t quantile 2.776).
fn measured_window(conn: &Connection, job: i64, vx_change: f64, vx_t: f64) {
    conn.execute(
        "INSERT INTO chute_stationarity (job_id, phase, start_s, end_s, ke_mean_j, ke_change, \
         ke_t, vx_mean_m_per_s, vx_change, vx_t, t_critical, stress_ratio, ratio_ok, flowing, \
         steady) VALUES (?1, 'measurement', 160.0, 400.0, 1000.0, 0.02, 0.5, 1.0, ?2, ?3, \
         2.776, 0.51, 1, 1, 0)",
        rusqlite::params![job, vx_change, vx_t],
    )
    .expect("window");
}

#[test]
fn a_drift_the_swings_could_make_reads_as_steady() {
    let (conn, c) = db();
    // The drifted replica of db() (D × 2) drifted beyond 5 % and its error; a fifth one
    // recorded as drifted changed by 6.6 % with t = 2.06, which its swings could make.
    let moving: i64 = conn
        .query_row(
            "SELECT job_id FROM campaign_jobs WHERE label LIKE '%=27,replica=3'",
            [],
            |r| r.get(0),
        )
        .expect("the drifted replica");
    measured_window(&conn, moving, 0.096, 4.9);
    let quiet = add(&conn, c, 27.0, 4, 1.0, "drifted");
    measured_window(&conn, quiet, 0.066, 2.06);
    tolerances(&conn);
    let steady: Vec<i64> = done_chute_jobs(&conn, c, false)
        .expect("jobs")
        .iter()
        .map(|j| j.job_id)
        .collect();
    assert!(
        steady.contains(&quiet) && !steady.contains(&moving),
        "{steady:?}"
    );
    let left = crate::store::chute_reads::left_out_chute_jobs(&conn, c).expect("left out");
    assert_eq!(left.len(), 1, "{left:?}");
    assert_eq!(left[0].state, "drifted");
    assert!(left[0].label.ends_with("replica=3"), "{left:?}");
    let verdicts = crate::store::chute_reads::flow_verdicts(&conn, c).expect("verdicts");
    assert_eq!(verdicts[&quiet].state, "steady");
    assert_eq!(verdicts[&moving].state, "drifted");
    let points = pooled_points(&conn, c).expect("points");
    assert_eq!((points[0].jobs.len(), points[0].steady_jobs.len()), (5, 4));
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

/// A steady replica whose density profile oscillates through the bed (ordered layers) is left
/// out as layered: not drawn, not counted among its point's steady replicas, named with why.
#[test]
fn a_steady_replica_in_ordered_layers_is_left_out() {
    let (conn, c) = db();
    add(&conn, c, 28.0, 1, 1.0, "steady");
    let layered: i64 = conn
        .query_row("SELECT MAX(id) FROM jobs", [], |r| r.get(0))
        .expect("job");
    let heights: Vec<f64> = conn
        .prepare("SELECT z_m FROM chute_fields WHERE job_id = ?1")
        .expect("prepare")
        .query_map([layered], |r| r.get(0))
        .expect("query")
        .collect::<rusqlite::Result<_>>()
        .expect("heights");
    for z in heights {
        // Layers one particle apart: ±20 % of the mean density.
        let rho = 1500.0 * (1.0 + 0.2 * (std::f64::consts::TAU * z / (0.87 * L)).sin());
        conn.execute(
            "UPDATE chute_fields SET density_kg_per_m3 = ?1 WHERE job_id = ?2 AND z_m = ?3",
            rusqlite::params![rho, layered, z],
        )
        .expect("update");
    }
    let steady: Vec<i64> = done_chute_jobs(&conn, c, false)
        .expect("jobs")
        .iter()
        .map(|j| j.job_id)
        .collect();
    assert!(!steady.contains(&layered), "{steady:?}");
    assert_eq!(steady.len(), 4, "the other steady replicas stay");
    let all = done_chute_jobs(&conn, c, true).expect("all");
    let job = all.iter().find(|j| j.job_id == layered).expect("listed");
    assert!(
        !job.steady && job.layering.is_some_and(|v| v > 0.1),
        "{job:?}"
    );
    // The disordered replicas' constant density: no layering.
    assert!(all
        .iter()
        .filter(|j| j.job_id != layered)
        .all(|j| j.layering == Some(0.0)));
    let verdicts = crate::store::chute_reads::flow_verdicts(&conn, c).expect("verdicts");
    assert_eq!(verdicts[&layered].state, "layered", "status says why");
    assert_eq!(verdicts[&(layered - 1)].state, "steady");
    let points = pooled_points(&conn, c).expect("points");
    assert_eq!(
        (points[1].jobs.len(), points[1].steady_jobs.len()),
        (2, 1),
        "the layered replica does not count as steady"
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let fig6 = crate::report::render_figure(&conn, "fig6", None, dir.path()).expect("fig6");
    assert!(
        fig6.table.contains(
            "aspect_ratio=1.3,inclination_deg=28,replica=1 (steady but in ordered layers)"
        ),
        "{}",
        fig6.table
    );
}

#[test]
fn a_job_a_round_runs_on_stays_drawn_from_its_earlier_end() {
    let (mut conn, c) = db();
    // The 28° point's only replica: without it, its point would leave every figure.
    let label = "aspect_ratio=1.3,inclination_deg=28,replica=0";
    let job: i64 = conn
        .query_row(
            "SELECT job_id FROM campaign_jobs WHERE label = ?1",
            [label],
            |r| r.get(0),
        )
        .expect("job");
    let dir = tempfile::tempdir().expect("tempdir");
    let (before, after) = (dir.path().join("before"), dir.path().join("after"));
    for figure in ["fig3", "fig6"] {
        crate::report::render_figure(&conn, figure, None, &before).expect(figure);
    }
    let tx = conn.transaction().expect("tx");
    assert!(crate::store::targets::extend(&tx, job, 400.0, 400.0).expect("extend"));
    tx.commit().expect("commit");
    assert!(
        done_chute_jobs(&conn, c, true)
            .expect("jobs")
            .iter()
            .all(|j| j.job_id != job),
        "the claims read ended jobs only"
    );
    for figure in ["fig3", "fig6"] {
        let r = crate::report::render_figure(&conn, figure, None, &after).expect(figure);
        let csv = |d: &std::path::Path| {
            std::fs::read_to_string(d.join(format!("chute_{figure}.csv"))).expect("csv")
        };
        assert_eq!(csv(&after), csv(&before), "{figure} keeps the job's values");
        let note = format!(
            "1 of them from their earlier end while a round runs them on: {label} (job {job}, \
             to 400 s)"
        );
        assert!(r.table.contains(&note), "{figure}: {}", r.table);
    }
    let svg = std::fs::read_to_string(after.join("chute_fig6.svg")).expect("svg");
    assert!(svg.contains("run on by a round"), "fig6's caption names it");
}
