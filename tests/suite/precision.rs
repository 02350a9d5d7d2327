//! f32 at paper scale: positions keep their precision far from the origin (`engine/position.rs`)
//! on the CPU and on the GPU. Each scene is run near the origin and 100 m away from it; with
//! plain f32 coordinates (before split positions) every test below fails: at 100 m f32 numbers
//! are 7.6·10⁻⁶ m apart, so a step of 10⁻⁹ m is lost and an overlap of 10⁻⁷ m cannot be formed.

use crate::common;

use crate::common::gpu::device;
use sweep::engine::gpu::{GpuEngine, GpuOptions};
use sweep::engine::walls::{Wall, WallShape};
use sweep::engine::{Backend, CpuEngine, EngineConfig, State};

const R: f64 = 0.0029;
const RHO: f64 = 2655.0;
const G: f64 = 9.81;
const KN: f64 = 1.0e4;

fn mass() -> f64 {
    RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3)
}

/// A frictionless floor (plane z = floor[2] through `floor`) under gravity.
fn config(floor: [f64; 3], dt: f64) -> EngineConfig {
    let law = common::linear_law(KN, 0.5, 0.0);
    EngineConfig {
        dt_s: dt,
        gravity: [0.0, 0.0, -G],
        particle_law: law,
        wall_law: law,
        walls: vec![Wall {
            shape: WallShape::Plane {
                point: floor,
                normal: [0.0, 0.0, 1.0],
            },
            rotation: None,
        }],
        periodic_x: None,
        periodic_y: None,
        sink_z: None,
        skin_m: 0.2 * R,
    }
}

/// The backends under test: CPU f32 (2 threads) and, where an adapter exists, the GPU.
fn backends(cfg: &EngineConfig, s: &State<f64>) -> Vec<(&'static str, Box<dyn Backend>)> {
    let mut out: Vec<(&'static str, Box<dyn Backend>)> = vec![(
        "cpu f32",
        Box::new(CpuEngine::<f32>::new(cfg.clone(), s.convert(), 2)),
    )];
    if let Some(dev) = device() {
        let g = GpuEngine::new(&dev, cfg.clone(), s, GpuOptions::default()).expect("GPU engine");
        out.push(("gpu", Box::new(g)));
    }
    out
}

/// A sphere sliding at 1 mm/s on a frictionless floor, resting on it at its static overlap:
/// after 10⁴ steps of 10⁻⁶ s it has travelled v·t within 0.1 %, 0.2 m and 100 m from the origin.
#[test]
fn a_slow_sphere_slides_its_full_distance_far_from_the_origin() {
    let (v, dt, steps) = (1.0e-3, 1.0e-6, 10_000u64);
    for far in [0.2, 100.0] {
        let floor = [far, far, far];
        let cfg = config(floor, dt);
        let mut s = State::<f64>::new(true, 8);
        let rest = mass() * G / KN;
        let start = [far, far, far + R - rest];
        s.push_sphere(0, start, [v, 0.0, 0.0], R, RHO, false);
        for (name, mut b) in backends(&cfg, &s) {
            for _ in 0..10 {
                b.advance(steps / 10).expect("advance");
            }
            let end = b.download().position_f64(0);
            let travelled = end[0] - start[0];
            let expected = v * dt * steps as f64;
            eprintln!("{name}, {far} m: travelled {travelled:.6e} m, v t = {expected:.6e} m");
            assert!(
                (travelled - expected).abs() <= 1e-3 * expected,
                "{name}, {far} m from the origin: travelled {travelled:.6e} m, expected {expected:.6e} m"
            );
            assert!(
                (end[1] - start[1]).abs() < 1e-3 * expected,
                "{name}: moved sideways"
            );
        }
    }
}

/// Overlaps of a column of three spheres resting on the floor, from downloaded positions.
fn resting_overlaps(s: &State<f64>, floor_z: f64) -> Vec<f64> {
    let mut z: Vec<f64> = (0..s.len()).map(|i| s.position_f64(i)[2]).collect();
    z.sort_by(f64::total_cmp);
    let mut ov = vec![R - (z[0] - floor_z)];
    ov.extend(z.windows(2).map(|w| 2.0 * R - (w[1] - w[0])));
    ov
}

/// A column of three spheres settles on the floor; 100 m from the origin in f32 (CPU and GPU)
/// its overlaps (2.6–7.8·10⁻⁷ m) match those at the origin in f64 within 1 %.
#[test]
fn a_resting_column_far_from_the_origin_has_the_overlaps_of_f64_at_the_origin() {
    let (dt, steps) = (1.0e-5, 20_000u64);
    let column = |far: f64| {
        let mut s = State::<f64>::new(true, 8);
        for k in 0..3u32 {
            let z = far + R + 2.0 * R * f64::from(k);
            s.push_sphere(k, [far, far, z], [0.0; 3], R, RHO, false);
        }
        s
    };
    let cfg0 = config([0.0; 3], dt);
    let mut reference = CpuEngine::<f64>::new(cfg0.clone(), column(0.0), 1);
    reference.advance(steps).expect("advance");
    let want = resting_overlaps(&reference.download(), 0.0);
    // The static overlaps: the floor carries 3 mg, the contacts above 2 mg and mg.
    let mg = mass() * G / KN;
    for (k, &w) in want.iter().enumerate() {
        let exact = (3 - k) as f64 * mg;
        assert!(
            (w - exact).abs() < 1e-3 * exact,
            "f64 reference: {w:e} vs {exact:e}"
        );
    }
    let far = 100.0;
    let cfg = config([far, far, far], dt);
    for (name, mut b) in backends(&cfg, &column(far)) {
        b.advance(steps).expect("advance");
        let got = resting_overlaps(&b.download(), far);
        eprintln!("{name}: overlaps {got:?} at {far} m, f64 at the origin {want:?}");
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (g - w).abs() <= 0.01 * w,
                "{name} at {far} m: overlap {g:e} vs {w:e} in f64 at the origin"
            );
        }
    }
}
