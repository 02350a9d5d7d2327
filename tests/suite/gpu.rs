//! The GPU backend against the CPU backend in f32 (run on lavapipe where there is no GPU).
//! - One step's forces and torques on a random dense packing (polydisperse, some fixed spheres,
//!   random velocities, spins and stored tangential springs) match `CpuEngine<f32>` within 1e-5
//!   relative, for Hertz–Mindlin and linear spring–dashpot, with a closed rotating plate and a
//!   tilted plane under periodic x/y, and with a cylinder, a rotating orifice plate (rim contacts
//!   included) and a tilted plane. Positions are quantised so that the drift is exact in f32 on
//!   both sides: what is compared is the force evaluation alone. "Relative" is |ΔF| / |F| with
//!   |F| floored at 1e-3 of the packing's rms force (forces that nearly cancel). Torques, whose
//!   terms cancel more (rim contacts), are held against the CPU f64 result: within 1e-5, or no
//!   farther than twice the CPU f32 result is (both then err by f32 rounding, summed in
//!   different orders). History rows hold the same partners with springs within 1e-5 relative.
//!   Measured on lavapipe: forces ≤ 4e-7, springs ≤ 3e-7; torques against f64: GPU ≤ 1.4e-4,
//!   CPU f32 ≤ 1.4e-4 (the two within 10 % of each other).
//! - Head-on collisions (linear and Hertz): restitution and contact time within 1e-4 of the CPU
//!   f32 values (their analytic values are engine_collisions.rs's contracts, run on the GPU too).
//! - 1000 steps of a frictional packing falling under gravity (periodic onto a rotating plate, and
//!   a silo with a rotating orifice plate and a sink) stay within 1e-2 d in position and 5e-2 of
//!   the largest speed of the CPU f32 run, and no farther from the CPU f64 run than CPU f32 is
//!   (the GPU keeps each velocity's rest, so it may sit nearer f64); the same particles are
//!   removed at the same steps. GPU and CPU sum contacts in different orders, so they differ by
//!   rounding, which the dynamics amplifies like any f32 rounding.
//! - Checkpoints move both ways: GPU → CPU and CPU → GPU continuations stay within the same
//!   bounds of straight runs, and a GPU run resumed from its own download is bit-identical.
//! - Particles raining into a sink: the GPU follows the free-fall parabola within 10⁻⁶ d and
//!   10⁻⁷ m/s over 900 steps (CPU f32, which rounds each velocity to f32, within 10⁻³ d and
//!   10⁻⁴ m/s; measured 4·10⁻⁷ d against 1.8·10⁻⁴ d) and removes each particle at the step the
//!   parabola crosses the sink (CPU f32 at that step or the next), with the same masses; removed
//!   particles never show in a download (the GPU compacts them lazily).
//! - A full history table, an overlap beyond the watchdog and a non-finite velocity fail with the
//!   CPU engine's errors (the non-finite one word for word); 17 walls are refused.
//! - `sweep bench --backend gpu --allow-software-gpu` runs, and refuses f64 with a clear message;
//!   without the flag a software adapter (all CI has) is refused with a message naming the flag,
//!   and `--gpu 99` is refused with the number of adapters there are.
//!
//! Without an adapter the tests print a message and pass, except under CI=true, where a missing
//! adapter fails them. A failure of the parity tests means a kernel's formula or order departs
//! from the CPU engine's; of the trajectory tests, a missed contact or a wrong integration step.

use crate::common;
use crate::common::gpu::{by_id, cpu_f32 as cpu, device, engine as gpu, quantise, worst_relative};
use crate::common::{plane, Noise};

use std::collections::HashMap;
use std::f64::consts::PI;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, NormalModel};
use sweep::engine::gpu::{GpuDevice, GpuEngine, GpuOptions};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::history::{wall_key, EMPTY};
use sweep::engine::walls::{Wall, WallRotation, WallShape};
use sweep::engine::{Backend, CpuEngine, EngineConfig, State, V3};

const R: f64 = 0.0029;
const D: f64 = 2.0 * R;
const RHO: f64 = 2655.0;

fn mass() -> f64 {
    RHO * 4.0 / 3.0 * PI * R.powi(3)
}

fn hertz(e: f64, mu: f64) -> ContactLaw {
    common::hertz_shear_law(3.0e7, e, mu)
}

fn linear(e: f64, mu: f64) -> ContactLaw {
    common::linear_law(1.0e4, e, mu)
}

fn config(law: ContactLaw, dt: f64, walls: Vec<Wall>, periodic: Option<[f64; 2]>) -> EngineConfig {
    EngineConfig {
        dt_s: dt,
        gravity: [0.0; 3],
        particle_law: law,
        wall_law: law,
        walls,
        periodic_x: periodic,
        periodic_y: periodic,
        sink_z: None,
        skin_m: 0.2 * D,
    }
}

