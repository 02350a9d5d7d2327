//! `sweep plan FILE`: each job's effects and estimated cost, without running anything. Wall
//! times come from this machine's `sweep bench` results in the database.

use std::collections::BTreeSet;

use sweep::campaign::SceneKind;
use sweep::engine::Effects;
use sweep::project::{JobRateQuery, Project, RateQuery, StoredJob};
use sweep::scene::silo::{SiloPhase, SiloScene};
use sweep::scene::ChuteScene;

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// Campaign file (JSON).
    pub file: std::path::PathBuf,
    #[command(flatten)]
    pub db: DbArg,
    /// Engine threads per job the estimate assumes (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Where the jobs without a backend of their own will run: cpu, or gpu (estimated from
    /// `sweep bench --backend gpu`; a campaign launched with --backend auto on a machine with a
    /// hardware GPU runs its f32 jobs there).
    #[arg(long, default_value = "cpu", value_parser = ["cpu", "gpu"])]
    pub backend: String,
    /// Also write each sphere chute job's scene (its initial state, law, gravity, dt, box) as a
    /// LAMMPS data file and input, in DIR/job-K (K as numbered here), running the job's longest
    /// time; `scripts/compare-lammps-chute.sh` runs both codes from it.
    #[arg(long, value_name = "DIR")]
    pub lammps: Option<std::path::PathBuf>,
    /// A line for every job, however many (by default the first 20 of a campaign of more than
    /// 200 jobs).
    #[arg(long)]
    pub all_jobs: bool,
}

