//! Which undecided claims a claims round can still afford. A claim whose forecast (the
//! particle-steps its interval needs to clear its bound) exceeds what the budget has left gets
//! no work: spending the rest of the budget on it would decide nothing, and the cheaper claims
//! would wait behind it. What a claim still needs is forecast here too.

use crate::observe::claims::{PointData, Verdict};

use super::claim_replicas::steady_share;
use super::evaluation::Evaluation;

/// The particle-steps the budget has left: those under `max_particle_steps`, and the
/// core-hours under `max_core_hours` at the campaign's own particle-steps per core-hour so far;
/// the fewer where both are set. None without a cap, or with only the core-hours one before
/// any work.
pub(super) fn steps_left(
    spent_steps: f64,
    spent_core_hours: f64,
    max_core_hours: Option<f64>,
    max_particle_steps: Option<f64>,
) -> Option<f64> {
    let by_hours = max_core_hours.and_then(|max| {
        (spent_core_hours > 0.0 && spent_steps > 0.0)
            .then(|| (max - spent_core_hours).max(0.0) * spent_steps / spent_core_hours)
    });
    let by_steps = max_particle_steps.map(|max| (max - spent_steps).max(0.0));
    match (by_hours, by_steps) {
        (Some(h), Some(s)) => Some(h.min(s)),
        (h, s) => h.or(s),
    }
}

/// Why claim `id` gets no work this round: its `forecast` needs more particle-steps than the
/// budget has `left`. None when it is within reach, or when no forecast or no budget says.
pub(super) fn out_of_reach(id: &str, forecast: Option<f64>, left: Option<f64>) -> Option<String> {
    let (need, left) = (forecast?, left?);
    (need.is_finite() && need > left).then(|| {
        format!(
            "{id}: out of reach, no work for it (it needs {need:.2e} particle-steps by the forecast, the budget has {left:.2e} left)"
        )
    })
}

/// The items of a round that the budget has `left` for: taken in the round's order of priority,
/// each run of consecutive items of one point as a whole (a chute point short of steady
/// replicas gets them all or none: a part would spend without giving it a result), a group that
/// would pass what is left skipped for the cheaper ones after it. With items left out, the line
/// that names them. An item whose cost is unknown (not finite) is kept and not counted.
/// Everything is kept without a cap.
pub(super) fn within_budget<T>(
    items: Vec<T>,
    cost: impl Fn(&T) -> f64,
    label: impl Fn(&T) -> String,
    left: Option<f64>,
) -> (Vec<T>, Option<String>) {
    let Some(left) = left else {
        return (items, None);
    };
    let n = items.len();
    let known = |c: f64| if c.is_finite() { c } else { 0.0 };
    let all: f64 = items.iter().map(|i| known(cost(i))).sum();
    let mut groups: Vec<(String, Vec<T>)> = Vec::new();
    for item in items {
        let l = label(&item);
        match groups.last_mut() {
            Some((last, g)) if *last == l => g.push(item),
            _ => groups.push((l, vec![item])),
        }
    }
    let mut spent = 0.0;
    let mut kept = Vec::new();
    let mut out = Vec::new();
    for (l, g) in groups {
        let c: f64 = g.iter().map(|i| known(cost(i))).sum();
        if spent + c <= left {
            spent += c;
            kept.extend(g);
        } else {
            out.push(format!("{l} ({} item(s), {c:.2e})", g.len()));
        }
    }
    if out.is_empty() {
        return (kept, None);
    }
    let why = format!(
        "the budget left ({left:.2e} particle-steps) covers {} of {n} work item(s) ({spent:.2e} of {all:.2e} particle-steps expected); left out: {}",
        kept.len(),
        out.join(", ")
    );
    (kept, Some(why))
}

/// Particle-steps still needed to decide an undecided claim, if it can be said: `work` times
/// what its points ran ([`work_to_decide`]: the errors fall as 1/√work while the degrees of
/// freedom grow); failing that, its interval's half-width falls as 1/√(work) on its points
/// and must shrink to the value's distance from the bound. A point without a result first
/// needs a replica. None on the bound (no amount of work decides a value that sits on it) or
/// without any estimate.
pub(super) fn forecast_steps(
    v: &Verdict,
    work: Option<f64>,
    points: &[PointData],
    ev: &Evaluation,
) -> Option<f64> {
    let used: f64 = v.points.iter().map(|&i| points[i].particle_steps).sum();
    if !(v.lo.is_finite() && v.hi.is_finite()) {
        let missing: Vec<usize> = v
            .points
            .iter()
            .copied()
            .filter(|&i| points[i].missing.is_some() || points[i].results.is_empty())
            .collect();
        if missing.is_empty() {
            return None;
        }
        // A chute point short of steady replicas gets them all in one round.
        return Some(
            missing
                .iter()
                .map(|&i| {
                    let short = points[i].replicas_short.max(1);
                    f64::from(short) / point_steady_share(ev, i) * ev.points[i].state.replica_cost
                })
                .sum(),
        );
    }
    let (gap, half) = (v.gap(), v.half_width());
    if !(gap > 0.0 && half > 0.0) {
        return None;
    }
    let factor = work.unwrap_or((half / gap).powi(2)).max(1.1);
    Some((factor - 1.0) * used)
}

