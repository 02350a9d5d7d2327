//! Spherocylinders on the GPU backend against the CPU engine in f32 (lavapipe where there is no
//! GPU). Run in release mode. Tolerances, with what they stand for:
//! - One step on a compressed lattice of rods (ξ = 1.00, 1.01, 1.3, 3.0; exactly parallel, 10⁻⁷
//!   and 1.5·10⁻⁶ rad off parallel, and 0.03 rad tilted neighbours: every branch of the segment
//!   search; some fixed rods; a floor and a tilted lid; periodic x/y; random velocities, angular
//!   momenta and stored springs): positions drift exactly (quantised), axes within 1e-6 (sin/cos
//!   come from f64 on the CPU and from a polynomial on the GPU), forces and torques within 1e-5
//!   relative (|F| floored at 1e-3 of the rms) and the same history partners with springs within
//!   1e-5, as for spheres. Measured on lavapipe: forces ≤ 6e-7, torques ≤ 4e-7, springs ≤ 2e-7,
//!   axes ≤ 1e-12.
//! - Two-particle geometries at rest the lattice lacks (a T, axes that exactly intersect — the
//!   touching-normal branch —, a cap on a side, parallel rods with overlapping ends, the ramp at
//!   sin θ = 1.5e-6, collinear and antiparallel rods, a rod on a fixed base sphere of radius
//!   L/2): one step's forces and torques within 1e-5 of the CPU's (torques relative to
//!   max(|τ|, 1e-3 |F| L)).
//! - A rod dropped flat, on its end and tilted by 30° onto a plane (ξ = 2.5, e = 0.5, μ = 0.5):
//!   the contract `rods::dropped_rod_comes_to_rest` on the GPU (kinetic + potential energy never
//!   rises by more than 1e-8 of its start, the GPU keeping each velocity's and L's rest below
//!   f32, measured ≤ 3.3e-11; K < 1e-6 of the drop energy at the end). CPU f32's energy rises
//!   by at most 1e-5 (its velocities round at ~1e-7, measured ≤ 1.2e-6), and the GPU rests in
//!   its rest state: height within 1e-4 d, axis within 1e-3 rad. The horizontal place after the
//!   tilted rod's bounces is ill-conditioned (1 nm of drop height moves it by up to 1e-2 L), so
//!   the GPU's must lie within the span of CPU f32 and CPU f64 runs from heights nudged by 0,
//!   ±1, ±2 nm, widened by that span plus 1e-3 L (measured at 30°: GPU 0.4458 L, span 0.4382
//!   to 0.4483 L).
//! - Two rods colliding crossed, side by side (parallel) and end to end (ξ = 2, e = 0.9, μ = 0.5,
//!   off-centre so that they spin): after the collision each rod's velocity within 1e-4 of the
//!   approach speed and its angular momentum within 1e-4 of m v L of the CPU f32 run (measured
//!   ≤ 4e-9); total momentum within 1e-6 and total angular momentum (orbital + spin) within 1e-6
//!   of m v and m v L (f32 velocities and positions round at 6e-8, the pair forces are bitwise
//!   ±F; measured 0 and ≤ 7e-7).
//! - A free symmetric top (ξ = 3, L 1.4 rad off the axis), 10⁴ steps (9 rad of precession): L
//!   bitwise constant, |q| within 1e-6 of 1, the axis within 1e-4 rad of the exact precession
//!   about L at |L|/I⊥ and within 1e-5 rad of the CPU f32 run, the rotational energy no further
//!   from its start than twice the CPU f32 run's plus 1e-6 (in f32 the axis' phase error moves
//!   π3 = L·u: both drift ~1e-5).
//! - A short chute (300 rods, ξ = 1.3, 28°, periodic 5L × 5L, rough base, n_c = 20): GPU, CPU
//!   f32 and CPU f64 from the same poured state for 6 s (the pour lands and starts to flow); the
//!   mean flow velocity and kinetic energy averaged over the last second. The runs start
//!   identical and part by rounding, which the flow amplifies into different realisations of the
//!   same flow; so the GPU's must lie within the span of four CPU realisations (f32 and f64, from
//!   the pour and from the pour moved by 1 nm) widened by that span, plus 2 % (a floor for runs
//!   that have not parted). Measured: v_x GPU 0.234, CPU 0.172 to 0.218 m/s; K GPU 25.3, CPU
//!   16.2 to 21.6 J.
//! - Checkpoints (the compressed lattice of ξ = 1.3 at the chute's time step): a GPU download
//!   uploaded to the CPU and back gives the same State bit for bit, but for the velocities' and
//!   angular momenta's rests below f32, which CPU f32 does not keep; a run moved GPU → CPU → GPU
//!   stays as close to the straight GPU run over 300 steps as twice the distance between CPU f64
//!   and CPU f32 runs (the lattice amplifies rounding fast: they part by ~3e-2 of the top speed);
//!   a GPU run resumed from its own download is bit-identical.
//!
//! Without an adapter the tests print a message and pass, except under CI=true, where a missing
//! adapter fails them. A failure of the one-step test means a kernel's formula departs from the
//! CPU engine's; of the others, a wrong integration step, rotor or contact point.

