//! Running one chute job: the poured gas flows from rest in chunks of `CHUNK_S` (0.05 s); the
//! steady-state detector watches the kinetic energy (every chunk) and the bulk stress ratio
//! (every `STRESS_EVERY` chunks, from the contact list the engine builds only then); once steady
//! (or at `steady_max_time_s`) the chute observer samples every `sample_interval_s` (a whole
//! number of chunks) for `measure_time_s`.
//! Checkpoints at chunk boundaries carry the detector and the observer, so a resumed run repeats
//! exactly the same operations; the results and the job's completion go in one transaction.

use std::sync::atomic::Ordering;
use std::time::Instant;

use anyhow::Context;
use rusqlite::{params, Connection, TransactionBehavior};
use serde::{Deserialize, Serialize};

use super::backend;
use super::silo_job::{job_dir, save_checkpoint, JobContext, Outcome};
use crate::campaign::JobSpec;
use crate::checkpoint;
use crate::engine::{Backend, State};
use crate::observe::chute::{
    ChuteGeometry, ChuteObserver, ChuteObserverSettings, ChuteSnapshot, CHUNK_S,
};
use crate::observe::snapshots::SnapshotWriter;
use crate::observe::steady::{SteadyDetector, SteadySettings};
use crate::scene::chute::ChuteScene;
use crate::store::jobs::{self, JobRow, Lease};

/// The stress ratio is sampled every this many chunks while waiting for the steady state
/// (every 0.5 s at the default 0.05 s interval): it needs the contact list, and one snapshot's
/// ratio is noisy anyway (the detector averages over its window).
const STRESS_EVERY: u64 = 10;

/// The bulk over which the stress ratio is taken, as fractions of the expected bed height:
/// away from the base's boundary layer and the dilute free surface.
const BULK: (f64, f64) = (0.2, 0.7);

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
enum Phase {
    /// Flowing from rest, waiting for the steady state.
    Flowing,
    /// Sampling.
    Measuring,
}

/// What a checkpoint keeps besides the particles.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Progress {
    chunk: u64,
    phase: Phase,
    detector: SteadyDetector,
    /// (t, kinetic energy of the flowing particles, bulk μ when sampled).
    series: Vec<(f64, f64, Option<f64>)>,
    observer: Option<ChuteObserver>,
    steady_time_s: Option<f64>,
    steady_stress_ratio: Option<f64>,
    steady: bool,
    measure_start_chunk: u64,
    particle_steps: u64,
    wall_time_s: f64,
    #[serde(default)]
    numerics: crate::store::JobNumerics,
}

/// The flowing particles of a downloaded state as the observer reads them.
struct Flowing {
    id: Vec<u32>,
    pos: Vec<[f64; 3]>,
    vel: Vec<[f64; 3]>,
    axis: Vec<[f64; 3]>,
    mass: Vec<f64>,
}

impl Flowing {
    fn of(s: &State<f64>) -> Self {
        let mut f = Flowing {
            id: Vec::new(),
            pos: Vec::new(),
            vel: Vec::new(),
            axis: Vec::new(),
            mass: Vec::new(),
        };
        for i in 0..s.len() {
            if s.inv_mass[i] == 0.0 {
                continue;
            }
            f.id.push(s.id[i]);
            f.pos.push(s.pos[i].to_f64());
            f.vel.push(s.vel[i].to_f64());
            f.axis.push(s.axis(i).to_f64());
            f.mass.push(s.mass[i]);
        }
        f
    }

    fn snapshot<'a>(
        &'a self,
        time_s: f64,
        contacts: &'a [crate::engine::contact::ContactRecord],
    ) -> ChuteSnapshot<'a> {
        ChuteSnapshot {
            time_s,
            id: &self.id,
            pos: &self.pos,
            vel: &self.vel,
            axis: &self.axis,
            mass: &self.mass,
            contacts,
        }
    }
}

