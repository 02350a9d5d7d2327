//! A job a round runs on (extended, not ended again) keeps its point in the figures, drawn from
//! its earlier end and named as such, while the claims' rows leave it out.

use super::*;

#[test]
fn a_job_a_round_runs_on_is_drawn_from_its_earlier_end_and_named() {
    let mut conn = synthetic_db(&[0.0, 0.5, 1.0]);
    let id = test_rows::campaign_id(&conn, "rotating");
    let label = "orifice_diameter_m=0.048,rotation_frequency_hz=1,replica=0";
    let job: i64 = conn
        .query_row(
            "SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1 AND label = ?2",
            rusqlite::params![id, label],
            |r| r.get(0),
        )
        .expect("job");
    let dir = tempfile::tempdir().expect("tempdir");
    let before = dir.path().join("before");
    let after = dir.path().join("after");
    for figure in ["fig2", "fig3", "fig4", "fig5"] {
        render_figure(&conn, figure, None, &before).expect(figure);
    }

    let tx = conn.transaction().expect("tx");
    assert!(crate::store::targets::extend(&tx, job, 200.0, 200.0).expect("extend"));
    tx.commit().expect("commit");
    let done = crate::store::silo_reads::done_discharge_rows(&conn, id).expect("rows");
    assert!(
        done.iter().all(|r| r.job_id != job),
        "the claims' rows hold ended jobs only"
    );

    // The job is the only run at D = 48 mm, f = 1 Hz: each figure (Fig. 2 among its M(t)
    // curves, Figs. 4–5 as the reference f) would lose the point without it.
    for figure in ["fig2", "fig3", "fig4", "fig5"] {
        let r = render_figure(&conn, figure, None, &after).expect(figure);
        let csv = |d: &Path| std::fs::read_to_string(d.join(format!("{figure}.csv"))).expect("csv");
        assert_eq!(
            csv(&after),
            csv(&before),
            "{figure} keeps the point's values"
        );
        let note =
            format!("earlier end of job(s) a round runs on: job {job} (48 mm, 1 Hz, to 200 s)");
        assert!(r.table.contains(&note), "{figure}: {}", r.table);
        assert!(
            r.missing.iter().any(|m| m == label),
            "{figure}: still not done"
        );
        let svg = std::fs::read_to_string(after.join(format!("{figure}.svg"))).expect("svg");
        // Words only: the note is wrapped at spaces.
        assert!(
            svg.contains("earlier") && svg.contains("job(s)"),
            "{figure}'s drawing names it"
        );
    }
    // A failed extension is not running on: its point leaves the figure, as for the claims.
    conn.execute("UPDATE jobs SET status = 'failed' WHERE id = ?1", [job])
        .expect("fail");
    let r = render_figure(&conn, "fig3", None, &after).expect("fig3");
    assert!(!r.table.contains("earlier end of job(s)"), "{}", r.table);
}