use crate::common::backends::On;
use crate::common::gpu::{by_id, cpu_f32 as cpu, device, engine as gpu, quantise, worst_relative};
use crate::common::rods::{
    config, drop_rod, dropped, dropped_rod_comes_to_rest, momenta, shape, stiffness, L, RHO,
};
use crate::common::{plane, Noise};

use std::collections::{BTreeSet, HashMap};

use sweep::engine::gpu::{GpuDevice, GpuEngine, GpuOptions};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::history::{wall_key, EMPTY};
use sweep::engine::shape::{contact_spherocylinders, Quat, Spherocylinder};
use sweep::engine::watchdog::Watchdog;
use sweep::engine::{Backend, CpuEngine, EngineConfig, State, V3};
use sweep::scene::{ChuteParams, ChuteScene};

// ---------------------------------------------------------------------------------------------
// One step against the CPU.

/// A lattice of rods along x, end to end at 0.985 L and side by side at 0.985 d (so neighbours
/// overlap by up to a few % of d), 8 × 4 × 3 cells in a box periodic in x and y; rod k is exactly
/// along ±x (k % 4 = 0), 10⁻⁷ rad off (1: the parallel branch), 1.5·10⁻⁶ rad off (2: the ramp
/// between parallel and exact) or 0.03 rad off (3: crossed); every 11th is fixed. A floor under
/// the bottom layer and a tilted lid over the top one touch some rods.
fn lattice(xi: f64, seed: u64) -> (EngineConfig, State<f64>) {
    let sh = shape(xi);
    let d = sh.diameter();
    let (ax, ay) = (0.985 * L, 0.985 * d);
    let (nx, ny, nz) = (8, 4, 3);
    let mut noise = Noise::new(seed);
    let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
    let mut id = 0u32;
    for iz in 0..nz {
        for iy in 0..ny {
            for ix in 0..nx {
                let tilt = match id % 4 {
                    0 => 0.0,
                    1 => 1e-7,
                    2 => 1.5e-6,
                    _ => 0.03,
                };
                let sign = if (id / 4).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                let phi = std::f64::consts::PI * noise.next();
                let u = V3::new(sign, tilt * phi.cos(), tilt * phi.sin());
                let u = u * (1.0 / u.norm());
                let c = [
                    quantise((ix as f64 + 0.5) * ax + 0.01 * d * noise.next()),
                    quantise((iy as f64 + 0.5) * ay + 0.01 * d * noise.next()),
                    quantise(0.5 * d + iz as f64 * ay + 0.01 * d * noise.next()),
                ];
                let v = [
                    (4.0 * noise.next()).round() / 16.0,
                    (4.0 * noise.next()).round() / 16.0,
                    (4.0 * noise.next()).round() / 16.0,
                ];
                let q = Quat::from_axis_z(u).to_f64();
                s.push_spherocylinder(id, c, v, q, sh, RHO, id % 11 == 7);
                let k = s.len() - 1;
                if id % 11 != 7 {
                    s.set_angular_velocity(
                        k,
                        [5.0 * noise.next(), 5.0 * noise.next(), 5.0 * noise.next()],
                    );
                }
                id += 1;
            }
        }
    }
    let top = 0.5 * d + (nz - 1) as f64 * ay;
    let walls = vec![
        plane([0.0, 0.0, 0.02 * d], [0.0, 0.0, 1.0]),
        plane([0.0, 0.0, top + 0.49 * d], [0.01, -0.005, -1.0]),
    ];
    let mut cfg = config(xi, 0.7, 0.5, 0.0, walls);
    // dt = 2⁻²⁰ s: v dt is a multiple of 2⁻²⁴ m, so the drift is exact in f32.
    cfg.dt_s = 1.0 / 1_048_576.0;
    cfg.periodic_x = Some([0.0, nx as f64 * ax]);
    cfg.periodic_y = Some([0.0, ny as f64 * ay]);
    seed_history(&mut s, &cfg, seed + 1);
    (cfg, s)
}