fn plate(z: f64, orifice_radius: f64, omega: f64) -> Wall {
    Wall {
        shape: WallShape::OrificePlate {
            z,
            center_xy: [0.0, 0.0],
            orifice_radius,
        },
        rotation: Some(WallRotation {
            axis_xy: [0.0, 0.0],
            omega_rad_per_s: omega,
        }),
    }
}

/// Which scene a packing fills.
#[derive(Clone, Copy, Debug)]
enum Scene {
    /// Periodic x/y box of side `BOX`, a closed rotating plate at z = 0 and a tilted lid.
    Periodic,
    /// Cylinder of radius 5 d round a rotating plate with an orifice of radius 1.6 d.
    Silo,
}

/// Side of the periodic box (2⁻⁴ m: exact in f32, so wrapped positions stay on the 2⁻²⁴ grid).
const BOX: f64 = 0.0625;
const RC: f64 = 5.0 * D;
const RO: f64 = 1.6 * D;
/// Height of the tilted lid over a dense packing (its top layer touches it).
const LID: f64 = 3.9 * D;

fn walls(scene: Scene, lid: f64) -> Vec<Wall> {
    let lid = plane([0.0, 0.0, lid], [0.02, -0.01, -1.0]);
    match scene {
        Scene::Periodic => vec![plate(0.0, 0.0, 2.0 * PI), lid],
        Scene::Silo => vec![
            Wall {
                shape: WallShape::Cylinder {
                    axis_xy: [0.0, 0.0],
                    radius: RC,
                    z_min: -D,
                    z_max: 1.0,
                },
                rotation: None,
            },
            plate(0.0, RO, 2.0 * PI),
            lid,
        ],
    }
}

/// A random packing: a cubic lattice of spacing about `spacing` d (0.97: dense, overlapping), jittered by ±0.02 d, radii within
/// ±4 %, every 17th sphere fixed, velocities k/16 m/s (|v| ≤ 0.5 m/s per component) and spins up
/// to 40 rad/s. The silo also gets spheres hanging in the orifice, touching its rim.
fn packing(scene: Scene, spacing: f64, friction: bool, seed: u64) -> State<f64> {
    let mut noise = Noise::new(seed);
    let mut s = State::<f64>::new(friction, if friction { HISTORY_SLOTS } else { 0 });
    let mut sites = Vec::new();
    let (a, lo, n_xy) = match scene {
        // A whole number of spacings across the box, so that contacts straddle the seams.
        Scene::Periodic => {
            let n = (BOX / (spacing * D)).floor();
            (BOX / n, 0.5 * BOX / n, n as i64)
        }
        Scene::Silo => (
            spacing * D,
            -RC,
            (2.0 * RC / (spacing * D)).floor() as i64 + 1,
        ),
    };
    for iz in 0..4 {
        for ix in 0..n_xy {
            for iy in 0..n_xy {
                let p = [
                    lo + ix as f64 * a,
                    lo + iy as f64 * a,
                    0.97 * R + iz as f64 * spacing * D,
                ];
                if let Scene::Silo = scene {
                    let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
                    if r > RC - 0.9 * R {
                        continue;
                    }
                    // Leave the orifice's column to the hanging spheres below.
                    if iz == 0 && r < RO {
                        continue;
                    }
                }
                sites.push(p);
            }
        }
    }
    if let Scene::Silo = scene {
        for k in 0..8 {
            let th = k as f64 * PI / 4.0;
            let r = RO - 0.75 * R;
            sites.push([
                r * th.cos(),
                r * th.sin(),
                -0.5 * R + 0.2 * R * noise.next(),
            ]);
        }
    }
    for (id, p) in sites.into_iter().enumerate() {
        let j = 0.02 * D;
        let pos = [
            quantise(p[0] + j * noise.next()),
            quantise(p[1] + j * noise.next()),
            quantise(p[2] + j * noise.next()),
        ];
        let vel = [
            (8.0 * noise.next()).round() / 16.0,
            (8.0 * noise.next()).round() / 16.0,
            (8.0 * noise.next()).round() / 16.0,
        ];
        let radius = R * (1.0 + 0.04 * noise.next());
        s.push_sphere(id as u32, pos, vel, radius, RHO, id % 17 == 5);
        if friction {
            let w = [
                40.0 * noise.next(),
                40.0 * noise.next(),
                40.0 * noise.next(),
            ];
            s.omega[id] = V3::from_f64(w);
        }
    }
    s
}

/// Minimum image along periodic x and y.
fn image(d: f64, periodic: Option<[f64; 2]>) -> f64 {
    match periodic {
        Some([a, b]) => {
            let l = b - a;
            d - l * (d / l + 0.5).floor()
        }
        None => d,
    }
}

