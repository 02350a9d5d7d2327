//! Replicas pooled into one point: their count, a narrower interval, the figures' points.

use super::*;

/// A campaign 'pooled' (the only one) at f = 0 and 1 Hz over four orifices, one run each,
/// except three replicas at D = 30 mm, f = 1 Hz that record their 10 blocks: Q ± 0.2 % with a
/// CI of 5 % each.
fn pooled_db() -> (Connection, f64) {
    let conn = test_rows::empty_db();
    let id = add_campaign(&conn, "pooled", "silo", "2026-01-01T00:00:00.000Z");
    let d_rep = 0.030;
    for d in [0.020, 0.024, d_rep, 0.036] {
        for f in [0.0, 1.0] {
            let q = law(d, f);
            let label =
                |r: u32| format!("orifice_diameter_m={d},rotation_frequency_hz={f},replica={r}");
            if d == d_rep && f == 1.0 {
                for (r, k) in [1.002, 1.0, 0.998].into_iter().enumerate() {
                    let label = label(r as u32);
                    let q = Some((q * k, 0.05 * q));
                    add_job_with_blocks(&conn, id, &label, "done", d, f, q, Some(10));
                }
            } else {
                let q = Some((q, 0.05 * q));
                add_job_with_blocks(&conn, id, &label(0), "done", d, f, q, Some(10));
            }
        }
    }
    (conn, d_rep)
}

#[test]
fn three_pooled_replicas_show_their_count_and_a_narrower_interval() {
    let (conn, d_rep) = pooled_db();
    let q = law(d_rep, 1.0);
    let dir = tempfile::tempdir().expect("tempdir");
    let fig3 = render_figure(&conn, "fig3", None, dir.path()).expect("fig3");
    assert!(fig3.table.contains("campaign 'pooled'"), "{}", fig3.table);
    let csv = std::fs::read_to_string(dir.path().join("fig3.csv")).expect("csv");
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (q_col, ci_col, from_col, n_col) = (
        col("q_kg_per_s"),
        col("q_ci95_kg_per_s"),
        col("q_ci95_source"),
        col("replicas"),
    );
    let mut seen = 0;
    for line in csv.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let (f, d): (f64, f64) = (v[0].parse().expect("f"), v[1].parse().expect("D"));
        let ci: f64 = v[ci_col].parse().expect("ci");
        assert_eq!(v[from_col], "pooled blocks", "{line}");
        if d == d_rep && f == 1.0 {
            assert_eq!(v[n_col], "3", "{line}");
            let mean: f64 = v[q_col].parse().expect("q");
            assert!((mean - q).abs() < 1e-12 * q, "{line}");
            // Three replicas of 10 blocks: t_27 / (t_9 √3) of each one's CI, about half.
            assert!(ci < 0.6 * 0.05 * q && ci > 0.4 * 0.05 * q, "{line}");
            seen += 1;
        } else {
            assert_eq!(v[n_col], "1", "{line}");
            assert!((ci - 0.05 * law(d, f)).abs() < 1e-9 * ci, "{line}");
        }
    }
    assert_eq!(seen, 1);
    let svg = std::fs::read_to_string(dir.path().join("fig3.svg")).expect("svg");
    let text = svg_text(&svg);
    assert_eq!(text.matches("n=3").count(), 1, "beside the point: {text}");
    assert!(text.contains("n=K beside a point"), "the note: {text}");
    assert!(!text.contains("n=1"), "{text}");
    for figure in ["fig4", "fig5"] {
        let drawn = render_figure(&conn, figure, None, dir.path()).expect(figure);
        let csv = std::fs::read_to_string(dir.path().join(format!("{figure}.csv"))).expect("csv");
        let row = csv
            .lines()
            .find(|l| l.split(',').nth(8) == Some("3"))
            .unwrap_or_else(|| panic!("{figure}: no row with 3 replicas\n{csv}"));
        assert!(row.ends_with(",3,pooled blocks,0"), "{row}");
        let svg = std::fs::read_to_string(dir.path().join(format!("{figure}.svg"))).expect("svg");
        assert!(svg_text(&svg).contains("n=3"), "{figure}");
        assert!(drawn.table.contains("replicas"), "{}", drawn.table);
    }
}

#[test]
fn pooled_q_points_are_the_figure_points() {
    let (conn, d_rep) = pooled_db();
    let id = test_rows::campaign_id(&conn, "pooled");
    let points = crate::pooled::silo::pooled_q_points(&conn, id).expect("points");
    let rows = crate::pooled::silo::done_discharge_rows(&conn, id).expect("rows");
    let combined = crate::pooled::silo::combine_replicas(&rows);
    assert_eq!(points.len(), 8);
    assert_eq!(combined.len(), 8);
    for ((key, label, jobs, point), c) in points.iter().zip(&combined) {
        let p = point.as_ref().expect("every point has Q");
        assert_eq!((p.q, p.ci, p.replicas), (c.q, c.ci, c.replicas));
        assert_eq!(jobs.len(), p.replicas);
        assert!(!label.contains("replica"), "{label}");
        assert!(label.starts_with("orifice_diameter_m="), "{label}");
        let job = rows.iter().find(|r| r.job_id == jobs[0]).expect("job");
        assert_eq!(key, &crate::campaign::point_key(&job.params_json));
    }
    let rep = points
        .iter()
        .find(|p| {
            p.3.as_ref()
                .is_some_and(|q| q.d_m == d_rep && q.f_hz == 1.0)
        })
        .expect("the replicated point");
    assert_eq!(rep.2.len(), 3);
    assert_eq!(
        rep.1,
        format!("orifice_diameter_m={d_rep},rotation_frequency_hz=1")
    );
    // A point whose every run clogged has its jobs and no Q.
    add_clogged_job(&conn, id, 0.010, 0.0);
    let points = crate::pooled::silo::pooled_q_points(&conn, id).expect("points");
    let clogged: Vec<_> = points.iter().filter(|p| p.3.is_none()).collect();
    assert_eq!(clogged.len(), 1);
    assert_eq!(clogged[0].2.len(), 1);
}
