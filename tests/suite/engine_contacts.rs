//! Single-sphere contacts with a wall against analytic results of rigid-body mechanics, on every
//! backend (`common::backends`). Where the GPU's f32 or lavapipe's speed changes a run or a
//! tolerance, `On::pick` says so; measured values are lavapipe's.
//! - Oblique impact on a plane (Hertz–Mindlin, Y = 3 GPa, ν = 0.25, e = 0.9, μ = 0.3). Sliding
//!   regime (v_t/v_n = 10, above the gross-sliding threshold 7/2 μ (1 + e)): Δv_t = μ (1 + e) v_n
//!   within 2 %, with e the measured normal restitution, and Δω = 5/2 Δv_t / R within 2 % (GPU
//!   +0.24 %, −0.19 %). (The engine's lever arm is R − δ/2, so Δω falls short of the rigid value
//!   by about δ/2R; the stiff Y keeps δ below 1 % of R.) Sticking regime (v_t/v_n = 0.2): the
//!   tangential impulse stays strictly below μ × the normal impulse and the contact-point slip
//!   speed is smaller after the impact than before.
//! - Rest on a plane under gravity: static overlap m g / k_n (linear) and
//!   (3 m g / (4 Y* √R))^{2/3} (Hertz) within 1 % (GPU −0.23 %, −0.10 %), settled to
//!   |v_z| < 1e-9 m/s after 5 000 steps; on the GPU 2 000 steps (40 t_c) and |v_z| < ulp(z)/dt
//!   (f32: z moves in whole ulps, so the force at the nearest representable z misses m g and v_z
//!   creeps until it moves z by one; measured 6e-6 and 8e-6 m/s against 2e-5).
//! - Incline with vertical gravity: below tan θ = 7/2 μ the sphere rolls without slipping
//!   (slip < 1e-3 m/s) with a = 5/7 g sin θ; above, it slides with a = g (sin θ − μ cos θ); both
//!   within 2 %, fitted over t ∈ [0.05, 0.25] s (GPU: 0.15 s; −0.02 %, 0.00 %).
//! - Turntable (closed plate spinning at f = 1 Hz): once sliding stops, the contact-point velocity
//!   v + ω × b (b = −R n) equals the plate's surface velocity within 1 % of the local surface
//!   speed, and the centre circles at 2Ω/7 in the lab frame within 5 % (measured as the turning
//!   rate of the centre's velocity) over 1.2 s, a 2-rad arc (GPU: 0.6 s, 1 rad; +0.09 %).
//!   Released at rest at r0, the ball sticks almost at once with v = 2/7 Ω r0, so its circle is
//!   centred on the axis with radius r0.
//!
//! A failure means the tangential spring, its Coulomb truncation, the torque lever arm, the wall
//! surface velocity or the integration of rotation is wrong.

use crate::common;
use crate::common::backends::{per_backend, On};
use crate::common::fit::{fit_circle, slope, unwrap};

use std::f64::consts::PI;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, NormalModel};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::walls::{Wall, WallRotation, WallShape};
use sweep::engine::{Backend, EngineConfig, State};

const R: f64 = 0.0029;
const RHO: f64 = 2655.0;
const G: f64 = 9.81;

fn mass() -> f64 {
    RHO * 4.0 / 3.0 * PI * R.powi(3)
}

fn floor() -> Wall {
    common::plane([0.0; 3], [0.0, 0.0, 1.0])
}

/// Time step t_c / 50 for a sphere–wall contact at `speed`.
fn wall_dt(law: &ContactLaw, speed: f64) -> f64 {
    contact_time(
        law,
        ContactPair {
            r_eff: R,
            m_eff: mass(),
        },
        speed,
    ) / 50.0
}

/// One sphere at `pos` with velocity `vel` against `walls`, on `on`.
fn one_sphere(
    on: &On,
    law: ContactLaw,
    dt: f64,
    gravity: [f64; 3],
    walls: Vec<Wall>,
    pos: [f64; 3],
    vel: [f64; 3],
) -> Box<dyn Backend> {
    let friction = law.friction > 0.0;
    let mut s = State::<f64>::new(friction, if friction { HISTORY_SLOTS } else { 0 });
    s.push_sphere(0, pos, vel, R, RHO, false);
    let config = EngineConfig {
        dt_s: dt,
        gravity,
        particle_law: law,
        wall_law: law,
        walls,
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.2 * R,
    };
    on.build(&config, &s)
}

