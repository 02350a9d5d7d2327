//! Stability in the cases that break DEM codes, and the energy watchdog. Run in release mode.
//!
//! Every run is checked after each chunk (tolerances stated at each case):
//! - no NaN or Inf in positions, velocities, angular velocities or orientations;
//! - bounded kinetic energy: K + V ≤ K₀ + U₀ + V₀ + allowance, with U the elastic energy in the
//!   contacts and V the gravitational energy above a height no centre can pass. Contacts only
//!   store or dissipate energy and static walls do no work, so this holds for any healthy run
//!   (U ≥ 0); the allowance is 1 % of K₀ + U₀ (integrator error) and M g · 1e-8 m (rounding of
//!   f32 heights), plus ½ M (2 v_w)² where a wall moves at surface speed up to v_w (a rebound at
//!   twice the wall speed);
//! - the largest overlap of any step (the chunk report's) under a stated fraction of d;
//! - total momentum, where nothing external acts (no walls, no gravity, no fixed particles).
//!
//! Sphere cases use the silo paper's law (Hertz–Mindlin, Y = 3 GPa, G = 0.1 GPa, e = 0.9,
//! μ = 0.5, d = 5.8 mm) at dt = 1 µs unless stated; each runs on the CPU and, where a GPU adapter
//! exists, on the GPU backend (f32). The spherocylinder cases (8a, 8b) run on the CPU in f64 and
//! on the GPU, where only the momentum bounds are widened to f32 rounding. GPU tests share one device
//! (`common::gpu`, any adapter, lavapipe included); without an adapter they print a message and
//! pass, except under CI=true, where a missing adapter fails them.
//!
//! A failure means the engine diverged, tunnelled, created energy or momentum, or (for the
//! watchdog tests) that the watchdog missed a blow-up or stopped a healthy accelerating flow.

use crate::common;
use crate::common::gpu::device;
use crate::common::rods::{shape as rod, L as ROD_L, RHO as ROD_RHO};
use crate::common::Noise;

use std::f64::consts::PI;
use std::sync::OnceLock;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, Elasticity, NormalModel};
use sweep::engine::gpu::{GpuDevice, GpuEngine, GpuOptions};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::shape::{contact_spherocylinders, Quat};
use sweep::engine::walls::{Wall, WallRotation, WallShape};
use sweep::engine::watchdog::Watchdog;
use sweep::engine::{Backend, CpuEngine, EngineConfig, EngineError, State, V3};

const G: f64 = 9.81;
const RHO: f64 = 2655.0;
const D: f64 = 0.0058;
const R: f64 = D / 2.0;
/// Radius of the small silo: 4 d.
const RC: f64 = 4.0 * D;
/// Silo time step (s), the paper's.
const DT: f64 = 1.0e-6;

fn silo_law(e: f64) -> ContactLaw {
    ContactLaw {
        normal: NormalModel::Hertz(Elasticity::YoungShear {
            youngs_modulus_pa: 3.0e9,
            shear_modulus_pa: 1.0e8,
        }),
        restitution: e,
        tangential_restitution: e,
        friction: 0.5,
    }
}

fn mass() -> f64 {
    RHO * PI / 6.0 * D.powi(3)
}

/// Hertz contact time of two silo spheres meeting at 1 m/s (s): about 47 µs.
fn tc() -> f64 {
    let pair = ContactPair {
        r_eff: R / 2.0,
        m_eff: mass() / 2.0,
    };
    contact_time(&silo_law(0.9), pair, 1.0)
}

fn plane(point: [f64; 3], normal: [f64; 3]) -> Wall {
    Wall {
        shape: WallShape::Plane { point, normal },
        rotation: None,
    }
}

fn cylinder() -> Wall {
    Wall {
        shape: WallShape::Cylinder {
            axis_xy: [0.0, 0.0],
            radius: RC,
            z_min: 0.0,
            z_max: 1.0,
        },
        rotation: None,
    }
}

/// The silo bottom at z = 0 with an orifice of radius `orifice_radius` (0: closed), turning at
/// `hz` about the silo axis.
fn plate(orifice_radius: f64, hz: f64) -> Wall {
    Wall {
        shape: WallShape::OrificePlate {
            z: 0.0,
            center_xy: [0.0, 0.0],
            orifice_radius,
        },
        rotation: (hz != 0.0).then_some(WallRotation {
            axis_xy: [0.0, 0.0],
            omega_rad_per_s: 2.0 * PI * hz,
        }),
    }
}

