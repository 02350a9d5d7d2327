//! A head-on collision of two equal spheres, shared by the CPU and GPU collision tests.

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair};
use sweep::engine::{Backend, EngineConfig, State};

/// Two spheres of radius `r` and density `rho` approaching at relative speed `v` along x, touching
/// after about 5 steps, with dt = t_c / n_c (t_c at speed `v`). No gravity, no walls.
pub fn head_on(law: ContactLaw, v: f64, n_c: f64, r: f64, rho: f64) -> (EngineConfig, State<f64>) {
    head_on_phased(law, v, n_c, r, rho, 0.0)
}

/// As `head_on`, with the touch delayed by `phase` (a fraction of a step, in [0, 1)): where
/// within a step the contact begins, which a coarse step resolves differently.
pub fn head_on_phased(
    law: ContactLaw,
    v: f64,
    n_c: f64,
    r: f64,
    rho: f64,
    phase: f64,
) -> (EngineConfig, State<f64>) {
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let tc = contact_time(
        &law,
        ContactPair {
            r_eff: r / 2.0,
            m_eff: m / 2.0,
        },
        v,
    );
    let dt = tc / n_c;
    let friction = law.friction > 0.0;
    let mut s = State::<f64>::new(
        friction,
        if friction {
            sweep::engine::history::HISTORY_SLOTS
        } else {
            0
        },
    );
    let gap = v * (2.5 + phase) * dt;
    s.push_sphere(
        0,
        [-(r + gap / 2.0), 0.0, 0.0],
        [v / 2.0, 0.0, 0.0],
        r,
        rho,
        false,
    );
    s.push_sphere(
        1,
        [r + gap / 2.0, 0.0, 0.0],
        [-v / 2.0, 0.0, 0.0],
        r,
        rho,
        false,
    );
    let config = EngineConfig {
        dt_s: dt,
        gravity: [0.0; 3],
        particle_law: law,
        wall_law: law,
        walls: vec![],
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.2 * r,
    };
    (config, s)
}

/// Steps `b` one step at a time through the collision started by `head_on`; returns the
/// restitution and the contact time, with touch and release interpolated within their steps.
pub fn collide(b: &mut dyn Backend, v: f64, r: f64) -> (f64, f64) {
    let mut t_in = None;
    for _ in 0..100_000 {
        b.advance(1).unwrap();
        let st = b.download();
        let (a, c) = if st.id[0] == 0 { (0, 1) } else { (1, 0) };
        let d = st.pos[c].x - st.pos[a].x;
        if d < 2.0 * r && t_in.is_none() {
            t_in = Some(st.time - (2.0 * r - d) / v);
        }
        if let (true, Some(t0)) = (d >= 2.0 * r, t_in) {
            let vrel = st.vel[c].x - st.vel[a].x;
            let t_out = st.time - (d - 2.0 * r) / vrel;
            return (vrel / v, t_out - t0);
        }
    }
    panic!("no separation within 100 000 steps");
}
