//! Spherocylinders in the CPU engine (oriented path), each test against a conservation law or an
//! exact property, tolerances stated:
//! - a rod dropped flat, on its end, and tilted onto a plane: kinetic + potential energy never
//!   exceeds its initial value by more than 1e-6 relative (contacts only dissipate), and it comes
//!   to rest (kinetic energy < 1e-8 of the drop energy): the contract
//!   `rods::dropped_rod_comes_to_rest`, on the GPU in gpu_rods.rs; here it also lies flat, or
//!   stands when dropped exactly upright;
//! - an elastic (e = 1, μ = 0) gas of rods in a periodic box conserves kinetic + elastic energy
//!   within 1e-4 over 10⁴ steps at dt = t_c/50 — wrong lever arms or a non-conservative contact
//!   point would pump energy;
//! - frictional, inelastic rods colliding in free space: total linear momentum and total angular
//!   momentum (orbital + spin) constant within 1e-10 relative;
//! - 1 and 2 threads give bitwise identical states; a checkpoint round trip and resume gives the
//!   bitwise identical state to an uninterrupted run;
//! - ξ = 1 through the oriented path follows the sphere path within 1e-9 relative (the two store
//!   tangential springs differently, so they may differ by rounding only);
//! - the overlap watchdog's error names the deepest contact (rod and wall, two rods, two spheres).

use crate::common::backends::On;
use crate::common::linear_law as law;
use crate::common::rods::{self, momenta, shape, stiffness, G, L, RHO};
use crate::common::{plane, Noise};

use sweep::checkpoint::{self, Header};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::real::V3;
use sweep::engine::shape::{contact_spherocylinders, rotational_energy, Quat, Spherocylinder};
use sweep::engine::{Backend, CpuEngine, EngineConfig, State};

/// The dropped rod's contract on the CPU (`rods::dropped_rod_comes_to_rest`).
fn drop_rod(tilt_deg: f64) -> State<f64> {
    rods::dropped_rod_comes_to_rest(&On::Cpu, tilt_deg)
}

#[test]
fn a_rod_dropped_flat_comes_to_rest_flat() {
    let s = drop_rod(90.0);
    let u = s.orientation[0].axis_z();
    let sh = shape(2.5);
    assert!(u.z.abs() < 1e-6, "axis tilted: u_z = {}", u.z);
    // Static overlap: the weight on the plane, m g = k_n δ (one contact under the centre).
    let (kn, _) = stiffness(2.5);
    let delta = s.mass[0] * G / kn;
    let expect = sh.radius - delta;
    assert!(
        (s.pos[0].z - expect).abs() < 1e-3 * delta,
        "height {} vs {expect} (δ = {delta:e})",
        s.pos[0].z
    );
}

#[test]
fn a_rod_dropped_upright_comes_to_rest_upright() {
    let s = drop_rod(0.0);
    let u = s.orientation[0].axis_z();
    assert!((u.z - 1.0).abs() < 1e-12, "axis tilted: u_z = {}", u.z);
    let sh = shape(2.5);
    let (kn, _) = stiffness(2.5);
    let expect = sh.half_length + sh.radius - s.mass[0] * G / kn;
    assert!((s.pos[0].z - expect).abs() < 1e-3 * sh.radius * 1e-2);
}

#[test]
fn a_tilted_rod_falls_over_and_lies_flat() {
    let s = drop_rod(30.0);
    let u = s.orientation[0].axis_z();
    assert!(u.z.abs() < 1e-4, "axis still tilted: u_z = {}", u.z);
    assert!((s.pos[0].z - shape(2.5).radius).abs() < 1e-3 * L);
}

