//! The GPU engine's step as the device pays for it, on the bench's silo bed (lavapipe in CI):
//! - a steady step (no list build) is at most two dispatches, counted by the engine;
//! - neither where the host records list builds (every step, every third, or only when the
//!   device found the lists stale) nor how many steps go into one command buffer changes a bit
//!   of the state or of the chunk reports;
//! - where particles sit in the buffers (the upload's order, sorted by cell or not) changes no
//!   bit of the state, the reports or the kinetic energy;
//! - where chunks end (one chunk or several, the state moved through the host between them as
//!   a resume moves it) changes no bit of the state or of the kinetic energy;
//! - two runs of 10⁵ particles with many list builds end in the same bits;
//! - the history and the lists bound in two ranges each (as beds past the device's binding limit
//!   are) change no bit, and a bed of 6·10⁵ spheres, whose history passes lavapipe's 128 MiB,
//!   steps to the same bits in one chunk or two, its energy within the watchdog's budget;
//! - dispatches in rows of workgroups (as beds past 4.19·10⁶ slots run) change no bit;
//! - the kinetic energy summed on the device is the downloaded state's, to f32 rounding.
//!
//! Without an adapter the tests print a message and pass, except under CI=true (common::gpu).

use crate::common::gpu::{device, report_bits, state_bits};
use sweep::engine::gpu::{GpuDevice, GpuEngine, GpuOptions};
use sweep::engine::Backend;

fn engine(dev: &GpuDevice, n: usize) -> GpuEngine {
    let sc = sweep::bench::scene("silo-bed", n, 7).expect("bench scene");
    GpuEngine::new(dev, sc.config, &sc.state, GpuOptions::default()).expect("GPU engine")
}

/// The bed stirred (`stirred_scene`) on the GPU.
fn stirred(dev: &GpuDevice, n: usize, options: GpuOptions) -> GpuEngine {
    let sc = stirred_scene("silo-bed", n);
    GpuEngine::new(dev, sc.config, &sc.state, options).expect("GPU engine")
}

/// `chunks` chunks of `steps`: the reports' bits and the final state's.
fn run(e: &mut GpuEngine, chunks: usize, steps: u64) -> (Vec<u64>, Vec<u64>) {
    let mut reports = Vec::new();
    for _ in 0..chunks {
        reports.extend(report_bits(&e.advance(steps).expect("chunk")));
    }
    (reports, state_bits(&e.download()))
}

#[test]
fn a_steady_step_is_at_most_two_dispatches() {
    let Some(dev) = device() else { return };
    let mut e = engine(&dev, 2000);
    for _ in 0..3 {
        e.advance(400).expect("chunk");
    }
    let d = e
        .dispatches()
        .expect("the GPU engine counts its dispatches");
    eprintln!("{d:?}");
    assert_eq!(d.steps, 1200);
    assert!(d.steady_steps > 0, "no steady step in 1200: {d:?}");
    assert!(d.max_steady_step <= 2, "{d:?}");
    assert_eq!(d.steady_dispatches, 2 * d.steady_steps);
    // Builds are rare: the predicted ones and the redone stale steps stay well under one in
    // four steps on this settling bed.
    assert!(d.builds * 4 < d.steps, "{d:?}");
}

#[test]
fn where_lists_are_built_does_not_change_the_bits() {
    let Some(dev) = device() else { return };
    let reference = run(&mut stirred(&dev, 1500, GpuOptions::default()), 3, 100);
    let variants = [
        ("one step per command buffer", 1, None),
        ("seven steps per command buffer", 7, None),
        ("a build every step", 64, Some(1)),
        ("a build every third step", 5, Some(3)),
        ("builds only when stale", 64, Some(1_000_000)),
    ];
    for (what, per_submit, build_every) in variants {
        let options = GpuOptions {
            steps_per_submit: per_submit,
            build_every,
            ..GpuOptions::default()
        };
        let mut e = stirred(&dev, 1500, options);
        let got = run(&mut e, 3, 100);
        if build_every.is_some_and(|n| n > 100) {
            assert!(
                e.dispatches().unwrap().voided_steps > 0,
                "no stale step redone"
            );
        }
        eprintln!("{what}: {:?}", e.dispatches().unwrap());
        assert!(
            got.0 == reference.0,
            "{what}: chunk reports differ: {:?} vs {:?}",
            &got.0[..got.0.len().min(12)],
            &reference.0[..reference.0.len().min(12)]
        );
        assert!(got.1 == reference.1, "{what}: states differ");
    }
}

