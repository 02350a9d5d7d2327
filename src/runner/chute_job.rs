//! Running one chute job: the poured gas flows from rest in chunks of `CHUNK_S` (0.05 s); the
//! steady-state detector watches the kinetic energy and the bed's mean V_x (every chunk) and the
//! bulk stress ratio (every `STRESS_EVERY` chunks, from the contact list the engine builds only
//! then); once steady the chute observer samples every `sample_interval_s` (a whole number of
//! chunks) for `measure_time_s`, and the same criteria are checked again on the measurement
//! window. A bed that stops flowing, or a flow not steady by `steady_max_time_s`, measures
//! nothing (unless `measure_unsteady`); the verdict and every criterion are stored
//! (`FlowRecord`).
//! Checkpoints at chunk boundaries carry the detector and the observer, so a resumed run repeats
//! exactly the same operations; the results and the job's completion go in one transaction.

use anyhow::Context;
use rusqlite::Connection;
use serde::{Deserialize, Serialize};

use super::job::{self, JobContext, JobRun, Ledger, Outcome, Start, Study};
use crate::campaign::JobSpec;
use crate::engine::{Backend, ChunkReport, EngineConfig, State};
use crate::observe::chute::{
    ChuteGeometry, ChuteObserver, ChuteObserverSettings, ChuteSnapshot, FlowRecord, FlowState,
    TrendTolerances, CHUNK_S,
};
use crate::observe::stationarity::Trend;
use crate::observe::steady::{
    check_window, FlowSample, SteadyDetector, SteadySettings, WindowCheck,
};
use crate::scene::ChuteScene;
use crate::store::jobs::{self, JobRow, Lease};
use crate::store::ChuteJobResults;

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
    /// Ended without measuring: not flowing, or not steady by `steady_max_time_s`.
    Ended,
}

/// What a checkpoint keeps besides the particles.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Progress {
    #[serde(flatten)]
    ledger: Ledger,
    phase: Phase,
    detector: SteadyDetector,
    /// Kinetic energy, mean V_x and bulk μ (when sampled) of the flowing particles, every chunk.
    series: Vec<FlowSample>,
    observer: Option<ChuteObserver>,
    /// The criteria on the transient's last window (when measurement started or the job ended).
    transient: Option<WindowCheck>,
    steady_time_s: Option<f64>,
    measure_start_chunk: u64,
    /// Time the measurement started, or the job ended without one (s).
    measure_start_s: f64,
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
    /// Mass-weighted mean V_x (m/s).
    fn mean_vx(&self) -> f64 {
        let m: f64 = self.mass.iter().sum();
        let p: f64 = self.vel.iter().zip(&self.mass).map(|(v, m)| v[0] * m).sum();
        if m > 0.0 {
            p / m
        } else {
            0.0
        }
    }

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
    let settings: ChuteObserverSettings = spec.observers.chute.clone().unwrap_or_default();
    // A throwaway observer for the stress ratio while flowing (it keeps no state for that).
    let probe = match ChuteObserver::new(settings.clone(), geometry(&scene)) {
        Ok(o) => o,
        Err(problems) => {
            let text: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
            return Ok(Outcome::Failed(format!(
                "observers.chute: {}",
                text.join("; ")
            )));
        }
    };
    // A fixed chunk (see CHUNK_S), shortened only for an observer that samples faster.
    let chunk_steps = (CHUNK_S.min(settings.sample_interval_s) / scene.dt)
        .round()
        .max(1.0) as u64;
    let chunk_dt = chunk_steps as f64 * scene.dt;
    let study = ChuteStudy {
        sample_every: ((settings.sample_interval_s / chunk_dt).round() as u64).max(1),
        // A campaign's target may have run the measurement on: the job's end then stands
        // past the file's `steady_max_time_s + measure_time_s`.
        measure_chunks: ((job.target_time_s - scene.p.steady_max_time_s)
            .max(scene.p.measure_time_s)
            / chunk_dt)
            .round()
            .max(1.0) as u64,
        bed: expected_bed_height(&scene),
        chunk_steps,
        probe,
        spec,
        scene,
    };
    job::run(conn, job, lease, ctx, &study)
}

/// A chute job: its parameters, scene, chunking and stress-ratio probe.
struct ChuteStudy {
    spec: JobSpec,
    scene: ChuteScene,
    probe: ChuteObserver,
    chunk_steps: u64,
    /// Chunks between two observer samples.
    sample_every: u64,
    /// Chunks of measurement.
    measure_chunks: u64,
    /// The expected bed height (m), for the bulk of the stress ratio.
    bed: f64,
}