/// Stored springs (random, up to 1e-4 d per component) for every current contact, so that the
/// spring rotation and the Coulomb truncation are exercised in the first step.
fn seed_history(s: &mut State<f64>, cfg: &EngineConfig, seed: u64) {
    let slots = s.history.slots;
    let mut noise = Noise::new(seed);
    let walls: Vec<_> = cfg.walls.iter().map(|w| w.kernel::<f64>()).collect();
    let image = |mut d: V3<f64>| {
        if let Some([a, b]) = cfg.periodic_x {
            d.x -= (b - a) * (d.x / (b - a) + 0.5).floor();
        }
        if let Some([a, b]) = cfg.periodic_y {
            d.y -= (b - a) * (d.y / (b - a) + 0.5).floor();
        }
        d
    };
    let sh = |k: usize| Spherocylinder {
        half_length: s.half_length[k],
        radius: s.radius[k],
    };
    for i in 0..s.len() {
        let mut keys = Vec::new();
        for j in 0..s.len() {
            let both_fixed = s.inv_mass[i] == 0.0 && s.inv_mass[j] == 0.0;
            if j == i || both_fixed {
                continue;
            }
            let d = image(s.pos[i] - s.pos[j]);
            if contact_spherocylinders(d, s.axis(i), &sh(i), s.axis(j), &sh(j)).is_some() {
                keys.push(s.id[j]);
            }
        }
        if s.inv_mass[i] != 0.0 {
            for (w, wall) in walls.iter().enumerate() {
                if wall
                    .touch_oriented(s.pos[i], s.lo(i), s.axis(i), &sh(i))
                    .is_some()
                {
                    keys.push(wall_key(w));
                }
            }
        }
        assert!(keys.len() <= slots, "lattice too dense for the history");
        let scale = 1e-4 * 2.0 * s.radius[i];
        for (k, key) in keys.into_iter().enumerate() {
            s.history.partner[i * slots + k] = key;
            s.history.spring[i * slots + k] = V3::from_f64([
                scale * noise.next(),
                scale * noise.next(),
                scale * noise.next(),
            ]);
        }
    }
    // Both rows of a pair hold its canonical spring, that of the lower id's view (what the
    // engines write; the CPU's half lists read the pair's spring from one row).
    let place: HashMap<u32, usize> = s.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    for i in 0..s.len() {
        for q in i * slots..(i + 1) * slots {
            let key = s.history.partner[q];
            if key == EMPTY || key >= wall_key(0) || key > s.id[i] {
                continue;
            }
            let j = place[&key];
            s.history.spring[q] = s.history.spring_of(j, s.id[i]);
        }
    }
}

fn one_step(dev: &GpuDevice, xi: f64, seed: u64) {
    let (cfg, s) = lattice(xi, seed);
    let mut c = cpu(&cfg, &s);
    let mut g = gpu(dev, &cfg, &s);
    c.advance(1).unwrap();
    g.advance(1).unwrap();
    let (sc, sg) = (c.download(), g.download());
    assert_eq!(sc.len(), sg.len());
    let ig = by_id(&sg);
    let mut axis_err: f64 = 0.0;
    for (k, id) in sc.id.iter().enumerate() {
        assert_eq!(
            sc.pos[k], sg.pos[ig[id]],
            "ξ = {xi}: drift of particle {id} differs"
        );
        axis_err = axis_err.max((sc.axis(k) - sg.axis(ig[id])).norm());
    }
    let rms = |v: &[V3<f64>]| (v.iter().map(|x| x.norm2()).sum::<f64>() / v.len() as f64).sqrt();
    let (f_rms, t_rms) = (rms(&sc.force), rms(&sc.torque));
    assert!(f_rms > 0.0, "ξ = {xi}: no contact forces");
    let ef = worst_relative(&sg, &sc, |s| &s.force, 1e-3 * f_rms);
    let et = worst_relative(&sg, &sc, |s| &s.torque, 1e-3 * t_rms);
    let el = worst_relative(&sg, &sc, |s| &s.ang_mom, 1e-30);
    let slots = sc.history.slots;
    let (mut es, mut contacts, mut wall_contacts) = (0.0f64, 0usize, 0usize);
    for (k, id) in sc.id.iter().enumerate() {
        let rows = |s: &State<f64>, i: usize| -> HashMap<u32, V3<f64>> {
            (i * slots..(i + 1) * slots)
                .filter(|&q| s.history.partner[q] != EMPTY)
                .map(|q| (s.history.partner[q], s.history.spring[q]))
                .collect()
        };
        let (hc, hg) = (rows(&sc, k), rows(&sg, ig[id]));
        assert_eq!(
            hc.keys().collect::<BTreeSet<_>>(),
            hg.keys().collect::<BTreeSet<_>>(),
            "ξ = {xi}: history partners of particle {id} differ"
        );
        contacts += hc.len();
        wall_contacts += hc.keys().filter(|&&k| k >= wall_key(0)).count();
        let scale = hc.values().map(|v| v.norm()).fold(0.0, f64::max);
        for (key, v) in &hc {
            es = es.max((*v - hg[key]).norm() / scale.max(1e-30));
        }
    }
    eprintln!(
        "ξ = {xi}: {} rods, {contacts} contacts ({wall_contacts} with walls): force error {ef:.2e}, \
         torque error {et:.2e} (bounds 1e-5), spring error {es:.2e} (bound 1e-5), axis error {axis_err:.2e} (bound 1e-6), \
         angular momentum error {el:.2e}",
        sc.len()
    );
    assert!(
        contacts > sc.len() && wall_contacts > 0,
        "ξ = {xi}: too few contacts"
    );
    assert!(ef <= 1e-5, "ξ = {xi}: force error {ef:.2e}");
    assert!(et <= 1e-5, "ξ = {xi}: torque error {et:.2e}");
    assert!(es <= 1e-5, "ξ = {xi}: spring error {es:.2e}");
    assert!(axis_err <= 1e-6, "ξ = {xi}: axes differ by {axis_err:.2e}");
}

