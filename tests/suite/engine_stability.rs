//! Numerical stability of dense, stiff and overlapping packings.
//! - Initial overlaps of 10 % of d (a 5 × 5 × 5 lattice of spacing 0.9 d in a closed box, Hertz,
//!   e = 0.5, μ = 0.5, gravity): they relax without an explosion. Bound: the mechanical energy
//!   (kinetic + Hertz elastic + gravitational) never exceeds its t = 0 value by more than 1 %, so
//!   the kinetic energy stays below the elastic energy stored at t = 0 plus the gravitational
//!   energy above the floor; no NaN; and after 0.12 s the kinetic energy is below 0.1 % of that.
//! - A dense frictional bed of 300 silo spheres (Y = 3 GPa, G = 0.1 GPa, d = 5.8 mm, e = 0.9,
//!   μ = 0.5, dt = 1e-6 s) in a box: no NaN or Inf after 10⁵ steps.
//! - The same spheres in f32 at dt = 1e-6 s on a small settled column (52 spheres, FCC stacking,
//!   8 layers) stay at rest (KE per particle < 1e-6 m g d), and every contact's overlap stays
//!   within 2e-8 m of the f64 run started from the same state: about 11 f32 ulps of the centres'
//!   heights (1.9e-9 m at z = 5 d) and 3 % of the largest overlap (≈ 6e-7 m). The overlap itself
//!   cannot be resolved more finely than an ulp or two of the centres.
//! - Determinism: a colliding bed of 1 200 spheres with 1 and 2 threads gives bitwise-identical
//!   positions, velocities, angular velocities and contact histories after 2 000 steps.
//!
//! A failure means the time step, the stiffness or the initial overlaps drive the integrator
//! unstable, f32 cannot resolve the silo's contacts, or the result depends on the thread count.

use crate::common::Noise;

use std::f64::consts::PI;

use sweep::engine::contact::{contact_time, ContactLaw, ContactPair, Elasticity, NormalModel};
use sweep::engine::history::HISTORY_SLOTS;
use sweep::engine::walls::{Wall, WallShape};
use sweep::engine::{Backend, CpuEngine, EngineConfig, Real, State};

const G: f64 = 9.81;
const RHO: f64 = 2655.0;
/// Silo paper diameter (m).
const D: f64 = 0.0058;
const R: f64 = D / 2.0;

/// The silo paper's law: Hertz–Mindlin, Y = 3 GPa, G = Y/30, e = 0.9, μ = 0.5.
fn silo_law() -> ContactLaw {
    let el = Elasticity::YoungShear {
        youngs_modulus_pa: 3.0e9,
        shear_modulus_pa: 1.0e8,
    };
    ContactLaw {
        normal: NormalModel::Hertz(el),
        restitution: 0.9,
        tangential_restitution: 0.9,
        friction: 0.5,
    }
}

/// A plane wall as (point, inward unit normal).
type Plane = ([f64; 3], [f64; 3]);

/// Plane walls closing the box [0, lx] × [0, ly] × [0, lz].
fn box_planes(lx: f64, ly: f64, lz: f64) -> Vec<Plane> {
    vec![
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        ([lx, 0.0, 0.0], [-1.0, 0.0, 0.0]),
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, ly, 0.0], [0.0, -1.0, 0.0]),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, lz], [0.0, 0.0, -1.0]),
    ]
}

fn config(law: ContactLaw, dt: f64, planes: &[Plane]) -> EngineConfig {
    let walls = planes
        .iter()
        .map(|&(point, normal)| Wall {
            shape: WallShape::Plane { point, normal },
            rotation: None,
        })
        .collect();
    EngineConfig {
        dt_s: dt,
        gravity: [0.0, 0.0, -G],
        particle_law: law,
        wall_law: law,
        walls,
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.2 * R,
    }
}