/// What an oblique impact on the plane z = 0 did, starting without spin.
struct Impact {
    /// Normal restitution v_z,out / v_n.
    e: f64,
    /// Loss of tangential velocity v_t − v_x,out (> 0 when friction opposes the motion).
    dvt: f64,
    /// Angular velocity gained about y (rad/s).
    dw: f64,
    /// Contact-point slip speed after the impact (it is v_t before).
    slip_out: f64,
}

/// A sphere 5 steps above the plane moving at (v_t, 0, −v_n), dt = t_c/50 at v_n.
fn oblique_impact(on: &On, law: ContactLaw, vn: f64, vt: f64) -> Impact {
    let dt = wall_dt(&law, vn);
    let mut b = one_sphere(
        on,
        law,
        dt,
        [0.0; 3],
        vec![floor()],
        [0.0, 0.0, R + 5.0 * vn * dt],
        [vt, 0.0, -vn],
    );
    let mut touched = false;
    for _ in 0..100_000 {
        b.advance(1).unwrap();
        let s = b.download();
        if s.pos[0].z < R {
            touched = true;
        } else if touched {
            let (v, w) = (s.vel[0], s.omega[0]);
            // Contact point b = −R ẑ: slip = v + ω × b, whose x part is v_x − R ω_y.
            let slip = [v.x - R * w.y, v.y + R * w.x];
            return Impact {
                e: v.z / vn,
                dvt: vt - v.x,
                dw: w.y,
                slip_out: slip[0].hypot(slip[1]),
            };
        }
    }
    panic!("the sphere never left the wall");
}

fn oblique_impact_sliding_obeys_coulomb_impulse(on: &On) {
    let mu = 0.3;
    let (vn, vt) = (0.5, 5.0);
    let r = oblique_impact(on, common::hertz_law(3.0e9, 0.9, mu), vn, vt);
    let expected_dvt = mu * (1.0 + r.e) * vn;
    let expected_dw = 2.5 * r.dvt / R;
    eprintln!("{}: sliding: e = {:.5}, Δv_t = {:.6} (μ(1+e)v_n = {expected_dvt:.6}), Δω = {:.4} (5/2 Δv_t/R = {expected_dw:.4})", on.name(), r.e, r.dvt, r.dw);
    assert!(
        (r.e - 0.9).abs() < 0.02,
        "normal restitution {} far from 0.9",
        r.e
    );
    assert!(
        (r.dvt - expected_dvt).abs() / expected_dvt < 0.02,
        "Δv_t = {}, expected μ(1+e)v_n = {expected_dvt} within 2 %",
        r.dvt
    );
    assert!(
        (r.dw - expected_dw).abs() / expected_dw < 0.02,
        "Δω = {}, expected 5/2 Δv_t/R = {expected_dw} within 2 %",
        r.dw
    );
}

fn oblique_impact_sticking_stays_inside_the_friction_cone(on: &On) {
    let mu = 0.3;
    let (vn, vt) = (0.5, 0.1);
    let r = oblique_impact(on, common::hertz_law(3.0e9, 0.9, mu), vn, vt);
    let (jt, jn) = (r.dvt.abs(), (1.0 + r.e) * vn); // impulses per unit mass
    eprintln!(
        "{}: sticking: e = {:.5}, J_t/m = {jt:.6}, μ J_n/m = {:.6}, slip {vt} → {:.6} m/s",
        on.name(),
        r.e,
        mu * jn,
        r.slip_out
    );
    assert!(
        jt < mu * jn,
        "tangential impulse {jt} reaches μ × normal impulse {}: the contact slid",
        mu * jn
    );
    assert!(
        r.slip_out < vt,
        "slip speed grew from {vt} to {}",
        r.slip_out
    );
}

