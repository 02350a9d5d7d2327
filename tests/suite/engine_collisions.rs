//! Binary collisions against analytic values, on every backend (`common::backends`).
//! - Linear spring–dashpot: contact time t_c = π/ω and restitution e_n within 1 %, at four
//!   impact speeds (both are speed independent for this law).
//! - Hertz–Mindlin: e_n independent of speed (spread < 0.005) and within 2 % of the target; for
//!   e = 1 the rebound within 0.005 of 1 and the contact time within 2 % of Hertz's
//!   2.87 (m*²/(R* Y*² v))^{1/5}. Measured on lavapipe (f32): e_n −0.02 %, spread 9e-5, elastic
//!   rebound 1e-4 off, t_c −0.07 %.
//!
//! A failure means the force law, its damping or the integrator is wrong.

use crate::common;
use crate::common::backends::{per_backend, On};

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair};

const R: f64 = 0.0029;
const RHO: f64 = 2655.0;

fn mass() -> f64 {
    RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3)
}

/// A head-on collision at relative speed `v` with dt = t_c / n_c: (restitution, contact time).
fn collide(on: &On, law: ContactLaw, v: f64, n_c: f64) -> (f64, f64) {
    let (config, state) = common::collision::head_on(law, v, n_c, R, RHO);
    let (e, t) = common::collision::collide(&mut *on.build(&config, &state), v, R);
    eprintln!("{}: v = {v} m/s: e = {e:.6}, t_c = {t:.5e} s", on.name());
    (e, t)
}

fn linear_contact_time_and_restitution(on: &On) {
    let law = common::linear_law(1.0e4, 0.9, 0.0);
    let pair = ContactPair {
        r_eff: R / 2.0,
        m_eff: mass() / 2.0,
    };
    let tc = contact_time(&law, pair, 1.0);
    for v in [0.1, 0.5, 1.0, 2.0] {
        let (e, t) = collide(on, law, v, 200.0);
        assert!(
            (e - 0.9).abs() / 0.9 < 0.01,
            "v = {v}: e = {e}, expected 0.9 within 1 %"
        );
        assert!(
            (t - tc).abs() / tc < 0.01,
            "v = {v}: t_c = {t}, expected π/ω = {tc} within 1 %"
        );
    }
}

fn hertz_restitution_is_speed_independent_and_on_target(on: &On) {
    let law = common::hertz_shear_law(3.0e7, 0.9, 0.0);
    let mut es = vec![];
    for v in [0.05, 0.1, 0.5, 1.0, 2.0] {
        let (e, _) = collide(on, law, v, 100.0);
        es.push(e);
        assert!(
            (e - 0.9).abs() / 0.9 < 0.02,
            "v = {v}: e = {e}, expected 0.9 within 2 %"
        );
    }
    let spread =
        es.iter().cloned().fold(f64::MIN, f64::max) - es.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread < 0.005, "restitution varies with speed: {es:?}");
}

fn hertz_elastic_contact_time_matches_hertz_theory(on: &On) {
    let y = 3.0e7;
    let law = common::hertz_shear_law(y, 1.0, 0.0);
    for v in [0.05, 0.5, 2.0] {
        let analytic = 2.87 * ((mass() / 2.0).powi(2) / (R / 2.0 * y * y * v)).powf(0.2);
        let (e, t) = collide(on, law, v, 100.0);
        assert!((e - 1.0).abs() < 0.005, "v = {v}: elastic rebound e = {e}");
        assert!(
            (t - analytic).abs() / analytic < 0.02,
            "v = {v}: t_c = {t}, Hertz {analytic} within 2 %"
        );
    }
}

per_backend!(
    linear_contact_time_and_restitution,
    hertz_restitution_is_speed_independent_and_on_target,
    hertz_elastic_contact_time_matches_hertz_theory,
);