fn stage(phase: Phase) -> &'static str {
    match phase {
        Phase::Flowing => "flow",
        Phase::Measuring => "measure",
        Phase::Ended => "ended",
    }
}

impl ChuteStudy {
    /// The log line when the transient ends.
    fn transient_words(
        &self,
        check: Option<&WindowCheck>,
        t: f64,
        steady: bool,
        stopped: bool,
    ) -> String {
        let p = &self.scene.p;
        let verdict = if stopped {
            "NOT flowing"
        } else if steady {
            "steady"
        } else {
            "NOT steady (steady_max_time_s reached)"
        };
        let criteria = check.map_or_else(String::new, |c| format!(" ({})", self.criteria(c)));
        let next = if self.measures(steady, stopped) {
            format!("; measuring for {} s", p.measure_time_s)
        } else {
            "; measuring nothing".into()
        };
        format!("{verdict} at t = {t:.2} s{criteria}{next}")
    }

    /// A window's criteria in words: each trend's change with its t statistic against the
    /// quantile, the mean V_x, and μ against tan α.
    fn criteria(&self, c: &WindowCheck) -> String {
        let trend = |t: Option<Trend>| {
            t.map_or("-".into(), |t| {
                format!(
                    "{:.1} % (t {:.2} of {:.2})",
                    100.0 * t.relative_change,
                    t.t_statistic,
                    t.t_critical
                )
            })
        };
        format!(
            "KE change {}, V_x change {}, mean V_x {:.3} m/s, μ {}, tan α = {:.3}",
            trend(c.ke),
            trend(c.vx),
            c.mean_vx_m_per_s,
            c.stress_ratio.map_or("-".into(), |m| format!("{m:.3}")),
            self.scene.tan_alpha()
        )
    }

    fn measures(&self, steady: bool, stopped: bool) -> bool {
        steady || (!stopped && self.scene.p.measure_unsteady)
    }
}

impl Study for ChuteStudy {
    type Progress = Progress;

    fn spec(&self) -> &JobSpec {
        &self.spec
    }

    fn ledger(p: &Progress) -> &Ledger {
        &p.ledger
    }

    fn ledger_mut(p: &mut Progress) -> &mut Ledger {
        &mut p.ledger
    }

    fn start(&self, _run: &JobRun) -> anyhow::Result<Start<Progress>> {
        let p = &self.scene.p;
        let prog = Progress {
            ledger: Ledger::default(),
            phase: Phase::Flowing,
            detector: SteadyDetector::new(
                SteadySettings::of_chute(p, p.steady_window_s),
                p.inclination_deg,
            ),
            series: Vec::new(),
            observer: None,
            transient: None,
            steady_time_s: None,
            measure_start_chunk: 0,
            measure_start_s: 0.0,
        };
        Ok(Start::Ready(
            Box::new(self.scene.start_state(self.spec.seed())),
            prog,
        ))
    }

    fn engine_config(&self) -> EngineConfig {
        self.scene.engine_config()
    }

    fn chunk_steps(&self) -> u64 {
        self.chunk_steps
    }

    fn dt(&self) -> f64 {
        self.scene.dt
    }

    fn describe_resume(&self, s: &State<f64>, _: &Progress) -> String {
        format!("t = {:.3} s", s.time)
    }