#[test]
fn one_step_forces_and_torques_match_the_cpu() {
    let Some(dev) = device() else { return };
    for (k, xi) in [1.0, 1.01, 1.3, 3.0].into_iter().enumerate() {
        one_step(&dev, xi, 40 + k as u64);
    }
}

/// Pairs the lattice does not hold, each at rest, one step on both backends: forces and torques
/// within 1e-5 relative of the CPU's.
#[test]
fn pair_geometries_match_the_cpu() {
    let Some(dev) = device() else { return };
    let rod = shape(2.0);
    let (d, h) = (rod.diameter(), rod.half_length);
    let x = V3::new(1.0, 0.0, 0.0);
    let y = V3::new(0.0, 1.0, 0.0);
    let z = V3::new(0.0, 0.0, 1.0);
    let tilted = |a: f64| V3::new(a.cos(), a.sin(), 0.0);
    // (name, centre of rod 1, axis of rod 0, axis of rod 1, rod 1 a fixed sphere of radius L/2)
    let cases = [
        ("T", V3::new(0.0, 0.0, h + 0.98 * d), x, z, false),
        (
            "crossed, axes exactly intersecting",
            V3::zero(),
            x,
            y,
            false,
        ),
        (
            "cap on the side",
            V3::new(0.3 * h, 0.0, h + 0.98 * d),
            x,
            z,
            false,
        ),
        (
            "parallel, overlapping ends",
            V3::new(1.5 * h, 0.0, 0.97 * d),
            x,
            x,
            false,
        ),
        (
            "ramp, sin θ = 1.5e-6",
            V3::new(0.5 * h, 0.0, 0.97 * d),
            x,
            tilted(1.5e-6),
            false,
        ),
        (
            "collinear end to end",
            V3::new(2.0 * h + 0.98 * d, 0.0, 0.0),
            x,
            x,
            false,
        ),
        (
            "antiparallel side by side",
            V3::new(0.0, 0.97 * d, 0.0),
            x,
            -x,
            false,
        ),
        (
            "rod on a fixed base sphere",
            V3::new(0.4 * h, 0.0, -(0.5 * d + 0.49 * L)),
            x,
            z,
            true,
        ),
        (
            "rod end on a fixed base sphere",
            V3::new(h, 0.0, -(0.5 * d + 0.49 * L)),
            tilted(0.3),
            z,
            true,
        ),
    ];
    for (name, c1, u0, u1, sphere) in cases {
        let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
        let q0 = Quat::from_axis_z(u0).to_f64();
        s.push_spherocylinder(0, [0.0; 3], [0.0; 3], q0, rod, RHO, false);
        if sphere {
            s.push_sphere(1, c1.to_f64(), [0.0; 3], 0.5 * L, RHO, true);
        } else {
            let q1 = Quat::from_axis_z(u1).to_f64();
            s.push_spherocylinder(1, c1.to_f64(), [0.0; 3], q1, rod, RHO, false);
        }
        let cfg = config(2.0, 0.9, 0.5, 0.0, vec![]);
        // Intersecting axes overlap by a whole diameter: past the default overlap watchdog.
        let watchdog = Watchdog {
            max_overlap_ratio: 2.0,
            ..Watchdog::default()
        };
        let mut c = cpu(&cfg, &s);
        c.watchdog = watchdog;
        let options = GpuOptions {
            watchdog,
            ..GpuOptions::default()
        };
        let mut g = GpuEngine::new(&dev, cfg.clone(), &s, options).expect("GPU engine");
        c.advance(1).unwrap();
        g.advance(1).unwrap();
        let (sc, sg) = (c.download(), g.download());
        let f_scale = sc.force[0].norm();
        let t_scale = sc.torque[0].norm().max(1e-3 * f_scale * L);
        let mut ef = 0.0f64;
        let mut et = 0.0f64;
        // Matched by id: each engine may order its particles by cell.
        for k in 0..2 {
            let g = sg
                .id
                .iter()
                .position(|&id| id == sc.id[k])
                .expect("same ids");
            ef = ef.max((sg.force[g] - sc.force[k]).norm() / f_scale);
            et = et.max((sg.torque[g] - sc.torque[k]).norm() / t_scale);
        }
        eprintln!(
            "{name}: |F| {f_scale:.3e} N, |τ| {:.3e} N m; GPU force error {ef:.2e}, torque error {et:.2e} (bounds 1e-5)",
            sc.torque[0].norm()
        );
        assert!(f_scale > 0.0, "{name}: no contact");
        assert!(ef <= 1e-5, "{name}: force error {ef:.2e}");
        assert!(et <= 1e-5, "{name}: torque error {et:.2e}");
    }
}

// ---------------------------------------------------------------------------------------------
// A rod dropped onto a plane.

