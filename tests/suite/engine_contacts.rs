//! Single-sphere contacts with a wall against analytic results of rigid-body mechanics.
//! - Oblique impact on a plane (Hertz–Mindlin, Y = 3 GPa, ν = 0.25, e = 0.9, μ = 0.3). Sliding
//!   regime (v_t/v_n = 10, above the gross-sliding threshold 7/2 μ (1 + e)): Δv_t = μ (1 + e) v_n
//!   within 2 %, with e the measured normal restitution, and Δω = 5/2 Δv_t / R within 2 %. (The
//!   engine's lever arm is R − δ/2, so Δω falls short of the rigid value by about δ/2R; the stiff
//!   Y keeps δ below 1 % of R.) Sticking regime (v_t/v_n = 0.2): the tangential impulse stays
//!   strictly below μ × the normal impulse and the contact-point slip speed is smaller after the
//!   impact than before.
//! - Rest on a plane under gravity: static overlap m g / k_n (linear) and
//!   (3 m g / (4 Y* √R))^{2/3} (Hertz) within 1 %.
//! - Incline with vertical gravity: below tan θ = 7/2 μ the sphere rolls without slipping with
//!   a = 5/7 g sin θ; above, it slides with a = g (sin θ − μ cos θ); both within 2 %, measured
//!   after the start-up transient.
//! - Turntable (closed plate spinning at f = 1 Hz): once sliding stops, the contact-point velocity
//!   v + ω × b (b = −R n) equals the plate's surface velocity within 1 % of the local surface
//!   speed, and the centre circles at 2Ω/7 in the lab frame within 5 % (measured as the turning
//!   rate of the centre's velocity). Released at rest at r0, the ball sticks almost at once with
//!   v = 2/7 Ω r0, so its circle is centred on the axis with radius r0.
//!
//! A failure means the tangential spring, its Coulomb truncation, the torque lever arm, the wall
//! surface velocity or the integration of rotation is wrong.

use crate::common;
use crate::common::fit::{fit_circle, slope, unwrap};

use std::f64::consts::PI;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, Elasticity, NormalModel};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::walls::{Wall, WallRotation, WallShape};
use sweep::engine::{Backend, CpuEngine, EngineConfig, State};

const R: f64 = 0.0029;
const RHO: f64 = 2655.0;
const G: f64 = 9.81;

fn mass() -> f64 {
    RHO * 4.0 / 3.0 * PI * R.powi(3)
}

fn hertz(y: f64, e: f64, mu: f64) -> ContactLaw {
    let el = Elasticity::YoungPoisson {
        youngs_modulus_pa: y,
        poisson_ratio: 0.25,
    };
    ContactLaw {
        normal: NormalModel::Hertz(el),
        restitution: e,
        tangential_restitution: e,
        friction: mu,
    }
}