/// Stored springs for every current contact (random, up to 4 µm per component), so that the
/// spring rotation and the Coulomb truncation are exercised in the first step. A pair's two
/// rows hold opposite springs, as every run leaves them (each side's update is the other's
/// negated, exactly): the CPU engine keeps one spring per pair and reads it from one row.
fn seed_history(s: &mut State<f64>, cfg: &EngineConfig, seed: u64) {
    let slots = s.history.slots;
    if slots == 0 {
        return;
    }
    let mut noise = Noise::new(seed);
    let mut pair_springs: HashMap<(u32, u32), V3<f64>> = HashMap::new();
    let walls: Vec<_> = cfg.walls.iter().map(|w| w.kernel::<f64>()).collect();
    for i in 0..s.len() {
        let mut keys = Vec::new();
        for j in 0..s.len() {
            let d = [
                image(s.pos[i].x - s.pos[j].x, cfg.periodic_x),
                image(s.pos[i].y - s.pos[j].y, cfg.periodic_y),
                s.pos[i].z - s.pos[j].z,
            ];
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if j != i && dist < s.radius[i] + s.radius[j] {
                keys.push(s.id[j]);
            }
        }
        for (w, wall) in walls.iter().enumerate() {
            if wall.touch(s.pos[i], s.radius[i]).is_some() {
                keys.push(wall_key(w));
            }
        }
        assert!(keys.len() <= slots, "packing too dense for the history");
        for (k, key) in keys.into_iter().enumerate() {
            let mut random = || {
                V3::from_f64([
                    4e-6 * noise.next(),
                    4e-6 * noise.next(),
                    4e-6 * noise.next(),
                ])
            };
            let own = s.id[i];
            let spring = if key >= wall_key(0) {
                random()
            } else if own < key {
                *pair_springs.entry((own, key)).or_insert_with(random)
            } else {
                -*pair_springs.entry((key, own)).or_insert_with(random)
            };
            s.history.partner[i * slots + k] = key;
            s.history.spring[i * slots + k] = spring;
        }
    }
}

/// One step on both backends from the same packing; returns (force error, torque error as a
/// fraction of its allowance: 0 within 1e-5 of f64, else relative to twice the CPU f32's).
fn one_step(dev: &GpuDevice, scene: Scene, law: ContactLaw, seed: u64) -> (f64, f64) {
    let periodic = match scene {
        Scene::Periodic => Some([0.0, BOX]),
        Scene::Silo => None,
    };
    // dt = 2⁻²⁰ s: v dt is a multiple of 2⁻²⁴ m, so the drift is exact in f32.
    let cfg = config(law, 1.0 / 1_048_576.0, walls(scene, LID), periodic);
    let mut s = packing(scene, 0.97, law.friction > 0.0, seed);
    seed_history(&mut s, &cfg, seed + 1);
    let mut c = cpu(&cfg, &s);
    let mut g = gpu(dev, &cfg, &s);
    c.advance(1).unwrap();
    g.advance(1).unwrap();
    let (sc, sg) = (c.download(), g.download());
    assert_eq!(sc.len(), sg.len());
    let ig = by_id(&sg);
    for (k, id) in sc.id.iter().enumerate() {
        assert_eq!(
            sc.pos[k], sg.pos[ig[id]],
            "{scene:?}: drift of particle {id} differs"
        );
    }
    let rms = |v: &[V3<f64>]| (v.iter().map(|x| x.norm2()).sum::<f64>() / v.len() as f64).sqrt();
    let f_rms = rms(&sc.force);
    assert!(f_rms > 0.0, "no contact forces: the packing is not dense");
    let ef = worst_relative(&sg, &sc, |s| &s.force, 1e-3 * f_rms);
    // Torques sum many terms that nearly cancel (a rim contact against its neighbours), so f32
    // rounding alone moves them by up to ~1e-4 relative, and the CPU's order of summation
    // (own pairs, then partners, then walls) is not the GPU's. Either engine is compared with
    // the CPU f64 result: the GPU must be within 1e-5 of it, or no farther than twice the
    // CPU f32's own distance from it (the same precision, so the same rounding allowance).
    let et = if sc.rotation {
        let mut c64 = CpuEngine::<f64>::new(cfg.clone(), s.clone(), 1);
        c64.advance(1).unwrap();
        let s64 = c64.download();
        let floor = 1e-3 * rms(&s64.torque);
        let (eg, ec) = (
            worst_relative(&sg, &s64, |s| &s.torque, floor),
            worst_relative(&sc, &s64, |s| &s.torque, floor),
        );
        eprintln!("{scene:?}: torque error against f64: GPU {eg:.2e}, CPU f32 {ec:.2e}");
        assert!(
            ec <= 1e-3,
            "{scene:?}: CPU f32 torque error {ec:.2e} against f64"
        );
        if eg <= 1e-5 {
            0.0
        } else {
            eg / (2.0 * ec)
        }
    } else {
        0.0
    };
    // History: the same partners, springs within 1e-5 of the largest spring of the particle.
    let slots = sc.history.slots;
    let mut es: f64 = 0.0;
    for (k, id) in sc.id.iter().enumerate() {
        let kg = ig[id];
        let rows = |s: &State<f64>, i: usize| -> HashMap<u32, V3<f64>> {
            (i * slots..(i + 1) * slots)
                .filter(|&q| s.history.partner[q] != EMPTY)
                .map(|q| (s.history.partner[q], s.history.spring[q]))
                .collect()
        };
        let (hc, hg) = (rows(&sc, k), rows(&sg, kg));
        assert_eq!(
            hc.keys().collect::<std::collections::BTreeSet<_>>(),
            hg.keys().collect::<std::collections::BTreeSet<_>>(),
            "{scene:?}: history partners of particle {id} differ"
        );
        let scale = hc.values().map(|v| v.norm()).fold(0.0, f64::max);
        for (key, v) in &hc {
            es = es.max((*v - hg[key]).norm() / scale.max(1e-30));
        }
    }
    eprintln!(
        "{scene:?} {}: {} particles, force error {ef:.2e}, torque error {et:.2e}, spring error {es:.2e}",
        if let NormalModel::Hertz(_) = law.normal { "Hertz" } else { "linear" },
        sc.len()
    );
    assert!(es <= 1e-5, "{scene:?}: spring error {es:.2e}");
    (ef, et)
}

