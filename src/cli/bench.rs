//! `sweep bench`: throughput of the engine on a benchmark scene, stored in the database for
//! `sweep plan`'s estimates.

use std::time::Instant;

use sweep::bench::Settling;
use sweep::campaign::Precision;
use sweep::project::{BenchRun, Project};
use sweep::runner::backend::{self, BackendChoice};

pub use super::bench_args::Arguments;
use super::bench_dispatches::{describe_passes, dispatch_json, since, PROFILED_STEPS};

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    let precision = match a.precision.as_str() {
        "f32" => Precision::F32,
        "f64" => Precision::F64,
        p => anyhow::bail!("--precision: expected f32 or f64, got {p:?}"),
    };
    let mut sc = sweep::bench::scene(&a.scene, a.particles, 1)?;
    let dt = sc.config.dt_s;
    let mut settled = None;
    if a.settle {
        let Some(how) = sweep::bench::settling(&a.scene, &sc) else {
            anyhow::bail!(
                "--settle: silo-bed and chute-bed only; got --scene {}",
                a.scene
            );
        };
        let (state, steps) = settled_bed(&sc, how, &a)?;
        sc.state = state;
        settled = Some(steps);
    }
    let scene_name = match settled {
        Some(_) => sweep::bench::settled_name(&a.scene).expect("a scene with a settling"),
        None => a.scene.clone(),
    };
    if let Some(dir) = &a.lammps {
        let input = sweep::lammps::export(&scene_name, &sc, a.steps, dir)?;
        eprintln!("LAMMPS input: {}", input.display());
    }
    if let Some(j) = a.batch {
        return super::bench_batch::run(&a, &sc, &scene_name, j as usize);
    }
    let Timed {
        mut engine,
        report: r,
        checksum: sum,
        steps,
        runs,
        rate,
        secs,
        best,
        dispatches,
    } = timed_runs(&a, &sc, precision)?;
    let info = engine.describe();
    let state = engine.download();
    let mobile = state.inv_mass.iter().filter(|&&m| m > 0.0).count();
    // What a LAMMPS run of the same scene (`--lammps`) prints as `ke` and `vcm(mobile,x)` after
    // the same 100 + steps: a check that the two ran the same physics.
    let (ke, mass, px) = (0..state.len()).filter(|&i| state.inv_mass[i] > 0.0).fold(
        (0.0, 0.0, 0.0),
        |(e, m, p), i| {
            let (mi, v) = (state.mass[i], state.vel[i]);
            (e + 0.5 * mi * v.norm2(), m + mi, p + mi * v.x)
        },
    );
    let vcm_x = px / mass;
    // Per-pass device times over one more chunk (state put back), where the GPU stamps passes.
    let passes = engine
        .profile_passes(a.steps.min(PROFILED_STEPS))
        .map_err(|e| anyhow::anyhow!("timing the passes: {e}"))?;
    let machine = format!(
        "{} cores, {}",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        std::env::consts::ARCH
    );
    if a.json {
        println!(
            "{}",
            serde_json::json!({
                "scene": scene_name, "settle_steps": settled, "particles": mobile, "steps": steps, "chunk_steps": a.steps, "dt_s": dt, "backend": info.kind, "adapter": info.adapter,
                "precision": info.precision, "threads": info.threads, "particle_steps_per_s": rate,
                "contacts_per_particle": r.contacts_per_particle, "list_builds": r.list_builds, "seconds": secs, "state_checksum": sum, "machine": machine,
                "translational_ke_j": ke, "vcm_x_m_per_s": vcm_x,
                "runs_particle_steps_per_s": runs, "best_particle_steps_per_s": best,
                "dispatches": dispatches.map(|d| dispatch_json(&d)),
                // The GPU engine's variants (environment; recorded for every backend, read by the GPU's).
                "gpu_options": sweep::runner::gpu_variants::gpu_options()
                    .map_or(serde_json::Value::Null, |o| sweep::runner::gpu_variants::describe(&o)),
                "gpu_pass_times": passes
            })
        );
    } else {
        println!(
            "{}: N = {mobile}, {} steps, dt = {dt:.3e} s, {} {} ({}): {rate:.3e} particle-steps/s, {:.2} contacts/particle, {} list builds, {secs:.2} s, checksum {sum}",
            scene_name, steps, info.kind, info.precision, info.adapter, r.contacts_per_particle, r.list_builds
        );
        println!(
            "  end state: translational kinetic energy {ke:.6e} J, mean x velocity {vcm_x:.6e} m/s"
        );
        if let Some(d) = &dispatches {
            println!(
                "  dispatches: {:.2} per step, {} per steady step, {} list builds ({} sorting by cell), {} steps voided and redone, {} submissions",
                d.dispatches as f64 / d.steps.max(1) as f64,
                d.max_steady_step,
                d.builds,
                d.sorting_builds,
                d.voided_steps,
                d.submissions
            );
        }
        if let Some(p) = &passes {
            println!("  {}", describe_passes(p));
        } else if info.kind == "gpu" {
            println!("  pass times: the adapter has no timestamp queries");
        }
        if runs.len() > 1 {
            let all: Vec<String> = runs.iter().map(|x| format!("{x:.3e}")).collect();
            println!(
                "  median of {} runs; best {best:.3e}; runs: {}",
                runs.len(),
                all.join(", ")
            );
        }
    }
    if !a.no_store {
        Project::open(&a.db.db)?.record_bench(&BenchRun {
            scene: &scene_name,
            backend: &info.kind,
            precision: &info.precision,
            threads: info.threads as i64,
            particles: mobile as i64,
            steps: steps as i64,
            dt_s: dt,
            particle_steps_per_s: rate,
            contacts_per_particle: r.contacts_per_particle,
            state_checksum: &sum,
            machine: &machine,
        })?;
    }
    Ok(0)
}