fn plane(normal: [f64; 3]) -> Wall {
    Wall {
        shape: WallShape::Plane {
            point: [0.0; 3],
            normal,
        },
        rotation: None,
    }
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

/// One sphere at `pos` with velocity `vel` against `walls`.
fn engine(
    law: ContactLaw,
    dt: f64,
    gravity: [f64; 3],
    walls: Vec<Wall>,
    pos: [f64; 3],
    vel: [f64; 3],
) -> CpuEngine<f64> {
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
    CpuEngine::new(config, s, 1)
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

fn oblique_impact(law: ContactLaw, vn: f64, vt: f64) -> Impact {
    let dt = wall_dt(&law, vn);
    let mut e = engine(
        law,
        dt,
        [0.0; 3],
        vec![plane([0.0, 0.0, 1.0])],
        [0.0, 0.0, R + 5.0 * vn * dt],
        [vt, 0.0, -vn],
    );
    let mut touched = false;
    for _ in 0..100_000 {
        e.advance(1).unwrap();
        let s = e.download();
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

#[test]
fn oblique_impact_sliding_obeys_coulomb_impulse() {
    let mu = 0.3;
    let law = hertz(3.0e9, 0.9, mu);
    let (vn, vt) = (0.5, 5.0);
    let r = oblique_impact(law, vn, vt);
    let expected_dvt = mu * (1.0 + r.e) * vn;
    let expected_dw = 2.5 * r.dvt / R;
    eprintln!("sliding: e = {:.5}, Δv_t = {:.6} (μ(1+e)v_n = {expected_dvt:.6}), Δω = {:.4} (5/2 Δv_t/R = {expected_dw:.4})", r.e, r.dvt, r.dw);
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

#[test]
fn oblique_impact_sticking_stays_inside_the_friction_cone() {
    let mu = 0.3;
    let law = hertz(3.0e9, 0.9, mu);
    let (vn, vt) = (0.5, 0.1);
    let r = oblique_impact(law, vn, vt);
    let (jt, jn) = (r.dvt.abs(), (1.0 + r.e) * vn); // impulses per unit mass
    eprintln!(
        "sticking: e = {:.5}, J_t/m = {jt:.6}, μ J_n/m = {:.6}, slip {vt} → {:.6} m/s",
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

/// Settles a sphere on the plane z = 0 under gravity and returns its overlap.
fn static_overlap(law: ContactLaw, dt: f64) -> f64 {
    let mut e = engine(
        law,
        dt,
        [0.0, 0.0, -G],
        vec![plane([0.0, 0.0, 1.0])],
        [0.0, 0.0, R],
        [0.0; 3],
    );
    // Damping with e = 0.3 kills the oscillation within a few periods; 5 000 steps are ~100 t_c.
    e.advance(5_000).unwrap();
    let s = e.download();
    assert!(s.vel[0].z.abs() < 1e-9, "not settled: v_z = {}", s.vel[0].z);
    R - s.pos[0].z
}

#[test]
fn resting_overlap_matches_static_equilibrium() {
    let kn = 1.0e4;
    let linear = common::linear_law(kn, 0.3, 0.0);
    let delta = static_overlap(linear, wall_dt(&linear, 0.1));
    let expected = mass() * G / kn;
    eprintln!("linear: δ = {delta:.6e} m, m g / k_n = {expected:.6e} m");
    assert!(
        (delta - expected).abs() / expected < 0.01,
        "linear overlap {delta}, expected {expected} within 1 %"
    );

    let law = hertz(3.0e7, 0.3, 0.0);
    let NormalModel::Hertz(el) = law.normal else {
        unreachable!()
    };
    let (y_eff, _) = el.effective();
    let delta = static_overlap(law, wall_dt(&law, 0.1));
    let expected = (3.0 * mass() * G / (4.0 * y_eff * R.sqrt())).powf(2.0 / 3.0);
    eprintln!("hertz: δ = {delta:.6e} m, (3 m g / 4 Y* √R)^(2/3) = {expected:.6e} m");
    assert!(
        (delta - expected).abs() / expected < 0.01,
        "Hertz overlap {delta}, expected {expected} within 1 %"
    );
}

/// Down-slope acceleration of a sphere released on an incline of angle θ, fitted over
/// t ∈ [0.05, 0.25] s, and the largest contact-point slip speed over that span.
fn incline(theta: f64, mu: f64) -> (f64, f64) {
    let law = hertz(3.0e7, 0.5, mu);
    let n = [-theta.sin(), 0.0, theta.cos()];
    let down = [-theta.cos(), 0.0, -theta.sin()];
    let NormalModel::Hertz(el) = law.normal else {
        unreachable!()
    };
    let (y_eff, _) = el.effective();
    // Start at the static overlap under g cos θ so that no normal bounce disturbs the fit.
    let d0 = (3.0 * mass() * G * theta.cos() / (4.0 * y_eff * R.sqrt())).powf(2.0 / 3.0);
    let p0 = [n[0] * (R - d0), 0.0, n[2] * (R - d0)];
    let dt = wall_dt(&law, 0.1);
    let mut e = engine(law, dt, [0.0, 0.0, -G], vec![plane(n)], p0, [0.0; 3]);
    let (mut ts, mut vs) = (vec![], vec![]);
    let mut slip_max: f64 = 0.0;
    let chunk = 20;
    while e.state.time < 0.25 {
        e.advance(chunk).unwrap();
        let s = e.download();
        if s.time < 0.05 {
            continue;
        }
        let (v, w) = (s.vel[0].to_f64(), s.omega[0].to_f64());
        let b = [-R * n[0], 0.0, -R * n[2]];
        let slip = [
            v[0] + w[1] * b[2] - w[2] * b[1],
            v[1] + w[2] * b[0] - w[0] * b[2],
            v[2] + w[0] * b[1] - w[1] * b[0],
        ];
        slip_max = slip_max.max((slip[0] * slip[0] + slip[1] * slip[1] + slip[2] * slip[2]).sqrt());
        ts.push(s.time);
        vs.push(v[0] * down[0] + v[1] * down[1] + v[2] * down[2]);
    }
    (slope(&ts, &vs), slip_max)
}

#[test]
fn incline_rolls_below_and_slides_above_the_friction_threshold() {
    let mu = 0.3; // rolling needs tan θ < 7/2 μ = 1.05 (θ < 46.4°)
    let theta = 20f64.to_radians();
    let (a, slip) = incline(theta, mu);
    let expected = 5.0 / 7.0 * G * theta.sin();
    eprintln!("rolling θ = 20°: a = {a:.5} m/s², 5/7 g sin θ = {expected:.5}, largest slip {slip:.2e} m/s");
    assert!(
        (a - expected).abs() / expected < 0.02,
        "rolling acceleration {a}, expected {expected} within 2 %"
    );
    assert!(slip < 1e-3, "the rolling sphere slips at {slip} m/s");

    let theta = 60f64.to_radians();
    let (a, slip) = incline(theta, mu);
    let expected = G * (theta.sin() - mu * theta.cos());
    eprintln!("sliding θ = 60°: a = {a:.5} m/s², g (sin θ − μ cos θ) = {expected:.5}, slip up to {slip:.3} m/s");
    assert!(
        (a - expected).abs() / expected < 0.02,
        "sliding acceleration {a}, expected {expected} within 2 %"
    );
}

#[test]
fn turntable_ball_rolls_with_the_plate_and_circles_at_two_sevenths_omega() {
    let f = 1.0;
    let omega = 2.0 * PI * f;
    let r0 = 0.02;
    let law = hertz(1.0e7, 0.5, 0.5);
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
    let dt = wall_dt(&law, 0.1);
    // Dropped gently: released at rest a tenth of a micron above the plate.
    let mut e = engine(
        law,
        dt,
        [0.0, 0.0, -G],
        vec![plate],
        [r0, 0.0, R + 1e-7],
        [0.0; 3],
    );
    let (mut ts, mut xs, mut ys, mut heading) = (vec![], vec![], vec![], vec![]);
    let mut rolling_since = None;
    let mut worst: f64 = 0.0;
    // Rolling, dv/dt = 2/7 Ω ẑ × v: the velocity turns at 2Ω/7 ≈ 1.8 rad/s, so 1.2 s give a
    // 2-radian arc, plenty for the slope (the full orbit would take 3.5 s).
    while e.state.time < 1.2 {
        e.advance(50).unwrap();
        let s = e.download();
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
        "turntable: sliding stopped at t = {t0:.4} s; worst contact-velocity mismatch {worst:.2e} of the surface speed; \
         orbit centre ({cx:.2e}, {cy:.2e}) m, radius {radius:.5} m (r0 = {r0}), angular frequency {w_orbit:.5} rad/s, 2Ω/7 = {expected:.5}"
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