#[test]
fn pipelines_build_and_an_empty_run_advances() {
    let Some(dev) = device() else { return };
    let cfg = config(hertz(0.9, 0.5), 1e-6, walls(Scene::Silo, LID), None);
    let s = State::<f64>::new(true, HISTORY_SLOTS);
    let mut g = gpu(&dev, &cfg, &s);
    let r = g.advance(10).unwrap();
    assert_eq!(r.steps, 10);
    let d = g.download();
    assert_eq!(d.step, 10);
    assert!(d.is_empty());
    let info = g.describe();
    assert_eq!(
        (info.kind.as_str(), info.precision.as_str()),
        ("gpu", "f32")
    );
    assert_eq!(info.adapter, dev.info.name);
}

#[test]
fn one_step_forces_and_torques_match_the_cpu() {
    let Some(dev) = device() else { return };
    for (scene, seed) in [(Scene::Periodic, 11), (Scene::Silo, 12)] {
        for law in [hertz(0.9, 0.5), linear(0.9, 0.5), hertz(0.8, 0.0)] {
            let (ef, et) = one_step(&dev, scene, law, seed);
            assert!(ef <= 1e-5, "{scene:?}: force error {ef:.2e} > 1e-5");
            assert!(
                et <= 1.0,
                "{scene:?}: GPU torques {et:.2} × twice the CPU f32's distance from f64"
            );
        }
    }
}

/// Head-on collisions on the GPU and on CPU f32 at n_c = 100: the same restitution and contact
/// time within 1e-4 (the analytic values are the contracts of engine_collisions.rs, run on both).
#[test]
fn collisions_match_the_cpu_f32() {
    let Some(dev) = device() else { return };
    for law in [linear(0.9, 0.0), hertz(0.9, 0.0)] {
        for v in [0.1, 1.0] {
            let (cfg, s) = common::collision::head_on(law, v, 100.0, R, RHO);
            let (e_gpu, t_gpu) = common::collision::collide(&mut gpu(&dev, &cfg, &s), v, R);
            let (e_cpu, t_cpu) = common::collision::collide(&mut cpu(&cfg, &s), v, R);
            eprintln!("v = {v}: GPU e = {e_gpu:.6}, t_c = {t_gpu:.4e}; CPU f32 e = {e_cpu:.6}, t_c = {t_cpu:.4e}");
            assert!(
                (e_gpu - e_cpu).abs() < 1e-4,
                "v = {v}: GPU e = {e_gpu}, CPU {e_cpu}"
            );
            assert!(
                (t_gpu - t_cpu).abs() / t_cpu < 1e-4,
                "v = {v}: GPU t_c = {t_gpu}, CPU {t_cpu}"
            );
        }
    }
}

/// A frictional packing settling under gravity at dt = t_c/50 (lid raised out of reach): the
/// periodic box, or the silo with its orifice open, a sink 6 d below it and its eight hanging
/// spheres moved into the orifice's column below the plate, falling at 2 m/s, so that some reach
/// the sink at different steps.
fn settling(scene: Scene, seed: u64) -> (EngineConfig, State<f64>) {
    let law = hertz(0.9, 0.5);
    let dt = contact_time(
        &law,
        ContactPair {
            r_eff: R / 2.0,
            m_eff: mass() / 2.0,
        },
        1.0,
    ) / 50.0;
    let periodic = match scene {
        Scene::Periodic => Some([0.0, BOX]),
        Scene::Silo => None,
    };
    let mut cfg = config(law, dt, walls(scene, 10.0 * D), periodic);
    cfg.gravity = [0.0, 0.0, -9.81];
    // No initial overlaps (spacing 1.04 d, the bottom layer lifted by 0.05 d), slow velocities.
    let mut s = packing(scene, 1.04, true, seed);
    for i in 0..s.len() {
        s.pos[i].z += 0.05 * D;
        s.vel[i] = V3::from_f64([0.02 * s.vel[i].x, 0.02 * s.vel[i].y, -0.3]);
        s.omega[i] = V3::zero();
    }
    if let Scene::Silo = scene {
        cfg.sink_z = Some(-6.0 * D);
        let n = s.len();
        for k in 0..8 {
            let side = if k % 2 == 0 { 0.5 } else { -0.5 };
            s.pos[n - 8 + k] = V3::from_f64([side * RO, 0.0, -1.2 * D - 0.6 * D * k as f64]);
            s.vel[n - 8 + k] = V3::from_f64([0.0, 0.0, -2.0]);
        }
    }
    (cfg, s)
}

