//! The GPU device shared by the tests of one test crate: acquired once, on any adapter (lavapipe
//! included). Without an adapter the tests print a message and pass, except under CI=true, where a
//! missing adapter fails them. `SWEEP_TEST_GPU=hardware` (the GPU machine's check,
//! `scripts/gpu-device-check.sh`) takes only a hardware adapter and fails without one.

use std::collections::HashMap;
use std::sync::OnceLock;

use sweep::engine::gpu::{AdapterPolicy, GpuDevice, GpuEngine, GpuOptions};
use sweep::engine::{CpuEngine, EngineConfig, State, V3};

/// The shared device, or None (with a message) when there is no adapter outside CI.
pub fn device() -> Option<GpuDevice> {
    static DEV: OnceLock<Option<GpuDevice>> = OnceLock::new();
    DEV.get_or_init(|| {
        if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
            // Mesa complains without it; a private directory keeps it quiet.
            let dir = tempfile::tempdir().expect("temp dir").keep();
            std::env::set_var("XDG_RUNTIME_DIR", dir);
        }
        let hardware = std::env::var("SWEEP_TEST_GPU").as_deref() == Ok("hardware");
        let policy = if hardware {
            AdapterPolicy::Hardware
        } else {
            AdapterPolicy::Any
        };
        match GpuDevice::acquire(policy) {
            Ok(d) => Some(d),
            Err(e) if hardware => panic!("SWEEP_TEST_GPU=hardware and no hardware adapter: {e}"),
            Err(e) if std::env::var("CI").as_deref() == Ok("true") => {
                panic!("CI=true and no usable GPU adapter: {e}")
            }
            Err(e) => {
                eprintln!("skipping GPU tests: {e}");
                None
            }
        }
    })
    .clone()
}

/// Every number of a state as bits (ids, positions, velocities, spins, forces and torques,
/// angular momenta and orientations, history, time and step): two states are the same run's only if these are equal.
pub fn state_bits(s: &sweep::engine::State<f64>) -> Vec<u64> {
    let mut out: Vec<u64> = s.id.iter().map(|&i| i as u64).collect();
    for v in s.pos.iter().chain(&s.vel).chain(&s.omega).chain(&s.force) {
        out.extend(v.to_f64().map(f64::to_bits));
    }
    for v in s.torque.iter().chain(&s.ang_mom) {
        out.extend(v.to_f64().map(f64::to_bits));
    }
    for q in &s.orientation {
        out.extend(q.to_f64().map(f64::to_bits));
    }
    for v in &s.history.spring {
        out.extend([v.x, v.y, v.z].map(f64::to_bits));
    }
    out.extend(s.history.partner.iter().map(|&p| p as u64));
    out.push(s.time.to_bits());
    out.push(s.step);
    out
}

/// What a chunk reports, as bits, list builds aside (those depend on where they were recorded).
pub fn report_bits(r: &sweep::engine::ChunkReport) -> Vec<u64> {
    let mut out = vec![
        r.steps,
        r.particle_steps,
        r.max_overlap_ratio.to_bits(),
        r.contacts_per_particle.to_bits(),
    ];
    for e in &r.removed {
        out.extend([e.id as u64, e.time_s.to_bits(), e.mass_kg.to_bits()]);
    }
    out
}

/// A GPU engine with the default options.
pub fn engine(dev: &GpuDevice, config: &EngineConfig, s: &State<f64>) -> GpuEngine {
    GpuEngine::new(dev, config.clone(), s, GpuOptions::default()).expect("GPU engine")
}

/// The CPU engine in f32 (two threads), the GPU's reference at the same precision.
pub fn cpu_f32(config: &EngineConfig, s: &State<f64>) -> CpuEngine<f32> {
    CpuEngine::new(config.clone(), s.convert(), 2)
}

/// Rows of `s` by id (each engine may order its particles by cell).
pub fn by_id(s: &State<f64>) -> HashMap<u32, usize> {
    s.id.iter().enumerate().map(|(i, &id)| (id, i)).collect()
}

/// Rounds to a multiple of 2⁻²⁴ (positions, |x| < 1) so that x + v dt is exact in f32 when
/// v dt is.
pub fn quantise(x: f64) -> f64 {
    (x * 16_777_216.0).round() / 16_777_216.0
}

/// Largest |a − b| / max(|b|, floor) over the particles of `b`, matched by id (forces that
/// nearly cancel are compared on the scale `floor`).
pub fn worst_relative(
    a: &State<f64>,
    b: &State<f64>,
    pick: fn(&State<f64>) -> &Vec<V3<f64>>,
    floor: f64,
) -> f64 {
    let ia = by_id(a);
    let mut worst: f64 = 0.0;
    for (k, id) in b.id.iter().enumerate() {
        let va = pick(a)[ia[id]];
        let vb = pick(b)[k];
        worst = worst.max((va - vb).norm() / vb.norm().max(floor));
    }
    worst
}
