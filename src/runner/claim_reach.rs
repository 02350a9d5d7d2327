//! Which undecided claims a claims round can still afford. A claim whose forecast (the
//! particle-steps its interval needs to clear its bound) exceeds what the budget has left gets
//! no work: spending the rest of the budget on it would decide nothing, and the cheaper claims
//! would wait behind it.

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

/// The first items of a round, in its order of priority, whose expected particle-steps fit
/// in what the budget has `left`; the round stops at the first item that would pass it (a later,
/// cheaper item would buy a lower priority). With the items cut, the line that says so. An item
/// whose cost is unknown (not finite) is kept and not counted. Everything is kept without a cap.
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
    let all: f64 = items.iter().map(&cost).filter(|c| c.is_finite()).sum();
    let mut spent = 0.0;
    let mut kept = Vec::new();
    let mut out = Vec::new();
    for item in items {
        let c = cost(&item);
        if out.is_empty() && (!c.is_finite() || spent + c <= left) {
            spent += if c.is_finite() { c } else { 0.0 };
            kept.push(item);
        } else {
            out.push(item);
        }
    }
    if out.is_empty() {
        return (kept, None);
    }
    let mut points: Vec<String> = Vec::new();
    for l in out.iter().map(&label) {
        if !points.contains(&l) {
            points.push(l);
        }
    }
    let why = format!(
        "the budget left ({left:.2e} particle-steps) covers the first {} of {n} work item(s) ({spent:.2e} of {all:.2e} particle-steps expected); left out: {}",
        kept.len(),
        points.join(", ")
    );
    (kept, Some(why))
}

#[cfg(test)]
mod tests {
    use super::{out_of_reach, steps_left, within_budget};

    #[test]
    fn a_round_stops_at_the_first_item_the_budget_cannot_pay() {
        let items = vec![("a", 4e10), ("b", 3e10), ("c", 2e10), ("d", 1e9)];
        let (kept, why) = within_budget(items.clone(), |i| i.1, |i| i.0.to_string(), Some(8e10));
        // a + b = 7e10 fit; c would pass 8e10, and d, cheaper, comes after it.
        assert_eq!(kept, items[..2].to_vec());
        let why = why.expect("cut");
        assert!(
            why.contains("covers the first 2 of 4")
                && why.contains("7.00e10 of 9.10e10")
                && why.contains("left out: c, d"),
            "{why}"
        );
        let (kept, why) = within_budget(items.clone(), |i| i.1, |i| i.0.to_string(), None);
        assert_eq!((kept.len(), why), (4, None));
        let (kept, why) = within_budget(items.clone(), |i| i.1, |i| i.0.to_string(), Some(1e12));
        assert_eq!((kept.len(), why), (4, None));
        // Nothing fits: nothing is added, and the line says so.
        let (kept, why) = within_budget(items, |i| i.1, |i| i.0.to_string(), Some(1e9));
        assert!(kept.is_empty() && why.unwrap().contains("first 0 of 4"));
        // A cost not known is kept, uncounted.
        let (kept, _) = within_budget(
            vec![("x", f64::NAN), ("y", 5e9)],
            |i| i.1,
            |i| i.0.to_string(),
            Some(6e9),
        );
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
