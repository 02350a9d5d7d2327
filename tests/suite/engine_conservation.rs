//! Conservation laws and the periodic seam.
//! - An elastic (e = 1, μ = 0) gas of 200 spheres, periodic in x and y between plane walls in z,
//!   no gravity: kinetic plus elastic energy (Σ ½ k_n δ² for the linear law, Σ 8/15 Y* √R* δ^{5/2}
//!   for Hertz, walls included, computed here from the downloaded state with the minimum image)
//!   stays within 1e-4 of its initial value over 10⁴ steps at dt = t_c/50; on the GPU too
//!   (`common::backends`), within 1.5 times the drift of CPU f32 and f64 runs.
//! - A particle crossing the seam keeps its velocity bit for bit (no contact acts on it), and a
//!   frictional contact straddling both seams exerts the same force and torque as the same
//!   contact in the middle of the box, within 1e-12 relative (f64).
//! - 300 frictional, inelastic spheres colliding, fully periodic in x and y, no walls, no
//!   gravity: total linear momentum constant within 1e-10 relative over 10³ steps (f64).
//!
//! A failure means a force is not applied equally and oppositely, the minimum image or the wrap
//! is wrong, or the integrator injects or removes energy.

use crate::common;
use crate::common::backends::{per_backend, On};
use crate::common::Noise;

use std::f64::consts::PI;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, NormalModel};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::walls::Wall;
use sweep::engine::{Backend, CpuEngine, EngineConfig, State};

const R: f64 = 0.0029;
const D: f64 = 2.0 * R;
const RHO: f64 = 2655.0;

fn mass() -> f64 {
    RHO * 4.0 / 3.0 * PI * R.powi(3)
}

fn config(law: ContactLaw, dt: f64, walls: Vec<Wall>, l: f64) -> EngineConfig {
    EngineConfig {
        dt_s: dt,
        gravity: [0.0; 3],
        particle_law: law,
        wall_law: law,
        walls,
        periodic_x: Some([0.0, l]),
        periodic_y: Some([0.0, l]),
        sink_z: None,
        skin_m: 0.2 * R,
    }
}

/// `n` spheres on a cubic lattice of spacing `a` filling an `l` × `l` × `h` box, with random
/// velocities of amplitude `v` per component plus the common drift `drift`.
fn gas(n: usize, l: f64, h: f64, v: f64, drift: [f64; 3], friction: bool, seed: u64) -> State<f64> {
    let mut s = State::<f64>::new(friction, if friction { HISTORY_SLOTS } else { 0 });
    let (nx, nz) = (
        (l / (1.2 * D)).floor() as usize,
        (h / (1.2 * D)).floor() as usize,
    );
    assert!(nx * nx * nz >= n, "box too small for {n} spheres");
    let (a, c) = (l / nx as f64, h / nz as f64);
    let mut noise = Noise::new(seed);
    for k in 0..n {
        let (i, j, m) = (k % nx, (k / nx) % nx, k / (nx * nx));
        let p = [
            (i as f64 + 0.5) * a,
            (j as f64 + 0.5) * a,
            (m as f64 + 0.5) * c,
        ];
        let u = [
            drift[0] + v * noise.next(),
            drift[1] + v * noise.next(),
            drift[2] + v * noise.next(),
        ];
        s.push_sphere(k as u32, p, u, R, RHO, false);
    }
    s
}