/// Hertz elastic energy Σ 8/15 Y* √R* δ^{5/2} of the particle and wall contacts (J).
fn elastic_energy(s: &State<f64>, y_eff: f64, planes: &[Plane]) -> f64 {
    let u = |delta: f64, r: f64| {
        if delta > 0.0 {
            8.0 / 15.0 * y_eff * r.sqrt() * delta.powf(2.5)
        } else {
            0.0
        }
    };
    let mut e = 0.0;
    for i in 0..s.len() {
        let (p, ri) = (s.pos[i].to_f64(), s.radius[i]);
        for j in i + 1..s.len() {
            let q = s.pos[j].to_f64();
            let rj = s.radius[j];
            let dist =
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
            e += u(ri + rj - dist, ri * rj / (ri + rj));
        }
        for (a, n) in planes {
            let dist = (p[0] - a[0]) * n[0] + (p[1] - a[1]) * n[1] + (p[2] - a[2]) * n[2];
            e += u(ri - dist, ri);
        }
    }
    e
}

/// Gravitational energy relative to every centre resting on the floor, Σ m g (z − R) (J).
fn gravity_energy(s: &State<f64>) -> f64 {
    (0..s.len())
        .map(|i| s.mass[i] * G * (s.pos[i].z - s.radius[i]))
        .sum()
}

fn assert_finite(s: &State<f64>) {
    for i in 0..s.len() {
        let ok =
            s.pos[i].is_finite() && s.vel[i].is_finite() && (!s.rotation || s.omega[i].is_finite());
        assert!(
            ok,
            "particle {} is not finite at step {}: {:?} {:?}",
            s.id[i], s.step, s.pos[i], s.vel[i]
        );
    }
}

#[test]
fn ten_percent_initial_overlaps_relax_without_explosion() {
    let el = Elasticity::YoungShear {
        youngs_modulus_pa: 3.0e7,
        shear_modulus_pa: 1.0e6,
    };
    let law = ContactLaw {
        normal: NormalModel::Hertz(el),
        restitution: 0.5,
        tangential_restitution: 0.5,
        friction: 0.5,
    };
    let m = RHO * PI / 6.0 * D.powi(3);
    // dt for the scene's ordinary impacts (1 m/s), not for the overlaps it starts with.
    let dt = contact_time(
        &law,
        ContactPair {
            r_eff: R / 2.0,
            m_eff: m / 2.0,
        },
        1.0,
    ) / 50.0;
    let a = 0.9 * D;
    let (lx, lz) = (8.0 * D, 8.0 * D);
    let planes = box_planes(lx, lx, lz);
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    let x0 = 0.5 * lx - 2.0 * a;
    for k in 0..125 {
        let (i, j, l) = (k % 5, (k / 5) % 5, k / 25);
        s.push_sphere(
            k as u32,
            [x0 + i as f64 * a, x0 + j as f64 * a, R + l as f64 * a],
            [0.0; 3],
            R,
            RHO,
            false,
        );
    }
    let el0 = elastic_energy(&s, 3.0e7, &planes);
    let e0 = el0 + gravity_energy(&s);
    let mut e = CpuEngine::new(config(law, dt, &planes), s, 1);
    let (mut ke_max, mut e_max, mut ov_max): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for _ in 0..200 {
        let r = e.advance(100).unwrap();
        let s = e.download();
        assert_finite(&s);
        let ke = s.kinetic_energy();
        ke_max = ke_max.max(ke);
        e_max = e_max.max(ke + elastic_energy(&s, 3.0e7, &planes) + gravity_energy(&s));
        ov_max = ov_max.max(r.max_overlap_ratio);
    }
    let s = e.download();
    let ke_end = s.kinetic_energy();
    eprintln!(
        "initial overlaps: E_el(0) = {el0:.4e} J, E_mech(0) = {e0:.4e} J, largest KE {ke_max:.4e} J ({:.3} of E_mech(0)), \
         largest E_mech {e_max:.4e} J, largest overlap seen {ov_max:.3} d, KE after {:.3} s {ke_end:.3e} J",
        ke_max / e0,
        s.time
    );
    assert!(
        e_max <= 1.01 * e0,
        "mechanical energy grew from {e0:.4e} to {e_max:.4e} J: the relaxation injected energy"
    );
    assert!(ke_max < e0, "kinetic energy {ke_max:.4e} J exceeds the stored elastic plus gravitational energy {e0:.4e} J");
    assert!(
        ke_end < 1e-3 * e0,
        "still agitated after {} s: KE {ke_end:.3e} J",
        s.time
    );
}