/// Largest position difference (in d) and velocity difference (in m/s) between two states.
fn deviation(a: &State<f64>, b: &State<f64>) -> (f64, f64) {
    assert_eq!(a.len(), b.len(), "different particle counts");
    let ia = by_id(a);
    let (mut dx, mut dv): (f64, f64) = (0.0, 0.0);
    for (k, id) in b.id.iter().enumerate() {
        let i = ia[id];
        dx = dx.max((a.pos[i] - b.pos[k]).norm() / D);
        dv = dv.max((a.vel[i] - b.vel[k]).norm());
    }
    (dx, dv)
}

/// Runs `chunks` chunks of `steps`; returns the end state and the removed ids with their steps.
fn run(b: &mut dyn Backend, chunks: usize, steps: u64, dt: f64) -> (State<f64>, Vec<(u32, i64)>) {
    let mut removed = Vec::new();
    for _ in 0..chunks {
        let r = b.advance(steps).unwrap();
        removed.extend(
            r.removed
                .iter()
                .map(|e| (e.id, (e.time_s / dt).round() as i64)),
        );
    }
    removed.sort();
    (b.download(), removed)
}

/// Bounds on GPU vs CPU f32 after up to 1000 steps: positions within 1e-2 d, velocities within
/// 5e-2 of the largest speed, and no farther from CPU f32 than CPU f64 is. Measured on lavapipe
/// over eight seeds: ≤ 1.1e-3 d and ≤ 6e-3 m/s (silo, rim collisions on a rotating plate), ≤ 1e-5 d
/// (periodic box), 3.5 to 300 times inside the f32-vs-f64 difference.
const TRAJ_DX: f64 = 1e-2;
const TRAJ_DV: f64 = 5e-2;

#[test]
fn a_thousand_steps_follow_the_cpu_trajectory() {
    let Some(dev) = device() else { return };
    for (scene, seed) in [(Scene::Periodic, 21), (Scene::Silo, 22)] {
        let (cfg, s) = settling(scene, seed);
        let (sg, rg) = run(&mut gpu(&dev, &cfg, &s), 10, 100, cfg.dt_s);
        let (sc, rc) = run(&mut cpu(&cfg, &s), 10, 100, cfg.dt_s);
        let (s64, _) = run(
            &mut CpuEngine::<f64>::new(cfg.clone(), s.clone(), 2),
            10,
            100,
            cfg.dt_s,
        );
        let (dx, dv) = deviation(&sg, &sc);
        let (dx64, dv64) = deviation(&s64, &sc);
        let (gx64, gv64) = deviation(&sg, &s64);
        let v_scale = sc.vel.iter().map(|v| v.norm()).fold(0.0, f64::max);
        eprintln!(
            "{scene:?}: {} particles, 1000 steps: GPU vs CPU f32 |Δx| ≤ {dx:.2e} d, |Δv| ≤ {dv:.2e} m/s; CPU f64 vs f32 {dx64:.2e} d, {dv64:.2e} m/s (v max {v_scale:.3} m/s), removed {} / {}",
            sc.len(),
            rg.len(),
            rc.len()
        );
        assert_eq!(
            rg, rc,
            "{scene:?}: different particles removed, or at different steps"
        );
        if let Scene::Silo = scene {
            assert!(
                !rc.is_empty(),
                "the silo test removed nothing: the sink is untested"
            );
        }
        assert!(dx < TRAJ_DX, "{scene:?}: positions differ by {dx:.2e} d");
        assert!(
            dv < TRAJ_DV * v_scale,
            "{scene:?}: velocities differ by {dv:.2e} m/s"
        );
        // The GPU stays inside the f32 rounding envelope around f64 (its velocities keep
        // their rests, so it may sit nearer f64 than CPU f32 does).
        eprintln!("{scene:?}: GPU vs CPU f64 {gx64:.2e} d, {gv64:.2e} m/s");
        assert!(
            gx64 <= dx64 && gv64 <= dv64,
            "{scene:?}: GPU farther from CPU f64 ({gx64:.2e} d, {gv64:.2e} m/s) than CPU f32 is"
        );
    }
}

