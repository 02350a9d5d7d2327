//! What the CLI says about claims: a look's verdicts (launch, resume, status, plan) and the
//! claims table of `sweep report --claims`.

use std::path::Path;

use anyhow::Context;

use sweep::project::{Project, VerdictRow};
use sweep::runner::claim_rounds::ClaimsRound;

fn value(r: &VerdictRow) -> String {
    let s = sweep::observe::claims::short;
    // A value not yet stored is NaN where the store would hold NULL: both read n/a.
    let finite = |x: Option<f64>| x.filter(|v| v.is_finite());
    match (finite(r.value), finite(r.lo), finite(r.hi)) {
        (Some(v), Some(lo), Some(hi)) => format!("{} [{}, {}]", s(v), s(lo), s(hi)),
        (Some(v), _, _) => s(v),
        _ => "n/a".into(),
    }
}

/// A look's verdicts, one line per claim: verdict, value and interval against its bound, and
/// what deciding an undecided one would still cost.
pub fn print_verdicts(rows: &[VerdictRow]) {
    let Some(first) = rows.first() else { return };
    let decided = rows.iter().filter(|r| r.verdict != "undecided").count();
    println!(
        "claims: {decided} of {} decided at look {} (intervals at {} at this look, 95 % over all looks)",
        rows.len(),
        first.round,
        sweep::report::claims::levels_text(rows)
    );
    print_claim_lines(rows);
}

/// What a look taken now would read, said as such: `sweep plan` computes it to forecast the
/// cost, but no look is stored and no α spent, so its verdicts are not the campaign's.
pub fn print_preview(rows: &[VerdictRow]) {
    if rows.is_empty() {
        return;
    }
    let decided = rows.iter().filter(|r| r.verdict != "undecided").count();
    println!(
        "claims as a look taken now would read them (a preview, not a look: nothing is stored and \
         no α spent; {decided} of {} would be decided, intervals at {})",
        rows.len(),
        sweep::report::claims::levels_text(rows)
    );
    print_claim_lines(rows);
}

fn print_claim_lines(rows: &[VerdictRow]) {
    for r in rows {
        let mut line = format!(
            "  {:<24} {:<12} {} = {} {}",
            r.claim_id,
            r.verdict,
            r.what,
            value(r),
            r.bound
        );
        if !r.note.is_empty() {
            line.push_str(&format!("  ({})", r.note));
        }
        if r.verdict == "undecided" {
            match (r.forecast_particle_steps, r.forecast_wall_s) {
                (Some(s), Some(w)) => line.push_str(&format!(
                    "  still needs ≈ {s:.2e} particle-steps, {:.1} min",
                    w / 60.0
                )),
                (Some(s), None) => {
                    line.push_str(&format!("  still needs ≈ {s:.2e} particle-steps"))
                }
                _ => line.push_str("  cost cannot be forecast"),
            }
        }
        println!("{line}");
    }
}

/// A recorded look's claims whose data read today give another reading.
pub fn print_reread(lines: &[String]) {
    for line in lines {
        println!("claims: {line}");
    }
}

/// A claims target's look: its verdicts, what was spent, and why it stops if it does.
pub fn print_round(r: &ClaimsRound) {
    print_verdicts(&r.verdicts);
    println!(
        "claims: spent {:.3e}{} particle-steps, {:.1} min of job wall time, {:.3}{} core-hours",
        r.spent.particle_steps,
        r.budget_words.0,
        r.spent.wall_s / 60.0,
        r.spent.core_hours,
        r.budget_words.1
    );
    for why in &r.limited {
        println!("claims: limited: {why}");
    }
    print_reread(&r.reread);
    if let Some(why) = &r.stop {
        println!("claims: stopped: {why}");
        let open: Vec<&VerdictRow> = r
            .verdicts
            .iter()
            .filter(|v| v.verdict == "undecided")
            .collect();
        for v in open {
            println!(
                "  undecided: {} would still cost {}",
                v.claim_id,
                v.forecast_particle_steps.map_or_else(
                    || "an unknown amount (no forecast)".into(),
                    |s| format!("≈ {s:.2e} particle-steps")
                )
            );
        }
    }
}

/// `sweep report --claims`: the campaign's claims table (its latest stored look, or a look
/// taken now when none was stored) as NAME.md and NAME.csv in `out` (NAME@vK for an older
/// version named so), named after the campaign so that several campaigns' tables share one
/// directory; printed too.
pub fn report(project: &Project, campaign: Option<&str>, out: &Path) -> anyhow::Result<i32> {
    let conn = project.conn();
    let c = sweep::report::find_campaign(conn, campaign, None)?;
    let (scale, rows, spent) = match sweep::report::claims::stored_claims(conn, c.id, &c.scene)? {
        Some(x) => x,
        None => {
            let ev = match sweep::runner::evaluation::evaluate(conn, c.id) {
                Ok(ev) if !ev.file.claims.is_empty() => ev,
                _ => {
                    eprintln!(
                        "sweep: campaign '{}' has no claims: add a `claims` list to its file",
                        c.name
                    );
                    return Ok(2);
                }
            };
            let look = sweep::runner::claim_rounds::look(conn, c.id, &ev, true)?;
            (
                sweep::report::claims::campaign_scale(conn, c.id, &c.scene)?,
                look.claims.into_iter().map(|x| x.2).collect(),
                // Taken now, at the work to date: the campaign's look once its jobs have
                // ended (claims looked at once, added by a version whose jobs had run), a
                // preview while some are open.
                sweep::report::claims::Spending {
                    at: if ev.open > 0 {
                        sweep::report::claims::SpentAt::Preview
                    } else {
                        sweep::report::claims::SpentAt::Look
                    },
                    ..sweep::report::claims::spending(conn, c.id)?
                },
            )
        }
    };
    std::fs::create_dir_all(out)?;
    let md = sweep::report::claims::claims_markdown(&c.name, &scale, &rows, spent);
    let csv = sweep::report::claims::claims_csv(&scale, &rows, spent.at);
    // An older version named as NAME@vK keeps that suffix, so it does not overwrite the
    // latest version's table.
    let latest = project.campaign_named(&c.name, None)?.map(|l| l.id);
    let stem = match campaign {
        Some(asked) if latest != Some(c.id) => asked.to_string(),
        _ => c.name.clone(),
    };
    let md_path = out.join(format!("{stem}.md"));
    let csv_path = out.join(format!("{stem}.csv"));
    std::fs::write(&md_path, &md).with_context(|| format!("writing {}", md_path.display()))?;
    std::fs::write(&csv_path, &csv).with_context(|| format!("writing {}", csv_path.display()))?;
    println!("{md}");
    println!("wrote {}", md_path.display());
    println!("wrote {}", csv_path.display());
    Ok(0)
}
