//! Batched jobs on the GPU (lavapipe in CI): silo beds draining through orifices of different
//! diameters D under bottoms turning at different frequencies f, advanced J = 1, 3 and 8 at a
//! time in the same dispatches, and three beds of spherocylinders. Each job's chunk reports (sink events included) and final state
//! must be bit for bit those of the same job run alone, also when a job is stopped midway and
//! when a job's particles are replaced (a resume) while the others run.
//!
//! Without an adapter the tests print a message and pass, except under CI=true (common::gpu).

use crate::common::cli::{
    assert_same_results, campaign, results, stderr, stdout, sweep_cmd, write_campaign,
};
use crate::common::gpu::{device, report_bits, state_bits};
use sweep::engine::gpu::{GpuDevice, GpuEngine, GpuOptions};
use sweep::engine::walls::{WallRotation, WallShape};
use sweep::engine::{Backend, EngineConfig, State};

const D: f64 = 0.0058;

/// A silo bed of `n` spheres draining through an orifice of `d_over` d under a bottom turning at
/// `f_hz`.
fn silo(n: usize, seed: u64, d_over: f64, f_hz: f64) -> (EngineConfig, State<f64>) {
    let mut sc = sweep::bench::scene("silo-bed", n, seed).expect("bench scene");
    for w in &mut sc.config.walls {
        if let WallShape::OrificePlate { orifice_radius, .. } = &mut w.shape {
            *orifice_radius = 0.5 * d_over * D;
            w.rotation = Some(WallRotation {
                axis_xy: [0.0, 0.0],
                omega_rad_per_s: 2.0 * std::f64::consts::PI * f_hz,
            });
        }
    }
    // Particles that fall through are removed a diameter below the plate.
    sc.config.sink_z = Some(-D);
    // Start with the bed falling at 3 m/s, so that it drains within a few hundred steps.
    for v in &mut sc.state.vel {
        v.z = -3.0;
    }
    (sc.config, sc.state)
}

/// The eight jobs: D = 3, 4, 5 d and f = 0, 0.5, 1, 2 Hz, two particle counts.
fn jobs() -> Vec<(EngineConfig, State<f64>)> {
    let params = [
        (3.0, 0.0),
        (4.0, 0.5),
        (5.0, 1.0),
        (4.0, 2.0),
        (5.0, 0.0),
        (3.0, 1.0),
        (5.0, 2.0),
        (4.0, 0.0),
    ];
    params
        .iter()
        .enumerate()
        .map(|(k, &(d, f))| silo(if k == 1 { 700 } else { 800 }, 11 + k as u64, d, f))
        .collect()
}

const CHUNKS: usize = 3;
const STEPS: u64 = 250;

/// A job run alone: its reports' bits per chunk and its final state's.
fn alone(dev: &GpuDevice, job: &(EngineConfig, State<f64>)) -> (Vec<Vec<u64>>, Vec<u64>, usize) {
    let mut e = GpuEngine::new(dev, job.0.clone(), &job.1, GpuOptions::default()).unwrap();
    let mut reports = Vec::new();
    let mut removed = 0;
    for _ in 0..CHUNKS {
        let r = e.advance(STEPS).unwrap();
        removed += r.removed.len();
        reports.push(report_bits(&r));
    }
    (reports, state_bits(&e.download()), removed)
}

fn batch(dev: &GpuDevice, jobs: &[(EngineConfig, State<f64>)]) -> GpuEngine {
    let configs = jobs.iter().map(|j| j.0.clone()).collect();
    let states: Vec<&State<f64>> = jobs.iter().map(|j| &j.1).collect();
    GpuEngine::batch(dev, configs, &states, GpuOptions::default()).unwrap()
}

/// `CHUNKS` chunks of the whole batch: each job's reports' bits per chunk.
fn batch_reports(e: &mut GpuEngine) -> Vec<Vec<Vec<u64>>> {
    let mut reports = vec![Vec::new(); e.jobs()];
    for _ in 0..CHUNKS {
        for (k, r) in e.advance_batch(STEPS).unwrap().into_iter().enumerate() {
            reports[k].push(report_bits(&r.unwrap()));
        }
    }
    reports
}

#[test]
fn batched_jobs_give_the_bits_of_each_job_alone() {
    let Some(dev) = device() else { return };
    let all = jobs();
    let solo: Vec<_> = all.iter().map(|j| alone(&dev, j)).collect();
    let drained: usize = solo.iter().map(|s| s.2).sum();
    assert!(
        drained > 40,
        "only {drained} particles left the silos: the sink is untested"
    );
    for j in [1, 3, 8] {
        let mut e = batch(&dev, &all[..j]);
        let reports = batch_reports(&mut e);
        eprintln!("J = {j}: {:?}", e.dispatches().unwrap());
        for k in 0..j {
            assert!(
                reports[k] == solo[k].0,
                "J = {j}: job {k}'s chunk reports differ from its run alone"
            );
            let s = state_bits(&e.download_job(k).unwrap());
            assert!(
                s == solo[k].1,
                "J = {j}: job {k}'s state differs from its run alone"
            );
        }
    }
}

