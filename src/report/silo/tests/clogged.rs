//! Clogged runs: marked in the figures and their tables, never given values.

use super::*;

#[test]
fn clogged_runs_are_marked_not_dropped_and_never_values() {
    let conn = synthetic_db(&[0.0, 0.5, 1.0]);
    let id = test_rows::campaign_id(&conn, "rotating");
    // A small orifice that clogs at f = 0 (as the paper's D/d < 4.8).
    add_clogged_job(&conn, id, 0.010, 0.0);
    let dir = tempfile::tempdir().expect("tempdir");
    for figure in ["fig3", "fig4", "fig5"] {
        render_figure(&conn, figure, None, dir.path()).expect(figure);
    }
    let fig3 = std::fs::read_to_string(dir.path().join("fig3.csv")).expect("csv");
    let row = fig3
        .lines()
        .find(|l| l.starts_with("0,0.01,"))
        .expect("a fig3 row for the clogged (D, f)");
    assert!(row.contains(",clogged,") && row.contains(",,"), "{row}");
    let svg = std::fs::read_to_string(dir.path().join("fig3.svg")).expect("svg");
    assert!(
        svg.contains("clogged (no Q)"),
        "fig3 has no 'clogged' legend"
    );
    let svg = std::fs::read_to_string(dir.path().join("fig4.svg")).expect("svg");
    assert!(
        svg.contains("clogged (no Q)"),
        "fig4 has no 'clogged' legend"
    );
    let fig4 = render_figure(&conn, "fig4", None, dir.path()).expect("fig4");
    assert!(
        fig4.table.contains("clogged: D = 10 mm") && fig4.table.contains("f = 0 Hz"),
        "{}",
        fig4.table
    );
    // fig4.csv lists the clogged point the figure marks: empty values, its runs.
    let csv = std::fs::read_to_string(dir.path().join("fig4.csv")).expect("csv");
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    assert_eq!(header.last(), Some(&"clogged_runs"), "{csv}");
    let row = csv
        .lines()
        .find(|l| l.starts_with("0.01,"))
        .expect("a fig4 row for the clogged (D, f)");
    let v: Vec<&str> = row.split(',').collect();
    assert!(v[3].is_empty() && v[6].is_empty() && v[10] == "1", "{row}");
}