/// `n` rods of ξ at random non-overlapping positions and orientations in a periodic cube of side
/// `box_l`, with random velocities and spins.
fn rod_gas(n: usize, xi: f64, box_l: f64, friction: bool, seed: u64) -> State<f64> {
    let sh = shape(xi);
    let mut noise = Noise::new(seed);
    let mut s = State::<f64>::new_oriented(if friction { HISTORY_SLOTS } else { 0 });
    let mut placed: Vec<(V3<f64>, V3<f64>)> = Vec::new();
    let min_image = |mut d: V3<f64>| {
        d.x -= box_l * (d.x / box_l).round();
        d.y -= box_l * (d.y / box_l).round();
        d.z -= box_l * (d.z / box_l).round();
        d
    };
    while placed.len() < n {
        // Clear of the plane walls at z = 0 and z = box_l.
        let reach = sh.half_length + sh.radius;
        let c = V3::new(
            box_l * 0.5 * (noise.next() + 1.0),
            box_l * 0.5 * (noise.next() + 1.0),
            reach + (box_l - 2.0 * reach) * 0.5 * (noise.next() + 1.0),
        );
        let u = V3::new(noise.next(), noise.next(), noise.next());
        if u.norm() < 0.1 || u.norm() > 1.0 {
            continue;
        }
        let u = u * (1.0 / u.norm());
        if placed
            .iter()
            .any(|&(p, v)| contact_spherocylinders(min_image(c - p), u, &sh, v, &sh).is_some())
        {
            continue;
        }
        placed.push((c, u));
    }
    for (k, (c, u)) in placed.iter().enumerate() {
        let v = [noise.next() * 0.3, noise.next() * 0.3, noise.next() * 0.3];
        s.push_spherocylinder(
            k as u32,
            c.to_f64(),
            v,
            Quat::from_axis_z(*u).to_f64(),
            sh,
            RHO,
            false,
        );
        s.set_angular_velocity(
            k,
            [noise.next() * 3.0, noise.next() * 3.0, noise.next() * 3.0],
        );
    }
    s
}

fn periodic_config(xi: f64, box_l: f64, e: f64, mu: f64, periodic_z_walls: bool) -> EngineConfig {
    let (kn, dt) = stiffness(xi);
    let walls = if periodic_z_walls {
        vec![
            plane([0.0; 3], [0.0, 0.0, 1.0]),
            plane([0.0, 0.0, box_l], [0.0, 0.0, -1.0]),
        ]
    } else {
        Vec::new()
    };
    EngineConfig {
        dt_s: dt,
        gravity: [0.0; 3],
        particle_law: law(kn, e, mu),
        wall_law: law(kn, e, mu),
        walls,
        periodic_x: Some([0.0, box_l]),
        periodic_y: Some([0.0, box_l]),
        sink_z: None,
        skin_m: 0.05 * L,
    }
}

/// Kinetic energy plus Σ ½ k_n δ² over rod pairs and rod–wall contacts (f64, minimum image).
fn elastic_total(s: &State<f64>, kn: f64, box_l: f64) -> f64 {
    let mut e = s.kinetic_energy();
    let sh = |k: usize| Spherocylinder {
        half_length: s.half_length[k],
        radius: s.radius[k],
    };
    for i in 0..s.len() {
        let ui = s.orientation[i].axis_z();
        for j in 0..i {
            let mut d = s.pos[i] - s.pos[j];
            d.x -= box_l * (d.x / box_l).round();
            d.y -= box_l * (d.y / box_l).round();
            if let Some(c) =
                contact_spherocylinders(d, ui, &sh(i), s.orientation[j].axis_z(), &sh(j))
            {
                e += 0.5 * kn * c.overlap * c.overlap;
            }
        }
        // Walls at z = 0 and z = box_l: the lower/upper axis end.
        let h = (ui * s.half_length[i]).z.abs();
        for gap in [s.pos[i].z - h, box_l - s.pos[i].z - h] {
            let ov = s.radius[i] - gap;
            if ov > 0.0 {
                e += 0.5 * kn * ov * ov;
            }
        }
    }
    e
}

#[test]
fn an_elastic_rod_gas_conserves_energy() {
    let (xi, box_l) = (2.0, 6.0 * L);
    let s = rod_gas(120, xi, box_l, false, 11);
    let (kn, _) = stiffness(xi);
    let e0 = elastic_total(&s, kn, box_l);
    let mut e = CpuEngine::<f64>::new(periodic_config(xi, box_l, 1.0, 0.0, true), s, 1);
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        e.advance(100).unwrap();
        let st = e.download();
        worst = worst.max(((elastic_total(&st, kn, box_l) - e0) / e0).abs());
    }
    assert!(
        worst < 1e-4,
        "energy drifted by {worst:e} of its initial value over 10⁴ steps"
    );
}