/// Elastic energy stored in the contacts of `s` (J), with the minimum image in x and y.
fn elastic_energy(s: &State<f64>, law: &ContactLaw, l: f64, h: f64) -> f64 {
    // Energy of an overlap δ at effective radius r.
    let u = |delta: f64, r: f64| match law.normal {
        NormalModel::Linear { kn_n_per_m, .. } => 0.5 * kn_n_per_m * delta * delta,
        NormalModel::Hertz(el) => 8.0 / 15.0 * el.effective().0 * r.sqrt() * delta.powf(2.5),
    };
    let image = |d: f64| d - l * (d / l + 0.5).floor();
    let mut e = 0.0;
    for i in 0..s.len() {
        let (pi, ri) = (s.pos[i], s.radius[i]);
        for j in i + 1..s.len() {
            let (pj, rj) = (s.pos[j], s.radius[j]);
            let d = [image(pi.x - pj.x), image(pi.y - pj.y), pi.z - pj.z];
            let delta = ri + rj - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if delta > 0.0 {
                e += u(delta, ri * rj / (ri + rj));
            }
        }
        for delta in [ri - pi.z, ri - (h - pi.z)] {
            if delta > 0.0 {
                e += u(delta, ri);
            }
        }
    }
    e
}

/// The elastic gas: 200 spheres in a 10 d cube, periodic in x and y between planes in z, at
/// dt = t_c/50 (t_c at 2 m/s, above the gas's fastest relative speed).
fn gas_setup(law: ContactLaw) -> (EngineConfig, State<f64>) {
    let (l, h) = (GAS_BOX, GAS_BOX);
    let walls = vec![
        common::plane([0.0; 3], [0.0, 0.0, 1.0]),
        common::plane([0.0, 0.0, h], [0.0, 0.0, -1.0]),
    ];
    let dt = contact_time(
        &law,
        ContactPair {
            r_eff: R / 2.0,
            m_eff: mass() / 2.0,
        },
        2.0,
    ) / 50.0;
    (
        config(law, dt, walls, l),
        gas(200, l, h, 0.5, [0.0; 3], false, 7),
    )
}

/// Side and height of the elastic gas's box.
const GAS_BOX: f64 = 10.0 * D;

/// Largest |ΔE|/E over 10⁴ steps (sampled every 100), and the most contacts per particle.
fn energy_drift(b: &mut dyn Backend, law: &ContactLaw) -> (f64, f64) {
    let total = |s: &State<f64>| s.kinetic_energy() + elastic_energy(s, law, GAS_BOX, GAS_BOX);
    let e0 = total(&b.download());
    let (mut worst, mut contacts): (f64, f64) = (0.0, 0.0);
    for _ in 0..100 {
        let report = b.advance(100).unwrap();
        contacts = contacts.max(report.contacts_per_particle);
        worst = worst.max((total(&b.download()) - e0).abs() / e0);
    }
    (worst, contacts)
}

/// Kinetic plus elastic energy within 1e-4 of its start on the CPU. On the GPU within 1.5 times
/// the larger drift of CPU f32 and f64 runs: the drift is the integrator's, and its sampled size
/// varies between realisations of the chaotic gas (measured: linear GPU 1.02e-4, CPU f32 8.3e-5,
/// CPU f64 8.3e-5; Hertz 1.7e-5, 1.6e-5, 1.6e-5).
fn elastic_gas_conserves_energy(on: &On, name: &str, law: ContactLaw) {
    let (cfg, s) = gas_setup(law);
    let (drift, contacts) = energy_drift(&mut *on.build(&cfg, &s), &law);
    let limit = match on {
        On::Cpu => 1e-4,
        On::Gpu(_) => {
            let (f32_drift, _) = energy_drift(&mut common::gpu::cpu_f32(&cfg, &s), &law);
            let (f64_drift, _) = energy_drift(&mut *On::Cpu.build(&cfg, &s), &law);
            eprintln!("{name}: CPU f32 |ΔE|/E ≤ {f32_drift:.3e}, CPU f64 {f64_drift:.3e}");
            1.5 * f32_drift.max(f64_drift)
        }
    };
    eprintln!(
        "{}: {name}: dt = {:.3e} s, contacts per particle up to {contacts:.3}, |ΔE|/E ≤ {drift:.3e} (limit {limit:.3e})",
        on.name(),
        cfg.dt_s
    );
    assert!(
        contacts > 0.1,
        "{name}: too few collisions to test anything ({contacts} contacts per particle)"
    );
    assert!(
        drift < limit,
        "{name}: energy drifted by {drift:.3e} of its initial value (limit {limit:.3e})"
    );
}

