//! Fig. 2 draws and writes a long M(t) thinned, but from its first to its last stored sample.

use super::*;

#[test]
fn a_long_mass_series_is_thinned_to_its_ends() {
    let conn = synthetic_db(&[0.0]);
    let id = test_rows::campaign_id(&conn, "rotating");
    // Drop the synthetic jobs' short series and give one job 5001 samples (50 s at 0.01 s).
    conn.execute("DELETE FROM discharge_series", [])
        .expect("clear");
    let job: i64 = conn
        .query_row(
            "SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1 ORDER BY job_id LIMIT 1",
            [id],
            |r| r.get(0),
        )
        .expect("a job");
    for i in 0..=5000 {
        let t = f64::from(i) * 0.01;
        test_rows::discharge_sample(&conn, job, t, 0.2 * t, i64::from(i));
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let fig2 = render_figure(&conn, "fig2", Some("rotating"), dir.path()).expect("fig2");
    assert!(
        fig2.table.contains("5001"),
        "stored samples\n{}",
        fig2.table
    );
    let csv = std::fs::read_to_string(dir.path().join("fig2.csv")).expect("csv");
    let t: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').nth(1).expect("t_s").parse().expect("t"))
        .collect();
    assert_eq!(t.len(), 1000, "rows of the one curve with samples");
    assert_eq!((t[0], t[999]), (0.0, 50.0));
    assert!(t.windows(2).all(|w| w[1] > w[0]), "t not increasing");
}
