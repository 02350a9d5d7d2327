//! The GPU device shared by the tests of one test crate: acquired once, on any adapter (lavapipe
//! included). Without an adapter the tests print a message and pass, except under CI=true, where a
//! missing adapter fails them. `SWEEP_TEST_GPU=hardware` (the GPU machine's check,
//! `scripts/gpu-device-check.sh`) takes only a hardware adapter and fails without one.

use std::sync::OnceLock;

use sweep::engine::gpu::{AdapterPolicy, GpuDevice};

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