/// The timed runs of `--repeat`: the last run's engine, report and end-state checksum (every
/// run must end in the same one), the steps timed, each run's rate, the median run's rate and
/// time (the upper one of an even count), the best rate, and the dispatches of the last run.
struct Timed {
    engine: Box<dyn sweep::engine::Backend>,
    report: sweep::engine::ChunkReport,
    checksum: String,
    steps: u64,
    runs: Vec<f64>,
    rate: f64,
    secs: f64,
    best: f64,
    dispatches: Option<sweep::engine::DispatchCount>,
}

fn timed_runs(
    a: &Arguments,
    sc: &sweep::bench::BenchScene,
    precision: Precision,
) -> anyhow::Result<Timed> {
    let mut rates = Vec::new();
    let mut last = None;
    let mut dispatches = None;
    // The steps timed: --steps, or as many chunks of it as the first run needed to last
    // --min-seconds.
    let mut timed_steps = None;
    for _ in 0..a.repeat {
        let config = sc.config.clone();
        let mut engine = backend::build_with(
            a.backend,
            &a.gpu.select(),
            precision,
            config,
            &sc.state,
            a.threads,
        )?;
        engine
            .advance(100)
            .map_err(|e| anyhow::anyhow!("warm-up: {e}"))?;
        let d0 = engine.dispatches();
        let t0 = Instant::now();
        let mut r = engine
            .advance(a.steps)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut done = a.steps;
        while timed_steps.map_or(t0.elapsed().as_secs_f64() < a.min_seconds, |n| done < n) {
            let more = engine
                .advance(a.steps)
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            r.particle_steps += more.particle_steps;
            r.list_builds += more.list_builds;
            r.contacts_per_particle = more.contacts_per_particle;
            done += a.steps;
        }
        timed_steps = Some(done);
        let secs = t0.elapsed().as_secs_f64();
        dispatches = engine.dispatches().zip(d0).map(|(d1, d0)| since(&d1, &d0));
        rates.push((r.particle_steps as f64 / secs, secs));
        let sum = sweep::bench::checksum(&engine.download());
        if let Some((_, _, _, first)) = &last {
            anyhow::ensure!(
                *first == sum,
                "bench: run {} ended in state {sum}, the first in {first}: the engine is not deterministic",
                rates.len()
            );
        }
        last = Some((engine, r, secs, sum));
    }
    let (engine, r, _, sum) = last.expect("at least one run");
    let steps = timed_steps.expect("at least one run");
    let runs: Vec<f64> = rates.iter().map(|x| x.0).collect();
    rates.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The median run's rate and time (the upper one of an even count).
    let (rate, secs) = rates[rates.len() / 2];
    let best = rates[rates.len() - 1].0;
    Ok(Timed {
        engine,
        report: r,
        checksum: sum,
        steps,
        runs,
        rate,
        secs,
        best,
        dispatches,
    })
}

