//! Which parameter to name when a derived quantity (a contact time, a time step, a step count)
//! comes out unusable: the fields whose paper value alone would make it usable. A campaign's
//! error then points at `base.youngs_modulus_pa` when Y = 1e308 makes t_c = 0, rather than at
//! every input of the formula.

use serde::Serialize;

use super::silo::FieldError;

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

/// A run length that must be a whole step count: its words for messages, its own fields, and
/// how to read it.
pub(crate) type RunLength<'a, P> = (&'static str, &'a [Reset<P>], fn(&P) -> f64);

/// How a scene's time step is made, for naming the fields behind an unusable one.
pub(crate) struct TimeStepInputs<'a, P> {
    /// The fields the contact time depends on.
    pub contact_fields: &'a [Reset<P>],
    /// The fields that turn t_c into dt (dt_s, contact_steps).
    pub step_fields: &'a [Reset<P>],
    /// The field named when `time_step` itself refuses.
    pub step_field: &'static str,
    /// Each run length that must be a whole step count.
    pub durations: &'a [RunLength<'a, P>],
    pub contact_time: fn(&P) -> f64,
    pub time_step: fn(&P) -> Result<f64, String>,
    /// "gives a Hertz contact time t_c = …", with whatever else the scene wants said.
    pub contact_words: String,
    /// What t_c depends on, for messages.
    pub contact_inputs: &'static str,
    /// How dt is formed, for messages ("dt" or "dt = t_c / contact_steps").
    pub dt_words: &'static str,
}

/// The time step a job will use: t_c finite and > 0, dt finite and > 0, and each run length a
/// step count that fits in a u64. Each problem names the field(s) whose default would cure it.
pub(crate) fn time_step_problems<P: Clone + PartialEq + Serialize>(
    p: &P,
    ts: &TimeStepInputs<P>,
) -> Vec<FieldError> {
    let problem = |field: &str, what: String| FieldError {
        field: field.into(),
        message: format!("{field} = {}: {what}", value_of(p, field)),
    };
    let blame = |fields: &[Reset<P>], ok: &dyn Fn(&P) -> bool, what: &str| -> Vec<FieldError> {
        culprits(p, fields, ok)
            .into_iter()
            .map(|f| problem(f, what.to_string()))
            .collect()
    };
    let tc = (ts.contact_time)(p);
    let tc_ok = |q: &P| {
        let tc = (ts.contact_time)(q);
        tc.is_finite() && tc > 0.0
    };
    if !tc_ok(p) {
        return blame(
            ts.contact_fields,
            &tc_ok,
            &format!(
                "{} = {tc:e} s, so no time step resolves a contact; expected t_c finite and > 0 \
                 (t_c depends on {})",
                ts.contact_words, ts.contact_inputs
            ),
        );
    }
    let dt = match (ts.time_step)(p) {
        Ok(dt) => dt,
        Err(m) => {
            return vec![FieldError {
                field: ts.step_field.into(),
                message: m,
            }]
        }
    };
    let mut dt_fields = ts.contact_fields.to_vec();
    dt_fields.extend_from_slice(ts.step_fields);
    let dt_ok = |q: &P| (ts.time_step)(q).is_ok_and(|dt| dt.is_finite() && dt > 0.0);
    if !dt_ok(p) {
        return blame(
            &dt_fields,
            &dt_ok,
            &format!(
                "gives a time step {} = {dt:e} s (t_c = {tc:e} s); expected dt finite and > 0",
                ts.dt_words
            ),
        );
    }
    let mut e: Vec<FieldError> = Vec::new();
    for (words, own, length) in ts.durations {
        let seconds = length(p);
        if step_count_fits(seconds, dt) {
            continue;
        }
        let mut fields = own.to_vec();
        fields.extend(dt_fields.iter().copied());
        let fits = |q: &P| (ts.time_step)(q).is_ok_and(|dt| step_count_fits(length(q), dt));
        let what = format!(
            "{words} / dt = {seconds} s / {dt:e} s = {:e} steps: expected a finite step count \
             that fits in 64 bits (< {:e})",
            seconds / dt,
            u64::MAX as f64
        );
        for f in blame(&fields, &fits, &what) {
            if !e.iter().any(|x| x.field == f.field) {
                e.push(f);
            }
        }
    }
    e
}