/// The share of point `i`'s done replicas that were steady ([`steady_share`]); 1 for a silo
/// point, whose every run gives a result.
pub(super) fn point_steady_share(ev: &Evaluation, i: usize) -> f64 {
    let p = &ev.points[i];
    if ev.file.scene == crate::campaign::SceneKind::Chute {
        steady_share(p.row.replicas as f64, p.done)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::{out_of_reach, steps_left, within_budget};

    #[test]
    fn a_round_takes_what_the_budget_pays_for_keeping_each_points_work_whole() {
        let cost = |i: &(&str, f64)| i.1;
        let label = |i: &(&str, f64)| i.0.to_string();
        // a, then b's two replicas (a group), c, d: a + b = 7e10 fit 8e10; c would pass it and
        // is skipped; d, cheaper, still fits.
        let items = vec![
            ("a", 4e10),
            ("b", 1.5e10),
            ("b", 1.5e10),
            ("c", 2e10),
            ("d", 1e9),
        ];
        let (kept, why) = within_budget(items.clone(), cost, label, Some(8e10));
        assert_eq!(kept, vec![items[0], items[1], items[2], items[4]]);
        let why = why.expect("cut");
        assert!(
            why.contains("covers 4 of 5")
                && why.contains("7.10e10 of 9.10e10")
                && why.contains("left out: c (1 item(s), 2.00e10)"),
            "{why}"
        );
        // A group is never split: b's pair does not fit 5.5e10 after a, though one of it would.
        let (kept, why) = within_budget(items.clone(), cost, label, Some(5.5e10));
        assert_eq!(kept, vec![items[0], items[4]]);
        assert!(why.unwrap().contains("b (2 item(s), 3.00e10), c"));
        let (kept, why) = within_budget(items.clone(), cost, label, None);
        assert_eq!((kept.len(), why), (5, None));
        let (kept, why) = within_budget(items.clone(), cost, label, Some(1e12));
        assert_eq!((kept.len(), why), (5, None));
        // Nothing fits: nothing is added, and the line says so.
        let (kept, why) = within_budget(items, cost, label, Some(1e8));
        assert!(kept.is_empty() && why.unwrap().contains("covers 0 of 5"));
        // A cost not known is kept, uncounted.
        let (kept, _) = within_budget(vec![("x", f64::NAN), ("y", 5e9)], cost, label, Some(6e9));
        assert_eq!(kept.len(), 2);
    }

    #[test]
    fn the_budget_left_is_counted_at_the_campaigns_own_rate() {
        // 10 of 48 core-hours spent on 1e10 particle-steps: 38 more buy 3.8e10.
        let left = steps_left(1e10, 10.0, Some(48.0), None).unwrap();
        assert!((left - 3.8e10).abs() < 1.0, "{left}");
        assert_eq!(steps_left(1e10, 50.0, Some(48.0), None), Some(0.0));
        assert_eq!(steps_left(1e10, 10.0, None, None), None);
        assert_eq!(steps_left(0.0, 0.0, Some(48.0), None), None);
    }

    #[test]
    fn a_particle_step_budget_is_counted_as_it_stands_and_the_tighter_cap_binds() {
        // 1e10 of 5e10 particle-steps spent: 4e10 left, whatever the core-hours were.
        assert_eq!(steps_left(1e10, 10.0, None, Some(5e10)), Some(4e10));
        assert_eq!(steps_left(0.0, 0.0, None, Some(5e10)), Some(5e10));
        assert_eq!(steps_left(6e10, 10.0, None, Some(5e10)), Some(0.0));
        // Core-hours inflated by a shared machine leave 3.8e10; the particle-steps cap 4e10.
        assert_eq!(steps_left(1e10, 10.0, Some(48.0), Some(5e10)), Some(3.8e10));
        assert_eq!(steps_left(1e10, 10.0, Some(480.0), Some(5e10)), Some(4e10));
    }

    #[test]
    fn a_claim_beyond_the_budget_gets_no_work() {
        let why = out_of_reach("fig4_part", Some(3e11), Some(3.8e10)).expect("out of reach");
        assert!(
            why.contains("fig4_part") && why.contains("3.00e11"),
            "{why}"
        );
        assert_eq!(out_of_reach("c", Some(1e10), Some(3.8e10)), None);
        // No forecast (a point without results) or no budget: work as before.
        assert_eq!(out_of_reach("c", None, Some(3.8e10)), None);
        assert_eq!(out_of_reach("c", Some(f64::INFINITY), Some(3.8e10)), None);
        assert_eq!(out_of_reach("c", Some(3e11), None), None);
    }
}
