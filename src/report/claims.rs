//! The claims table (`sweep report --claims`, and a section of `--figure all`'s index): each
//! claim with the paper's words and number, sweep's value and interval, the verdict, the scale
//! the jobs ran at and what deciding it cost, as markdown, CSV and HTML. Read-only: the
//! verdicts are the ones stored at the campaign's latest look.

use std::fmt::Write as _;

use serde_json::Value;

use super::table::{csv_num, escape};
use crate::observe::claims::short;
use crate::store::claims::VerdictRow;

/// What the campaign spent, and when.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spending {
    pub particle_steps: f64,
    pub wall_s: f64,
    pub core_hours: f64,
    pub at: SpentAt,
}

/// What a claims table shows and when its cost was counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpentAt {
    /// A stored look, with the cost it recorded.
    Look,
    /// A stored look taken by a sweep that did not record its cost: the work to date, which
    /// later rounds may have added to.
    ToDate,
    /// No look is stored yet: the table is what a look taken now would read, decides nothing,
    /// and the cost is the work to date.
    Preview,
}

/// The scale a campaign's jobs ran at, in one line: N, container, stiffness, time step,
/// precision and duration, from a job's stored parameters (the paper's in brackets where the
/// scene's default is the paper's).
pub fn scale_of(scene: &str, params_json: &str, precision: &str) -> String {
    let v: Value = serde_json::from_str(params_json).unwrap_or(Value::Null);
    let p = &v[scene];
    let num = |k: &str| p.get(k).and_then(Value::as_f64);
    let mut parts = Vec::new();
    match scene {
        "silo" => {
            if let Some(n) = num("particle_count") {
                parts.push(format!("N = {n} (paper 30 144)"));
            }
            if let (Some(r), Some(h)) = (num("cylinder_radius_m"), num("cylinder_height_m")) {
                parts.push(format!(
                    "R_c = {} cm, h = {} cm (paper 9.5, 40)",
                    short(100.0 * r),
                    short(100.0 * h)
                ));
            }
            if let Some(y) = num("youngs_modulus_pa") {
                parts.push(format!("Y = {} Pa (paper 3e9)", short(y)));
            }
            match (num("contact_steps"), num("dt_s")) {
                (Some(nc), _) => parts.push(format!("n_c = {} (paper ≈ 50)", short(nc))),
                (None, Some(dt)) => parts.push(format!("dt = {} s (paper 1e-6)", short(dt))),
                _ => {}
            }
            if let Some(t) = num("discharge_time_s") {
                parts.push(format!("{} s per job as launched", short(t)));
            }
            match p.get("reinsert").and_then(Value::as_bool) {
                Some(true) => parts.push("refilled (exits re-inserted)".into()),
                Some(false) => parts.push("draining".into()),
                None => {}
            }
        }
        _ => {
            if let Some(n) = num("particle_count") {
                parts.push(format!("N = {n}"));
            }
            if let (Some(x), Some(y), Some(h)) = (
                num("box_x_lengths"),
                num("box_y_lengths"),
                num("bed_height_lengths"),
            ) {
                parts.push(format!(
                    "box {}L × {}L, bed {}L (paper 16 × 16, ≈ 20)",
                    short(x),
                    short(y),
                    short(h)
                ));
            }
            if let Some(k) = num("stiffness_factor") {
                parts.push(format!("k_n = {} m g / l (paper 2e5)", short(k)));
            }
            if let Some(nc) = num("contact_steps") {
                parts.push(format!("n_c = {} (paper 50)", short(nc)));
            }
            if let Some(t) = num("measure_time_s") {
                parts.push(format!("{} s measured per job", short(t)));
            }
        }
    }
    parts.push(precision.to_string());
    parts.join(", ")
}

fn value_text(r: &VerdictRow) -> String {
    // A value not yet stored is NaN where the store would hold NULL: both read n/a.
    let finite = |x: Option<f64>| x.filter(|v| v.is_finite());
    match (finite(r.value), finite(r.lo), finite(r.hi)) {
        (Some(v), Some(lo), Some(hi)) => format!("{} [{}, {}]", short(v), short(lo), short(hi)),
        (Some(v), _, _) => format!("{} (no interval)", short(v)),
        _ => "n/a".into(),
    }
}

