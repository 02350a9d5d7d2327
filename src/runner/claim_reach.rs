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

#[cfg(test)]
mod tests {
    use super::{out_of_reach, steps_left};

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