#[test]
#[ignore = "long tier (minutes on lavapipe): bash scripts/test-long.sh"]
fn rods_dropped_onto_a_plane_come_to_the_cpus_rest() {
    let Some(dev) = device() else { return };
    for tilt in [90.0, 0.0, 30.0] {
        // The contract (energy never rises, the rod comes to rest), then the CPU f32's rest.
        let fg = dropped_rod_comes_to_rest(&On::Gpu(Box::new(dev.clone())), tilt);
        let (cfg, s) = dropped(tilt);
        let d = 2.0 * s.radius[0];
        let (fc, rise_c, drop) = drop_rod(&mut cpu(&cfg, &s));
        // The rest place after the bounces is ill-conditioned: 1 nm of drop height moves it
        // by up to ~10⁻² L. Its realisations: CPU f64 from heights nudged by 0, ±1 and ±2 nm,
        // and CPU f32.
        let mut places = vec![(fc.pos[0].x, fc.pos[0].y)];
        for nm in [0.0, -1.0, 1.0, -2.0, 2.0] {
            let mut nudged = s.clone();
            nudged.pos[0].z += nm * 1e-9;
            let (f, _, _) = drop_rod(&mut CpuEngine::<f64>::new(cfg.clone(), nudged, 1));
            places.push((f.pos[0].x, f.pos[0].y));
        }
        let span = |k: usize| {
            let c = places.iter().map(|p| if k == 0 { p.0 } else { p.1 });
            let lo = c.clone().fold(f64::INFINITY, f64::min);
            (lo, c.fold(f64::NEG_INFINITY, f64::max))
        };
        let ((x_lo, x_hi), (y_lo, y_hi)) = (span(0), span(1));
        let slack_x = (x_hi - x_lo) + 1e-3 * L;
        let slack_y = (y_hi - y_lo) + 1e-3 * L;
        let place_ok = fg.pos[0].x >= x_lo - slack_x
            && fg.pos[0].x <= x_hi + slack_x
            && fg.pos[0].y >= y_lo - slack_y
            && fg.pos[0].y <= y_hi + slack_y;
        eprintln!(
            "drop at {tilt}°: rest x GPU {:.4e} L, realisations [{:.4e}, {:.4e}] L; y GPU {:.4e} L, [{:.4e}, {:.4e}] L",
            fg.pos[0].x / L,
            x_lo / L,
            x_hi / L,
            fg.pos[0].y / L,
            y_lo / L,
            y_hi / L
        );
        let (kg, kc) = (fg.kinetic_energy(), fc.kinetic_energy());
        let dz = (fg.pos[0].z - fc.pos[0].z).abs();
        let dxy =
            ((fg.pos[0].x - fc.pos[0].x).powi(2) + (fg.pos[0].y - fc.pos[0].y).powi(2)).sqrt();
        let du = (fg.axis(0) - fc.axis(0)).norm();
        eprintln!(
            "drop at {tilt}°: energy rise CPU f32 {rise_c:.2e} (bound 1e-5); K/drop GPU {:.2e}, CPU {:.2e}; \
             rest state: |Δz| {:.2e} d (bound 1e-4), |Δxy| {:.2e} L, |Δu| {du:.2e} (bound 1e-3); \
             u_z GPU {:.6}, CPU {:.6}",
            kg / drop,
            kc / drop,
            dz / d,
            dxy / L,
            fg.axis(0).z,
            fc.axis(0).z
        );
        assert!(rise_c < 1e-5, "{tilt}°: the CPU f32 run gained energy");
        assert!(dz < 1e-4 * d, "{tilt}°: rest heights differ");
        assert!(
            place_ok,
            "{tilt}°: the GPU's rest place is off the CPU realisations'"
        );
        assert!(du < 1e-3, "{tilt}°: rest axes differ");
    }
}

// ---------------------------------------------------------------------------------------------
// Two rods colliding in free space.

/// Rod 0 at the origin, rod 1 at `c1`, with axes `u0`, `u1`, approaching at 0.5 m/s each along
/// `dir` (from rod 0 to rod 1).
fn pair(u0: V3<f64>, c1: V3<f64>, u1: V3<f64>, dir: V3<f64>) -> (EngineConfig, State<f64>) {
    let xi = 2.0;
    let sh = shape(xi);
    let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
    let v = dir * 0.5;
    for (id, (c, u, v)) in [(V3::zero(), u0, v), (c1, u1, -v)].into_iter().enumerate() {
        let q = Quat::from_axis_z(u * (1.0 / u.norm())).to_f64();
        s.push_spherocylinder(id as u32, c.to_f64(), v.to_f64(), q, sh, RHO, false);
    }
    (config(xi, 0.9, 0.5, 0.0, vec![]), s)
}