fn elastic_gas_conserves_energy_linear(on: &On) {
    let law = ContactLaw {
        normal: NormalModel::Linear {
            kn_n_per_m: 1.0e4,
            kt_n_per_m: 0.0,
        },
        restitution: 1.0,
        tangential_restitution: 1.0,
        friction: 0.0,
    };
    elastic_gas_conserves_energy(on, "linear", law);
}

fn elastic_gas_conserves_energy_hertz(on: &On) {
    elastic_gas_conserves_energy(on, "Hertz", common::hertz_shear_law(3.0e7, 1.0, 0.0));
}

per_backend!(
    elastic_gas_conserves_energy_linear,
    elastic_gas_conserves_energy_hertz
);

fn frictional_law() -> ContactLaw {
    common::hertz_law(3.0e7, 0.8, 0.5)
}

#[test]
fn crossing_the_seam_keeps_the_velocity_bitwise() {
    let law = frictional_law();
    let l = 10.0 * D;
    let v0 = [0.7, -0.45, 0.013];
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    s.push_sphere(0, [l - 0.3 * D, 0.2 * D, 0.0], v0, R, RHO, false);
    let dt = 1.0e-5;
    let mut e = CpuEngine::new(config(law, dt, vec![], l), s, 1);
    let steps = 4_000; // x travels 0.028 m (crosses x = l), y travels −0.018 m (crosses y = 0)
    e.advance(steps).unwrap();
    let s = e.download();
    let v = s.vel[0];
    assert_eq!(
        [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()],
        v0.map(f64::to_bits),
        "velocity changed across the seam: {v:?}"
    );
    let t = steps as f64 * dt;
    let expected = [
        l - 0.3 * D + v0[0] * t - l,
        0.2 * D + v0[1] * t + l,
        v0[2] * t,
    ];
    let p = s.pos[0].to_f64();
    for k in 0..3 {
        assert!(
            (p[k] - expected[k]).abs() < 1e-12,
            "position {p:?} is not the wrapped straight line {expected:?}"
        );
    }
}

/// Force and torque on particles 0 and 1 after 20 steps of a frictional contact whose first
/// particle starts at `p0`, the second at p0 + `sep` (wrapped into the box).
fn pair(p0: [f64; 3], l: f64) -> [[f64; 3]; 4] {
    let law = frictional_law();
    // Separation 0.98 d along an oblique direction: the pair straddles the x and y seams when p0
    // sits near the box corner.
    let dir: [f64; 3] = [0.7, 0.6, 0.3];
    let norm = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let sep = dir.map(|c| 0.98 * D * c / norm);
    let wrap = |x: f64| x - l * (x / l).floor();
    let p1 = [wrap(p0[0] + sep[0]), wrap(p0[1] + sep[1]), p0[2] + sep[2]];
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    // Approaching and sliding past each other, so the normal, damping and spring all act.
    s.push_sphere(0, p0, [0.05, 0.02, -0.03], R, RHO, false);
    s.push_sphere(1, p1, [-0.04, 0.03, 0.01], R, RHO, false);
    let dt = contact_time(
        &law,
        ContactPair {
            r_eff: R / 2.0,
            m_eff: mass() / 2.0,
        },
        1.0,
    ) / 50.0;
    let mut e = CpuEngine::new(config(law, dt, vec![], l), s, 1);
    e.advance(20).unwrap();
    let s = e.download();
    let a = s.id.iter().position(|&i| i == 0).unwrap();
    let b = 1 - a;
    [
        s.force[a].to_f64(),
        s.force[b].to_f64(),
        s.torque[a].to_f64(),
        s.torque[b].to_f64(),
    ]
}