/// Plane walls closing the box [0, l] × [0, l] × [0, h].
fn box_walls(l: f64, h: f64) -> Vec<Wall> {
    vec![
        plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        plane([l, 0.0, 0.0], [-1.0, 0.0, 0.0]),
        plane([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        plane([0.0, l, 0.0], [0.0, -1.0, 0.0]),
        plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        plane([0.0, 0.0, h], [0.0, 0.0, -1.0]),
    ]
}

fn config(law: ContactLaw, dt: f64, walls: Vec<Wall>, gravity: f64) -> EngineConfig {
    EngineConfig {
        dt_s: dt,
        gravity: [0.0, 0.0, -gravity],
        particle_law: law,
        wall_law: law,
        walls,
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.2 * D,
    }
}

/// A run to check and its bounds.
#[derive(Clone)]
struct Case {
    name: &'static str,
    config: EngineConfig,
    state: State<f64>,
    chunks: usize,
    steps: u64,
    /// Largest overlap allowed in any step, as a fraction of d.
    max_overlap: f64,
    /// No centre can get below this height (m): V = Σ m g (z − z_ref) ≥ 0.
    z_ref: f64,
    /// Allowance in the energy bound besides the moving-wall term, relative to K₀ + U₀.
    energy_slack: f64,
    /// Σ m |v₀| times this bounds the momentum drift; None where momentum is not conserved.
    momentum_tol: Option<f64>,
    /// The engine's watchdog (the default unless a case says why not).
    watchdog: Watchdog,
}

/// What a checked run saw.
struct Seen {
    /// Largest (K + V − V₀) / (K₀ + U₀ + allowance): at most 1.
    energy_ratio: f64,
    /// Largest overlap of any step (fraction of d).
    overlap: f64,
    /// Largest |p − p₀| / Σ m |v₀| (0 where not checked).
    momentum: f64,
    /// Largest K₁/B of the energy watchdog (None on the GPU, which does not measure it).
    growth: Option<f64>,
    removed: usize,
    last: State<f64>,
}

fn finite(s: &State<f64>) -> Result<(), String> {
    for i in 0..s.len() {
        let mut ok = s.pos[i].is_finite() && s.vel[i].is_finite();
        if s.rotation {
            ok &= s.omega[i].is_finite();
        }
        if s.oriented {
            ok &= s.orientation[i].norm2().is_finite() && s.ang_mom[i].is_finite();
        }
        if !ok {
            return Err(format!(
                "particle {} not finite at step {}: x {:?} v {:?}",
                s.id[i], s.step, s.pos[i], s.vel[i]
            ));
        }
    }
    Ok(())
}

/// Σ m g (z − z_ref) over the mobile particles (J).
fn potential(s: &State<f64>, g: f64, z_ref: f64) -> f64 {
    (0..s.len())
        .filter(|&i| s.inv_mass[i] > 0.0)
        .map(|i| s.mass[i] * g * (s.pos[i].z - z_ref))
        .sum()
}

/// Σ m |v| over the mobile particles (kg m/s).
fn momentum_scale(s: &State<f64>) -> f64 {
    (0..s.len())
        .filter(|&i| s.inv_mass[i] > 0.0)
        .map(|i| s.mass[i] * s.vel[i].norm())
        .sum()
}

/// The fastest surface speed of a rotating wall at the silo's radius (m/s).
fn wall_speed(c: &EngineConfig) -> f64 {
    c.walls
        .iter()
        .filter_map(|w| w.rotation)
        .map(|r| r.omega_rad_per_s.abs() * RC)
        .fold(0.0, f64::max)
}

/// Runs `case` on `b` (which holds `case.state`), checking the bounds after every chunk.
fn check(case: &Case, b: &mut dyn Backend, label: &str) -> Seen {
    // The state as this backend holds it (f32 backends round it).
    let s0 = b.download();
    let g = -case.config.gravity[2];
    assert_eq!(case.config.gravity[..2], [0.0, 0.0]);
    let u0 = CpuEngine::<f64>::new(case.config.clone(), s0.clone(), 1).elastic_energy();
    let (k0, v0) = (s0.kinetic_energy(), potential(&s0, g, case.z_ref));
    let m_total: f64 = (0..s0.len())
        .filter(|&i| s0.inv_mass[i] > 0.0)
        .map(|i| s0.mass[i])
        .sum();
    let vw = wall_speed(&case.config);
    // Relative slack, the rounding of f32 heights (1e-8 m, five f32 ulps at 5 d), and the
    // moving-wall term.
    let allowance =
        case.energy_slack * (k0 + u0) + m_total * g * 1e-8 + 0.5 * m_total * (2.0 * vw).powi(2);
    let (p0, pscale) = (s0.momentum(), momentum_scale(&s0));
    let mut seen = Seen {
        energy_ratio: 0.0,
        overlap: 0.0,
        momentum: 0.0,
        growth: None,
        removed: 0,
        last: s0.clone(),
    };
    for chunk in 0..case.chunks {
        let r = b
            .advance(case.steps)
            .unwrap_or_else(|e| panic!("{label}: chunk {chunk}: {e}"));
        let s = b.download();
        finite(&s).unwrap_or_else(|e| panic!("{label}: {e}"));
        seen.removed += r.removed.len();
        seen.overlap = seen.overlap.max(r.max_overlap_ratio);
        if let Some(g) = r.kinetic_growth {
            seen.growth = Some(seen.growth.unwrap_or(0.0).max(g));
        }
        let ratio =
            (s.kinetic_energy() + potential(&s, g, case.z_ref) - v0) / (k0 + u0 + allowance);
        seen.energy_ratio = seen.energy_ratio.max(ratio);
        assert!(
            ratio <= 1.0,
            "{label}: chunk {chunk}: K + V − V₀ = {:.4e} J exceeds K₀ + U₀ + allowance = {:.4e} J: energy was created",
            ratio * (k0 + u0 + allowance),
            k0 + u0 + allowance
        );
        assert!(
            r.max_overlap_ratio <= case.max_overlap,
            "{label}: chunk {chunk}: overlap {:.4} d exceeds {} d",
            r.max_overlap_ratio,
            case.max_overlap
        );
        if let Some(tol) = case.momentum_tol {
            let p = s.momentum();
            let dp = ((p[0] - p0[0]).powi(2) + (p[1] - p0[1]).powi(2) + (p[2] - p0[2]).powi(2))
                .sqrt()
                / pscale;
            seen.momentum = seen.momentum.max(dp);
            assert!(
                dp <= tol,
                "{label}: chunk {chunk}: momentum drifted by {dp:.3e} of Σ m|v| (bound {tol:e})"
            );
        }
        seen.last = s;
    }
    eprintln!(
        "{label}: {} × {} steps: (K + V − V₀)/(K₀ + U₀ + allowance) ≤ {:.3e} (bound 1; K₀ {k0:.3e} J, U₀ {u0:.3e} J), \
         overlap ≤ {:.3e} d (bound {}), momentum drift {:.2e} (bound {:?}), watchdog K₁/B ≤ {} (limit {}), removed {}",
        case.chunks,
        case.steps,
        seen.energy_ratio,
        seen.overlap,
        case.max_overlap,
        seen.momentum,
        case.momentum_tol,
        seen.growth.map_or("n/a".into(), |g| format!("{g:.3}")),
        case.watchdog.max_kinetic_growth,
        seen.removed
    );
    seen
}

fn cpu64(case: &Case) -> CpuEngine<f64> {
    let mut e = CpuEngine::new(case.config.clone(), case.state.clone(), 1);
    e.watchdog = case.watchdog;
    e
}

fn cpu32(case: &Case) -> CpuEngine<f32> {
    let mut e = CpuEngine::new(case.config.clone(), case.state.convert(), 1);
    e.watchdog = case.watchdog;
    e
}

// ---------------------------------------------------------------------------------------------
// Scenes.

/// Spheres at `sites`, at rest, ids in order.
fn spheres(sites: &[[f64; 3]]) -> State<f64> {
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    for (k, &p) in sites.iter().enumerate() {
        s.push_sphere(k as u32, p, [0.0; 3], R, RHO, false);
    }
    s
}

/// A bed of 276 spheres in the small silo (radius 4 d, closed bottom) settled under gravity:
/// square layers of spacing 1.02 d, alternate layers shifted into the hollows and dropped
/// 0.03 d; the edges of the shifted layers collapse, so it settles for 60 ms with e = 0.1 (the
/// top sinks from 5.5 d to 4.8 d) and is then cleared of velocity. Shared by the tests (built
/// once).
fn settled_bed() -> &'static State<f64> {
    static BED: OnceLock<State<f64>> = OnceLock::new();
    BED.get_or_init(|| {
        let mut noise = Noise::new(7);
        let a = 1.02 * D;
        let n = (2.0 * RC / a).ceil() as i64;
        let mut sites = Vec::new();
        for layer in 0..8 {
            let shift = if layer % 2 == 0 { 0.0 } else { 0.5 * a };
            for ix in -n..=n {
                for iy in -n..=n {
                    let x = ix as f64 * a + shift + 0.004 * D * noise.next();
                    let y = iy as f64 * a + shift + 0.004 * D * noise.next();
                    if (x * x + y * y).sqrt() > RC - 0.51 * D {
                        continue;
                    }
                    sites.push([x, y, R + 0.005 * D + layer as f64 * 0.72 * D]);
                }
            }
        }
        let walls = vec![cylinder(), plate(0.0, 0.0)];
        let mut e = CpuEngine::<f64>::new(config(silo_law(0.1), DT, walls, G), spheres(&sites), 1);
        e.advance(60_000).expect("settling the bed");
        let mut s = e.download();
        for v in s.vel.iter_mut().chain(s.omega.iter_mut()) {
            *v = V3::zero();
        }
        s.time = 0.0;
        s.step = 0;
        let m = mass();
        eprintln!(
            "settled bed: {} spheres, top at {:.2} d, KE before clearing {:.2e} m g d per particle",
            s.len(),
            s.pos.iter().map(|p| p.z).fold(0.0, f64::max) / D,
            e.download().kinetic_energy() / (s.len() as f64 * m * G * D)
        );
        s
    })
}

/// The settled bed under the silo law, with the bottom given an orifice of radius
/// `orifice_radius` turning at `hz`, and a sink at −d.
fn silo_case(name: &'static str, orifice_radius: f64, hz: f64) -> Case {
    let mut config = config(
        silo_law(0.9),
        DT,
        vec![cylinder(), plate(orifice_radius, hz)],
        G,
    );
    config.sink_z = Some(-D);
    Case {
        name,
        config,
        state: settled_bed().clone(),
        chunks: 10,
        steps: 1_000,
        max_overlap: 0.01,
        z_ref: -D,
        energy_slack: 1e-2,
        momentum_tol: None,
        watchdog: Watchdog::default(),
    }
}

/// The largest overlap of a silo state (pairs, plate at z = 0 away from any orifice, cylinder),
/// as a fraction of d.
fn largest_overlap(s: &State<f64>) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..s.len() {
        let p = s.pos[i];
        worst = worst.max(R - p.z);
        worst = worst.max(R - (RC - (p.x * p.x + p.y * p.y).sqrt()));
        for j in i + 1..s.len() {
            worst = worst.max(D - (p - s.pos[j]).norm());
        }
    }
    worst / D
}