/// A bed of `n` silo spheres on a jittered square lattice of spacing `a`, `side` × `side` per
/// layer, with random velocities of amplitude `v` per component, in a closed box two layers
/// taller than the lattice; returns it and the box's planes.
fn bed(n: usize, side: usize, a: f64, v: f64, seed: u64) -> (State<f64>, Vec<Plane>) {
    let l = side as f64 * a;
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    let mut noise = Noise::new(seed);
    for k in 0..n {
        let (i, j, m) = (k % side, (k / side) % side, k / (side * side));
        let p = [
            (i as f64 + 0.5) * a + 0.02 * D * noise.next(),
            (j as f64 + 0.5) * a + 0.02 * D * noise.next(),
            R + 0.01 * D + m as f64 * a,
        ];
        s.push_sphere(
            k as u32,
            p,
            [v * noise.next(), v * noise.next(), v * noise.next()],
            R,
            RHO,
            false,
        );
    }
    let height = (n / (side * side) + 2) as f64 * a;
    (s, box_planes(l, l, height))
}

#[test]
fn dense_frictional_bed_stays_finite_for_1e5_steps() {
    let (s, planes) = bed(300, 5, 1.05 * D, 0.0, 3);
    let mut e = CpuEngine::new(config(silo_law(), 1.0e-6, &planes), s, 1);
    let start = std::time::Instant::now();
    let mut ov: f64 = 0.0;
    for _ in 0..10 {
        let r = e.advance(10_000).unwrap();
        ov = ov.max(r.max_overlap_ratio);
        assert_finite(&e.download());
    }
    let s = e.download();
    eprintln!(
        "bed: {} steps in {:.2?}, largest overlap {ov:.2e} d, final KE {:.3e} J, {} spheres",
        s.step,
        start.elapsed(),
        s.kinetic_energy(),
        s.len()
    );
    assert_eq!(s.step, 100_000);
}

/// Largest difference of any contact's overlap (particle pairs and walls) between two states
/// holding the same ids, and the largest overlap of the first.
fn overlap_difference(a: &State<f64>, b: &State<f64>, planes: &[Plane]) -> (f64, f64) {
    let overlaps = |s: &State<f64>| {
        let mut by_id = vec![0; s.len()];
        for (k, &id) in s.id.iter().enumerate() {
            by_id[id as usize] = k;
        }
        let p = |id: usize| s.pos[by_id[id]].to_f64();
        let mut out = vec![];
        for i in 0..s.len() {
            let pi = p(i);
            for (a, n) in planes {
                out.push(
                    R - ((pi[0] - a[0]) * n[0] + (pi[1] - a[1]) * n[1] + (pi[2] - a[2]) * n[2]),
                );
            }
            for j in i + 1..s.len() {
                let pj = p(j);
                out.push(
                    D - ((pi[0] - pj[0]).powi(2)
                        + (pi[1] - pj[1]).powi(2)
                        + (pi[2] - pj[2]).powi(2))
                    .sqrt(),
                );
            }
        }
        out
    };
    let (oa, ob) = (overlaps(a), overlaps(b));
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for (x, y) in oa.iter().zip(&ob) {
        // Compare contact overlaps (0 when apart), so a touching pair that opens by a hair in one
        // run does not count its gap.
        worst = worst.max((x.max(0.0) - y.max(0.0)).abs());
        largest = largest.max(*x);
    }
    (worst, largest)
}

/// A column of 8 square layers in FCC (100) stacking: 3 × 3 touching spheres filling a box of
/// side 3 d, then 2 × 2 in their hollows, and so on; layers 0.001 d higher than touching, so it
/// settles at once into a packing that cannot rearrange.
fn column() -> (State<f64>, Vec<Plane>) {
    let h = D / 2f64.sqrt() + 0.001 * D;
    let mut s = State::<f64>::new(true, HISTORY_SLOTS);
    let mut z = R + 0.001 * D;
    let mut id = 0;
    for layer in 0..8 {
        let (k, offset) = if layer % 2 == 0 { (3, 0.5) } else { (2, 1.0) };
        for i in 0..k {
            for j in 0..k {
                s.push_sphere(
                    id,
                    [(i as f64 + offset) * D, (j as f64 + offset) * D, z],
                    [0.0; 3],
                    R,
                    RHO,
                    false,
                );
                id += 1;
            }
        }
        z += h;
    }
    (s, box_planes(3.0 * D, 3.0 * D, z + D))
}

