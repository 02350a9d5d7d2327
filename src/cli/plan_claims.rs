//! `sweep plan` for a campaign whose target decides claims: what a look taken now would read
//! (a preview) and the work its undecided claims still need.

use sweep::project::Project;

/// A claims target's plan: the claims' verdicts on what has run (not stored), each undecided
/// one with the particle-steps and wall time still forecast to decide it.
pub(super) fn claims_forecast(
    project: Option<&Project>,
    name: &str,
    t: &sweep::campaign::Target,
) -> anyhow::Result<()> {
    if !t.decides_claims() {
        println!(
            "claims: looked at once, at 95 %, when the campaign's jobs have ended (no target adds work for them)"
        );
    } else {
        println!(
        "target: decide every claim (max_rounds {}, max_replicas {}, max_time_s {}, max_core_hours {}, max_particle_steps {}, allocation {})",
        t.max_rounds,
        t.max_replicas,
        t.max_time_s.map_or_else(|| "none".into(), |m| format!("{m} s")),
        t.max_core_hours.map_or_else(|| "none".into(), |h| format!("{h}")),
        t.max_particle_steps.map_or_else(|| "none".into(), |s| format!("{s:.3e}")),
        t.allocation.name()
    );
    }
    let (Some(project), Some((campaign_id, ev))) = (project, stored_evaluation(
        project,
        name,
        t,
        "the claims are first looked at after the jobs above: launch it, then `sweep plan` again for their verdicts and what each still needs",
        "the verdicts use",
    )?)
    else {
        return Ok(());
    };
    let conn = project.conn();
    let look = sweep::runner::claim_rounds::look(conn, campaign_id, &ev, false)?;
    let rows: Vec<_> = look.claims.into_iter().map(|c| c.2).collect();
    super::claims::print_preview(&rows);
    let undecided: Vec<_> = rows
        .iter()
        .filter(|r| r.verdict == "undecided")
        .map(|r| {
            (
                r.points.as_str(),
                r.forecast_particle_steps,
                r.forecast_wall_s,
            )
        })
        .collect();
    if !undecided.is_empty() {
        println!(
            "  still to run for the undecided claims: {}",
            still_to_run(&undecided)
        );
    }
    Ok(())
}

/// One undecided claim's forecast: the points it reads ("; "-separated labels), the
/// particle-steps and the wall seconds it still needs.
type Forecast<'a> = (&'a str, Option<f64>, Option<f64>);

/// The work the undecided claims still need. Claims that read a common point share its
/// replicas, so within each group of claims linked by shared points the costliest alone is the
/// least the store will run for them and their sum the most; groups add up.
fn still_to_run(forecasts: &[Forecast]) -> String {
    let steps: Option<Vec<f64>> = forecasts.iter().map(|f| f.1).collect();
    let Some(steps) = steps else {
        return "unknown for some (no forecast)".into();
    };
    let walls: Option<Vec<f64>> = forecasts.iter().map(|f| f.2).collect();
    let groups = point_groups(forecasts);
    let range = |v: &[f64], f: &dyn Fn(f64) -> String| {
        let least: f64 = groups
            .iter()
            .map(|g| g.iter().map(|&i| v[i]).fold(0.0, f64::max))
            .sum();
        let most: f64 = v.iter().sum();
        if most > least * (1.0 + 1e-9) {
            (format!("{} to {}", f(least), f(most)), true)
        } else {
            (f(most), false)
        }
    };
    let (steps_text, ranged) = range(&steps, &|x| format!("{x:.3e}"));
    let mut text = format!("{steps_text} particle-steps");
    if let Some(w) = walls.filter(|w| w.iter().sum::<f64>() > 0.0) {
        let (wall_text, _) = range(&w, &|x| format!("{:.1}", x / 60.0));
        text.push_str(&format!(", about {wall_text} min of job wall time"));
    }
    if ranged {
        text.push_str(" (claims at common points share replicas: the least counts each group's costliest claim alone, the most every claim)");
    }
    text
}

/// The claims grouped by shared points (indices into `forecasts`), each claim in one group.
fn point_groups(forecasts: &[Forecast]) -> Vec<Vec<usize>> {
    let points = |i: usize| -> std::collections::HashSet<&str> {
        forecasts[i]
            .0
            .split("; ")
            .filter(|p| !p.is_empty())
            .collect()
    };
    let mut groups: Vec<(Vec<usize>, std::collections::HashSet<&str>)> = Vec::new();
    for i in 0..forecasts.len() {
        let mut members = vec![i];
        let mut set = points(i);
        // Merge every group this claim touches into one.
        let mut k = 0;
        while k < groups.len() {
            if groups[k].1.iter().any(|p| set.contains(p)) {
                let (m, s) = groups.swap_remove(k);
                members.extend(m);
                set.extend(s);
            } else {
                k += 1;
            }
        }
        groups.push((members, set));
    }
    groups.into_iter().map(|g| g.0).collect()
}

/// The stored campaign `name` (its id) evaluated under `t` (its ended jobs), saying
/// how many are still open (`uses`: what reads the ended ones); None, saying
/// `not_yet`, before it is launched.
pub(super) fn stored_evaluation(
    project: Option<&Project>,
    name: &str,
    t: &sweep::campaign::Target,
    not_yet: &str,
    uses: &str,
) -> anyhow::Result<Option<(i64, sweep::runner::evaluation::Evaluation)>> {
    let campaign = match project {
        Some(p) => p.campaign_named(name, None)?,
        None => None,
    };
    let (Some(conn), Some(campaign)) = (project.map(Project::conn), campaign) else {
        println!("  {not_yet}");
        return Ok(None);
    };
    let ev = sweep::runner::evaluation::evaluate_for(conn, campaign.id, Some(t))?;
    if ev.open > 0 {
        println!(
            "  ({} job(s) of the campaign not ended: {uses} the ended ones)",
            ev.open
        );
    }
    Ok(Some((campaign.id, ev)))
}

#[cfg(test)]
mod tests {
    use super::still_to_run;

    #[test]
    fn claims_sharing_work_are_given_as_a_range() {
        let one = still_to_run(&[("a", Some(2e9), Some(600.0))]);
        assert_eq!(
            one,
            "2.000e9 particle-steps, about 10.0 min of job wall time"
        );
        // Two claims at the same point: the costliest alone to both.
        let shared = still_to_run(&[
            ("a; b", Some(2e9), Some(600.0)),
            ("b", Some(1e9), Some(300.0)),
        ]);
        assert!(
            shared.starts_with("2.000e9 to 3.000e9 particle-steps, about 10.0 to 15.0 min"),
            "{shared}"
        );
        // At different points their work adds up: no range.
        let apart = still_to_run(&[("a", Some(2e9), Some(600.0)), ("c", Some(1e9), Some(300.0))]);
        assert_eq!(
            apart,
            "3.000e9 particle-steps, about 15.0 min of job wall time"
        );
        // A claim linking two others puts all three in one group.
        let linked = [
            ("a", Some(1e9), None),
            ("c", Some(1e9), None),
            ("a; c", Some(3e9), None),
        ];
        assert!(
            still_to_run(&linked).starts_with("3.000e9 to 5.000e9"),
            "{}",
            still_to_run(&linked)
        );
        assert_eq!(
            still_to_run(&[("a", Some(2e9), None), ("b", None, None)]),
            "unknown for some (no forecast)"
        );
    }
}