/// Case 1: the stiff silo law in f32 on the settled bed (closed bottom), 20 000 steps. f32 carries
/// about 7 digits and the bed's overlaps (≈ 1e-6 m) are 3e-5 of the centres' heights: the largest
/// overlap of any step must agree with the f64 run's within 10 % (measured 2.2 %; at the end of the
/// run 4.7 %; GPU over 4 000 steps 0.04 %), and both stay under 0.01 d with K + V − V₀ within the
/// bound.
fn bed_case() -> Case {
    Case {
        name: "f32 bed",
        config: config(silo_law(0.9), DT, vec![cylinder(), plate(0.0, 0.0)], G),
        state: settled_bed().clone(),
        chunks: 10,
        steps: 2_000,
        max_overlap: 0.01,
        z_ref: 0.0,
        energy_slack: 1e-2,
        momentum_tol: None,
        watchdog: Watchdog::default(),
    }
}

#[test]
fn stiff_hertz_in_f32_keeps_the_f64_overlaps() {
    let case = bed_case();
    let a = check(&case, &mut cpu64(&case), "bed, CPU f64");
    let b = check(&case, &mut cpu32(&case), "bed, CPU f32");
    let (la, lb) = (largest_overlap(&a.last), largest_overlap(&b.last));
    let rel = (b.overlap - a.overlap).abs() / a.overlap;
    eprintln!(
        "bed: largest overlap of any step f64 {:.4e} d, f32 {:.4e} d (relative difference {rel:.2e}, bound 0.1); \
         at the end f64 {la:.4e} d, f32 {lb:.4e} d",
        a.overlap, b.overlap
    );
    assert!(
        rel < 0.1,
        "f32 largest overlap {:.4e} d vs f64 {:.4e} d",
        b.overlap,
        a.overlap
    );
}

/// Case 2: a 5 × 5 × 5 lattice of spacing 0.9 d (overlaps of 10 % of d, each sphere pressed by up
/// to six neighbours) in a closed box of 8 d, silo law at dt = 1 µs. The stored elastic energy
/// (checked against Σ 8/15 Y √R* δ^{5/2} within 1e-9) is about 0.5 J per contact with Y = 3 GPa:
/// the lattice flies apart at up to 48 m/s and its rows hit the walls 0.28 ms later, pressing the
/// outer spheres 0.209 d into them. That peak is the law's, not the integrator's: the first 600
/// steps at dt/2 must give the same largest overlap within 2 % (measured 0.2 %). It exceeds the
/// default overlap watchdog (0.2 d, which stops this healthy run at step 278), so this case runs
/// with a limit of 0.25 d. Bounds: K + V − V₀ ≤ U₀ (1 + 1e-2) (no explosion); overlaps ≤ 0.25 d; K
/// at the end below 5 % of U₀ (the contacts dissipate it).
fn overlap_case() -> Case {
    let a = 0.9 * D;
    let l = 8.0 * D;
    let x0 = 0.5 * l - 2.0 * a;
    let sites: Vec<[f64; 3]> = (0..125)
        .map(|k| {
            let (i, j, m) = (k % 5, (k / 5) % 5, k / 25);
            [x0 + i as f64 * a, x0 + j as f64 * a, R + m as f64 * a]
        })
        .collect();
    Case {
        name: "overlaps",
        config: config(silo_law(0.9), DT, box_walls(l, l), G),
        state: spheres(&sites),
        chunks: 20,
        steps: 1_000,
        max_overlap: 0.25,
        z_ref: 0.0,
        energy_slack: 1e-2,
        momentum_tol: None,
        watchdog: Watchdog {
            max_overlap_ratio: 0.25,
            ..Watchdog::default()
        },
    }
}

#[test]
fn ten_percent_insertion_overlaps_relax_without_explosion() {
    let case = overlap_case();
    let s = &case.state;
    // Independent Hertz sum: pairs at 0.9 d and the floor at δ = 0 (springs are zero at t = 0).
    let y = 3.0e9;
    let mut u = 0.0;
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            let delta = D - (s.pos[i] - s.pos[j]).norm();
            if delta > 0.0 {
                u += 8.0 / 15.0 * y * (R / 2.0).sqrt() * delta.powf(2.5);
            }
        }
    }
    let mut e = cpu64(&case);
    let u0 = e.elastic_energy();
    assert!(
        (u0 - u).abs() < 1e-9 * u,
        "engine elastic energy {u0:e} J vs {u:e} J"
    );
    // The peak overlap, at dt and dt/2.
    let peak = |div: f64| {
        let mut c = case.clone();
        c.config.dt_s /= div;
        cpu64(&c)
            .advance((600.0 * div) as u64)
            .unwrap()
            .max_overlap_ratio
    };
    let (p1, p2) = (peak(1.0), peak(2.0));
    eprintln!(
        "overlaps: largest overlap in the first 0.6 ms {p1:.5} d at dt, {p2:.5} d at dt/2 (relative difference {:.2e}, bound 0.02)",
        (p1 - p2).abs() / p2
    );
    assert!(
        (p1 - p2).abs() < 0.02 * p2,
        "peak overlap not converged in dt"
    );
    let seen = check(&case, &mut e, "overlaps, CPU f64");
    let k = seen.last.kinetic_energy();
    eprintln!(
        "overlaps: U₀ {u0:.3e} J, K after {} steps {k:.3e} J ({:.2e} of U₀, bound 0.05)",
        seen.last.step,
        k / u0
    );
    assert!(k < 0.05 * u0, "not relaxing: K {k:.3e} J vs U₀ {u0:.3e} J");
}