/// Up to this many jobs, the plan has a line per job; above, the first `FIRST_LINES`.
const LINE_PER_JOB_UP_TO: usize = 200;
const FIRST_LINES: usize = 20;

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    let (file, jobs) = match sweep::campaign::load(&a.file) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("sweep: error: {e}");
            return Ok(2);
        }
    };
    if a.lammps.is_some() && file.scene != SceneKind::Chute {
        eprintln!("sweep: error: --lammps writes chute jobs; {} is a silo campaign (see `sweep bench --lammps`)", a.file.display());
        return Ok(2);
    }
    let threads = if a.threads > 0 {
        a.threads
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    };
    let (bench_scene, settled) = bench_scene_of(&file, &jobs);
    let project = if a.db.db.exists() {
        Some(Project::open(&a.db.db)?)
    } else {
        None
    };
    let mut rates = Rates {
        project: project.as_ref(),
        scene: bench_scene,
        settled: settled.as_deref().unwrap_or(bench_scene).to_string(),
        default_backend: a.backend.clone(),
        threads,
        found: Default::default(),
        measured: Default::default(),
    };
    let source = match settled {
        Some(_) => {
            format!("`sweep bench --scene {bench_scene} --settle` (else `--scene {bench_scene}`)")
        }
        None => format!("`sweep bench --scene {bench_scene}`"),
    };
    println!(
        "campaign {}: {} job(s), {} thread(s) per CPU job; throughput from {source} results in {} (the bench nearest each job's N)",
        file.name,
        jobs.len(),
        threads,
        a.db.db.display()
    );
    let mut total_wall = Some(0.0);
    let mut fills = BTreeSet::new();
    let mut total_ps = 0.0;
    println!(
        "{:>4}  {:>10} {:>8} {:>10} {:>12} {:>10}  parameters",
        "job", "dt_s", "N", "steps", "particle-st", "wall_s"
    );
    // A campaign of many jobs gets the first lines only. Replicas of one point share its scene
    // and its cost: each point is costed once, for all its replicas.
    let lines = if jobs.len() <= LINE_PER_JOB_UP_TO || a.all_jobs {
        jobs.len()
    } else {
        FIRST_LINES
    };
    let replicas = jobs.replicas() as usize;
    let mut in_store = InStore::default();
    // Each point's bench rate (the bench nearest its N), for the target's forecast.
    let mut bench_rates = std::collections::HashMap::new();
    for (p, point) in jobs.points().iter().enumerate() {
        let cost = match point.scene {
            SceneKind::Chute => chute_cost(point)?,
            // The fill stage is shared by jobs with the same fill parameters (other replicas
            // have their own): count it once.
            SceneKind::Silo => silo_cost(point, fills.insert(point.fill_key().0))?,
        };
        total_ps += cost.particle_steps * replicas as f64;
        let rate = rates.of(point);
        if let Some(r) = rate {
            bench_rates.insert(
                sweep::campaign::label_without_replica(&point.replica(0).label),
                r,
            );
        }
        total_wall = total_wall
            .zip(rate)
            .map(|(w, r)| w + cost.particle_steps / r * replicas as f64);
        let wall = rate.map_or("?".to_string(), |r| {
            format!("{}{:.0}", cost.at_most, cost.particle_steps / r)
        });
        for r in 0..replicas {
            let k = p * replicas + r;
            if k == lines {
                println!(
                    "      … and {} more job(s), counted in the total: `--all-jobs` lists every one",
                    jobs.len() - lines
                );
            }
            // Past the listed lines a job is only looked up in the store (or exported).
            if k >= lines && a.lammps.is_none() && project.is_none() {
                break;
            }
            let j = point.replica(jobs.replica_index(r as u32));
            let stored = match &project {
                Some(p) => p.job_by_hash(&j.hash())?,
                None => None,
            };
            in_store.add(stored.as_ref(), cost.particle_steps);
            if k < lines {
                println!(
                    "{:>4}  {:>10.3e} {:>8} {:>10.0} {:>12.3e} {:>10}  {}{}",
                    k + 1,
                    cost.dt,
                    j.particle_count(),
                    cost.steps,
                    cost.particle_steps,
                    wall,
                    j.label,
                    stored.as_ref().map_or(String::new(), stored_note)
                );
            }
            if k == 0 {
                println!(
                    "      effects: {}",
                    serde_json::to_string(&effects_of(&j)?)?
                );
            }
            if let (Some(dir), SceneKind::Chute) = (&a.lammps, j.scene) {
                let run = sweep::lammps::chute::ChuteRun::of(&j);
                let input =
                    sweep::lammps::chute::export(&j, run, &dir.join(format!("job-{}", k + 1)))?;
                println!("      LAMMPS: {}", input.display());
            }
        }
    }
    println!(
        "total: {:.3e} particle-steps{}",
        total_ps,
        total_wall.map_or(String::new(), |w| format!(
            ", about {:.1} h on this machine with one job at a time ({:.0} s)",
            w / 3600.0,
            w
        ))
    );
    in_store.print(jobs.len());
    let caps = file.target.as_ref().filter(|t| t.decides_claims());
    let over_hours = caps
        .and_then(|t| t.max_core_hours)
        .zip(total_wall.map(|w| w * threads as f64 / 3600.0))
        .filter(|(cap, h)| h > cap)
        .map(|(cap, h)| format!("{h:.1} core-hours, over the target's max_core_hours {cap}"));
    let over_steps = caps
        .and_then(|t| t.max_particle_steps)
        .filter(|&cap| total_ps > cap)
        .map(|cap| {
            format!("{total_ps:.3e} particle-steps, over the target's max_particle_steps {cap:.3e}")
        });
    for over in over_hours.into_iter().chain(over_steps) {
        println!(
            "note: these jobs alone forecast {over}: they run in full, since the caps stop only the rounds a look would add"
        );
    }
    if let Some(t) = &file.target {
        // The first round is the jobs above; what follows depends on the measured scatter.
        target_forecast(project.as_ref(), &file.name, t, &bench_rates)?;
    } else if !file.claims.is_empty() {
        super::plan_claims::claims_forecast(
            project.as_ref(),
            &file.name,
            &sweep::campaign::Target::claims_looked_at_once(),
        )?;
    }
    rates.print_missing();
    Ok(0)
}