#[test]
fn colliding_rods_conserve_linear_and_angular_momentum() {
    let xi = 3.0;
    // A big periodic box is never crossed in this time: free space for the angular momentum.
    let box_l = 40.0 * L;
    let mut s = rod_gas(0, xi, box_l, true, 1);
    let sh = shape(xi);
    let mut noise = Noise::new(5);
    // Two clusters of rods flying into each other.
    let mut k = 0u32;
    for (cx, vx) in [(19.0 * L, 1.0), (21.0 * L, -1.0)] {
        for a in 0..3 {
            for b in 0..3 {
                let c = [cx, (18.0 + a as f64 * 1.6) * L, (18.0 + b as f64 * 1.6) * L];
                let u = V3::new(noise.next(), noise.next(), 0.3 + noise.next().abs());
                let u = u * (1.0 / u.norm());
                s.push_spherocylinder(
                    k,
                    c,
                    [vx, 0.1 * noise.next(), 0.1 * noise.next()],
                    Quat::from_axis_z(u).to_f64(),
                    sh,
                    RHO,
                    false,
                );
                k += 1;
            }
        }
    }
    let (p0, l0) = momenta(&s);
    let mut e = CpuEngine::<f64>::new(periodic_config(xi, box_l, 0.5, 0.5, false), s, 1);
    e.advance(4000).unwrap();
    let st = e.download();
    let (p1, l1) = momenta(&st);
    // The first cluster (ids 0..9) flew at +1 m/s: the collision must have slowed it.
    let vx: f64 = (0..st.len())
        .filter(|&i| st.id[i] < 9)
        .map(|i| st.vel[i].x)
        .sum::<f64>()
        / 9.0;
    assert!(vx < 0.8, "the clusters never met (mean v_x {vx})");
    let scale_p = st.mass[0] * 1.0 * st.len() as f64;
    let scale_l = scale_p * 20.0 * L;
    assert!(
        (p1 - p0).norm() < 1e-10 * scale_p,
        "momentum changed by {:e}",
        (p1 - p0).norm()
    );
    assert!(
        (l1 - l0).norm() < 1e-10 * scale_l,
        "angular momentum changed by {:e} (scale {scale_l:e})",
        (l1 - l0).norm()
    );
    // Rotational energy is consistent with the stored angular momenta.
    let er: f64 = (0..st.len())
        .map(|i| rotational_energy(st.orientation[i], st.inv_inertia_body[i], st.ang_mom[i]))
        .sum();
    let ew: f64 = (0..st.len())
        .map(|i| 0.5 * st.omega[i].dot(st.ang_mom[i]))
        .sum();
    assert!((er - ew).abs() < 1e-12 * er.max(1e-300));
}

#[test]
fn threads_and_checkpoints_do_not_change_a_rod_run() {
    let (xi, box_l) = (1.5, 5.0 * L);
    let mut config = periodic_config(xi, box_l, 0.7, 0.5, true);
    config.gravity = [0.3, 0.0, -1.0];
    let s = rod_gas(150, xi, box_l, true, 3);
    let run = |threads: usize, split: bool| {
        let mut e = CpuEngine::<f64>::new(config.clone(), s.clone(), threads);
        e.advance(700).unwrap();
        if split {
            let h = Header {
                job_hash: "x".into(),
                step: 700,
                time_s: 0.0,
                backend: "cpu".into(),
                precision: "f64".into(),
            };
            let bytes = checkpoint::encode(&h, &e.download(), "");
            let (_, back, _) = checkpoint::decode(&bytes, "mem", Some("x")).unwrap();
            e = CpuEngine::<f64>::new(config.clone(), back, threads);
        }
        e.advance(700).unwrap();
        e.download()
    };
    let one = run(1, false);
    assert!(one
        .orientation
        .iter()
        .all(|q| (q.norm2() - 1.0).abs() < 1e-14));
    assert_eq!(one, run(2, false), "1 and 2 threads differ");
    assert_eq!(
        one,
        run(1, true),
        "a resumed run differs from an uninterrupted one"
    );
}