#[test]
fn contact_across_the_seam_equals_contact_inside() {
    let l = 10.0 * D;
    let inside = pair([0.5 * l, 0.5 * l, 0.0], l);
    let seam = pair([l - 0.3 * D, l - 0.2 * D, 0.0], l);
    let names = ["force on 0", "force on 1", "torque on 0", "torque on 1"];
    for k in 0..4 {
        let (a, b) = (inside[k], seam[k]);
        let mag = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let diff = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        eprintln!(
            "{}: inside {a:?}, across the seam {b:?}, relative difference {:.2e}",
            names[k],
            diff / mag
        );
        assert!(mag > 0.0, "{}: no contact formed", names[k]);
        assert!(
            diff <= 1e-12 * mag,
            "{}: {a:?} inside but {b:?} across the seam",
            names[k]
        );
    }
}

#[test]
fn frictional_collisions_conserve_momentum() {
    let law = frictional_law();
    let l = 10.0 * D;
    let s = gas(300, l, 6.0 * D, 1.0, [0.3, -0.2, 0.1], true, 11);
    let dt = contact_time(
        &law,
        ContactPair {
            r_eff: R / 2.0,
            m_eff: mass() / 2.0,
        },
        3.0,
    ) / 50.0;
    let mut e = CpuEngine::new(config(law, dt, vec![], l), s, 1);
    let p0 = e.download().momentum();
    let norm0 = (p0[0] * p0[0] + p0[1] * p0[1] + p0[2] * p0[2]).sqrt();
    let mut worst: f64 = 0.0;
    let mut contacts: f64 = 0.0;
    for _ in 0..10 {
        let r = e.advance(100).unwrap();
        contacts = contacts.max(r.contacts_per_particle);
        let p = e.download().momentum();
        let diff =
            ((p[0] - p0[0]).powi(2) + (p[1] - p0[1]).powi(2) + (p[2] - p0[2]).powi(2)).sqrt();
        worst = worst.max(diff / norm0);
    }
    let ke = e.download().kinetic_energy();
    eprintln!("momentum: |P0| = {norm0:.6e} kg m/s, largest |ΔP|/|P0| = {worst:.3e}, contacts per particle up to {contacts:.3}, final KE {ke:.3e} J");
    assert!(
        contacts > 0.1,
        "too few collisions to test anything ({contacts} contacts per particle)"
    );
    assert!(
        worst < 1e-10,
        "momentum changed by {worst:.3e} of |P0| (limit 1e-10)"
    );
}

/// Law: the engine's workers count the CPU time of the steps. The steps run on the engine's
/// pool, not on the caller (it waits), so over an advance of the elastic gas the workers run
/// most of the wall time and the caller little of it. A failure means a worker thread's clock
/// is not registered (the job's CPU time would leave out its steps) or is counted twice.
#[test]
fn an_engines_workers_count_the_cpu_time_of_its_steps() {
    let (cfg, s) = gas_setup(frictional_law());
    let mut e = CpuEngine::new(cfg, s, 2);
    let before = e.workers_cpu_s().expect("Linux gives thread clocks");
    let caller0 = sweep::engine::cpu_clock::this_thread_s().unwrap();
    let t0 = std::time::Instant::now();
    e.advance(20_000).unwrap();
    let wall = t0.elapsed().as_secs_f64();
    let workers = e.workers_cpu_s().unwrap() - before;
    let caller = sweep::engine::cpu_clock::this_thread_s().unwrap() - caller0;
    eprintln!("advance: {wall:.3} s wall, workers {workers:.3} s CPU, caller {caller:.3} s");
    assert!(workers > 0.3 * wall, "workers ran {workers} s of {wall} s");
    // Two pool threads and one team helper at most.
    assert!(
        workers <= 3.0 * wall + 0.05,
        "workers ran {workers} s of {wall} s"
    );
    assert!(
        caller < 0.2 * wall + 0.02,
        "the caller ran {caller} s of {wall} s"
    );
}