#[test]
fn batched_rods_give_the_bits_of_each_job_alone() {
    let Some(dev) = device() else { return };
    // Spherocylinders over a rough base, three beds of different size: each one's reports and
    // state in a batch of three are those it has alone (cell order, shapes and rotations
    // included).
    let rods: Vec<(EngineConfig, State<f64>)> = [(600, 31), (700, 32), (800, 33)]
        .iter()
        .map(|&(n, seed)| {
            let sc = sweep::bench::scene("chute-rods", n, seed).expect("bench scene");
            (sc.config, sc.state)
        })
        .collect();
    let solo: Vec<_> = rods.iter().map(|j| alone(&dev, j)).collect();
    let mut e = batch(&dev, &rods);
    let reports = batch_reports(&mut e);
    for k in 0..rods.len() {
        assert!(reports[k] == solo[k].0, "rod job {k}: chunk reports differ");
        let s = state_bits(&e.download_job(k).unwrap());
        assert!(
            s == solo[k].1,
            "rod job {k}: state differs from its run alone"
        );
    }
}

#[test]
fn a_stopped_or_replaced_job_leaves_the_others_unchanged() {
    let Some(dev) = device() else { return };
    let all = jobs();
    let three = &all[..3];
    let solo: Vec<_> = three.iter().map(|j| alone(&dev, j)).collect();
    let mut e = batch(&dev, three);
    e.advance_batch(STEPS).unwrap();
    // Job 1 stops after one chunk; job 2 is replaced by its own download (a resume).
    e.set_active(1, false);
    let s2 = e.download_job(2).unwrap();
    e.upload_job(2, &s2).unwrap();
    let stopped = state_bits(&e.download_job(1).unwrap());
    for _ in 1..CHUNKS {
        let r = e.advance_batch(STEPS).unwrap();
        assert_eq!(
            r[1].as_ref().unwrap().steps,
            0,
            "a stopped job reports no steps"
        );
    }
    assert!(
        state_bits(&e.download_job(1).unwrap()) == stopped,
        "the stopped job moved"
    );
    for k in [0, 2] {
        let s = state_bits(&e.download_job(k).unwrap());
        assert!(s == solo[k].1, "job {k} differs from its run alone");
    }
}

#[test]
fn sweep_bench_times_a_batch() {
    let Some(_dev) = device() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bench = |extra: &[&str]| {
        let mut args = vec![
            "bench",
            "--scene",
            "silo-bed",
            "--particles",
            "400",
            "--steps",
            "30",
            "--batch",
            "3",
            "--no-store",
            "--json",
        ];
        args.extend_from_slice(extra);
        assert_cmd::Command::new(crate::common::cli::bin())
            .current_dir(dir.path())
            .env_remove("SWEEP_DB")
            .args(args)
            .output()
            .unwrap()
    };
    let out = bench(&["--backend", "gpu", "--allow-software-gpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["jobs"], 3);
    let rate = v["particle_steps_per_s"].as_f64().unwrap();
    let per_job = v["per_job_particle_steps_per_s"].as_f64().unwrap();
    assert!(rate > 0.0 && (rate / per_job - 3.0).abs() < 1e-9, "{v}");
    assert!(
        v["dispatches"]["per_steady_step"].as_u64().unwrap() <= 2,
        "{v}"
    );
    // A batch on the CPU is refused by name.
    let out = bench(&["--backend", "cpu"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--backend gpu"));
}

/// `sweep launch --backend gpu --parallel 4 --batch J` on the tiny silo campaign (two orifices ×
/// two frequencies, f32); returns the database.
fn launch_batched(dir: &std::path::Path, batch: &str) -> (std::path::PathBuf, String) {
    let mut c = campaign("batched", &[0.02, 0.025], &[0.0, 1.0], 0.1);
    c["run"]["precision"] = serde_json::json!("f32");
    let file = write_campaign(dir, "batched.json", &c);
    let db = dir.join(format!("batch-{batch}.db"));
    let o = sweep_cmd(dir)
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
        ])
        .args([
            "--backend",
            "gpu",
            "--allow-software-gpu",
            "--parallel",
            "4",
        ])
        .args(["--batch", batch])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    (db, stderr(&o))
}

#[test]
fn a_campaign_run_in_batches_stores_what_it_stores_alone() {
    let Some(_dev) = device() else { return };
    let dir = tempfile::tempdir().unwrap();
    let (db, err) = launch_batched(dir.path(), "1");
    assert!(!err.contains("shared engines"), "{err}");
    let alone = results(&db);
    // Separate work directories: the fill stages are shared within one, not across.
    let dir2 = tempfile::tempdir().unwrap();
    let (db, err) = launch_batched(dir2.path(), "4");
    eprintln!("{err}");
    assert!(
        err.contains("shared engines, up to"),
        "no batch formed:\n{err}"
    );
    let batched = results(&db);
    // The fill stages ran on the GPU (stored under keys of their own).
    let fills = fill_backends(dir2.path());
    assert!(
        !fills.is_empty() && fills.iter().all(|b| b == "gpu"),
        "{fills:?}"
    );
    assert_eq!(alone.jobs.len(), 4);
    assert!(!alone.series.is_empty());
    assert_same_results(&alone, &batched);
}

/// The backend of every fill-stage checkpoint under `dir`.
fn fill_backends(dir: &std::path::Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                todo.push(p);
            } else if p.to_string_lossy().contains("stages")
                && p.extension().is_some_and(|x| x == "bin")
            {
                let bytes = std::fs::read(&p).unwrap();
                let (h, _, _) = sweep::checkpoint::decode(&bytes, "fill", None).unwrap();
                out.push(h.backend);
            }
        }
    }
    out
}
