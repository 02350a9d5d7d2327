//! The one-dispatch step (`GpuOptions::fused_step`, fused.wgsl) against the two-dispatch step on
//! the same beds: every bit of the chunk reports, the kinetic energy and the state after each
//! chunk, and the same list builds, voided steps and submissions, with one dispatch per steady
//! step. The beds cover what the fused step changes: spheres that die in the sink during the
//! very dispatch whose forces read them, rods (orientations kept in place), builds scheduled
//! between fused dispatches, stale steps redone, command buffers of one and seven steps, rows of
//! workgroups, and chunks that end on either copy of the state (the copy back).
//!
//! Skips where the adapter offers no immediates or too few storage buffers per kernel, saying
//! so, except under CI=true, where lavapipe offers both and a skip is a failure.

use crate::common::gpu::{device, report_bits, state_bits};
use crate::gpu_dispatch::stirred_scene;
use sweep::engine::gpu::{GpuEngine, GpuOptions};
use sweep::engine::{Backend, DispatchCount};

struct Case {
    scene: &'static str,
    n: usize,
    /// The sink at this fraction of the mobile particles' height range (None: no sink).
    sink: Option<f64>,
    steps_per_submit: u64,
    build_every: Option<u64>,
    max_row_groups: Option<u32>,
}

/// Chunks of odd and even lengths: a chunk of n steps ends on the second copy when n − 1 is odd.
const CHUNKS: [u64; 3] = [100, 37, 163];

fn run(case: &Case, fused_step: bool) -> (Vec<u64>, DispatchCount, usize) {
    let dev = device().expect("device");
    let mut sc = stirred_scene(case.scene, case.n);
    if let Some(f) = case.sink {
        let s = &sc.state;
        let z: Vec<f64> = (0..s.len())
            .filter(|&i| s.inv_mass[i] != 0.0)
            .map(|i| s.pos[i].to_f64()[2])
            .collect();
        let (lo, hi) = z
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        sc.config.sink_z = Some(lo + f * (hi - lo));
    }
    let options = GpuOptions {
        steps_per_submit: case.steps_per_submit,
        build_every: case.build_every,
        max_row_groups: case.max_row_groups,
        fused_step,
        ..GpuOptions::default()
    };
    let mut e = GpuEngine::new(&dev, sc.config.clone(), &sc.state, options).expect("GPU engine");
    let mut bits = Vec::new();
    let mut removed = 0;
    for steps in CHUNKS {
        let r = e.advance(steps).expect("chunk");
        removed += r.removed.len();
        bits.extend(report_bits(&r));
        bits.push(e.kinetic_energy().unwrap().to_bits());
        bits.extend(state_bits(&e.download()));
    }
    (bits, e.dispatches().expect("GPU counts"), removed)
}

#[test]
fn one_dispatch_steps_give_the_two_dispatch_bits() {
    let Some(dev) = device() else { return };
    if let Some(why) = dev.fused_step_unsupported() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true: {why}"
        );
        eprintln!("skipping the one-dispatch step: {why}");
        return;
    }
    let cases = [
        Case {
            scene: "silo-bed",
            n: 1500,
            sink: Some(0.3),
            steps_per_submit: 64,
            build_every: None,
            max_row_groups: None,
        },
        Case {
            scene: "silo-bed",
            n: 1500,
            sink: Some(0.5),
            steps_per_submit: 7,
            build_every: Some(3),
            max_row_groups: Some(5),
        },
        Case {
            scene: "silo-bed",
            n: 1500,
            sink: None,
            steps_per_submit: 64,
            build_every: Some(1_000_000),
            max_row_groups: None,
        },
        Case {
            scene: "chute-rods",
            n: 600,
            sink: None,
            steps_per_submit: 64,
            build_every: None,
            max_row_groups: None,
        },
        Case {
            scene: "chute-rods",
            n: 600,
            sink: None,
            steps_per_submit: 1,
            build_every: Some(1_000_000),
            max_row_groups: Some(5),
        },
    ];
    for case in &cases {
        let what = format!(
            "{} (N = {}, sink {:?}, {} steps per submission, builds every {:?}, rows of {:?})",
            case.scene,
            case.n,
            case.sink,
            case.steps_per_submit,
            case.build_every,
            case.max_row_groups
        );
        let (two, d2, removed) = run(case, false);
        let (one, d1, removed1) = run(case, true);
        eprintln!("{what}: two-dispatch {d2:?}\n  one-dispatch {d1:?}, {removed} removed");
        assert!(one == two, "{what}: the one-dispatch step changes the bits");
        assert_eq!(removed, removed1);
        if case.sink.is_some() {
            assert!(
                removed > 10,
                "{what}: only {removed} particles reached the sink"
            );
        }
        if case.build_every == Some(1_000_000) {
            assert!(d1.voided_steps > 0, "{what}: no stale step redone");
        }
        for (name, a, b) in [
            ("steps", d1.steps, d2.steps),
            ("builds", d1.builds, d2.builds),
            ("voided steps", d1.voided_steps, d2.voided_steps),
            ("submissions", d1.submissions, d2.submissions),
        ] {
            assert_eq!(a, b, "{what}: {name}");
        }
        assert!(
            d1.steady_steps > 0 || case.build_every == Some(3),
            "{what}: {d1:?}"
        );
        assert_eq!(d1.steady_dispatches, d1.steady_steps, "{what}: {d1:?}");
        assert_eq!(d2.steady_dispatches, 2 * d2.steady_steps, "{what}: {d2:?}");
        assert!(
            d1.fused_steps >= d1.steps - CHUNKS.len() as u64,
            "{what}: {d1:?}"
        );
        assert!(
            d1.copies_back >= 1,
            "{what}: no chunk ended on the second copy"
        );
        assert!(d1.dispatches < d2.dispatches, "{what}");
    }
}

/// `sweep bench`'s pass timings of a one-dispatch chunk of 20 steps: the first step's kick and
/// drift alone, 19 fused steps, the closing forces alone and, the chunk ending on the second
/// copy, one copy back; the profiled chunk leaves the state as it was.
#[test]
fn one_dispatch_chunks_are_timed_pass_by_pass() {
    let Some(dev) = device() else { return };
    if dev.fused_step_unsupported().is_some() {
        return; // said by the test above
    }
    let stamps = dev
        .device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY);
    let sc = stirred_scene("silo-bed", 1500);
    let options = GpuOptions {
        fused_step: true,
        ..GpuOptions::default()
    };
    let mut e = GpuEngine::new(&dev, sc.config.clone(), &sc.state, options).expect("GPU engine");
    e.advance(50).expect("chunk");
    let before = state_bits(&e.download());
    match e.profile_passes(20).expect("profiled chunk") {
        None => assert!(!stamps, "the device stamps passes but none were timed"),
        Some(p) => {
            eprintln!("{p:?}");
            let calls = |k: &str| p.iter().find(|t| t.kernel == k).map_or(0, |t| t.calls);
            assert_eq!(calls("kick_drift"), 1);
            assert_eq!(calls("fused_step"), 19);
            assert_eq!(calls("compute_forces"), 1);
            assert_eq!(calls("adopt"), 1);
        }
    }
    assert!(
        state_bits(&e.download()) == before,
        "profiling moved the state"
    );
}