fn resting_overlap_matches_static_equilibrium(on: &On) {
    let kn = 1.0e4;
    let hz = common::hertz_law(3.0e7, 0.3, 0.0);
    let NormalModel::Hertz(el) = hz.normal else {
        unreachable!()
    };
    let (y_eff, _) = el.effective();
    // Damping at e = 0.3 kills the bounce within a few periods: 5 000 steps are ~100 t_c
    // (shorter on the GPU).
    let steps = on.pick(5_000, 2_000);
    for (name, law, expected) in [
        ("linear", common::linear_law(kn, 0.3, 0.0), mass() * G / kn),
        (
            "Hertz",
            hz,
            (3.0 * mass() * G / (4.0 * y_eff * R.sqrt())).powf(2.0 / 3.0),
        ),
    ] {
        let dt = wall_dt(&law, 0.1);
        // (f32) z moves in whole ulps: settled means less than one ulp of z per step.
        let z = (R as f32).to_bits();
        let ulp = f64::from(f32::from_bits(z + 1) - f32::from_bits(z));
        let v_settled = on.pick(1e-9, ulp / dt);
        let mut b = one_sphere(
            on,
            law,
            dt,
            [0.0, 0.0, -G],
            vec![floor()],
            [0.0, 0.0, R],
            [0.0; 3],
        );
        b.advance(steps).unwrap();
        let s = b.download();
        let (delta, vz) = (R - s.pos[0].z, s.vel[0].z);
        eprintln!(
            "{}: {name}: δ = {delta:.6e} m, expected {expected:.6e} m; v_z = {vz:.2e} m/s (settled below {v_settled:.2e})",
            on.name()
        );
        assert!(
            vz.abs() < v_settled,
            "{name}: not settled: v_z = {vz:.3e} m/s, limit {v_settled:.3e}"
        );
        assert!(
            (delta - expected).abs() / expected < 0.01,
            "{name}: overlap {delta}, expected {expected} within 1 %"
        );
    }
}

/// Down-slope acceleration of a sphere released at its static overlap under g cos θ (no normal
/// bounce to disturb the fit) on an incline of angle θ, fitted over t ∈ [0.05, end] s, and the
/// largest contact-point slip speed over that span.
fn incline(on: &On, theta: f64, mu: f64) -> (f64, f64) {
    // 70 samples up to 0.15 s still fix the slope far inside 2 %, at 60 % of the GPU's steps.
    let (end, chunk) = on.pick((0.25, 20), (0.15, 100));
    let law = common::hertz_law(3.0e7, 0.5, mu);
    let n = [-theta.sin(), 0.0, theta.cos()];
    let down = [-theta.cos(), 0.0, -theta.sin()];
    let NormalModel::Hertz(el) = law.normal else {
        unreachable!()
    };
    let (y_eff, _) = el.effective();
    let d0 = (3.0 * mass() * G * theta.cos() / (4.0 * y_eff * R.sqrt())).powf(2.0 / 3.0);
    let p0 = [n[0] * (R - d0), 0.0, n[2] * (R - d0)];
    let walls = vec![common::plane([0.0; 3], n)];
    let mut b = one_sphere(
        on,
        law,
        wall_dt(&law, 0.1),
        [0.0, 0.0, -G],
        walls,
        p0,
        [0.0; 3],
    );
    let (mut ts, mut vs) = (vec![], vec![]);
    let mut slip_max: f64 = 0.0;
    loop {
        b.advance(chunk).unwrap();
        let s = b.download();
        if s.time > end {
            break;
        }
        if s.time < 0.05 {
            continue;
        }
        let (v, w) = (s.vel[0].to_f64(), s.omega[0].to_f64());
        let arm = [-R * n[0], 0.0, -R * n[2]];
        let slip = [
            v[0] + w[1] * arm[2] - w[2] * arm[1],
            v[1] + w[2] * arm[0] - w[0] * arm[2],
            v[2] + w[0] * arm[1] - w[1] * arm[0],
        ];
        slip_max = slip_max.max((slip[0] * slip[0] + slip[1] * slip[1] + slip[2] * slip[2]).sqrt());
        ts.push(s.time);
        vs.push(v[0] * down[0] + v[1] * down[1] + v[2] * down[2]);
    }
    (slope(&ts, &vs), slip_max)
}

fn incline_rolls_below_and_slides_above_the_friction_threshold(on: &On) {
    let mu = 0.3; // rolling needs tan θ < 7/2 μ = 1.05 (θ < 46.4°)
    let theta = 20f64.to_radians();
    let (a, slip) = incline(on, theta, mu);
    let expected = 5.0 / 7.0 * G * theta.sin();
    eprintln!("{}: rolling θ = 20°: a = {a:.5} m/s², 5/7 g sin θ = {expected:.5}, largest slip {slip:.2e} m/s", on.name());
    assert!(
        (a - expected).abs() / expected < 0.02,
        "rolling acceleration {a}, expected {expected} within 2 %"
    );
    assert!(slip < 1e-3, "the rolling sphere slips at {slip} m/s");

    let theta = 60f64.to_radians();
    let (a, slip) = incline(on, theta, mu);
    let expected = G * (theta.sin() - mu * theta.cos());
    eprintln!("{}: sliding θ = 60°: a = {a:.5} m/s², g (sin θ − μ cos θ) = {expected:.5}, slip up to {slip:.3} m/s", on.name());
    assert!(
        (a - expected).abs() / expected < 0.02,
        "sliding acceleration {a}, expected {expected} within 2 %"
    );
}