/// The campaign's jobs that the store already holds (by their parameters: another campaign's
/// job with the same parameters is the same job, run once), and the work still left of all.
#[derive(Default)]
struct InStore {
    ids: Vec<i64>,
    ended: usize,
    left_particle_steps: f64,
}

impl InStore {
    fn add(&mut self, stored: Option<&StoredJob>, planned_particle_steps: f64) {
        let Some(s) = stored else {
            self.left_particle_steps += planned_particle_steps;
            return;
        };
        self.ids.push(s.id);
        if matches!(s.status.as_str(), "done" | "failed") {
            self.ended += 1;
        } else {
            self.left_particle_steps += (planned_particle_steps - s.particle_steps as f64).max(0.0);
        }
    }

    fn print(&self, jobs: usize) {
        if self.ids.is_empty() {
            return;
        }
        println!(
            "in this store: {} of {jobs} job(s) already (job(s) {}), {} of them ended; still to run: at most {:.3e} particle-steps",
            self.ids.len(),
            id_ranges(&self.ids),
            self.ended,
            self.left_particle_steps
        );
    }
}

/// ` [job 14: running, 100.5 of 420.0 s]`: where a planned job stands in the store.
fn stored_note(s: &StoredJob) -> String {
    format!(
        "  [job {}: {}, {:.1} of {:.1} s]",
        s.id, s.status, s.sim_time_s, s.target_time_s
    )
}

/// `14-16, 20`: sorted ids with runs of consecutive ones joined.
fn id_ranges(ids: &[i64]) -> String {
    let mut ids = ids.to_vec();
    ids.sort_unstable();
    ids.dedup();
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < ids.len() {
        let mut k = i;
        while k + 1 < ids.len() && ids[k + 1] == ids[k] + 1 {
            k += 1;
        }
        parts.push(if k == i {
            ids[i].to_string()
        } else {
            format!("{}-{}", ids[i], ids[k])
        });
        i = k + 1;
    }
    parts.join(", ")
}

/// The bench scene that resembles the campaign's, and the name of its settled bed: a settled
/// Hertz bed for the silo (the random bed of `--settle` where there is one, else the lattice
/// start), flowing spherocylinders over a rough base for the chute (flowing spheres, chute-bed,
/// when every job is ξ = 1: those run on the sphere engine).
fn bench_scene_of(
    file: &sweep::campaign::CampaignFile,
    jobs: &sweep::campaign::Jobs,
) -> (&'static str, Option<String>) {
    match file.scene {
        SceneKind::Silo => ("silo-bed", sweep::bench::settled_name("silo-bed")),
        SceneKind::Chute if jobs.points().iter().all(|j| j.chute().spheres()) => {
            ("chute-bed", None)
        }
        SceneKind::Chute => ("chute-rods", None),
    }
}

/// Each job's throughput from the newest bench of its scene, engine and precision (a job
/// without a fixed backend is estimated on `--backend`, the CPU by default, where `auto` puts
/// it without a hardware GPU); the GPU's rate does not depend on CPU threads.
struct Rates<'a> {
    project: Option<&'a Project>,
    scene: &'static str,
    settled: String,
    default_backend: String,
    threads: usize,
    /// By (backend, precision, N): the rate found, or None.
    found: std::collections::BTreeMap<(String, String, i64), Option<f64>>,
    /// By (backend, precision): rates taken from the store's own done jobs (no bench fits),
    /// with how many jobs.
    measured: std::collections::BTreeMap<(String, String), usize>,
}