/// Case 3: dt = t_c/10 (t_c at 1 m/s; the scenes refuse dt > t_c/5): a frictional, inelastic gas of
/// 300 spheres at solid fraction 0.3 with velocities up to 1 m/s per component in a slab periodic
/// in x and y, no walls, no gravity. K ≤ K₀ (1 + 1e-2); overlaps ≤ 0.02 d (an impact at 2 m/s
/// compresses 0.5 % of d); momentum conserved within 1e-10 of Σ m|v| (pairs apply ±F up to the
/// rounding of the mirrored tangential springs).
fn coarse_dt_case() -> Case {
    let l = 8.0 * D;
    let mut noise = Noise::new(3);
    let mut sites: Vec<[f64; 3]> = Vec::new();
    let image = |d: f64| d - l * (d / l).round();
    while sites.len() < 300 {
        let p = [
            0.5 * l * (1.0 + noise.next()),
            0.5 * l * (1.0 + noise.next()),
            0.5 * l * (1.0 + noise.next()),
        ];
        let free = sites.iter().all(|q| {
            image(p[0] - q[0]).powi(2) + image(p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)
                >= 1.0001 * D * D
        });
        if free {
            sites.push(p);
        }
    }
    let mut state = spheres(&sites);
    for v in state.vel.iter_mut() {
        *v = V3::new(noise.next(), noise.next(), noise.next());
    }
    let mut config = config(silo_law(0.9), tc() / 10.0, vec![], 0.0);
    config.periodic_x = Some([0.0, l]);
    config.periodic_y = Some([0.0, l]);
    Case {
        name: "dt = t_c/10",
        config,
        state,
        chunks: 10,
        steps: 200,
        max_overlap: 0.02,
        z_ref: 0.0,
        energy_slack: 1e-2,
        momentum_tol: Some(1e-10),
        watchdog: Watchdog::default(),
    }
}

#[test]
fn a_tenth_of_the_contact_time_stays_stable() {
    let case = coarse_dt_case();
    eprintln!("t_c = {:.3e} s, dt = {:.3e} s", tc(), case.config.dt_s);
    check(&case, &mut cpu64(&case), "dt = t_c/10, CPU f64");
}

/// Case 4: the settled bed over an orifice of 0.8 d, f = 0, for 10 ms: nothing can pass, the silo
/// is clogged (the sphere over the hole drops into it and sits on the rim) and must keep running at
/// rest. No particle removed or below the plate; K + V − V₀ within the bound; overlaps ≤ 0.01 d.
fn clogged_case() -> Case {
    silo_case("clogged", 0.4 * D, 0.0)
}

fn assert_held(seen: &Seen, label: &str, floor: f64) {
    assert_eq!(seen.removed, 0, "{label}: particles left a clogged silo");
    let low = seen.last.pos.iter().map(|p| p.z).fold(f64::MAX, f64::min);
    assert!(
        low > floor,
        "{label}: a centre at z = {:.3} d went through",
        low / D
    );
}

#[test]
fn a_clogged_silo_keeps_running() {
    let case = clogged_case();
    let seen = check(&case, &mut cpu64(&case), "clogged, CPU f64");
    assert_held(&seen, "clogged, CPU f64", 0.0);
}

/// Case 5: the settled bed over an orifice of 3 d while the bottom turns at f = 5 Hz (rim speed
/// 0.73 m/s at R_c), for 10 ms: the bottom layer is dragged round and the spheres over the hole
/// start to fall (none reaches the sink at −d yet). K + V − V₀ ≤ the bound with ½ M (2 v_w)²;
/// overlaps ≤ 0.01 d.
fn rotating_case() -> Case {
    silo_case("5 Hz", 1.5 * D, 5.0)
}

#[test]
fn the_bottom_turning_at_5_hz_under_a_bed_stays_stable() {
    let case = rotating_case();
    check(&case, &mut cpu64(&case), "5 Hz, CPU f64");
}

/// Case 6: two spheres spanning an orifice of 1.8 d, each wedged between the rim and the other, and
/// a third pressing on both from above (all touching at t = 0), under gravity; first with the
/// bottom still, then turning at 5 Hz. The arch holds (nothing removed, every centre above the
/// plate), K + V − V₀ ≤ (K₀ + U₀)(1 + 1e-2) (+ the moving-wall term), overlaps ≤ 0.01 d.
fn wedge_case(hz: f64) -> Case {
    // Rim at ρ = 1.8 r; A and B touch at x = ±r, so the rim is 0.8 r away horizontally and
    // they sit 0.6 r above the plate; C touches both, √3 r above them.
    let z = 0.6 * R;
    let sites = [[-R, 0.0, z], [R, 0.0, z], [0.0, 0.0, z + 3f64.sqrt() * R]];
    let mut config = config(silo_law(0.9), DT, vec![cylinder(), plate(1.8 * R, hz)], G);
    config.sink_z = Some(-2.0 * D);
    Case {
        name: "wedge",
        config,
        state: spheres(&sites),
        chunks: 10,
        steps: 2_000,
        max_overlap: 0.01,
        z_ref: -2.0 * D,
        energy_slack: 1e-2,
        momentum_tol: None,
        watchdog: Watchdog::default(),
    }
}

#[test]
fn spheres_wedged_between_the_rim_and_a_neighbour_hold() {
    for hz in [0.0, 5.0] {
        let case = wedge_case(hz);
        let label = format!("wedge at {hz} Hz, CPU f64");
        let seen = check(&case, &mut cpu64(&case), &label);
        assert_held(&seen, &label, 0.0);
    }
}

/// Case 7: contacts across the periodic seams: a box periodic in x and y, [0, 6 d)², no walls, no
/// gravity; a 3 × 3 × 2 cluster of spacing 0.99 d centred on the corner (12 of its contacts cross a
/// seam), and pairs one above the other with one centre exactly on x = 0 (or y = 0, or both) and
/// the other at 6 d (1 − 1e-12), which f32 rounds onto the box's upper end: 19 contacts across a
/// seam at t = 0. Velocities up to 0.5 m/s per component. Momentum within 1e-10 of Σ m|v| in f64
/// (1e-5 in f32, whose contact sums round at 6e-8); K ≤ (K₀ + U₀)(1 + 1e-2); overlaps ≤ 0.02 d;
/// every downloaded centre in [0, 6 d).
const SEAM_L: f64 = 6.0 * D;

fn seam_case(f32_tol: bool) -> Case {
    let l = SEAM_L;
    let a = 0.99 * D;
    let mut sites = Vec::new();
    for i in -1..2 {
        for j in -1..2 {
            for k in 0..2 {
                let w = |x: f64| x.rem_euclid(l);
                sites.push([w(i as f64 * a), w(j as f64 * a), R + k as f64 * a]);
            }
        }
    }
    // Pairs one above the other, one centre exactly on the lower end of the box and the other
    // a hair below its upper end: across the x seam, the y seam, and both at the corner.
    let hi = l * (1.0 - 1e-12);
    let (z, up) = (3.0 * D, 3.99 * D);
    for k in 0..3 {
        let t = (2.0 + 1.05 * k as f64) * D;
        sites.push([0.0, t, z]);
        sites.push([hi, t, up]);
        sites.push([t, 0.0, z]);
        sites.push([t, hi, up]);
    }
    sites.push([hi, hi, 5.5 * D]);
    sites.push([0.0, 0.0, 6.49 * D]);
    let mut noise = Noise::new(11);
    let mut state = spheres(&sites);
    for v in state.vel.iter_mut() {
        *v = V3::new(0.5 * noise.next(), 0.5 * noise.next(), 0.5 * noise.next());
    }
    let mut config = config(silo_law(0.9), DT, vec![], 0.0);
    config.periodic_x = Some([0.0, l]);
    config.periodic_y = Some([0.0, l]);
    Case {
        name: "seams",
        config,
        state,
        chunks: 10,
        steps: 500,
        max_overlap: 0.02,
        z_ref: 0.0,
        energy_slack: 1e-2,
        momentum_tol: Some(if f32_tol { 1e-5 } else { 1e-10 }),
        watchdog: Watchdog::default(),
    }
}