#[test]
fn where_particles_sit_in_the_buffers_does_not_change_the_bits() {
    let Some(dev) = device() else { return };
    // The stirred bed uploaded in its own order or reversed, its particles sorted by cell at
    // every chunk's start or never: the same kinetic energy and state after every chunk.
    let run_as = |reversed: bool, reorder_by_cell: bool| {
        let options = GpuOptions {
            reorder_by_cell,
            ..GpuOptions::default()
        };
        let mut e = stirred(&dev, 1500, options);
        if reversed {
            let mut s = e.download();
            let order: Vec<u32> = (0..s.len() as u32).rev().collect();
            s.permute(&order);
            e.upload(&s);
        }
        let mut out = Vec::new();
        for steps in [100, 37, 163] {
            out.extend(report_bits(&e.advance(steps).expect("chunk")));
            out.push(e.kinetic_energy().unwrap().to_bits());
            out.extend(state_bits(&e.download()));
        }
        out
    };
    let reference = run_as(false, true);
    for (reversed, reorder) in [(false, false), (true, false), (true, true)] {
        assert!(
            run_as(reversed, reorder) == reference,
            "uploaded reversed: {reversed}, sorted by cell: {reorder}: bits differ"
        );
    }
}

/// `scene` of `n` particles with every particle given a velocity of up to 4 m/s (the lists go
/// stale every few steps) and, for rods, an angular velocity of up to 50 rad/s.
pub(crate) fn stirred_scene(name: &str, n: usize) -> sweep::bench::BenchScene {
    let mut sc = sweep::bench::scene(name, n, 7).expect("bench scene");
    let s = &mut sc.state;
    for i in 0..s.len() {
        if s.inv_mass[i] == 0.0 {
            continue;
        }
        let a = i as f64;
        // Exact in f32: the velocities start without a rest.
        let w = [(1.3 * a).sin(), (0.7 * a).cos(), (2.1 * a).sin()].map(|c| c as f32 as f64);
        s.vel[i] = sweep::engine::V3::from_f64(w.map(|c| c * 4.0));
        if s.oriented {
            s.set_angular_velocity(i, [w[2], w[0], w[1]].map(|c| c * 50.0));
        }
    }
    sc
}

#[test]
fn where_chunks_end_does_not_change_the_bits() {
    let Some(dev) = device() else { return };
    // Spheres with rotation and friction, and rods: 300 steps in one chunk, in chunks of odd
    // lengths, and in chunks with the state downloaded and uploaded into a new engine between
    // them (a resume from a checkpoint): the same state and kinetic energy to the last bit.
    for (name, n, dilute) in [
        ("silo-bed", 1500, false),
        ("silo-bed", 3000, true),
        ("chute-rods", 600, false),
    ] {
        let mut sc = stirred_scene(name, n);
        if dilute {
            // Every tenth mobile particle: most fly free between collisions.
            let keep: Vec<bool> = (0..sc.state.len())
                .map(|i| sc.state.inv_mass[i] == 0.0 || i % 10 == 0)
                .collect();
            sc.state.retain(&keep);
        }
        // Gravity tilted sideways by 10⁻⁷ rad: the y kicks of the free fliers (~10⁻¹² of their
        // speed) gather into velocity rests whose bits reach below what f64 holds beside the
        // value, unless the kernels cut them (`f64_rest`): the download and upload between
        // chunks must carry every bit.
        sc.config.gravity[1] = 9.81e-7;
        let run_as = |chunks: &[u64], reload: bool| {
            let mut e = GpuEngine::new(&dev, sc.config.clone(), &sc.state, GpuOptions::default())
                .expect("GPU engine");
            for &steps in chunks {
                if reload {
                    let s = e.download();
                    e = GpuEngine::new(&dev, sc.config.clone(), &s, GpuOptions::default())
                        .expect("GPU engine");
                }
                e.advance(steps).expect("chunk");
            }
            let mut out = state_bits(&e.download());
            out.push(e.kinetic_energy().unwrap().to_bits());
            out
        };
        let reference = run_as(&[300], false);
        for (chunks, reload) in [
            (&[100, 100, 100][..], false),
            (&[1, 37, 262][..], false),
            (&[1, 1, 298][..], true),
            (&[150, 1, 1, 148][..], true),
        ] {
            assert!(
                run_as(chunks, reload) == reference,
                "{name} (dilute: {dilute}): chunks {chunks:?} (new engine at each: {reload}) differ from one chunk"
            );
        }
    }
}