impl Rates<'_> {
    fn of(&mut self, j: &sweep::campaign::JobSpec) -> Option<f64> {
        let backend = j
            .backend
            .map_or(self.default_backend.as_str(), |b| b.name())
            .to_string();
        let precision = j.precision.name().to_string();
        let (project, scene, settled, threads) =
            (self.project, self.scene, &self.settled, self.threads);
        let particles = match j.scene {
            SceneKind::Chute => j.chute().count() as i64,
            SceneKind::Silo => j.silo().particle_count as i64,
        };
        let key = (backend.clone(), precision.clone(), particles);
        if let Some(r) = self.found.get(&key) {
            return *r;
        }
        let bench = project.and_then(|p| {
            p.newest_rate(&RateQuery {
                scene,
                settled_scene: settled,
                backend: &backend,
                precision: &precision,
                threads: threads as i64,
                particles,
            })
        });
        // Without a bench, the store's own finished jobs of the scene say what it runs at.
        let measured = bench.is_none().then(|| {
            project?.measured_rate(&JobRateQuery {
                scene: if scene == "silo-bed" { "silo" } else { "chute" },
                spheres: (scene != "silo-bed").then_some(scene == "chute-bed"),
                backend: &backend,
                precision: &precision,
                threads: threads as i64,
            })
        });
        let rate = bench.or_else(|| {
            let (r, n) = measured.flatten()?;
            self.measured.insert((key.0.clone(), key.1.clone()), n);
            Some(r)
        });
        self.found.insert(key, rate);
        rate
    }

    /// The bench to run for each engine and precision that had no rate.
    fn print_missing(&self) {
        let (bench_scene, threads) = (self.scene, self.threads);
        // A bench of any N serves every N: one line per engine and precision.
        let mut said = BTreeSet::new();
        for ((backend, precision, _), r) in &self.found {
            if !said.insert((backend, precision)) {
                continue;
            }
            if let (Some(r), Some(n)) =
                (r, self.measured.get(&(backend.clone(), precision.clone())))
            {
                println!(
                    "wall times for {backend}/{precision}: the median rate of this store's {n} done job(s) of the scene, {r:.3e} particle-steps/s (per CPU second where a one-thread job counted it; no `sweep bench --scene {bench_scene}` result)"
                );
            } else if r.is_none() {
                println!(
                    "no `sweep bench` result for {bench_scene}/{backend}/{precision}{}: run `sweep bench --scene {bench_scene} --backend {backend} --precision {precision}{}` for wall-time estimates (\"?\" above)",
                    if backend == "cpu" { format!("/{threads} threads") } else { String::new() },
                    if backend == "cpu" { format!(" --threads {threads}") } else { String::new() },
                );
            }
        }
    }
}

/// What one job of a point costs: its time step, steps and particle-steps.
struct JobCost {
    dt: f64,
    steps: f64,
    particle_steps: f64,
    /// "≤" where the cost is a bound (a chute job may stop once steady).
    at_most: &'static str,
}

/// A chute job at most: the longest wait for the steady state plus the measurement.
fn chute_cost(j: &sweep::campaign::JobSpec) -> anyhow::Result<JobCost> {
    let scene = ChuteScene::new(j.chute().clone()).map_err(|e| anyhow::anyhow!(e))?;
    let steps = (j.chute().max_time_s() / scene.dt).ceil();
    Ok(JobCost {
        dt: scene.dt,
        steps,
        particle_steps: j.chute().count() as f64 * steps,
        at_most: "≤",
    })
}

/// A silo job: its fill (where `own_fill`: not shared with an earlier job) and its discharge.
fn silo_cost(j: &sweep::campaign::JobSpec, own_fill: bool) -> anyhow::Result<JobCost> {
    let dt = SiloScene::new(j.silo().clone())
        .map_err(|e| anyhow::anyhow!(e))?
        .dt;
    let steps_discharge = (j.silo().discharge_time_s / dt).ceil();
    let fill = if own_fill {
        (j.silo().settle_max_time_s.min(1.0) / dt).ceil()
    } else {
        0.0
    };
    // Without re-insertion the silo empties towards `stop_remaining_fraction`: on average
    // about the mean of the start and the end counts are simulated.
    let n = j.silo().particle_count as f64;
    let n_mean = if j.silo().reinsert {
        n
    } else {
        n * (1.0 + j.silo().stop_remaining_fraction.max(0.5)) / 2.0
    };
    Ok(JobCost {
        dt,
        steps: fill + steps_discharge,
        particle_steps: n * fill + n_mean * steps_discharge,
        at_most: "",
    })
}