/// Pairs in contact whose centres lie on opposite sides of a seam.
fn seam_contacts(s: &State<f64>) -> usize {
    let l = SEAM_L;
    let image = |d: f64| d - l * (d / l).round();
    let mut n = 0;
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            let d = s.pos[i] - s.pos[j];
            let (x, y) = (image(d.x), image(d.y));
            let across = x != d.x || y != d.y;
            if across && (x * x + y * y + d.z * d.z) < D * D {
                n += 1;
            }
        }
    }
    n
}

fn assert_in_box(s: &State<f64>, label: &str) {
    for i in 0..s.len() {
        let p = s.pos[i];
        assert!(
            (0.0..SEAM_L).contains(&p.x) && (0.0..SEAM_L).contains(&p.y),
            "{label}: particle {} at ({:e}, {:e}) is outside [0, {:e})",
            s.id[i],
            p.x,
            p.y,
            SEAM_L
        );
    }
}

#[test]
fn contacts_across_the_periodic_seams() {
    let case = seam_case(false);
    let across = seam_contacts(&case.state);
    eprintln!("seams: {across} contacts across a seam at t = 0");
    assert!(across >= 19, "only {across} contacts cross a seam");
    let seen = check(&case, &mut cpu64(&case), "seams, CPU f64");
    assert_in_box(&seen.last, "seams, CPU f64");
    let case = seam_case(true);
    let seen = check(&case, &mut cpu32(&case), "seams, CPU f32");
    assert_in_box(&seen.last, "seams, CPU f32");
}

// ---------------------------------------------------------------------------------------------
// Spherocylinders (CPU, oriented path), in the chute paper's units: L = 0.125 m, ρ = 2600 kg/m³,
// linear law k_n = 2e5 m g / L with g = 1 m/s², k_t = 2/7 k_n, dt = t_c/50, no gravity.

fn rod_law(xi: f64, e: f64, mu: f64) -> (ContactLaw, f64) {
    let m = rod(xi).mass(ROD_RHO);
    let kn = 2e5 * m / ROD_L;
    let law = common::linear_law(kn, e, mu);
    let tc = contact_time(
        &law,
        ContactPair {
            r_eff: 0.25 * rod(xi).diameter(),
            m_eff: 0.5 * m,
        },
        1.0,
    );
    (law, tc / 50.0)
}

fn rod_config(xi: f64, e: f64, mu: f64, periodic: Option<f64>) -> EngineConfig {
    let (law, dt) = rod_law(xi, e, mu);
    EngineConfig {
        dt_s: dt,
        gravity: [0.0; 3],
        particle_law: law,
        wall_law: law,
        walls: vec![],
        periodic_x: periodic.map(|l| [0.0, l]),
        periodic_y: periodic.map(|l| [0.0, l]),
        sink_z: None,
        skin_m: 0.05 * ROD_L,
    }
}

/// Kinetic plus elastic energy (J) of a state (the springs as stored, evaluated in f64).
fn rod_energy(cfg: &EngineConfig, s: &State<f64>) -> f64 {
    s.kinetic_energy() + CpuEngine::<f64>::new(cfg.clone(), s.clone(), 1).elastic_energy()
}

/// What a rod case saw over its 20 chunks of 200 steps.
struct RodSeen {
    /// Largest (E − E₀)/E₀ and largest |E − E₀|/E₀, E = K + U.
    rise: f64,
    change: f64,
    /// Largest momentum drift / Σ m|v| and angular momentum drift / (Σ m|v| · 10 L).
    p_drift: f64,
    l_drift: f64,
    overlap: f64,
    /// Mean contacts per particle over the chunks.
    contacts: f64,
    /// K at the end / E₀, and the smallest |u_x| of any rod at the end.
    k_end: f64,
    axis_x: f64,
}

fn run_rods(b: &mut dyn Backend, cfg: &EngineConfig, label: &str) -> RodSeen {
    let s0 = b.download();
    let e0 = rod_energy(cfg, &s0);
    let (p0, l0) = common::rods::momenta(&s0);
    let pscale = momentum_scale(&s0);
    let mut seen = RodSeen {
        rise: f64::MIN,
        change: 0.0,
        p_drift: 0.0,
        l_drift: 0.0,
        overlap: 0.0,
        contacts: 0.0,
        k_end: 0.0,
        axis_x: 1.0,
    };
    for _ in 0..20 {
        let r = b
            .advance(200)
            .unwrap_or_else(|err| panic!("{label}: {err}"));
        let s = b.download();
        finite(&s).unwrap_or_else(|e| panic!("{label}: {e}"));
        seen.overlap = seen.overlap.max(r.max_overlap_ratio);
        seen.contacts += r.contacts_per_particle / 20.0;
        let e = rod_energy(cfg, &s);
        seen.rise = seen.rise.max((e - e0) / e0);
        seen.change = seen.change.max((e - e0).abs() / e0);
        let (p, l) = common::rods::momenta(&s);
        seen.p_drift = seen.p_drift.max((p - p0).norm() / pscale);
        seen.l_drift = seen.l_drift.max((l - l0).norm() / (pscale * 10.0 * ROD_L));
    }
    let s = b.download();
    seen.k_end = s.kinetic_energy() / e0;
    seen.axis_x = (0..s.len())
        .map(|i| s.orientation[i].axis_z().x.abs())
        .fold(1.0, f64::min);
    seen
}

/// Case 8a: a nematic gas: 100 rods of ξ whose axes lie within about 1e-3 rad of ±x (a fifth
/// exactly along +x, a fifth exactly along −x, a fifth within 1e-7 rad), at random non-overlapping
/// places in a box periodic in x and y (5.5 L, solid fraction 0.3), velocities up to 0.5 m/s per
/// component, no spin, elastic and frictionless (e = 1, μ = 0). Near-parallel pairs have nearly
/// degenerate closest points; a jump in the contact point would pump energy. Over 4 000 steps: K +
/// U within 1e-4 of its initial value, momentum within 1e-12 of Σ m|v| (pairs apply bitwise ±F),
/// overlaps ≤ 0.02 d (an impact at 1.7 m/s compresses 0.8 % of d).
fn near_parallel_case(xi: f64) -> (EngineConfig, State<f64>) {
    let sh = rod(xi);
    let box_l = 5.5 * ROD_L;
    let mut noise = Noise::new(21 + (xi * 100.0) as u64);
    let mut s = State::<f64>::new_oriented(0);
    let mut placed: Vec<(V3<f64>, V3<f64>)> = Vec::new();
    let image = |mut d: V3<f64>| {
        d.x -= box_l * (d.x / box_l).round();
        d.y -= box_l * (d.y / box_l).round();
        d
    };
    while placed.len() < 100 {
        let k = placed.len();
        let tilt = match k % 5 {
            0 | 1 => 0.0,
            2 => 1e-7,
            _ => 1e-3,
        };
        let sign = match k % 5 {
            0 => 1.0,
            1 => -1.0,
            _ if k.is_multiple_of(2) => 1.0,
            _ => -1.0,
        };
        let u = V3::new(sign, tilt * noise.next(), tilt * noise.next());
        let u = u * (1.0 / u.norm());
        let c = V3::new(
            0.5 * box_l * (1.0 + noise.next()),
            0.5 * box_l * (1.0 + noise.next()),
            0.5 * box_l * (1.0 + noise.next()),
        );
        if placed
            .iter()
            .any(|&(p, v)| contact_spherocylinders(image(c - p), u, &sh, v, &sh).is_some())
        {
            continue;
        }
        placed.push((c, u));
    }
    for (k, (c, u)) in placed.iter().enumerate() {
        let v = [0.5 * noise.next(), 0.5 * noise.next(), 0.5 * noise.next()];
        let q = Quat::from_axis_z(*u).to_f64();
        s.push_spherocylinder(k as u32, c.to_f64(), v, q, sh, ROD_RHO, false);
    }
    (rod_config(xi, 1.0, 0.0, Some(box_l)), s)
}