#[test]
fn spheres_through_the_oriented_path_match_the_sphere_path() {
    let (xi, box_l) = (1.0, 5.0 * L);
    let mut config = periodic_config(xi, box_l, 0.7, 0.5, true);
    config.gravity = [0.3, 0.0, -1.0];
    let rods = rod_gas(60, xi, box_l, true, 9);
    let mut spheres = State::<f64>::new(true, HISTORY_SLOTS);
    for i in 0..rods.len() {
        spheres.push_sphere(
            rods.id[i],
            rods.pos[i].to_f64(),
            rods.vel[i].to_f64(),
            rods.radius[i],
            RHO,
            false,
        );
        spheres.omega[i] = rods.omega[i];
    }
    let mut a = CpuEngine::<f64>::new(config.clone(), rods, 1);
    let mut b = CpuEngine::<f64>::new(config, spheres, 1);
    a.advance(1000).unwrap();
    b.advance(1000).unwrap();
    let (sa, sb) = (a.download(), b.download());
    let mut by_id = std::collections::HashMap::new();
    for i in 0..sb.len() {
        by_id.insert(sb.id[i], i);
    }
    let mut worst: f64 = 0.0;
    for i in 0..sa.len() {
        let j = by_id[&sa.id[i]];
        worst = worst.max((sa.pos[i] - sb.pos[j]).norm() / L);
        worst = worst.max((sa.vel[i] - sb.vel[j]).norm() / 0.3);
        worst = worst.max((sa.omega[i] - sb.omega[j]).norm() / 3.0);
    }
    assert!(
        worst < 1e-9,
        "oriented and sphere paths differ by {worst:e}"
    );
}

/// The overlap watchdog names the deepest contact, so that a user can tell what went wrong: a
/// rod pressed 0.3 d into the floor (wall 0), two rods crossing 0.3 d deep, or a sphere 0.3 d
/// deep in a fixed one stop the first step with an error that names them.
#[test]
fn the_overlap_watchdog_names_the_deepest_contact() {
    let xi = 2.5;
    let sh = shape(xi);
    let d = 2.0 * sh.radius;
    let flat = Quat::<f64>::from_axis_z(V3::new(1.0, 0.0, 0.0)).to_f64();
    let floor = plane([0.0; 3], [0.0, 0.0, 1.0]);
    let cfg = rods::config(xi, 0.5, 0.5, G, vec![floor]);
    let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
    s.push_spherocylinder(
        0,
        [0.0, 0.0, sh.radius - 0.3 * d],
        [0.0; 3],
        flat,
        sh,
        RHO,
        false,
    );
    stops_naming(&cfg, s, &["particle 0 (mobile", "and wall 0"]);
    // Two rods lying crossed, well above the floor, their axes 0.7 d apart.
    let across = Quat::<f64>::from_axis_z(V3::new(0.0, 1.0, 0.0)).to_f64();
    let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
    s.push_spherocylinder(3, [0.0, 0.0, L], [0.0; 3], flat, sh, RHO, false);
    s.push_spherocylinder(8, [0.0, 0.0, L + 0.7 * d], [0.0; 3], across, sh, RHO, false);
    stops_naming(
        &cfg,
        s,
        &["between particle 3 (mobile", "and particle 8 (mobile"],
    );
    // The sphere path (its motion lives outside the state while a chunk runs).
    let r = 0.5 * L;
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    s.push_sphere(0, [0.0, 0.0, L], [0.0; 3], r, RHO, true);
    s.push_sphere(1, [0.0, 0.0, L + 1.4 * r], [0.0; 3], r, RHO, false);
    let cfg = rods::config(1.0, 0.5, 0.5, G, vec![]);
    stops_naming(
        &cfg,
        s,
        &["between particle 0 (fixed", "and particle 1 (mobile"],
    );
}

/// One step of `s` stops on the overlap watchdog, whose error names a contact 0.3 d deep and
/// contains each of `parts`.
fn stops_naming(cfg: &EngineConfig, s: State<f64>, parts: &[&str]) {
    let text = CpuEngine::<f64>::new(cfg.clone(), s, 1)
        .advance(1)
        .unwrap_err()
        .to_string();
    assert!(text.contains("deepest contact 0.3"), "{text}");
    for p in parts {
        assert!(text.contains(p), "no {p:?} in: {text}");
    }
}