/// What the engine computes for a job (printed once, under the first job).
fn effects_of(j: &sweep::campaign::JobSpec) -> anyhow::Result<Effects> {
    Ok(match j.scene {
        SceneKind::Chute => {
            let scene = ChuteScene::new(j.chute().clone()).map_err(|e| anyhow::anyhow!(e))?;
            Effects::of(&scene.engine_config(), true, !j.chute().spheres())
        }
        SceneKind::Silo => {
            let scene = SiloScene::new(j.silo().clone()).map_err(|e| anyhow::anyhow!(e))?;
            Effects::of(&scene.engine_config(SiloPhase::Discharge), false, false)
        }
    })
}

/// What each point of a campaign with a target is expected to need still, from the jobs of it
/// already in the database: their measured scatter and throughput (where a point has not run
/// yet, the `sweep bench` rate nearest its N, by point label).
fn target_forecast(
    project: Option<&Project>,
    name: &str,
    t: &sweep::campaign::Target,
    bench_rates: &std::collections::HashMap<String, f64>,
) -> anyhow::Result<()> {
    use sweep::campaign::adaptive::forecast;
    if t.decides_claims() {
        return super::plan_claims::claims_forecast(project, name, t);
    }
    println!(
        "target: {} <= ±{:.1} % at every point (max_replicas {}, max_time_s {}, max_rounds {})",
        if t.q_ci95_rel.is_some() {
            "Q's 95 % CI"
        } else {
            "D's 95 % CI"
        },
        100.0 * t.ci95_rel(),
        t.max_replicas,
        t.max_time_s
            .map_or_else(|| "none".into(), |m| format!("{m} s")),
        t.max_rounds
    );
    let Some((_, ev)) = super::plan_claims::stored_evaluation(
        project,
        name,
        t,
        "the work after the jobs above depends on the scatter they measure: launch it, then `sweep plan` again for the rest",
        "the estimate uses",
    )?
    else {
        return Ok(());
    };
    let rounds_left = ev.target.max_rounds.saturating_sub(ev.rounds_done);
    let (mut total_ps, mut total_wall) = (0.0, Some(0.0));
    println!(
        "  {:<48} {:>9} {:>9} {:>9} {:>8} {:>11} {:>9}  outcome",
        "point", "CI now", "expected", "+time_s", "+replic", "+part-steps", "wall_s"
    );
    for p in &ev.points {
        let f = forecast(&p.state, &ev.target, rounds_left);
        let rate = p.rate.or_else(|| bench_rates.get(&p.state.label).copied());
        total_ps += f.particle_steps;
        total_wall = total_wall.zip(rate).map(|(w, r)| w + f.particle_steps / r);
        let pct =
            |v: Option<f64>| v.map_or_else(|| "n/a".into(), |x| format!("±{:.1} %", 100.0 * x));
        println!(
            "  {:<48} {:>9} {:>9} {:>9.2} {:>8} {:>11.3e} {:>9}  {}",
            p.state.label,
            pct(p.state.estimate.map(|e| e.ci95_rel())),
            pct(f.ci_rel),
            f.extend_s,
            f.replicas,
            f.particle_steps,
            rate.map_or_else(|| "?".into(), |r| format!("{:.0}", f.particle_steps / r)),
            if f.met {
                "met".to_string()
            } else {
                f.capped.unwrap_or_default()
            }
        );
    }
    println!(
        "  still to run: {total_ps:.3e} particle-steps{}",
        total_wall.map_or_else(String::new, |w| format!(
            ", about {:.0} s of one job's throughput here (the jobs' own rate, measured; divide by the jobs run side by side)",
            w
        ))
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::id_ranges;

    #[test]
    fn ids_read_as_ranges() {
        assert_eq!(id_ranges(&[16, 14, 15, 20, 22, 21, 3]), "3, 14-16, 20-22");
        assert_eq!(id_ranges(&[7]), "7");
    }
}