/// The chute's geometry for the observer: heights from the base spheres' centres (z = 0) up to
/// twice the expected bed (the poured gas is taller at first, and the grid must hold the
/// surface).
fn geometry(scene: &ChuteScene) -> ChuteGeometry {
    let p = &scene.p;
    let shape = p.shape();
    let (lx, ly) = p.box_size();
    ChuteGeometry {
        total_length_m: p.particle_length_m,
        diameter_m: 2.0 * shape.radius,
        cylinder_length_m: 2.0 * shape.half_length,
        box_x_m: lx,
        box_y_m: ly,
        z_base_m: 0.0,
        z_top_m: 2.0 * expected_bed_height(scene) + 2.0 * p.particle_length_m,
        inclination_deg: p.inclination_deg,
    }
}

/// Bed height from the particle count at the assumed flowing solid fraction (m).
fn expected_bed_height(scene: &ChuteScene) -> f64 {
    let p = &scene.p;
    let (lx, ly) = p.box_size();
    p.count() as f64 * p.shape().volume() / (p.flowing_solid_fraction * lx * ly)
}

/// Runs (or resumes) one chute job to its end, an interruption, or a failure.
///
/// # Errors
/// Database and I/O errors; physics failures are an `Outcome::Failed` instead.
pub fn run_chute_job(
    conn: &mut Connection,
    job: &JobRow,
    lease: &Lease,
    ctx: &JobContext,
) -> anyhow::Result<Outcome> {
    let spec: JobSpec = serde_json::from_str(&job.params_json)
        .with_context(|| format!("job {}: stored parameters unreadable", job.id))?;
    let scene = match ChuteScene::new(spec.chute().clone()) {
        Ok(s) => s,
        Err(e) => return Ok(Outcome::Failed(e)),
    };
    let p = scene.p.clone();
    let settings: ChuteObserverSettings = spec.observers.chute.clone().unwrap_or_default();
    let steady_settings = SteadySettings {
        window_s: p.steady_window_s,
        tol_ke: p.steady_kinetic_tolerance,
        tol_ratio: p.steady_stress_tolerance,
        ..SteadySettings::default()
    };
    let geom = geometry(&scene);
    // A throwaway observer for the stress ratio while flowing (it keeps no state for that).
    let probe = match ChuteObserver::new(settings.clone(), geom.clone()) {
        Ok(o) => o,
        Err(problems) => {
            let text: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
            return Ok(Outcome::Failed(format!(
                "observers.chute: {}",
                text.join("; ")
            )));
        }
    };
    let dir = job_dir(&ctx.work_dir, &job.hash);
    let started = Instant::now();
    let (found, refused) = checkpoint::load_latest(&dir, &job.hash);
    for r in refused {
        (ctx.log)(format!("job {}: {r}", job.id));
    }
    let (state, mut prog) = match found {
        Some((path, _, s, extra)) => {
            let prog = serde_json::from_str::<Progress>(&extra)
                .with_context(|| format!("{}: progress record unreadable", path.display()))?;
            (ctx.log)(format!(
                "job {}: resuming from {} (t = {:.3} s)",
                job.id,
                path.display(),
                s.time
            ));
            (s, prog)
        }
        None => {
            if job.sim_time_s > 0.0 {
                (ctx.log)(format!(
                    "job {}: no valid checkpoint; restarting from the beginning",
                    job.id
                ));
            }
            let s = scene.initial_state(spec.seed());
            let prog = Progress {
                chunk: 0,
                phase: Phase::Flowing,
                detector: SteadyDetector::new(steady_settings, p.inclination_deg),
                series: Vec::new(),
                observer: None,
                steady_time_s: None,
                steady_stress_ratio: None,
                steady: false,
                measure_start_chunk: 0,
                particle_steps: 0,
                wall_time_s: 0.0,
                numerics: Default::default(),
            };
            (s, prog)
        }
    };
    // `auto` takes a hardware GPU for f32 rods as for spheres (backend::build).
    let choice = backend::for_job(&spec, ctx.backend);
    let mut engine: Box<dyn Backend> = match backend::build(
        choice,
        spec.precision,
        scene.engine_config(),
        &state,
        ctx.threads,
    ) {
        Ok(e) => e,
        Err(e) => return Ok(Outcome::Failed(format!("{e:#}"))),
    };
    let info = engine.describe();
    jobs::set_backend(conn, job.id, &info.kind, &info.adapter, &info.precision)?;
    let stage = |phase: Phase| match phase {
        Phase::Flowing => "flow",
        Phase::Measuring => "measure",
    };
    jobs::set_stage(conn, job.id, lease, stage(prog.phase))?;

    // A fixed chunk (see CHUNK_S), shortened only for an observer that samples faster.
    let chunk_steps = (CHUNK_S.min(settings.sample_interval_s) / scene.dt)
        .round()
        .max(1.0) as u64;
    let chunk_dt = chunk_steps as f64 * scene.dt;
    let sample_every = ((settings.sample_interval_s / chunk_dt).round() as u64).max(1);
    let ckpt_every = ((ctx.checkpoint_interval_s / chunk_dt).round() as u64).max(1);
    let target = p.max_time_s();
    let bed = expected_bed_height(&scene);
    let wall0 = prog.wall_time_s;
    let mut last_beat = Instant::now();
    let save = |engine: &mut Box<dyn Backend>, prog: &Progress| {
        save_checkpoint(&dir, &job.hash, engine.as_mut(), &info, prog)
    };
    let measure_chunks = (p.measure_time_s / chunk_dt).round().max(1.0) as u64;
    let snapshots =
        SnapshotWriter::new(spec.observers.snapshots.as_ref(), &dir, &job.hash, chunk_dt);
    loop {
        let t = prog.chunk as f64 * chunk_dt;
        // Frames at chunk boundaries only, so a resumed run rewrites the same ones.
        snapshots.at_chunk(prog.chunk, t, || engine.try_download())?;
        if prog.phase == Phase::Measuring && prog.chunk >= prog.measure_start_chunk + measure_chunks
        {
            break;
        }
        // The progress target shrinks to the real end once measurement has started.
        let end = if prog.phase == Phase::Measuring {
            (prog.measure_start_chunk + measure_chunks) as f64 * chunk_dt
        } else {
            target
        };
        if ctx.interrupt.load(Ordering::SeqCst) {
            let path = save(&mut engine, &prog)?;
            jobs::heartbeat(
                conn,
                job.id,
                lease,
                t,
                t / end,
                prog.particle_steps,
                prog.wall_time_s,
                Some(&path.display().to_string()),
            )?;
            return Ok(Outcome::Paused);
        }
        let t0 = Instant::now();
        let report = match engine.advance(chunk_steps) {
            Ok(r) => r,
            Err(e) => return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)"))),
        };
        prog.chunk += 1;
        prog.particle_steps += report.particle_steps;
        prog.numerics.add(&report);
        let t_now = prog.chunk as f64 * chunk_dt;
        let s = match engine.try_download() {
            Ok(s) => s,
            Err(e) => return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)"))),
        };
        let flowing = Flowing::of(&s);
        let ke = s.kinetic_energy();
        match prog.phase {
            Phase::Flowing => {
                let ratio = if prog.chunk % STRESS_EVERY == 0 {
                    let contacts = engine
                        .contacts()
                        .map_err(|e| anyhow::anyhow!("contact list: {e}"))?;
                    probe.stress_ratio(
                        &flowing.snapshot(t_now, &contacts),
                        BULK.0 * bed,
                        BULK.1 * bed,
                    )
                } else {
                    None
                };
                prog.series.push((t_now, ke, ratio));
                let check = prog.detector.push(t_now, ke, ratio);
                // The criteria must hold on the current window, not at some earlier moment.
                let steady = t_now >= p.steady_min_time_s && check.is_some_and(|c| c.steady);
                if steady || t_now >= p.steady_max_time_s - 1e-9 {
                    let found = check;
                    prog.steady = steady;
                    prog.steady_time_s = steady.then_some(t_now);
                    prog.steady_stress_ratio = found.and_then(|c| c.stress_ratio);
                    prog.phase = Phase::Measuring;
                    prog.measure_start_chunk = prog.chunk;
                    prog.observer = Some(probe.clone());
                    jobs::set_stage(conn, job.id, lease, stage(prog.phase))?;
                    (ctx.log)(format!(
                        "job {}: {} at t = {t_now:.2} s{}; measuring for {} s",
                        job.id,
                        if steady {
                            "steady"
                        } else {
                            "NOT steady (steady_max_time_s reached)"
                        },
                        prog.steady_stress_ratio
                            .map(|m| format!(" (μ = {m:.3}, tan α = {:.3})", scene.tan_alpha()))
                            .unwrap_or_default(),
                        p.measure_time_s
                    ));
                }
            }
            Phase::Measuring => {
                let sample = (prog.chunk - prog.measure_start_chunk) % sample_every == 0;
                let stress = prog.chunk % STRESS_EVERY == 0;
                let contacts = if sample || stress {
                    engine
                        .contacts()
                        .map_err(|e| anyhow::anyhow!("contact list: {e}"))?
                } else {
                    Vec::new()
                };
                let snap = flowing.snapshot(t_now, &contacts);
                let ratio = stress
                    .then(|| probe.stress_ratio(&snap, BULK.0 * bed, BULK.1 * bed))
                    .flatten();
                prog.series.push((t_now, ke, ratio));
                prog.numerics.energy.add(t_now, ke);
                if sample {
                    prog.observer
                        .as_mut()
                        .expect("observer exists while measuring")
                        .sample(&snap);
                }
            }
        }
        let rate = report.particle_steps as f64 / t0.elapsed().as_secs_f64().max(1e-9);
        prog.wall_time_s = wall0 + started.elapsed().as_secs_f64();
        let saved = if prog.chunk % ckpt_every == 0 {
            Some(save(&mut engine, &prog)?)
        } else {
            None
        };
        if saved.is_some() || last_beat.elapsed().as_secs_f64() > 2.0 {
            let path = saved.map(|p| p.display().to_string());
            jobs::heartbeat(
                conn,
                job.id,
                lease,
                t_now,
                (t_now / end).min(1.0),
                prog.particle_steps,
                prog.wall_time_s,
                path.as_deref(),
            )?;
            last_beat = Instant::now();
        }
        if let Some(pf) = &ctx.progress {
            pf(t_now, end, rate);
        }
    }
    let t_end = prog.chunk as f64 * chunk_dt;
    let observer = prog
        .observer
        .as_ref()
        .expect("measurement happened before the end");
    let mut results = observer.finish();
    results.summary.steady = prog.steady;
    results.summary.steady_time_s = prog.steady_time_s;
    results.summary.steady_stress_ratio = prog.steady_stress_ratio;
    let wall = wall0 + started.elapsed().as_secs_f64();
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let status: String = tx.query_row("SELECT status FROM jobs WHERE id = ?1", [job.id], |r| {
        r.get(0)
    })?;
    if status != "done" {
        results.write(&tx, job.id, &prog.series)?;
        prog.numerics.write(&tx, job.id, scene.dt)?;
        tx.execute(
            "UPDATE jobs SET status = 'done', lease_owner = NULL, progress = 1.0, sim_time_s = ?2, wall_time_s = ?3, particle_steps = ?4,
                finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1",
            params![job.id, t_end, wall, prog.particle_steps as i64],
        )?;
    }
    tx.commit()?;
    Ok(Outcome::Done)
}