#[test]
fn checkpoints_move_between_gpu_and_cpu() {
    let Some(dev) = device() else { return };
    let (cfg, s) = settling(Scene::Silo, 31);
    let dt = cfg.dt_s;
    // Straight runs of 600 steps.
    let (straight_g, _) = run(&mut gpu(&dev, &cfg, &s), 6, 100, dt);
    let (straight_c, _) = run(&mut cpu(&cfg, &s), 6, 100, dt);
    // 300 steps on one backend, the download uploaded to the other, 300 more.
    let (half_g, _) = run(&mut gpu(&dev, &cfg, &s), 3, 100, dt);
    let (g_then_c, _) = run(&mut cpu(&cfg, &half_g), 3, 100, dt);
    let (half_c, _) = run(&mut cpu(&cfg, &s), 3, 100, dt);
    let (c_then_g, _) = run(&mut gpu(&dev, &cfg, &half_c), 3, 100, dt);
    // And the GPU resumed from its own download.
    let (g_then_g, _) = run(&mut gpu(&dev, &cfg, &half_g), 3, 100, dt);
    assert!(
        half_g.history.partner.iter().any(|&k| k != EMPTY),
        "no history to carry over"
    );
    assert_eq!(g_then_g.step, 600);
    assert_eq!(g_then_c.step, 600);
    assert_eq!(c_then_g.step, 600);
    let v_scale = straight_c.vel.iter().map(|v| v.norm()).fold(0.0, f64::max);
    for (what, a, b) in [
        ("GPU → CPU vs straight GPU", &g_then_c, &straight_g),
        ("GPU → CPU vs straight CPU", &g_then_c, &straight_c),
        ("CPU → GPU vs straight CPU", &c_then_g, &straight_c),
        ("CPU → GPU vs straight GPU", &c_then_g, &straight_g),
    ] {
        let (dx, dv) = deviation(a, b);
        eprintln!("{what}: |Δx| ≤ {dx:.2e} d, |Δv| ≤ {dv:.2e} m/s");
        assert!(dx < TRAJ_DX, "{what}: positions differ by {dx:.2e} d");
        assert!(
            dv < TRAJ_DV * v_scale,
            "{what}: velocities differ by {dv:.2e} m/s"
        );
    }
    let (dx, dv) = deviation(&g_then_g, &straight_g);
    assert_eq!(
        (dx, dv),
        (0.0, 0.0),
        "a GPU run resumed from its download is not bit-identical"
    );
    assert_eq!(g_then_g.history, straight_g.history);
}