/// The share of consecutive live slots whose cells (z, y, x of the engine's grid) do not
/// decrease, and the number of live slots.
fn cell_ordered_share(e: &GpuEngine) -> (f64, usize) {
    let g = e.grid().expect("particles on the device");
    let cell = |p: [f32; 3]| {
        let axis = |k: usize| {
            let c = ((p[k] - g.lo[k]) / g.width[k]).floor() as i64;
            c.clamp(0, g.dims[k] as i64 - 1) as u64
        };
        (axis(2) * g.dims[1] as u64 + axis(1)) * g.dims[0] as u64 + axis(0)
    };
    let live: Vec<u64> = e
        .slots_job(0)
        .unwrap()
        .into_iter()
        .flatten()
        .map(|(_, p)| cell(p))
        .collect();
    let ordered = live.windows(2).filter(|w| w[0] <= w[1]).count();
    (ordered as f64 / (live.len() - 1) as f64, live.len())
}

#[test]
fn list_builds_sort_the_particles_by_cell() {
    let Some(dev) = device() else { return };
    for reorder_by_cell in [true, false] {
        let options = GpuOptions {
            reorder_by_cell,
            ..GpuOptions::default()
        };
        let mut e = stirred(&dev, 3000, options);
        // Uploaded in reverse: far from cell order.
        let mut s = e.download();
        let order: Vec<u32> = (0..s.len() as u32).rev().collect();
        s.permute(&order);
        e.upload(&s);
        // A chunk's first step follows a build: the slots are in the order it left.
        e.advance(1).expect("chunk");
        let (share, live) = cell_ordered_share(&e);
        eprintln!("sorted by cell: {reorder_by_cell}: {share:.3} of {live} slots in cell order");
        assert_eq!(live, 3000);
        if reorder_by_cell {
            assert!(share > 0.99, "{share}");
        } else {
            assert!(share < 0.9, "{share}");
        }
    }
}

#[test]
fn bindings_split_in_two_do_not_change_the_bits() {
    let Some(dev) = device() else { return };
    // Limits below the history's and the lists' sizes (hundreds of KiB here) bind them in two
    // ranges: both, then only the larger.
    for (name, n) in [("silo-bed", 1500), ("chute-rods", 600)] {
        let sc = stirred_scene(name, n);
        let run_with = |max_binding_bytes: Option<u64>| {
            let options = GpuOptions {
                max_binding_bytes,
                ..GpuOptions::default()
            };
            let mut e =
                GpuEngine::new(&dev, sc.config.clone(), &sc.state, options).expect("GPU engine");
            let split = e.split_bindings();
            (split, run(&mut e, 3, 100))
        };
        let ([(hist, false), (nbr, false)], reference) = run_with(None) else {
            panic!("{name}: split without a limit")
        };
        let (small, large) = (hist.min(nbr), hist.max(nbr));
        assert!(large < 2 * small, "{name}: {hist} and {nbr} bytes");
        for limit in [large / 2 + 1024, (small + large) / 2] {
            let (split, got) = run_with(Some(limit));
            eprintln!("{name}: history {hist} B, lists {nbr} B, limit {limit} B: {split:?}");
            assert!(split[0].1 == (hist > limit) && split[1].1 == (nbr > limit));
            assert!(split.iter().any(|s| s.1));
            assert!(
                got == reference,
                "{name}: bindings of at most {limit} bytes change the bits"
            );
        }
    }
}

#[test]
fn rows_of_workgroups_do_not_change_the_bits() {
    let Some(dev) = device() else { return };
    // A dispatch past 65 535 workgroups (4.19·10⁶ slots) runs in rows; rows of 5 workgroups
    // make the small beds run that way (1 536 slots: 5 rows of 5, the last workgroup past the
    // slots). The reports (kinetic growth from both energy sums), the kinetic energy, the
    // elastic energy and the states keep every bit.
    for (name, n) in [("silo-bed", 1500), ("chute-rods", 600)] {
        let sc = stirred_scene(name, n);
        let run_with = |max_row_groups: Option<u32>| {
            let options = GpuOptions {
                max_row_groups,
                ..GpuOptions::default()
            };
            let mut e =
                GpuEngine::new(&dev, sc.config.clone(), &sc.state, options).expect("GPU engine");
            let (mut reports, state) = run(&mut e, 3, 100);
            reports.push(e.kinetic_energy().unwrap().to_bits());
            reports.push(e.elastic_energy_job(0).unwrap().to_bits());
            (reports, state)
        };
        let reference = run_with(None);
        assert!(
            run_with(Some(5)) == reference,
            "{name}: rows of 5 workgroups change the bits"
        );
    }
}