#[test]
fn rod_collisions_match_the_cpu_and_conserve_momenta() {
    let Some(dev) = device() else { return };
    let sh = shape(2.0);
    let (d, gap) = (sh.diameter(), 0.02 * L);
    let x = V3::new(1.0, 0.0, 0.0);
    let y = V3::new(0.0, 1.0, 0.0);
    let z = V3::new(0.0, 0.0, 1.0);
    let cases = [
        // Crossed: rod 1 along y above rod 0, off its centre by 0.3 L along x.
        ("crossed", pair(x, V3::new(0.3 * L, 0.1 * L, d + gap), y, z)),
        // Side by side: both along x, rod 1 above and shifted by 0.4 L along x.
        ("parallel", pair(x, V3::new(0.4 * L, 0.0, d + gap), x, z)),
        // End to end along x, rod 1 offset sideways by 0.2 d.
        ("end to end", pair(x, V3::new(L + gap, 0.2 * d, 0.0), x, x)),
    ];
    for (name, (cfg, s)) in cases {
        // 0.02 L apart at 1 m/s, then 10 contact times (t_c = 50 dt).
        let steps = (gap / 1.0 / cfg.dt_s).ceil() as u64 + 500;
        let mut g = gpu(&dev, &cfg, &s);
        let mut c = cpu(&cfg, &s);
        g.advance(steps).unwrap();
        c.advance(steps).unwrap();
        let (sg, sc) = (g.download(), c.download());
        let m = sg.mass[0];
        let (p0, l0) = momenta(&s);
        let (pg, lg) = momenta(&sg);
        let p_scale = 2.0 * m * 0.5;
        let l_scale = p_scale * L;
        let ep = (pg - p0).norm() / p_scale;
        let el = (lg - l0).norm() / l_scale;
        let (mut dv, mut dl) = (0.0f64, 0.0f64);
        // Matched by id: each engine may order its particles by cell.
        for k in 0..2 {
            let g = sg
                .id
                .iter()
                .position(|&id| id == sc.id[k])
                .expect("same ids");
            dv = dv.max((sg.vel[g] - sc.vel[k]).norm() / 0.5);
            dl = dl.max((sg.ang_mom[g] - sc.ang_mom[k]).norm() / (m * 0.5 * L));
        }
        let spin = sc.ang_mom[0].norm() / (m * 0.5 * L);
        let turned = (sc.vel[0] - s.vel[0]).norm() / 0.5;
        eprintln!(
            "{name}: GPU vs CPU f32 velocities {dv:.2e} of v, angular momenta {dl:.2e} of m v L (bounds 1e-4); \
             GPU momentum drift {ep:.2e}, angular momentum drift {el:.2e} (bounds 1e-6); \
             spin after {spin:.3} m v L, velocity change {turned:.3} v"
        );
        assert!(
            turned > 0.5 && spin > 1e-3,
            "{name}: the rods did not collide"
        );
        assert!(dv < 1e-4, "{name}: velocities differ");
        assert!(dl < 1e-4, "{name}: angular momenta differ");
        assert!(ep < 1e-6, "{name}: momentum drifted");
        assert!(el < 1e-6, "{name}: angular momentum drifted");
    }
}

// ---------------------------------------------------------------------------------------------
// Torque-free precession.

#[test]
fn a_free_top_precesses_as_the_exact_solution() {
    let Some(dev) = device() else { return };
    let xi = 3.0;
    let sh = shape(xi);
    let mut s = State::<f64>::new_oriented(0);
    let u0 = V3::new(0.3f64, -0.2, 0.9);
    let u0 = u0 * (1.0 / u0.norm());
    s.push_spherocylinder(
        0,
        [0.0; 3],
        [0.0; 3],
        Quat::from_axis_z(u0).to_f64(),
        sh,
        RHO,
        false,
    );
    // ω = 20 rad/s along the axis and 25 across it: L is off the axis, so the axis precesses
    // about L at |L|/I⊥ (about 9 rad over the run).
    let across = u0.cross(V3::new(0.0, 0.0, 1.0));
    let across = across * (1.0 / across.norm());
    let w = u0 * 20.0 + across * 25.0;
    s.set_angular_velocity(0, w.to_f64());
    let cfg = config(xi, 0.9, 0.5, 0.0, vec![]);
    let steps = 10_000u64;
    let mut g = gpu(&dev, &cfg, &s);
    let mut c = cpu(&cfg, &s);
    let l0 = s.ang_mom[0];
    // L as the GPU holds it: f32 and its rest, within f64's rounding of the upload.
    let l_held = g.download().ang_mom[0];
    assert!(
        (l_held - l0).norm() <= 1e-14 * l0.norm(),
        "L uploaded as {l_held:?}, not {l0:?}"
    );
    let e0 = s.kinetic_energy();
    let i_perp = 1.0 / s.inv_inertia_body[0].x;
    let (mut de, mut de_cpu, mut dq) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..10 {
        g.advance(steps / 10).unwrap();
        c.advance(steps / 10).unwrap();
        let (sg, sc) = (g.download(), c.download());
        assert_eq!(sg.ang_mom[0], l_held, "L changed without a torque");
        de = de.max((sg.kinetic_energy() - e0).abs() / e0);
        de_cpu = de_cpu.max((sc.kinetic_energy() - e0).abs() / e0);
        dq = dq.max((sg.orientation[0].norm2().sqrt() - 1.0).abs());
    }
    let (sg, sc) = (g.download(), c.download());
    // Exact: the axis turns about L̂ by |L| t / I⊥ (the spin about the axis does not move it).
    let t = steps as f64 * cfg.dt_s;
    let lh = l0 * (1.0 / l0.norm());
    let angle = l0.norm() * t / i_perp;
    let exact = Quat::from_axis_angle(lh, angle).rotate(u0);
    let (ex, vs) = (
        (sg.axis(0) - exact).norm(),
        (sg.axis(0) - sc.axis(0)).norm(),
    );
    let off = lh.dot(u0).acos();
    eprintln!(
        "free top: L {off:.2} rad off the axis, turned {angle:.1} rad about L in {steps} steps; axis vs exact {ex:.2e} rad \
         (bound 1e-4), vs CPU f32 {vs:.2e} rad (bound 1e-5); energy GPU {de:.2e}, CPU f32 {de_cpu:.2e} (bound 2 × CPU + 1e-6); \
         |q| − 1 ≤ {dq:.2e} (bound 1e-6); L bitwise constant"
    );
    assert!(angle > 6.0, "the top barely turned");
    assert!(ex < 1e-4, "the axis left the exact precession by {ex:e}");
    assert!(vs < 1e-5, "the axis left the CPU's by {vs:e}");
    assert!(de < 2.0 * de_cpu + 1e-6, "energy changed by {de:e}");
    assert!(dq < 1e-6, "|q| left 1 by {dq:e}");
}

