//! Checks shared by every scene: where it sits and the gravity that drives it. A value no
//! experiment has (a scene 10³⁰⁰ m away, no gravity at all) is a typo, refused with its field
//! before a job is registered.

use super::silo::FieldError;

/// The farthest a scene may sit from the coordinate origin (m). Positions are stored split
/// (a coarse and a fine part), so precision holds well past this; squared distances of
/// positions near 10¹⁵⁴ m overflow.
pub const MAX_ORIGIN_M: f64 = 1.0e4;

/// The strongest gravity accepted (m/s², about 100 g): a centrifuge's, not a typo's.
pub const MAX_GRAVITY_M_PER_S2: f64 = 1.0e3;

/// `origin_m` finite and within `MAX_ORIGIN_M` of the coordinate origin in each axis.
pub fn origin_problem(origin: [f64; 3]) -> Option<FieldError> {
    let far = origin
        .iter()
        .any(|x| !(x.is_finite() && x.abs() <= MAX_ORIGIN_M));
    far.then(|| FieldError {
        field: "origin_m".into(),
        message: format!(
            "expected each coordinate within ±{MAX_ORIGIN_M} m of the coordinate origin (where the scene sits changes no result), got {origin:?}"
        ),
    })
}

/// Gravity drives both flows: without it a silo never discharges and a chute never flows.
pub fn gravity_problem(g: f64) -> Option<FieldError> {
    (!(g > 0.0 && g <= MAX_GRAVITY_M_PER_S2)).then(|| FieldError {
        field: "gravity_m_per_s2".into(),
        message: format!(
            "expected 0 < g ≤ {MAX_GRAVITY_M_PER_S2} m/s² (gravity drives the flow: without it nothing discharges or flows), got {g}"
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typos_are_refused_and_real_values_kept() {
        assert!(origin_problem([0.0, 100.0, -100.0]).is_none());
        assert!(origin_problem([1e300, 0.0, 0.0]).is_some());
        assert!(origin_problem([f64::NAN, 0.0, 0.0]).is_some());
        assert!(gravity_problem(9.81).is_none());
        assert!(gravity_problem(0.0).is_some());
        assert!(gravity_problem(-9.81).is_some());
        assert!(gravity_problem(f64::INFINITY).is_some());
    }
}