/// Runs case 8a on `b`; `energy_tol` and `momentum_tol` are the run precision's bounds.
fn near_parallel_rods(
    b: &mut dyn Backend,
    cfg: &EngineConfig,
    xi: f64,
    label: &str,
    tol: (f64, f64),
) {
    let seen = run_rods(b, cfg, label);
    let (energy_tol, momentum_tol) = tol;
    eprintln!(
        "near-parallel rods ξ = {xi}, {label}: |ΔE|/E₀ ≤ {:.2e} (bound {energy_tol:.0e}), momentum drift {:.2e} \
         (bound {momentum_tol:.0e}), overlap ≤ {:.2e} d (bound 0.02), {:.2} contacts per particle on average, \
         smallest |u_x| at the end {:.6}",
        seen.change, seen.p_drift, seen.overlap, seen.contacts, seen.axis_x
    );
    assert!(
        seen.contacts > 0.0,
        "ξ = {xi}, {label}: no contacts: the test compares nothing"
    );
    assert!(
        seen.change < energy_tol,
        "ξ = {xi}, {label}: energy changed by {:e}",
        seen.change
    );
    assert!(
        seen.p_drift < momentum_tol,
        "ξ = {xi}, {label}: momentum drifted by {:e}",
        seen.p_drift
    );
    assert!(
        seen.overlap <= 0.02,
        "ξ = {xi}, {label}: overlap {} d",
        seen.overlap
    );
}

/// Case 8b: rods end to end: three rows of six rods along x, 1.05 L apart centre to centre, rods
/// alternately at ±0.5 m/s so neighbours meet cap to cap at 1 m/s. Row 1 exactly collinear; row 2
/// tilted by ±1e-3 rad and offset sideways by ±1e-4 L; row 3 alternately along +x and −x and tilted
/// by 1e-7 rad. Frictional and inelastic (e = 0.9, μ = 0.5), free space. Over 4 000 steps: linear
/// and angular momentum within 1e-10 (relative to Σ m|v| and Σ m|v| · 10 L), K + U never above its
/// initial value by more than 1e-6 of it, overlaps ≤ 0.02 d.
fn end_to_end_case(xi: f64) -> (EngineConfig, State<f64>) {
    let sh = rod(xi);
    let mut noise = Noise::new(5);
    let mut s = State::<f64>::new_oriented(HISTORY_SLOTS);
    let mut id = 0u32;
    for row in 0..3 {
        for k in 0..6 {
            let alt = if k % 2 == 0 { 1.0 } else { -1.0 };
            let (u, offset) = match row {
                0 => (V3::new(1.0, 0.0, 0.0), 0.0),
                1 => (
                    V3::new(1.0, 1e-3 * alt, 1e-3 * noise.next()),
                    1e-4 * ROD_L * alt,
                ),
                _ => (V3::new(alt, 1e-7, -1e-7), 0.0),
            };
            let u = u * (1.0 / u.norm());
            let c = [
                k as f64 * 1.05 * ROD_L,
                2.0 * ROD_L * row as f64 + offset,
                0.0,
            ];
            let q = Quat::from_axis_z(u).to_f64();
            s.push_spherocylinder(id, c, [0.5 * alt, 0.0, 0.0], q, sh, ROD_RHO, false);
            id += 1;
        }
    }
    (rod_config(xi, 0.9, 0.5, None), s)
}

/// Runs case 8b on `b`; `tol` = (energy rise, momentum drift) bounds of the run's precision.
fn end_to_end_rods(b: &mut dyn Backend, cfg: &EngineConfig, xi: f64, label: &str, tol: (f64, f64)) {
    let seen = run_rods(b, cfg, label);
    let (rise_tol, momentum_tol) = tol;
    eprintln!(
        "end-to-end rods ξ = {xi}, {label}: (E − E₀)/E₀ ≤ {:.2e} (bound {rise_tol:.0e}), K at the end {:.3} of E₀, \
         momentum drift {:.2e}, angular momentum drift {:.2e} (bounds {momentum_tol:.0e}), overlap ≤ {:.2e} d (bound 0.02)",
        seen.rise, seen.k_end, seen.p_drift, seen.l_drift, seen.overlap
    );
    assert!(
        seen.k_end < 0.99,
        "ξ = {xi}, {label}: the rods never collided"
    );
    assert!(
        seen.rise < rise_tol,
        "ξ = {xi}, {label}: energy rose by {:e}",
        seen.rise
    );
    assert!(
        seen.p_drift < momentum_tol,
        "ξ = {xi}, {label}: momentum drifted by {:e}",
        seen.p_drift
    );
    assert!(
        seen.l_drift < momentum_tol,
        "ξ = {xi}, {label}: angular momentum drifted by {:e}",
        seen.l_drift
    );
    assert!(
        seen.overlap <= 0.02,
        "ξ = {xi}, {label}: overlap {} d",
        seen.overlap
    );
}

#[test]
fn near_parallel_spherocylinders_conserve_energy() {
    for xi in [1.00, 1.01] {
        let (cfg, s) = near_parallel_case(xi);
        let mut e = CpuEngine::<f64>::new(cfg.clone(), s, 1);
        near_parallel_rods(&mut e, &cfg, xi, "CPU f64", (1e-4, 1e-12));
    }
}

#[test]
fn end_to_end_spherocylinders_conserve_momentum() {
    for xi in [1.00, 1.01] {
        let (cfg, s) = end_to_end_case(xi);
        let mut e = CpuEngine::<f64>::new(cfg.clone(), s, 1);
        end_to_end_rods(&mut e, &cfg, xi, "CPU f64", (1e-6, 1e-10));
    }
}

// ---------------------------------------------------------------------------------------------
// The energy watchdog.

/// A loose bed: 8 × 8 × 5 silo spheres on a square lattice of spacing 1.01 d in a closed box,
/// at rest.
fn loose_bed(dt: f64) -> (EngineConfig, State<f64>) {
    let a = 1.01 * D;
    let mut sites = Vec::new();
    for k in 0..320 {
        let (i, j, m) = (k % 8, (k / 8) % 8, k / 64);
        sites.push([
            (i as f64 + 0.5) * a,
            (j as f64 + 0.5) * a,
            R + 0.005 * D + m as f64 * a,
        ]);
    }
    let l = 8.0 * a;
    (
        config(silo_law(0.9), dt, box_walls(l, 8.0 * l), G),
        spheres(&sites),
    )
}

/// Advances in chunks of `steps` until an error or `chunks` chunks; the error and the step.
fn run_until_error(b: &mut dyn Backend, chunks: usize, steps: u64) -> Option<(EngineError, u64)> {
    for k in 0..chunks {
        if let Err(e) = b.advance(steps) {
            return Some((e, k as u64 * steps));
        }
    }
    None
}

/// `err` is the energy watchdog's, past 4× its budget, in the chunk of 10 steps from step `at`.
fn assert_energy_blow_up(err: &EngineError, at: u64, label: &str) {
    let EngineError::EnergyBlowUp {
        to_j,
        budget_j,
        growth,
        first_step,
        step,
        ..
    } = *err
    else {
        panic!("{label}: expected EnergyBlowUp, got: {err}")
    };
    assert!(to_j > 4.0 * budget_j && growth > 4.0 && first_step == at + 1 && step == at + 10);
    assert!(err.to_string().contains("lower dt"), "{err}");
}

