//! Binary collisions against analytic values.
//! - Linear spring–dashpot: contact time t_c = π/ω and restitution e_n within 1 %, at three
//!   impact speeds (both are speed independent for this law).
//! - Hertz–Mindlin: e_n independent of speed and within 2 % of the target; for e = 1 the contact
//!   time within 2 % of Hertz's 2.87 (m*²/(R* Y*² v))^{1/5}.
//!
//! A failure means the force law, its damping or the integrator is wrong.

use crate::common;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, Elasticity, NormalModel};
use sweep::engine::CpuEngine;

const R: f64 = 0.0029;
const RHO: f64 = 2655.0;

/// Runs a head-on collision at relative speed `v` on the CPU; returns (restitution, contact time).
fn collide(law: ContactLaw, v: f64, n_c: f64) -> (f64, f64) {
    let (config, state) = common::collision::head_on(law, v, n_c, R, RHO);
    common::collision::collide(&mut CpuEngine::new(config, state, 1), v, R)
}

fn linear(e: f64, kn: f64) -> ContactLaw {
    common::linear_law(kn, e, 0.0)
}

fn hertz(e: f64, y: f64) -> ContactLaw {
    ContactLaw {
        normal: NormalModel::Hertz(Elasticity::YoungShear {
            youngs_modulus_pa: y,
            shear_modulus_pa: y / 30.0,
        }),
        restitution: e,
        tangential_restitution: e,
        friction: 0.0,
    }
}

#[test]
fn linear_contact_time_and_restitution() {
    let law = linear(0.9, 1.0e4);
    let m = RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let tc = contact_time(
        &law,
        ContactPair {
            r_eff: R / 2.0,
            m_eff: m / 2.0,
        },
        1.0,
    );
    for v in [0.1, 0.5, 2.0] {
        let (e, t) = collide(law, v, 200.0);
        assert!(
            (e - 0.9).abs() / 0.9 < 0.01,
            "v = {v}: e = {e}, expected 0.9 within 1 %"
        );
        assert!(
            (t - tc).abs() / tc < 0.01,
            "v = {v}: t_c = {t}, expected {tc} within 1 %"
        );
    }
}

#[test]
fn hertz_restitution_is_speed_independent_and_on_target() {
    let law = hertz(0.9, 3.0e7);
    let mut es = vec![];
    for v in [0.05, 0.5, 2.0] {
        let (e, _) = collide(law, v, 100.0);
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

#[test]
fn hertz_elastic_contact_time_matches_hertz_theory() {
    let y = 3.0e7;
    let law = hertz(1.0, y);
    let m = RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    for v in [0.05, 0.5, 2.0] {
        let analytic = 2.87 * ((m / 2.0).powi(2) / (R / 2.0 * y * y * v)).powf(0.2);
        let (e, t) = collide(law, v, 100.0);
        assert!((e - 1.0).abs() < 0.005, "elastic rebound e = {e}");
        assert!(
            (t - analytic).abs() / analytic < 0.02,
            "v = {v}: t_c = {t}, Hertz {analytic}"
        );
    }
}
