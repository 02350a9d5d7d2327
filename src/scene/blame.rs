//! Which parameter to name when a derived quantity (a contact time, a time step, a step count)
//! comes out unusable: the fields whose paper value alone would make it usable. A campaign's
//! error then points at `base.youngs_modulus_pa` when Y = 1e308 makes t_c = 0, rather than at
//! every input of the formula.

use serde::Serialize;

/// A field's name and how to put it back to its default.
pub(crate) type Reset<P> = (&'static str, fn(&mut P));

/// The fields of `resets` whose reset alone makes `ok` hold; failing that, those set away from
/// their default; failing that, the first one. Never empty (unless `resets` is).
pub(crate) fn culprits<P: Clone + PartialEq>(
    p: &P,
    resets: &[Reset<P>],
    ok: impl Fn(&P) -> bool,
) -> Vec<&'static str> {
    let reset = |f: fn(&mut P)| {
        let mut q = p.clone();
        f(&mut q);
        q
    };
    let fixing: Vec<&'static str> = resets
        .iter()
        .filter(|(_, f)| ok(&reset(*f)))
        .map(|(name, _)| *name)
        .collect();
    if !fixing.is_empty() {
        return fixing;
    }
    let set: Vec<&'static str> = resets
        .iter()
        .filter(|(_, f)| reset(*f) != *p)
        .map(|(name, _)| *name)
        .collect();
    if !set.is_empty() {
        return set;
    }
    resets.iter().take(1).map(|(name, _)| *name).collect()
}

/// A field's value as JSON text (`1e308`, `null`, `"total_length"`), for messages.
pub(crate) fn value_of<P: Serialize>(p: &P, field: &str) -> String {
    serde_json::to_value(p)
        .ok()
        .and_then(|v| v.get(field).cloned())
        .map_or_else(|| "?".into(), |v| v.to_string())
}

/// Whether `seconds / dt` steps is a finite, non-negative count that fits in a u64.
pub(crate) fn step_count_fits(seconds: f64, dt: f64) -> bool {
    let steps = (seconds / dt).ceil();
    steps.is_finite() && steps >= 0.0 && steps < u64::MAX as f64
}