/// Pass timings (`sweep bench`): where the device stamps passes, each step's two kernels are
/// timed once per step with a positive time, the builds and closing passes once; the profiled
/// chunk leaves no trace (the state and the run after it keep every bit). Without timestamp
/// queries there is nothing to report.
#[test]
fn pass_times_come_from_the_device_and_leave_the_run_alone() {
    let Some(dev) = device() else { return };
    let stamps = dev
        .device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY);
    let mut plain = stirred(&dev, 1500, GpuOptions::default());
    let mut timed = stirred(&dev, 1500, GpuOptions::default());
    plain.advance(50).expect("chunk");
    timed.advance(50).expect("chunk");
    let passes = timed.profile_passes(20).expect("profiled chunk");
    eprintln!(
        "{} ({}timestamps): {passes:?}",
        dev.info.name,
        if stamps { "" } else { "no " }
    );
    match passes {
        None => assert!(!stamps, "the device stamps passes but none were timed"),
        Some(p) => {
            let of = |k: &str| {
                p.iter()
                    .find(|t| t.kernel == k)
                    .unwrap_or_else(|| panic!("{k}: {p:?}"))
            };
            for k in ["kick_drift", "compute_forces"] {
                assert_eq!(of(k).calls, 20);
            }
            for k in ["build_list", "finish", "energy_sum"] {
                assert_eq!(of(k).calls, 1);
            }
            assert!(p.iter().all(|t| t.ns >= 0.0 && t.steps_timed <= 20));
            assert!(of("compute_forces").ns > 0.0, "{p:?}");
        }
    }
    assert!(state_bits(&plain.download()) == state_bits(&timed.download()));
    assert!(
        run(&mut plain, 2, 100) == run(&mut timed, 2, 100),
        "the profiled run differs after"
    );
}

/// 6·10⁵ spheres of the bench's silo bed: 16 history slots take 147 MiB, past lavapipe's
/// 128 MiB binding (two ranges), and the scratch of a sorting build does not bind (builds keep
/// the order). Three steps in one chunk and in chunks of 1 and 2 end in the same bits; every
/// chunk passes the watchdog (overlap, finiteness and the energy budget) and the kinetic energy
/// summed on the device is the downloaded state's to f32 rounding (1e-5).
#[test]
fn six_hundred_thousand_spheres_step_on_any_adapter() {
    let Some(dev) = device() else { return };
    let sc = sweep::bench::scene("silo-bed", 600_000, 7).expect("bench scene");
    let run_as = |chunks: &[u64]| {
        let mut e = GpuEngine::new(&dev, sc.config.clone(), &sc.state, GpuOptions::default())
            .expect("GPU engine");
        if dev.limits.max_storage_buffer_binding_size <= 128 << 20 {
            assert!(e.split_bindings()[0].1, "{:?}", e.split_bindings());
        }
        for &steps in chunks {
            let r = e.advance(steps).expect("chunk");
            assert!(r.kinetic_growth.is_some_and(|g| g <= 1.05), "{r:?}");
        }
        let s = e.download();
        let k = e.kinetic_energy().unwrap();
        let rel = (k - s.kinetic_energy()).abs() / s.kinetic_energy().max(f64::MIN_POSITIVE);
        eprintln!(
            "N = {}: chunks {chunks:?}, K {k:.6e} J (device sum against the download: {rel:.1e}), {:?}",
            s.len(),
            e.dispatches().unwrap()
        );
        assert!(
            k.is_finite() && rel < 1e-5,
            "K {k} J, relative difference {rel}"
        );
        let mut out = state_bits(&s);
        out.push(k.to_bits());
        out
    };
    assert!(run_as(&[3]) == run_as(&[1, 2]), "one chunk and two differ");
}

