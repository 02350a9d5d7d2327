//! The spherocylinder test scene's units, shape and stiffness: L = 0.125 m rods, ρ = 2600 kg/m³,
//! g = 1 m/s², k_n = 2·10⁵ m g / L (the law itself is `common::linear_law`); and the rod dropped
//! onto a plane, a contract of every backend.

use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::shape::{Quat, Spherocylinder};
use sweep::engine::walls::Wall;
use sweep::engine::{Backend, EngineConfig, State, V3};

use super::backends::On;

pub const L: f64 = 0.125;
pub const RHO: f64 = 2600.0;
pub const G: f64 = 1.0;

pub fn shape(xi: f64) -> Spherocylinder<f64> {
    Spherocylinder::from_aspect_ratio(L, xi).unwrap()
}

/// k_n = 2e5 m g / L (the chute's) and dt = t_c/50 with m* = m/2.
pub fn stiffness(xi: f64) -> (f64, f64) {
    let m = shape(xi).mass(RHO);
    let kn = 2e5 * m * G / L;
    let tc = std::f64::consts::PI * (0.5 * m / kn).sqrt();
    (kn, tc / 50.0)
}

/// Rods of ξ with the linear law (restitution `e`, friction `mu`) against `walls`, gravity
/// `gravity` along −z, not periodic, at the stiffness's dt.
pub fn config(xi: f64, e: f64, mu: f64, gravity: f64, walls: Vec<Wall>) -> EngineConfig {
    let (kn, dt) = stiffness(xi);
    EngineConfig {
        dt_s: dt,
        gravity: [0.0, 0.0, -gravity],
        particle_law: super::linear_law(kn, e, mu),
        wall_law: super::linear_law(kn, e, mu),
        walls,
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.05 * L,
    }
}

/// Total linear momentum and total angular momentum about the origin (orbital plus spin).
pub fn momenta(s: &State<f64>) -> (V3<f64>, V3<f64>) {
    let (mut p, mut l) = (V3::zero(), V3::zero());
    for i in 0..s.len() {
        let mv = s.vel[i] * s.mass[i];
        p += mv;
        l += s.pos[i].cross(mv) + s.ang_mom[i];
    }
    (p, l)
}

pub fn energy_with_gravity(s: &State<f64>) -> f64 {
    s.kinetic_energy()
        + (0..s.len())
            .map(|i| s.mass[i] * G * s.pos[i].z)
            .sum::<f64>()
}

/// One rod of ξ = 2.5 with its axis at `tilt_deg` from the vertical, its lowest point L/4 above
/// the plane z = 0, under g = 1 (e = 0.5, μ = 0.5).
pub fn dropped(tilt_deg: f64) -> (EngineConfig, State<f64>) {
    let xi = 2.5;
    let sh = shape(xi);
    let t = tilt_deg.to_radians();
    let axis = V3::new(t.sin(), 0.0, t.cos());
    let z = sh.radius + sh.half_length * t.cos() + 0.25 * L;
    let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
    let q = Quat::<f64>::from_axis_z(axis).to_f64();
    s.push_spherocylinder(0, [0.0, 0.0, z], [0.0; 3], q, sh, RHO, false);
    let floor = super::plane([0.0; 3], [0.0, 0.0, 1.0]);
    (config(xi, 0.5, 0.5, G, vec![floor]), s)
}

/// Runs the dropped rod on `b` for 80 000 steps (the fall, a few bounces, the fall over and the
/// damping of the rocking); returns the final state, the largest relative rise of kinetic +
/// potential energy (sampled every 200 steps) and the drop energy.
pub fn drop_rod(b: &mut dyn Backend) -> (State<f64>, f64, f64) {
    let s0 = b.download();
    let e0 = energy_with_gravity(&s0);
    let drop = e0 - s0.mass[0] * G * s0.radius[0];
    let mut worst = f64::MIN;
    for _ in 0..400 {
        b.advance(200).unwrap();
        worst = worst.max((energy_with_gravity(&b.download()) - e0) / e0);
    }
    (b.download(), worst, drop)
}

/// The contract: a dropped rod never gains energy (contacts only dissipate) and comes to rest.
/// The CPU's energy may rise by 1e-6 of its start and its rest is K < 1e-8 of the drop energy;
/// the GPU keeps each velocity's and L's rest below f32 (measured rise ≤ 3.3e-11): 1e-8, and
/// K < 1e-6. Returns the rest state.
pub fn dropped_rod_comes_to_rest(on: &On, tilt_deg: f64) -> State<f64> {
    let (cfg, s) = dropped(tilt_deg);
    let (fin, rise, drop) = drop_rod(&mut *on.build(&cfg, &s));
    let ke = fin.kinetic_energy();
    eprintln!(
        "{}: drop at {tilt_deg}°: energy rise {rise:.2e}, K/drop {:.2e}",
        on.name(),
        ke / drop
    );
    let rise_limit = on.pick(1e-6, 1e-8);
    assert!(
        rise < rise_limit,
        "tilt {tilt_deg}°: kinetic + potential energy rose by {rise:e} of its initial value (limit {rise_limit:e})"
    );
    let rest_limit = on.pick(1e-8, 1e-6);
    assert!(
        ke < rest_limit * drop,
        "tilt {tilt_deg}°: not at rest, kinetic energy {ke:e} J vs drop energy {drop:e} J (limit {rest_limit:e})"
    );
    fin
}