/// Case 9a: a loose bed at dt = 3 t_c explodes: with the default watchdog it must stop with
/// EnergyBlowUp, Overlap or NonFinite within 20 000 steps (chunks of 100; measured: Overlap at step
/// 22, 59.6 d). With the overlap check off and chunks of 10 steps, the energy check alone must stop
/// it with EnergyBlowUp before any value turns non-finite, at dt = 3 t_c and at dt = t_c (measured:
/// K grows 5.5e3× and 9.0e6× its budget within one chunk). With chunks of 100 and the overlap check
/// off, the blow-up reaches NaN inside the first chunk, before the chunk-end energy check:
/// NonFinite then reports it.
#[test]
fn the_watchdog_stops_an_exploding_bed() {
    let (cfg, s) = loose_bed(3.0 * tc());
    let mut e = CpuEngine::<f64>::new(cfg, s, 1);
    let (err, at) = run_until_error(&mut e, 200, 100).expect("dt = 3 t_c ran 20 000 steps");
    eprintln!("dt = 3 t_c, default watchdog: stopped in the chunk from step {at}: {err}");
    assert!(
        matches!(
            err,
            EngineError::EnergyBlowUp { .. }
                | EngineError::Overlap { .. }
                | EngineError::NonFinite { .. }
        ),
        "{err}"
    );
    for ratio in [3.0, 1.0] {
        let (cfg, s) = loose_bed(ratio * tc());
        let mut e = CpuEngine::<f64>::new(cfg, s, 1);
        e.watchdog.max_overlap_ratio = f64::INFINITY;
        let (err, at) =
            run_until_error(&mut e, 2_000, 10).expect("the bed ran 20 000 steps without error");
        eprintln!("dt = {ratio} t_c, overlap check off, chunks of 10: stopped in the chunk from step {at}: {err}");
        assert_energy_blow_up(&err, at, &format!("dt = {ratio} t_c"));
    }
}

/// Case 9b's chute at 40°: its configuration and its 400 spheres on the rough base.
fn accelerating_chute() -> (EngineConfig, State<f64>) {
    let d: f64 = 0.125;
    let r = d / 2.0;
    let sp = 1.01 * d;
    let (lx, ly) = (10.0 * sp, 5.0 * sp);
    let m = 2600.0 * PI / 6.0 * d.powi(3);
    let kn = 2e5 * m * 1.0 / d;
    let law = common::linear_law(kn, 0.88, 0.5);
    let tc = contact_time(
        &law,
        ContactPair {
            r_eff: r / 2.0,
            m_eff: m / 2.0,
        },
        1.0,
    );
    let a = 40f64.to_radians();
    let base = sweep::scene::fill_rods::base_monolayer(lx, ly, r, 0.0, 0.5, 3);
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    for (k, c) in base.iter().enumerate() {
        s.push_sphere(k as u32, *c, [0.0; 3], r, 2600.0, true);
    }
    let n0 = s.len();
    for k in 0..400 {
        let (i, j, l) = (k % 10, (k / 10) % 5, k / 50);
        let p = [
            (i as f64 + 0.5) * sp,
            (j as f64 + 0.5) * sp,
            2.0 * r + 0.01 * d + l as f64 * sp,
        ];
        s.push_sphere((n0 + k) as u32, p, [0.0; 3], r, 2600.0, false);
    }
    let cfg = EngineConfig {
        dt_s: tc / 50.0,
        gravity: [a.sin(), 0.0, -a.cos()],
        particle_law: law,
        wall_law: law,
        walls: vec![plane([0.0, 0.0, -r], [0.0, 0.0, 1.0])],
        periodic_x: Some([0.0, lx]),
        periodic_y: Some([0.0, ly]),
        sink_z: None,
        skin_m: 0.2 * d,
    };
    (cfg, s)
}

/// Runs case 9b's chute on `b` and checks it: the watchdog does not trip, K₁/B ≤ 1.05, and K
/// grows at least tenfold after the first chunk.
fn accelerating_chute_runs(b: &mut dyn Backend, label: &str) {
    const D_CHUTE: f64 = 0.125;
    let mut growth: f64 = 0.0;
    let mut k_first = 0.0;
    for chunk in 0..60 {
        let rep = b
            .advance(100)
            .unwrap_or_else(|err| panic!("{label}: chute at 40°, chunk {chunk}: {err}"));
        growth = growth.max(rep.kinetic_growth.expect("the engine measures it"));
        if chunk == 0 {
            k_first = b.download().kinetic_energy();
        }
    }
    let st = b.download();
    finite(&st).unwrap();
    let k_end = st.kinetic_energy();
    let vx: f64 = (0..st.len())
        .filter(|&i| st.inv_mass[i] > 0.0)
        .map(|i| st.vel[i].x)
        .sum::<f64>()
        / 400.0;
    eprintln!(
        "{label}: chute at 40°: largest K₁/B {growth:.3} (bound 1.05, watchdog limit {}), K after the first chunk {k_first:.3e} J, \
         after 6 000 steps {k_end:.3e} J ({:.0}×), mean v_x {vx:.3} m/s = {:.3} √(g d)",
        Watchdog::default().max_kinetic_growth,
        k_end / k_first,
        vx / D_CHUTE.sqrt()
    );
    assert!(growth <= 1.05, "{label}: K₁/B reached {growth}");
    assert!(
        k_end > 10.0 * k_first,
        "{label}: the chute did not accelerate: K {k_first:e} → {k_end:e} J"
    );
}

/// Case 9b: a chute of spheres at 40°, well above the angle at which a frictional bed flows: 400
/// spheres of d = 0.125 m (the chute paper's units: ρ = 2600, g = 1, k_n = 2e5 m g / d,
/// e = 0.88, μ = 0.5, dt = t_c/50) in a box periodic in x and y (10.1 d × 5.05 d) over a rough
/// base of fixed spheres, starting at rest from a lattice 0.01 d apart. It accelerates for 6 000
/// steps in chunks of only 100 (short chunks give the tightest budgets). The watchdog must not
/// trip, and K₁/B stays ≤ 1 up to integrator error (bound 1.05; a chunk in free fall meets the
/// budget exactly, measured 1.000); the kinetic energy must grow at least tenfold after the first
/// chunk (measured 3 086×: the flow accelerates).
#[test]
fn the_watchdog_lets_an_accelerating_chute_run() {
    let (cfg, s) = accelerating_chute();
    accelerating_chute_runs(&mut CpuEngine::<f64>::new(cfg, s, 1), "CPU f64");
}

// ---------------------------------------------------------------------------------------------
// The sphere cases on the GPU backend (f32), with the bounds of the f32 CPU runs.

fn gpu(dev: &GpuDevice, case: &Case) -> GpuEngine {
    let options = GpuOptions {
        watchdog: case.watchdog,
        ..GpuOptions::default()
    };
    GpuEngine::new(dev, case.config.clone(), &case.state, options).expect("GPU engine")
}

/// Runs a case on the GPU with `chunks` chunks instead of its own count (lavapipe is slow).
fn on_gpu(dev: &GpuDevice, mut case: Case, chunks: usize) -> Seen {
    case.chunks = chunks;
    let label = format!("{}, GPU", case.name);
    check(&case, &mut gpu(dev, &case), &label)
}