#[test]
#[ignore = "long tier (a minute on lavapipe): bash scripts/test-long.sh"]
fn a_hundred_thousand_particles_run_twice_to_the_same_bits() {
    let Some(dev) = device() else { return };
    let mut runs = Vec::new();
    for _ in 0..2 {
        let mut e = stirred(&dev, 100_000, GpuOptions::default());
        let r = run(&mut e, 3, 60);
        let d = e.dispatches().unwrap();
        eprintln!("N = 10⁵: {d:?}");
        assert!(d.builds >= 6, "only {} list builds: {d:?}", d.builds);
        runs.push(r);
    }
    assert!(runs[0] == runs[1], "two runs of the same scene differ");
}

#[test]
fn the_kinetic_energy_is_summed_on_the_device() {
    let Some(dev) = device() else { return };
    let mut e = engine(&dev, 3000);
    for _ in 0..3 {
        e.advance(200).expect("chunk");
        let on_device = e.kinetic_energy().unwrap();
        let downloaded = e.download().kinetic_energy();
        let rel = (on_device - downloaded).abs() / downloaded;
        eprintln!("K = {on_device:.9e} J on the device, {downloaded:.9e} J downloaded ({rel:.1e})");
        // f32 terms, each rounded to 2⁻⁴⁴ of the largest and summed exactly: a few ulps of f32.
        assert!(rel < 1e-5, "K differs by {rel:.2e}");
    }
}

/// The device's contact records against the CPU f32 engine's of the same downloaded state: the
/// same contacts, each once, with forces within 10⁻⁴ of the largest and branches within 10⁻⁶ d.
fn records_match(name: &str, config: sweep::engine::EngineConfig, e: &mut dyn Backend) {
    use std::collections::BTreeMap;
    let state = e.download();
    let gpu = e.contacts().unwrap();
    let mut cpu_engine = sweep::engine::CpuEngine::<f32>::new(config, state.convert(), 1);
    let cpu = cpu_engine.contact_records();
    assert!(cpu.len() > 100, "{name}: only {} contacts", cpu.len());
    assert_eq!(gpu.len(), cpu.len(), "{name}: contact counts differ");
    let fmax = cpu
        .iter()
        .map(|r| r.force_on_i.iter().map(|x| x * x).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    let d = 2.0 * state.radius.iter().cloned().fold(0.0, f64::max);
    // Pairs by (i, j); wall contacts of a particle summed.
    type Key = (u32, Option<u32>);
    let sum = |recs: &[sweep::engine::contact::ContactRecord]| {
        let mut m: BTreeMap<Key, ([f64; 3], [f64; 3], bool, usize)> = BTreeMap::new();
        for r in recs {
            let e = m
                .entry((r.i, r.j))
                .or_insert(([0.0; 3], [0.0; 3], r.j_fixed, 0));
            for k in 0..3 {
                e.0[k] += r.force_on_i[k];
                e.1[k] += r.branch[k];
            }
            e.3 += 1;
        }
        m
    };
    let (g, c) = (sum(&gpu), sum(&cpu));
    assert_eq!(
        g.keys().collect::<Vec<_>>(),
        c.keys().collect::<Vec<_>>(),
        "{name}: different contacts"
    );
    for (k, a) in &g {
        let b = &c[k];
        assert_eq!((a.2, a.3), (b.2, b.3), "{name}: contact {k:?}");
        for x in 0..3 {
            assert!(
                (a.0[x] - b.0[x]).abs() <= 1e-4 * fmax,
                "{name}: force of {k:?}: {:?} against {:?}",
                a.0,
                b.0
            );
            assert!(
                (a.1[x] - b.1[x]).abs() <= 1e-6 * d,
                "{name}: branch of {k:?}"
            );
        }
    }
}

#[test]
fn contacts_are_recorded_on_the_device_as_the_cpu_records_them() {
    let Some(dev) = device() else { return };
    let sc = sweep::bench::scene("silo-bed", 1500, 7).expect("bench scene");
    let mut e = engine(&dev, 1500);
    e.advance(200).unwrap();
    records_match("silo bed", sc.config, &mut e);
    let rods = sweep::bench::scene("chute-rods", 800, 3).expect("bench scene");
    let mut e = GpuEngine::new(
        &dev,
        rods.config.clone(),
        &rods.state,
        GpuOptions::default(),
    )
    .expect("GPU engine");
    e.advance(300).unwrap();
    records_match("rods on a rough base", rods.config, &mut e);
}