fn turntable_ball_rolls_with_the_plate_and_circles_at_two_sevenths_omega(on: &On) {
    // Rolling, dv/dt = 2/7 Ω ẑ × v: the velocity turns at 2Ω/7 ≈ 1.8 rad/s, so 1.2 s give a
    // 2-radian arc, plenty for the slope; half of it still well inside 5 % (GPU).
    let end = on.pick(1.2, 0.6);
    let omega = 2.0 * PI;
    let r0 = 0.02;
    let law = common::hertz_law(1.0e7, 0.5, 0.5);
    let plate = Wall {
        shape: WallShape::OrificePlate {
            z: 0.0,
            center_xy: [0.0, 0.0],
            orifice_radius: 0.0,
        },
        rotation: Some(WallRotation {
            axis_xy: [0.0, 0.0],
            omega_rad_per_s: omega,
        }),
    };
    // Dropped gently: released at rest a tenth of a micron above the plate.
    let mut b = one_sphere(
        on,
        law,
        wall_dt(&law, 0.1),
        [0.0, 0.0, -G],
        vec![plate],
        [r0, 0.0, R + 1e-7],
        [0.0; 3],
    );
    let (mut ts, mut xs, mut ys, mut heading) = (vec![], vec![], vec![], vec![]);
    let mut rolling_since = None;
    let mut worst: f64 = 0.0;
    loop {
        b.advance(50).unwrap();
        let s = b.download();
        if s.time > end {
            break;
        }
        let (p, v, w) = (s.pos[0].to_f64(), s.vel[0].to_f64(), s.omega[0].to_f64());
        // Contact point velocity v + ω × b with b = −R ẑ, against the plate's Ω ẑ × r.
        let contact = [v[0] - R * w[1], v[1] + R * w[0]];
        let surface = [-omega * p[1], omega * p[0]];
        let speed = omega * p[0].hypot(p[1]);
        let rel = (contact[0] - surface[0]).hypot(contact[1] - surface[1]) / speed;
        if rolling_since.is_none() && rel < 1e-3 {
            rolling_since = Some(s.time);
        }
        // Leave the settling of the tangential spring (a few contact times) out.
        if rolling_since.is_some_and(|t0| s.time > t0 + 0.05) {
            worst = worst.max(rel);
            ts.push(s.time);
            xs.push(p[0]);
            ys.push(p[1]);
            heading.push(v[1].atan2(v[0]));
        }
    }
    let t0 = rolling_since.expect("the ball never stopped sliding");
    // The centre moves on a circle, so its velocity turns at the orbit's angular frequency.
    let w_orbit = slope(&ts, &unwrap(&heading));
    let (cx, cy, radius) = fit_circle(&xs, &ys);
    let expected = 2.0 * omega / 7.0;
    eprintln!(
        "{}: turntable: sliding stopped at t = {t0:.4} s; worst contact-velocity mismatch {worst:.2e} of the surface speed; \
         orbit centre ({cx:.2e}, {cy:.2e}) m, radius {radius:.5} m (r0 = {r0}), angular frequency {w_orbit:.5} rad/s, 2Ω/7 = {expected:.5}",
        on.name()
    );
    assert!(
        worst < 0.01,
        "contact point moves at {worst} of the surface speed relative to the plate"
    );
    assert!(
        (w_orbit - expected).abs() / expected < 0.05,
        "orbit angular frequency {w_orbit}, expected 2Ω/7 = {expected} within 5 %"
    );
}

per_backend!(
    oblique_impact_sliding_obeys_coulomb_impulse,
    oblique_impact_sticking_stays_inside_the_friction_cone,
    resting_overlap_matches_static_equilibrium,
    incline_rolls_below_and_slides_above_the_friction_threshold,
    turntable_ball_rolls_with_the_plate_and_circles_at_two_sevenths_omega,
);