fn hours(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

fn forecast_text(r: &VerdictRow) -> String {
    if r.verdict != "undecided" {
        return String::new();
    }
    match (r.forecast_particle_steps, r.forecast_wall_s) {
        (Some(s), Some(w)) => format!("{s:.2e} particle-steps, ≈ {}", hours(w)),
        (Some(s), None) => format!("{s:.2e} particle-steps"),
        _ => "cannot be forecast (value on the bound, or no estimate)".into(),
    }
}

/// The claims table as markdown: a header with the campaign, its scale, the look and level,
/// then one row per claim.
pub fn claims_markdown(
    campaign: &str,
    scale: &str,
    rows: &[VerdictRow],
    spent: Spending,
) -> String {
    let mut m = String::new();
    let look = rows.first().map_or(0, |r| r.round);
    let level = levels_text(rows);
    let _ = writeln!(m, "## Claims of `{campaign}`\n");
    let _ = writeln!(m, "Scale: {scale}.\n");
    let levels = format!(
        "intervals at {level} at this look, so that the verdicts of all looks together (an earlier version's included) hold at 95 %"
    );
    let (what, spent_words) = match spent.at {
        SpentAt::Look => (format!("Look {look}: {levels}."), "Spent by this look"),
        SpentAt::ToDate => (
            format!("Look {look}: {levels}."),
            "Spent to date (the look's own cost was not recorded)",
        ),
        SpentAt::Preview => (
            format!("**A preview, not a look**: no look is stored yet (the first comes once the campaign's jobs have ended), so nothing below is decided or stored. It is what a look taken now would read, with {levels}."),
            "Spent to date",
        ),
    };
    let _ = writeln!(
        m,
        "{what} {spent_words}: {:.3e} particle-steps, {} wall, {:.3} core-hours.\n",
        spent.particle_steps,
        hours(spent.wall_s),
        spent.core_hours
    );
    m.push_str("| claim | paper | paper's value | test | sweep's value [interval] | bound | verdict | points | particle-steps | wall | still needed |\n");
    m.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let cell = |s: &str| s.replace('|', "\\|").replace('\n', " ");
        let note = if r.note.is_empty() {
            String::new()
        } else {
            format!(" ({})", r.note)
        };
        let _ = writeln!(
            m,
            "| **{}**: {} | {} | {} | {}: {} | {} | {} | **{}**{} | {} | {:.2e} | {} | {} |",
            cell(&r.claim_id),
            cell(&r.statement),
            cell(&r.paper),
            cell(&r.paper_value),
            r.test,
            cell(&r.what),
            value_text(r),
            r.bound,
            r.verdict,
            cell(&note),
            cell(&r.points),
            r.particle_steps,
            hours(r.wall_s),
            forecast_text(r)
        );
    }
    m
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The claims table as CSV, every number in full; a preview's `look` column reads "preview".
pub fn claims_csv(scale: &str, rows: &[VerdictRow], at: SpentAt) -> String {
    let mut c = String::from(
        "claim_id,statement,paper,paper_value,test,what,value,lo,hi,level,bound,verdict,note,points,scale,particle_steps,wall_s,forecast_particle_steps,forecast_wall_s,look\n",
    );
    for r in rows {
        let fields = [
            csv_field(&r.claim_id),
            csv_field(&r.statement),
            csv_field(&r.paper),
            csv_field(&r.paper_value),
            r.test.clone(),
            csv_field(&r.what),
            csv_num(r.value),
            csv_num(r.lo),
            csv_num(r.hi),
            format!("{}", r.level),
            csv_field(&r.bound),
            r.verdict.clone(),
            csv_field(&r.note),
            csv_field(&r.points),
            csv_field(scale),
            format!("{:e}", r.particle_steps),
            format!("{}", r.wall_s),
            csv_num(r.forecast_particle_steps),
            csv_num(r.forecast_wall_s),
            if at == SpentAt::Preview {
                "preview".to_string()
            } else {
                r.round.to_string()
            },
        ];
        c.push_str(&fields.join(","));
        c.push('\n');
    }
    c
}

/// The claims table as an HTML section (for the index of `--figure all`).
pub fn claims_html(scale: &str, rows: &[VerdictRow]) -> String {
    let mut h = String::new();
    let level = levels_text(rows);
    let _ = writeln!(
        h,
        "<h2 id=\"claims\">Claims</h2>\n<p>Scale: {}. Intervals at {} per look (95 % over all looks).</p>\n<table border=\"1\" cellpadding=\"4\" style=\"border-collapse:collapse\">\n<tr><th>claim</th><th>paper</th><th>paper's value</th><th>sweep's value [interval]</th><th>bound</th><th>verdict</th><th>particle-steps</th><th>wall</th><th>still needed</th></tr>",
        escape(scale),
        level
    );
    for r in rows {
        let _ = writeln!(
            h,
            "<tr><td><b>{}</b>: {}</td><td>{}</td><td>{}</td><td>{}: {}</td><td>{}</td><td><b>{}</b> {}</td><td>{:.2e}</td><td>{}</td><td>{}</td></tr>",
            escape(&r.claim_id),
            escape(&r.statement),
            escape(&r.paper),
            escape(&r.paper_value),
            escape(&r.what),
            escape(&value_text(r)),
            escape(&r.bound),
            escape(&r.verdict),
            escape(&r.note),
            r.particle_steps,
            escape(&hours(r.wall_s)),
            escape(&forecast_text(r))
        );
    }
    h.push_str("</table>\n");
    h
}

/// A campaign's stored claims: its scale, the verdicts of its latest look and what it spent;
/// None when no look was stored.
///
/// # Errors
/// Database errors.
pub fn stored_claims(
    conn: &rusqlite::Connection,
    campaign_id: i64,
    scene: &str,
) -> anyhow::Result<Option<(String, Vec<VerdictRow>, Spending)>> {
    let rows = crate::store::claims::latest_verdicts(conn, campaign_id)?;
    if rows.is_empty() {
        return Ok(None);
    }
    let spent = match crate::store::claims::look_spent(conn, campaign_id, rows[0].round)? {
        Some((particle_steps, wall_s, core_hours)) => Spending {
            particle_steps,
            wall_s,
            core_hours,
            at: SpentAt::Look,
        },
        None => spending(conn, campaign_id)?,
    };
    Ok(Some((
        campaign_scale(conn, campaign_id, scene)?,
        rows,
        spent,
    )))
}

/// The scale line of a campaign: its jobs' scale, or where points ran at different scales
/// (the chute's spheres in a larger box than its rods), each scale with how many jobs ran at it,
/// so that a table never states one point's scale for all.
///
/// # Errors
/// Database errors.
pub fn campaign_scale(
    conn: &rusqlite::Connection,
    campaign_id: i64,
    scene: &str,
) -> anyhow::Result<String> {
    let jobs = crate::store::targets::campaign_jobs(conn, campaign_id)?;
    let scales = jobs.iter().map(|j| {
        let v: Value = serde_json::from_str(&j.params_json).unwrap_or(Value::Null);
        let precision = v["precision"].as_str().unwrap_or("f64").to_string();
        scale_of(scene, &j.params_json, &precision)
    });
    Ok(distinct_scales(scales))
}

/// One line for a list of jobs' scales: the scale itself when all agree, else each distinct
/// scale (in the order first met) with its share of the jobs.
pub fn distinct_scales(scales: impl IntoIterator<Item = String>) -> String {
    let mut groups: Vec<(String, usize)> = Vec::new();
    let mut total = 0;
    for s in scales {
        total += 1;
        match groups.iter_mut().find(|(g, _)| *g == s) {
            Some((_, k)) => *k += 1,
            None => groups.push((s, 1)),
        }
    }
    if groups.len() <= 1 {
        return groups.pop().map_or_else(String::new, |(s, _)| s);
    }
    groups
        .iter()
        .map(|(s, k)| format!("{s} ({k} of {total} jobs)"))
        .collect::<Vec<_>>()
        .join("; ")
}

/// What a campaign's jobs have spent to date.
///
/// # Errors
/// Database errors.
pub fn spending(conn: &rusqlite::Connection, campaign_id: i64) -> anyhow::Result<Spending> {
    let (particle_steps, wall_s, core_hours) = crate::store::claims::spent(conn, campaign_id)?;
    Ok(Spending {
        particle_steps,
        wall_s,
        core_hours,
        at: SpentAt::ToDate,
    })
}

/// The rows' interval level as text: one level, or the range of each claim's own (a look that
/// could not test a claim spent none of its α, so claims' levels may differ).
pub fn levels_text(rows: &[VerdictRow]) -> String {
    let lo = rows.iter().map(|r| r.level).fold(f64::INFINITY, f64::min);
    let hi = rows
        .iter()
        .map(|r| r.level)
        .fold(f64::NEG_INFINITY, f64::max);
    if rows.is_empty() {
        "95.00 %".into()
    } else if hi - lo < 5e-5 {
        format!("{:.2} %", 100.0 * lo)
    } else {
        format!("{:.2}–{:.2} % by claim", 100.0 * lo, 100.0 * hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_scale_reads_plain_and_mixed_scales_are_each_counted() {
        let chute = |box_l: f64, bed: f64| {
            scale_of(
                "chute",
                &format!(
                    r#"{{"chute":{{"box_x_lengths":{box_l},"box_y_lengths":{box_l},"bed_height_lengths":{bed}}}}}"#
                ),
                "f32",
            )
        };
        let rods = chute(6.0, 16.0);
        assert_eq!(distinct_scales(vec![rods.clone(), rods.clone()]), rods);
        let mixed = distinct_scales(vec![chute(8.0, 20.0), rods.clone(), rods.clone()]);
        assert_eq!(
            mixed,
            format!("{} (1 of 3 jobs); {rods} (2 of 3 jobs)", chute(8.0, 20.0))
        );
        assert!(mixed.contains("box 8L × 8L, bed 20L") && mixed.contains("box 6L × 6L, bed 16L"));
        assert_eq!(distinct_scales(Vec::<String>::new()), "");
    }

    #[test]
    fn the_table_states_the_looks_own_cost_not_later_rounds_work() {
        use crate::store::{claims, test_rows};
        let conn = test_rows::empty_db();
        let row = VerdictRow {
            round: 0,
            claim_id: "a".into(),
            statement: String::new(),
            paper: String::new(),
            paper_value: String::new(),
            test: "compare".into(),
            what: "q ratio".into(),
            verdict: "undecided".into(),
            value: Some(0.0),
            lo: Some(-0.1),
            hi: Some(0.1),
            level: 0.99,
            bound: "> 0".into(),
            points: String::new(),
            note: String::new(),
            particle_steps: 1e9,
            wall_s: 100.0,
            forecast_particle_steps: None,
            forecast_wall_s: None,
        };
        let work = |job: i64, steps: f64| {
            conn.execute(
                "UPDATE jobs SET particle_steps = ?2, wall_time_s = 3600 WHERE id = ?1",
                rusqlite::params![job, steps],
            )
            .expect("work");
        };
        let c = test_rows::campaign(&conn, "c", "silo", "2026-01-01T00:00:00Z");
        let job = test_rows::silo_job(&conn, c, "j", "done", "{}");
        work(job, 1e9);
        claims::save_look_spent(&conn, c, 0, (1e9, 3600.0, 1.0)).expect("spent");
        claims::save_verdicts(&conn, c, std::slice::from_ref(&row)).expect("verdicts");
        // The look evaluated again after an interruption keeps its first cost.
        claims::save_look_spent(&conn, c, 0, (2e9, 7200.0, 2.0)).expect("again");
        // A round runs the job on after the look.
        work(job, 3e9);
        let (_, _, spent) = stored_claims(&conn, c, "silo")
            .expect("read")
            .expect("a look");
        assert_eq!(
            spent,
            Spending {
                particle_steps: 1e9,
                wall_s: 3600.0,
                core_hours: 1.0,
                at: SpentAt::Look
            }
        );
        let md = claims_markdown("c", "", std::slice::from_ref(&row), spent);
        assert!(
            md.contains("Spent by this look: 1.000e9 particle-steps"),
            "{md}"
        );

        // A look stored by a sweep that did not record its cost reads the work to date, so named.
        let d = test_rows::campaign(&conn, "d", "silo", "2026-01-01T00:00:00Z");
        let job = test_rows::silo_job(&conn, d, "k", "done", "{}");
        work(job, 3e9);
        claims::save_verdicts(&conn, d, std::slice::from_ref(&row)).expect("verdicts");
        // Evaluated again by this sweep, it records no cost: its jobs may have run on since.
        claims::save_look_spent(&conn, d, 0, (3e9, 3600.0, 1.0)).expect("again");
        let (_, _, spent) = stored_claims(&conn, d, "silo")
            .expect("read")
            .expect("a look");
        assert!(
            spent.at == SpentAt::ToDate && spent.particle_steps == 3e9,
            "{spent:?}"
        );
        let md = claims_markdown("d", "", std::slice::from_ref(&row), spent);
        assert!(
            md.contains("Spent to date (the look's own cost was not recorded): 3.000e9"),
            "{md}"
        );

        // A table taken while jobs are open says it decides nothing, in both files.
        let preview = Spending {
            at: SpentAt::Preview,
            ..spent
        };
        let md = claims_markdown("d", "", std::slice::from_ref(&row), preview);
        assert!(
            md.contains("**A preview, not a look**") && !md.contains("Look 0:"),
            "{md}"
        );
        let csv = claims_csv("", &[row], SpentAt::Preview);
        let last = |l: &str| l.rsplit(',').next().unwrap_or_default().to_string();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            (last(lines[0]), last(lines[1])),
            ("look".into(), "preview".into())
        );
    }
}