/// The settled bed for `--settle`: read from `bench-beds/` beside the database when a valid one
/// made from this very lattice is there, else settled and saved. Returns it and the steps it
/// took to settle.
fn settled_bed(
    sc: &sweep::bench::BenchScene,
    how: Settling,
    a: &Arguments,
) -> anyhow::Result<(sweep::engine::State<f64>, u64)> {
    use sweep::checkpoint::{self, Header};
    let dir =
        a.db.db
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join("bench-beds");
    let path = dir.join(format!("{}-{}.bin", a.scene, a.particles));
    // The key names the lattice (its checksum) and the engine that settles it: a changed scene
    // or engine refuses the old file instead of timing a different bed.
    let key = format!(
        "{} settled ({how:?}) from {} by cpu f32, format 1",
        a.scene,
        sweep::bench::checksum(&sc.state)
    );
    if let Ok(bytes) = std::fs::read(&path) {
        match checkpoint::decode(&bytes, &path.display().to_string(), Some(&key)) {
            Ok((h, state, _)) => {
                eprintln!("settled bed from {} ({} steps)", path.display(), h.step);
                return Ok((state, h.step));
            }
            Err(e) => eprintln!("not reusing the settled bed: {e}"),
        }
    }
    let t0 = Instant::now();
    let mut engine = backend::build(
        BackendChoice::Cpu,
        Precision::F32,
        sc.config.clone(),
        &sc.state,
        0,
    )?;
    let mut steps = 0;
    loop {
        let chunk = match how {
            Settling::Flow(total) => (total - steps).min(1000),
            Settling::Rest(_) => 1000,
        };
        engine
            .advance(chunk)
            .map_err(|e| anyhow::anyhow!("settling, step {steps}: {e}"))?;
        steps += chunk;
        match how {
            Settling::Flow(total) if steps >= total => break,
            Settling::Flow(_) => {}
            Settling::Rest(rest) => {
                let ke = engine
                    .kinetic_energy()
                    .map_err(|e| anyhow::anyhow!("settling: {e}"))?;
                if ke < rest {
                    break;
                }
                anyhow::ensure!(
                    steps < a.settle_max_steps,
                    "--settle: kinetic energy {ke:.3e} J after {steps} steps, still above \
                     {rest:.3e} J (10⁻⁴ m g d per particle); raise --settle-max-steps"
                );
            }
        }
    }
    let state = engine.download();
    eprintln!(
        "settled in {steps} steps ({:.1} s); kept in {}",
        t0.elapsed().as_secs_f64(),
        path.display()
    );
    let header = Header {
        job_hash: key,
        step: steps,
        time_s: steps as f64 * sc.config.dt_s,
        backend: "cpu".into(),
        precision: "f32".into(),
    };
    std::fs::create_dir_all(&dir)?;
    checkpoint::write_atomic(&path, &checkpoint::encode(&header, &state, "{}"))?;
    Ok((state, steps))
}