#[test]
fn gpu_stiff_hertz_bed_keeps_the_f64_overlaps() {
    let Some(dev) = device() else { return };
    let mut case = bed_case();
    case.chunks = 2;
    let a = check(&case, &mut cpu64(&case), "bed (2 chunks), CPU f64");
    let b = on_gpu(&dev, case, 2);
    let rel = (b.overlap - a.overlap).abs() / a.overlap;
    eprintln!(
        "bed: largest overlap f64 {:.4e} d, GPU {:.4e} d (relative difference {rel:.2e}, bound 0.1)",
        a.overlap, b.overlap
    );
    assert!(rel < 0.1);
}

#[test]
fn gpu_insertion_overlaps_relax() {
    let Some(dev) = device() else { return };
    on_gpu(&dev, overlap_case(), 3);
}

#[test]
fn gpu_a_tenth_of_the_contact_time() {
    let Some(dev) = device() else { return };
    let mut case = coarse_dt_case();
    case.momentum_tol = Some(1e-5);
    on_gpu(&dev, case, 10);
}

#[test]
fn gpu_clogged_silo_and_turning_bottom() {
    let Some(dev) = device() else { return };
    let seen = on_gpu(&dev, clogged_case(), 2);
    assert_held(&seen, "clogged, GPU", 0.0);
    on_gpu(&dev, rotating_case(), 2);
}

#[test]
fn gpu_wedged_spheres_hold() {
    let Some(dev) = device() else { return };
    for hz in [0.0, 5.0] {
        let seen = on_gpu(&dev, wedge_case(hz), 2);
        assert_held(&seen, &format!("wedge at {hz} Hz, GPU"), 0.0);
    }
}

#[test]
fn gpu_contacts_across_the_periodic_seams() {
    let Some(dev) = device() else { return };
    let seen = on_gpu(&dev, seam_case(true), 4);
    assert_in_box(&seen.last, "seams, GPU");
}

/// The exploding bed on the GPU stops with the GPU's own checks (overlap, non-finite, or a
/// neighbour list overflowing as the bed flies apart).
#[test]
fn gpu_stops_an_exploding_bed() {
    let Some(dev) = device() else { return };
    let (cfg, s) = loose_bed(3.0 * tc());
    let mut g = GpuEngine::new(&dev, cfg, &s, GpuOptions::default()).expect("GPU engine");
    let (err, at) = run_until_error(&mut g, 200, 100).expect("dt = 3 t_c ran 20 000 steps");
    eprintln!("dt = 3 t_c on the GPU: stopped in the chunk from step {at}: {err}");
    assert!(
        matches!(
            err,
            EngineError::Overlap { .. } | EngineError::NonFinite { .. } | EngineError::Device(_)
        ),
        "{err}"
    );
}

/// Case 9a's energy check alone on the GPU (overlap check off, chunks of 10), as on the CPU: it
/// must stop the bed with EnergyBlowUp at dt = 3 t_c and at dt = t_c, before any value turns
/// non-finite or a list overflows.
#[test]
fn gpu_energy_watchdog_stops_an_exploding_bed() {
    let Some(dev) = device() else { return };
    for ratio in [3.0, 1.0] {
        let (cfg, s) = loose_bed(ratio * tc());
        let options = GpuOptions {
            watchdog: Watchdog {
                max_overlap_ratio: f64::INFINITY,
                ..Watchdog::default()
            },
            ..GpuOptions::default()
        };
        let mut g = GpuEngine::new(&dev, cfg, &s, options).expect("GPU engine");
        let (err, at) =
            run_until_error(&mut g, 2_000, 10).expect("the bed ran 20 000 steps without error");
        eprintln!("dt = {ratio} t_c on the GPU, overlap check off, chunks of 10: stopped in the chunk from step {at}: {err}");
        assert_energy_blow_up(&err, at, &format!("dt = {ratio} t_c on the GPU"));
    }
}

/// Case 9b on the GPU (f32): the watchdog lets the accelerating chute run, with the CPU's bounds.
#[test]
fn gpu_watchdog_lets_an_accelerating_chute_run() {
    let Some(dev) = device() else { return };
    let (cfg, s) = accelerating_chute();
    let mut g = GpuEngine::new(&dev, cfg, &s, GpuOptions::default()).expect("GPU engine");
    accelerating_chute_runs(&mut g, "GPU");
}

/// The GPU's U₀ (the elastic energy `contact_energy` sums) against the CPU's on the same state:
/// case 6's beds overlapping by 10 % of d, relaxed for 10 steps in f64 on the CPU and uploaded to
/// both (springs included), which take one more step. Bound 1e-4 relative: f32 overlaps of
/// ~6e-4 m round at ~1e-7 relative, and one f32 step departs from the f64 one by about as much.
#[test]
fn gpu_elastic_energy_matches_the_cpu() {
    let Some(dev) = device() else { return };
    let case = overlap_case();
    let mut cpu = cpu64(&case);
    cpu.advance(10).expect("10 steps");
    let state = cpu.download();
    let u_cpu = cpu.elastic_energy();
    let mut g = GpuEngine::new(&dev, case.config.clone(), &state, GpuOptions::default())
        .expect("GPU engine");
    // One step builds the device's lists; the CPU takes the same step.
    g.advance(1).expect("GPU step");
    cpu.advance(1).expect("CPU step");
    let (u_gpu, u_cpu1) = (
        g.elastic_energy_job(0).expect("GPU sum"),
        cpu.elastic_energy(),
    );
    let rel = (u_gpu - u_cpu1).abs() / u_cpu1;
    eprintln!("elastic energy: CPU {u_cpu:.6e} J after 10 steps, {u_cpu1:.6e} J after 11; GPU {u_gpu:.6e} J (relative difference {rel:.2e}, bound 1e-4)");
    assert!(
        u_cpu1 > 0.0 && rel < 1e-4,
        "GPU {u_gpu:e} J against CPU {u_cpu1:e} J"
    );
}

/// Cases 8a and 8b on the GPU (f32). Bounds: 8a's energy 2e-4 (f32 rounding of overlaps of
/// ~5e-3 d adds to the f64 run's ~2e-5: measured 3e-5 and 6e-5 on lavapipe), 8b's energy rise
/// 1e-5; momenta 1e-5 (f32 velocities round at 6e-8 per step and particle, while the pair forces
/// are bitwise ±F on the GPU as on the CPU: measured ≤ 4e-8, angular ≤ 6e-7).
#[test]
fn gpu_near_parallel_spherocylinders_conserve_energy() {
    let Some(dev) = device() else { return };
    for xi in [1.00, 1.01] {
        let (cfg, s) = near_parallel_case(xi);
        let mut g =
            GpuEngine::new(&dev, cfg.clone(), &s, GpuOptions::default()).expect("GPU engine");
        near_parallel_rods(&mut g, &cfg, xi, "GPU", (2e-4, 1e-5));
    }
}

#[test]
fn gpu_end_to_end_spherocylinders_conserve_momentum() {
    let Some(dev) = device() else { return };
    for xi in [1.00, 1.01] {
        let (cfg, s) = end_to_end_case(xi);
        let mut g =
            GpuEngine::new(&dev, cfg.clone(), &s, GpuOptions::default()).expect("GPU engine");
        end_to_end_rods(&mut g, &cfg, xi, "GPU", (1e-5, 1e-5));
    }
}