    fn stage(&self, p: &Progress) -> &'static str {
        stage(p.phase)
    }

    fn done(&self, p: &Progress, _t: f64) -> bool {
        match p.phase {
            Phase::Flowing => false,
            Phase::Measuring => p.ledger.chunk >= p.measure_start_chunk + self.measure_chunks,
            Phase::Ended => true,
        }
    }

    fn end_time(&self, p: &Progress) -> f64 {
        // The progress target shrinks to the real end once measurement has started.
        match p.phase {
            Phase::Measuring => {
                (p.measure_start_chunk + self.measure_chunks) as f64
                    * self.chunk_steps as f64
                    * self.scene.dt
            }
            Phase::Ended => p.measure_start_s,
            Phase::Flowing => self.scene.p.max_time_s(),
        }
    }

    fn observe(
        &self,
        run: &JobRun,
        prog: &mut Progress,
        engine: &mut dyn Backend,
        _report: &ChunkReport,
        t_now: f64,
    ) -> anyhow::Result<Result<(), String>> {
        let p = &self.scene.p;
        let (bed, probe) = (self.bed, &self.probe);
        let s = match engine.try_download() {
            Ok(s) => s,
            Err(e) => return Ok(Err(format!("{e} (last good checkpoint kept)"))),
        };
        let flowing = Flowing::of(&s);
        let ke = s.kinetic_energy();
        let chunk = prog.ledger.chunk;
        match prog.phase {
            Phase::Flowing => {
                let ratio = if chunk.is_multiple_of(STRESS_EVERY) {
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
                let sample = FlowSample {
                    t: t_now,
                    ke,
                    vx: flowing.mean_vx(),
                    ratio,
                };
                prog.series.push(sample);
                let check = prog.detector.push(sample);
                // The criteria must hold on the current window, not at some earlier moment.
                let judged = t_now >= p.steady_min_time_s;
                let stopped = judged && check.is_some_and(|c| !c.flowing);
                let steady = judged && check.is_some_and(|c| c.steady);
                let timeout = t_now >= p.steady_max_time_s - 1e-9;
                if stopped || steady || timeout {
                    prog.transient = check.or(prog.transient);
                    prog.measure_start_s = t_now;
                    let measure = steady || (timeout && !stopped && p.measure_unsteady);
                    if measure {
                        prog.steady_time_s = steady.then_some(t_now);
                        prog.phase = Phase::Measuring;
                        prog.measure_start_chunk = chunk;
                        prog.observer = Some(probe.clone());
                    } else {
                        prog.phase = Phase::Ended;
                    }
                    jobs::set_stage(run.conn, run.job.id, run.lease, stage(prog.phase))?;
                    run.log(self.transient_words(prog.transient.as_ref(), t_now, steady, stopped));
                } else if let Some(c) = check.filter(|_| judged) {
                    // A long wait says, four times a window, which criterion holds it up.
                    let every = |t: f64| (t / (p.steady_window_s / 4.0)).floor();
                    let before = prog.series.iter().rev().nth(1).map(|s| s.t);
                    if before.is_some_and(|b| every(t_now) > every(b)) {
                        run.log(format!(
                            "not steady yet at t = {t_now:.1} s (by {} s at the latest): {}",
                            p.steady_max_time_s,
                            self.criteria(&c)
                        ));
                    }
                }
            }
            Phase::Measuring => {
                let sample = (chunk - prog.measure_start_chunk).is_multiple_of(self.sample_every);
                let stress = chunk.is_multiple_of(STRESS_EVERY);
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
                prog.series.push(FlowSample {
                    t: t_now,
                    ke,
                    vx: flowing.mean_vx(),
                    ratio,
                });
                prog.ledger.numerics.energy.add(t_now, ke);
                if sample {
                    prog.observer
                        .as_mut()
                        .expect("observer exists while measuring")
                        .sample(&snap);
                }
            }
            Phase::Ended => {}
        }
        Ok(Ok(()))
    }

    fn finish(
        &self,
        conn: &mut Connection,
        job: &JobRow,
        ctx: &JobContext,
        prog: Progress,
        t_end: f64,
    ) -> anyhow::Result<()> {
        let p = &self.scene.p;
        let measurement = prog.observer.as_ref().and_then(|_| {
            let window: Vec<FlowSample> = prog
                .series
                .iter()
                .filter(|s| s.t >= prog.measure_start_s - 1e-9)
                .copied()
                .collect();
            let span = window.last()?.t - window.first()?.t;
            check_window(
                &window,
                &SteadySettings::of_chute(p, span),
                prog.detector.tan_alpha(),
            )
        });
        let state = FlowState::judge(
            prog.transient.as_ref(),
            measurement.as_ref(),
            TrendTolerances::of_chute(p),
        );
        let results = prog
            .observer
            .as_ref()
            .filter(|_| state != FlowState::NotFlowing)
            .map(|o| {
                let mut r = o.finish();
                r.summary.steady = state == FlowState::Steady;
                r.summary.steady_time_s = prog.steady_time_s;
                r.summary.steady_stress_ratio = prog.transient.and_then(|c| c.stress_ratio);
                r
            });
        let flow = FlowRecord {
            state,
            measured: results.is_some(),
            min_flow_velocity_m_per_s: p.min_flow_velocity_m_per_s(),
            transient: prog.transient,
            measurement,
        };
        if state != FlowState::Steady {
            (ctx.log)(format!(
                "job {}: recorded as {} ({})",
                job.id,
                state.as_str(),
                state.words()
            ));
        }
        ChuteJobResults {
            results,
            flow,
            series: prog.series,
            wall_time_s: prog.ledger.wall_time_s,
            particle_steps: prog.ledger.particle_steps,
            sim_time_s: t_end,
            dt_s: self.scene.dt,
            numerics: prog.ledger.numerics,
        }
        .commit(conn, job.id)?;
        Ok(())
    }
}