// ---------------------------------------------------------------------------------------------
// A short chute.

/// Mean flow velocity v_x of the mobile particles (m/s) and their kinetic energy (J).
fn flow(s: &State<f64>) -> (f64, f64) {
    let (mut vx, mut n) = (0.0, 0usize);
    for i in 0..s.len() {
        if s.inv_mass[i] != 0.0 {
            vx += s.vel[i].x;
            n += 1;
        }
    }
    (vx / n.max(1) as f64, s.kinetic_energy())
}

/// Runs `b` for 6 s in chunks of `chunk` steps; returns the mean flow velocity and kinetic
/// energy averaged over the chunks of the last second, and the wall time (s).
fn run_chute(b: &mut dyn Backend, chunk: u64, dt: f64) -> (f64, f64, f64) {
    let chunks = (6.0 / (chunk as f64 * dt)).round() as usize;
    let last = (1.0 / (chunk as f64 * dt)).round() as usize;
    let (mut vx, mut k) = (0.0, 0.0);
    let start = std::time::Instant::now();
    for c in 0..chunks {
        b.advance(chunk).unwrap();
        if c >= chunks - last {
            let (v, e) = flow(&b.download());
            vx += v / last as f64;
            k += e / last as f64;
        }
    }
    (vx, k, start.elapsed().as_secs_f64())
}

#[test]
#[ignore = "long tier (minutes on lavapipe): bash scripts/test-long.sh"]
fn a_short_chute_flows_as_on_the_cpu() {
    let Some(dev) = device() else { return };
    let scene = ChuteScene::new(ChuteParams {
        aspect_ratio: 1.3,
        inclination_deg: 28.0,
        box_x_lengths: 5.0,
        box_y_lengths: 5.0,
        particle_count: Some(300),
        contact_steps: 20.0,
        ..ChuteParams::default()
    })
    .unwrap();
    let cfg = scene.engine_config();
    let s = scene.initial_state(7);
    let rods = s.inv_mass.iter().filter(|&&m| m != 0.0).count();
    let chunk = (0.1 / scene.dt).round() as u64;
    let (vg, kg, tg) = run_chute(&mut gpu(&dev, &cfg, &s), chunk, scene.dt);
    let (vc, kc, tc) = run_chute(&mut cpu(&cfg, &s), chunk, scene.dt);
    let (v64, k64, _) = run_chute(
        &mut CpuEngine::<f64>::new(cfg.clone(), s.clone(), 2),
        chunk,
        scene.dt,
    );
    // Two more realisations: the same pour with every rod moved by 1 nm along x.
    let mut nudged = s.clone();
    for i in 0..nudged.len() {
        if nudged.inv_mass[i] != 0.0 {
            nudged.pos[i].x += 1e-9;
        }
    }
    let (vn, kn, _) = run_chute(&mut cpu(&cfg, &nudged), chunk, scene.dt);
    let (vn64, kn64, _) = run_chute(
        &mut CpuEngine::<f64>::new(cfg.clone(), nudged, 2),
        chunk,
        scene.dt,
    );
    // As run_chute: whole chunks.
    let steps = (6.0 / (chunk as f64 * scene.dt)).round() * chunk as f64;
    eprintln!(
        "chute: {rods} rods of ξ = 1.3 on {} base spheres, 6 s; mean v_x over the last second: GPU {vg:.4} m/s, \
         CPU f32 {vc:.4}, CPU f64 {v64:.4}; K: GPU {kg:.4e} J, CPU f32 {kc:.4e}, CPU f64 {k64:.4e}; \
         wall time GPU {tg:.1} s ({:.2e} particle-steps/s), CPU f32 {tc:.1} s ({:.2e})",
        s.len() - rods,
        rods as f64 * steps / tg,
        rods as f64 * steps / tc
    );
    eprintln!("nudged by 1 nm: v_x CPU f32 {vn:.4}, CPU f64 {vn64:.4}; K CPU f32 {kn:.4e}, CPU f64 {kn64:.4e}");
    assert!(vc > 0.1, "the chute does not flow: v_x = {vc}");
    // The CPU realisations span [lo, hi]; the GPU's must lie within that span widened by its
    // own width on each side, plus 2 % (a floor for runs that have not parted).
    let within = |what: &str, gpu: f64, cpu: [f64; 4]| {
        let lo = cpu.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = cpu.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let slack = (hi - lo) + 0.02 * hi.abs();
        assert!(
            gpu >= lo - slack && gpu <= hi + slack,
            "{what}: GPU {gpu} outside the CPU realisations {cpu:?} widened by {slack}"
        );
    };
    within("flow velocity", vg, [vc, v64, vn, vn64]);
    within("kinetic energy", kg, [kc, k64, kn, kn64]);
}