#[test]
fn stiff_hertz_in_f32_stays_stable_and_close_to_f64() {
    let (s, planes) = column();
    // Settle with strong damping (e = 0.2); the comparison then runs the silo law itself.
    let settling = ContactLaw {
        restitution: 0.2,
        tangential_restitution: 0.2,
        ..silo_law()
    };
    let mut settle = CpuEngine::new(config(settling, 1.0e-6, &planes), s, 1);
    settle.advance(20_000).unwrap();
    let settled = settle.download();
    let m = settled.mass[0];
    let ke0 = settled.kinetic_energy() / settled.len() as f64 / (m * G * D);
    eprintln!(
        "column of {} settled: KE per particle {ke0:.2e} m g d",
        settled.len()
    );

    let config = config(silo_law(), 1.0e-6, &planes);
    let mut e64 = CpuEngine::<f64>::new(config.clone(), settled.clone(), 1);
    let mut e32 = CpuEngine::<f32>::new(config, settled.convert(), 1);
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for _ in 0..10 {
        e64.advance(2_000).unwrap();
        e32.advance(2_000).unwrap();
        let (a, b) = (e64.download(), e32.download());
        assert_finite(&b);
        let (w, l) = overlap_difference(&a, &b, &planes);
        worst = worst.max(w);
        largest = largest.max(l);
    }
    let s32 = e32.download();
    let ke32 = s32.kinetic_energy() / s32.len() as f64 / (m * G * D);
    // Spacing of f32 numbers near the column's top (z ≈ 5 d).
    let z = (5.0 * D) as f32;
    let ulp = (f32::from_bits(z.to_bits() + 1) - z) as f64;
    eprintln!(
        "f32 vs f64 after 20 000 steps: largest overlap {largest:.3e} m, largest overlap difference {worst:.3e} m \
         ({:.2} f32 ulps at z = 5 d, {:.3} of the largest overlap); f32 KE per particle {ke32:.2e} m g d",
        worst / ulp,
        worst / largest
    );
    assert!(
        ke32 < 1e-6,
        "the f32 column is not at rest: KE per particle {ke32:.2e} m g d"
    );
    assert!(
        worst < 2e-8,
        "f32 overlaps differ from f64 by {worst:.3e} m (bound 2e-8 m)"
    );
}

/// Raw bits of a state's kinematics and contact history, for bitwise comparison.
fn bits<R: Real>(s: &State<R>) -> Vec<u64> {
    let mut out: Vec<u64> = s.id.iter().map(|&i| i as u64).collect();
    for v in s
        .pos
        .iter()
        .chain(&s.vel)
        .chain(&s.omega)
        .chain(&s.history.spring)
    {
        out.extend([v.x, v.y, v.z].map(|c| c.to_f64().to_bits()));
    }
    out.extend(s.history.partner.iter().map(|&p| p as u64));
    out
}

#[test]
fn one_and_two_threads_give_identical_bits() {
    // 1 200 spheres: the engine hands rayon pieces of at least 512 particles, so a smaller bed
    // would run on one thread even in a pool of two and the test would compare nothing.
    let (s, planes) = bed(1_200, 10, D, 0.5, 9);
    let config = config(silo_law(), 1.0e-6, &planes);
    let mut one = CpuEngine::<f64>::new(config.clone(), s.clone(), 1);
    let mut two = CpuEngine::<f64>::new(config, s, 2);
    for _ in 0..4 {
        one.advance(500).unwrap();
        two.advance(500).unwrap();
    }
    let (a, b) = (bits(&one.state), bits(&two.state));
    let contacts = one
        .state
        .history
        .partner
        .iter()
        .filter(|&&p| p != u32::MAX)
        .count();
    eprintln!(
        "determinism: {} spheres, {contacts} history rows in use after 2 000 steps",
        one.state.len()
    );
    assert!(
        contacts > 0,
        "no contacts formed: the test compares nothing"
    );
    assert_eq!(a.len(), b.len());
    let first = a.iter().zip(&b).position(|(x, y)| x != y);
    assert!(
        first.is_none(),
        "1 and 2 threads differ at word {}",
        first.unwrap_or(0)
    );
}