#[test]
fn sweep_bench_runs_on_the_gpu() {
    let Some(_dev) = device() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = assert_cmd::Command::new(crate::common::cli::bin())
        .current_dir(dir.path())
        .env_remove("SWEEP_DB")
        .env_remove("SWEEP_ALLOW_SOFTWARE_GPU")
        .args([
            "bench",
            "--backend",
            "gpu",
            "--allow-software-gpu",
            "--scene",
            "silo-bed",
            "--particles",
            "500",
            "--steps",
            "20",
            "--precision",
            "f32",
            "--no-store",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["backend"], "gpu");
    assert_eq!(v["precision"], "f32");
    assert!(v["particle_steps_per_s"].as_f64().unwrap() > 0.0);
    // The engine's own count: a step without a list build is two dispatches.
    let per_steady = v["dispatches"]["per_steady_step"].as_u64().unwrap();
    assert!((1..=2).contains(&per_steady), "{}", v["dispatches"]);
    // Every build of this small bed also sorts it by cell (its scratch binds anywhere).
    let builds = v["dispatches"]["list_builds"].as_u64().unwrap();
    assert!(builds > 0, "{}", v["dispatches"]);
    assert_eq!(
        v["dispatches"]["list_builds_sorting_by_cell"].as_u64(),
        Some(builds),
        "{}",
        v["dispatches"]
    );
    // f64 on the GPU is refused with a clear message.
    let out = assert_cmd::Command::new(crate::common::cli::bin())
        .current_dir(dir.path())
        .args([
            "bench",
            "--backend",
            "gpu",
            "--precision",
            "f64",
            "--particles",
            "100",
            "--no-store",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("the GPU backend runs f32"));
}

/// `sweep bench` with `extra` after `--no-store --particles 200 --steps 5`, without
/// `SWEEP_ALLOW_SOFTWARE_GPU`: its output.
fn bench(extra: &[&str]) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    assert_cmd::Command::new(crate::common::cli::bin())
        .current_dir(dir.path())
        .env_remove("SWEEP_DB")
        .env_remove("SWEEP_ALLOW_SOFTWARE_GPU")
        .args(["bench", "--no-store", "--particles", "200", "--steps", "5"])
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn sweep_bench_refuses_a_software_adapter_unless_allowed() {
    let Some(_dev) = device() else { return };
    let adapters = sweep::engine::gpu::list_adapters();
    if adapters.iter().any(|a| a.hardware && a.unusable.is_none()) {
        eprintln!("skipping: a hardware adapter is there, which --backend gpu takes");
        return;
    }
    let out = bench(&["--backend", "gpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a software adapter was taken: {err}");
    assert!(
        err.contains("software adapter") && err.contains("--allow-software-gpu"),
        "{err}"
    );
    let first = adapters.iter().find(|a| a.unusable.is_none()).unwrap();
    assert!(err.contains(&first.info.name), "names the adapter: {err}");
    // The environment variable allows it as the flag does.
    let dir = tempfile::tempdir().unwrap();
    let out = assert_cmd::Command::new(crate::common::cli::bin())
        .current_dir(dir.path())
        .env_remove("SWEEP_DB")
        .env("SWEEP_ALLOW_SOFTWARE_GPU", "1")
        .args(["bench", "--no-store", "--particles", "200", "--steps", "5"])
        .args(["--backend", "gpu", "--json"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("software adapter"), "says so: {err}");
}

#[test]
fn sweep_bench_refuses_a_gpu_number_out_of_range() {
    sweep::engine::gpu::quiet_headless_device_select();
    let n = sweep::engine::gpu::list_adapters().len();
    let out = bench(&["--backend", "gpu", "--gpu", "99", "--allow-software-gpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("--gpu 99"), "{err}");
    assert!(
        err.contains(&format!("{n} adapter(s)")) || (n == 0 && err.contains("no GPU adapter")),
        "{err}"
    );
    // So is it with --backend auto: the user asked for that adapter.
    let out = bench(&["--backend", "auto", "--gpu", "99"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--gpu 99"));
}

/// `n` spheres in free fall in a column grid (no contacts), the lowest 0.5 d above the sink.
fn rain(n: usize) -> (EngineConfig, State<f64>) {
    let mut cfg = config(linear(0.9, 0.5), 1e-4, vec![], None);
    cfg.gravity = [0.0, 0.0, -9.81];
    cfg.sink_z = Some(0.0);
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    for k in 0..n {
        let p = [
            (k % 4) as f64 * 2.0 * D,
            ((k / 4) % 4) as f64 * 2.0 * D,
            (0.5 + 0.4 * k as f64) * D,
        ];
        s.push_sphere(k as u32, p, [0.0, 0.0, -1.0], R, RHO, false);
    }
    (cfg, s)
}

/// The largest distance (in d) and speed difference of `s`'s particles from the free fall of
/// `start`'s under g = 9.81 m/s² along −z.
fn off_free_fall(start: &State<f64>, s: &State<f64>) -> (f64, f64) {
    let t = s.time;
    let ia = by_id(start);
    let (mut dx, mut dv): (f64, f64) = (0.0, 0.0);
    for (k, id) in s.id.iter().enumerate() {
        let i = ia[id];
        let (p0, v0) = (start.pos[i].to_f64(), start.vel[i].to_f64());
        let (p, v) = (s.pos[k].to_f64(), s.vel[k].to_f64());
        let z = p0[2] + v0[2] * t - 0.5 * 9.81 * t * t;
        let vz = v0[2] - 9.81 * t;
        dx = dx.max(((p[0] - p0[0]).abs() + (p[1] - p0[1]).abs() + (p[2] - z).abs()) / D);
        dv = dv.max(v[0].abs() + v[1].abs() + (v[2] - vz).abs());
    }
    (dx, dv)
}

/// The step after which each particle of `start` has fallen below z = 0 within `steps` steps of
/// `dt`, from the parabola (velocity Verlet's positions are exact for a constant force), by id.
fn parabola_crossings(start: &State<f64>, dt: f64, steps: u64) -> Vec<(u32, i64)> {
    let mut out = Vec::new();
    for (i, &id) in start.id.iter().enumerate() {
        let (z0, v0) = (start.pos[i].to_f64()[2], start.vel[i].to_f64()[2]);
        let below = (1..=steps).find(|&n| {
            let t = n as f64 * dt;
            z0 + v0 * t - 0.5 * 9.81 * t * t < 0.0
        });
        if let Some(n) = below {
            out.push((id, n as i64));
        }
    }
    out.sort();
    out
}

#[test]
fn the_sink_removes_the_same_particles_and_compaction_is_invisible() {
    let Some(dev) = device() else { return };
    let (cfg, s) = rain(64);
    let mut g = gpu(&dev, &cfg, &s);
    let mut c = cpu(&cfg, &s);
    let (mut removed_g, mut removed_c) = (Vec::new(), Vec::new());
    let mut masses = std::collections::BTreeMap::new();
    for chunk in 0..6 {
        let (rg, rc) = (g.advance(150).unwrap(), c.advance(150).unwrap());
        for (r, to) in [(&rg, &mut removed_g), (&rc, &mut removed_c)] {
            for e in &r.removed {
                to.push((e.id, (e.time_s / cfg.dt_s).round() as i64));
                assert_eq!(*masses.entry(e.id).or_insert(e.mass_kg), e.mass_kg);
            }
        }
        // Removed particles never show in a download (the GPU compacts lazily).
        let (sg, sc) = (g.download(), c.download());
        assert_eq!(sg.len(), 64 - removed_g.len(), "chunk {chunk}");
        assert_eq!(sc.len(), 64 - removed_c.len(), "chunk {chunk}");
        // Velocity Verlet is exact for a constant force: both against the parabola, to their
        // velocities' rounding (the GPU keeps each velocity's rest, the CPU's f32 does not).
        let (gx, gv) = off_free_fall(&s, &sg);
        let (cx, cv) = off_free_fall(&s, &sc);
        eprintln!("chunk {chunk}: off the parabola GPU {gx:.2e} d {gv:.2e} m/s, CPU f32 {cx:.2e} d {cv:.2e} m/s");
        assert!(
            gx < 1e-6 && gv < 1e-7,
            "chunk {chunk}: GPU free fall {gx:.2e} d, {gv:.2e} m/s off"
        );
        assert!(
            cx < 1e-3 && cv < 1e-4,
            "chunk {chunk}: CPU free fall {cx:.2e} d, {cv:.2e} m/s off"
        );
    }
    // The GPU removes each particle at the step the parabola crosses the sink (the nearest
    // call here is 4·10⁻⁵ d below it, the GPU's drift 100 times less); CPU f32, 10⁻⁴ d off
    // after 900 steps, at that step or the next.
    removed_g.sort();
    removed_c.sort();
    let exact = parabola_crossings(&s, cfg.dt_s, 900);
    assert_eq!(removed_g, exact, "GPU removals off the parabola's");
    assert_eq!(removed_c.len(), exact.len(), "CPU removed other particles");
    for (c, e) in removed_c.iter().zip(&exact) {
        assert!(
            c.0 == e.0 && (c.1 - e.1).abs() <= 1,
            "CPU removal {c:?}, parabola {e:?}"
        );
    }
    assert!(
        removed_g.len() > 32,
        "only {} removed: compaction untested",
        removed_g.len()
    );
}

#[test]
fn failures_are_reported_like_the_cpu_does() {
    let Some(dev) = device() else { return };
    let law = hertz(0.9, 0.5);
    // A history table too small for a dense packing.
    let cfg = config(law, 1e-7, walls(Scene::Periodic, LID), Some([0.0, BOX]));
    let dense = packing(Scene::Periodic, 0.97, true, 41);
    let mut small = State::<f64>::new(true, 2);
    for i in 0..dense.len() {
        let (p, v) = (dense.pos[i].to_f64(), dense.vel[i].to_f64());
        small.push_sphere(dense.id[i], p, v, dense.radius[i], RHO, false);
    }
    let eg = gpu(&dev, &cfg, &small).advance(3).unwrap_err();
    let ec = cpu(&cfg, &small).advance(3).unwrap_err();
    assert!(
        matches!(
            eg,
            sweep::engine::EngineError::HistoryFull {
                slots: 2,
                step: 0,
                ..
            }
        ),
        "{eg}"
    );
    assert!(matches!(
        ec,
        sweep::engine::EngineError::HistoryFull {
            slots: 2,
            step: 0,
            ..
        }
    ));
    // Overlaps beyond the watchdog.
    let mut crushed = packing(Scene::Periodic, 0.97, true, 42);
    for p in crushed.pos.iter_mut() {
        p.z *= 0.6;
    }
    let eg = gpu(&dev, &cfg, &crushed).advance(2).unwrap_err();
    assert!(
        matches!(eg, sweep::engine::EngineError::Overlap { step: 1, .. }),
        "{eg}"
    );
    // A non-finite velocity.
    let mut bad = packing(Scene::Periodic, 1.04, true, 43);
    bad.pos.iter_mut().for_each(|p| p.z += D);
    bad.vel[7] = V3::from_f64([f64::NAN, 0.0, 0.0]);
    let eg = gpu(&dev, &cfg, &bad).advance(2).unwrap_err();
    let ec = cpu(&cfg, &bad).advance(2).unwrap_err();
    assert_eq!(without_detail(&eg), without_detail(&ec));
    // Too many walls for the kernels' uniform array.
    let mut many = cfg.clone();
    many.walls = vec![plane([0.0; 3], [0.0, 0.0, 1.0]); 17];
    let e = GpuEngine::new(&dev, many, &bad, GpuOptions::default())
        .err()
        .expect("17 walls accepted");
    assert!(e.to_string().contains("at most 16"), "{e}");
}

#[test]
fn list_rows_hold_more_than_any_packing_of_equal_spheres() {
    // d = 1, skin 0.2 d: at most ~29 centres fit within 1.2 d of a centre; a row holds more.
    let k = sweep::engine::gpu::list_capacity(0.5, 0.5, 0.2);
    assert!((40..=64).contains(&k), "{k}");
}

/// An engine error's message without what only the CPU can add (the overlap's deepest contact,
/// read from the state it holds).
fn without_detail(e: &sweep::engine::EngineError) -> String {
    match e {
        sweep::engine::EngineError::Overlap {
            ratio, limit, step, ..
        } => sweep::engine::EngineError::Overlap {
            ratio: *ratio,
            limit: *limit,
            step: *step,
            detail: String::new(),
        }
        .to_string(),
        _ => e.to_string(),
    }
}