// ---------------------------------------------------------------------------------------------
// Checkpoints across backends.

/// Largest position difference (in d) and velocity difference (m/s) between particles of equal
/// id, minimum image across the periodic box.
fn deviation(a: &State<f64>, b: &State<f64>, cfg: &EngineConfig) -> (f64, f64) {
    let ib = by_id(b);
    let (mut dx, mut dv) = (0.0f64, 0.0f64);
    for (k, id) in a.id.iter().enumerate() {
        let j = ib[id];
        let mut d = a.pos[k] - b.pos[j];
        if let Some([lo, hi]) = cfg.periodic_x {
            d.x -= (hi - lo) * (d.x / (hi - lo)).round();
        }
        if let Some([lo, hi]) = cfg.periodic_y {
            d.y -= (hi - lo) * (d.y / (hi - lo)).round();
        }
        dx = dx.max(d.norm() / (2.0 * a.radius[k]));
        dv = dv.max((a.vel[k] - b.vel[j]).norm());
    }
    (dx, dv)
}

#[test]
fn rod_checkpoints_move_between_gpu_and_cpu() {
    let Some(dev) = device() else { return };
    // The compressed lattice, at the chute's time step: overlaps, springs, walls, fixed rods.
    let (mut cfg, s) = lattice(1.3, 77);
    cfg.dt_s = stiffness(1.3).1;
    // A download carried to the other backend and back is the same State, bit for bit.
    let mut g = gpu(&dev, &cfg, &s);
    g.advance(100).unwrap();
    let from_gpu = g.download();
    assert!(
        from_gpu.history.partner.iter().any(|&k| k != EMPTY),
        "no history to carry over"
    );
    let mut c = cpu(&cfg, &from_gpu);
    // CPU f32 holds velocities and angular momenta in f32: the GPU's rests below that are all
    // the move drops.
    let mut in_f32 = from_gpu.clone();
    for v in in_f32.vel.iter_mut().chain(&mut in_f32.ang_mom) {
        *v = V3::from_f64(v.to_f64().map(|x| x as f32 as f64));
    }
    assert_eq!(c.download(), in_f32, "GPU → CPU changed the state");
    assert_eq!(
        gpu(&dev, &cfg, &c.download()).download(),
        in_f32,
        "CPU → GPU changed the state"
    );
    let mut back = gpu(&dev, &cfg, &from_gpu);
    assert_eq!(back.download(), from_gpu, "GPU → GPU changed the state");
    // 300 steps straight on the GPU; 100 on the GPU, 100 on the CPU, 100 on the GPU; and the
    // GPU resumed from its own download.
    g.advance(200).unwrap();
    let straight = g.download();
    c.advance(100).unwrap();
    let mut g2 = gpu(&dev, &cfg, &c.download());
    g2.advance(100).unwrap();
    let moved = g2.download();
    back.advance(200).unwrap();
    let resumed = back.download();
    assert_eq!(moved.step, straight.step);
    // The dense lattice amplifies rounding fast: the bound is how far CPU f64 and CPU f32 part
    // over the same 300 steps (any rounding difference grows like that), doubled.
    let mut c32 = cpu(&cfg, &s);
    let mut c64 = CpuEngine::<f64>::new(cfg.clone(), s.clone(), 2);
    c32.advance(300).unwrap();
    c64.advance(300).unwrap();
    let (dx_r, dv_r) = deviation(&c64.download(), &c32.download(), &cfg);
    let (dx, dv) = deviation(&moved, &straight, &cfg);
    eprintln!(
        "rod checkpoint GPU → CPU → GPU vs straight GPU over 300 steps: |Δx| ≤ {dx:.2e} d, |Δv| ≤ {dv:.2e} m/s; \
         bounds twice CPU f64 vs f32: {:.2e} d, {:.2e} m/s",
        2.0 * dx_r,
        2.0 * dv_r
    );
    assert!(dx <= 2.0 * dx_r, "positions differ by {dx:e} d");
    assert!(dv <= 2.0 * dv_r, "velocities differ by {dv:e} m/s");
    assert_eq!(
        resumed, straight,
        "a GPU run resumed from its download is not bit-identical"
    );
}
