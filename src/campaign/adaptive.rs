//! What a campaign's target asks next of one point: nothing (met, or capped), its job run on
//! from its checkpoint, or a new replica, whichever buys the point's interval more measurement
//! (blocks) per particle-step. Pure: `runner::adaptive` reads the store, calls this, and records
//! the work.
//!
//! The expectation is the one the pooled interval obeys when blocks are independent: its
//! standard error falls as 1/√W with W the blocks (or seconds) measured at the point. A longer
//! run adds blocks at the cost of its steps alone; a replica also pays its start-up (the part
//! of the run before measuring, and its fill unless another point already filled that seed)
//! but is the only way past a permanent clog, an emptied silo or `max_time_s`.

use super::target::Target;
use crate::observe::fits::{t_975, Pooled, PooledFrom};

/// A point's run as the target sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct RunState {
    pub job_id: i64,
    /// Its end (s), as run or as extended.
    pub end_s: f64,
    /// Why it cannot run on (None: it can).
    pub not_extendable: Option<String>,
}

/// One point of the campaign: its replicas combined, and what more work would cost.
#[derive(Clone, Debug, PartialEq)]
pub struct PointState {
    /// The point's label without its replica index.
    pub label: String,
    /// The replicas combined (None: no replica has an estimate yet).
    pub estimate: Option<Pooled>,
    /// Blocks (or seconds) measured at the point: the pooled weights' sum.
    pub weight: f64,
    /// Weight one more second of a run adds (1/block_s for Q's blocks).
    pub weight_per_s: f64,
    /// The point's runs, replica by replica.
    pub runs: Vec<RunState>,
    /// Particle-steps per simulated second of a run (N/dt).
    pub steps_per_s: f64,
    /// What a new replica costs (particle-steps: its own time, and its fill unless shared)
    /// and the weight it brings.
    pub replica_cost: f64,
    pub replica_weight: f64,
    /// A new replica's own end (s): the point's longest run (at least the campaign file's
    /// time), so that it pools with the replicas already run at a like weight.
    pub replica_end_s: f64,
    /// Extensions are rounded up to this (s): a block, so blocks stay whole.
    pub quantum_s: f64,
}

/// A piece of work for one point.
#[derive(Clone, Debug, PartialEq)]
pub enum Work {
    /// Run job `job_id` on from `from_s` to `to_s`.
    Extend { job_id: i64, from_s: f64, to_s: f64 },
    /// A new replica (its index is the point's next), run to `to_s`.
    Replica { to_s: f64 },
}

/// What the target decides for a point.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    Met,
    Work {
        work: Work,
        /// The point's relative interval now and as expected after the work (None: unknown,
        /// the point has no estimate yet).
        ci_rel_before: Option<f64>,
        ci_rel_expected: Option<f64>,
        /// Particle-steps the work is expected to cost.
        cost: f64,
    },
    /// Short of the target, and no work is allowed: why.
    Capped(String),
}

/// How far below the target a point is aimed, so that the interval's own noise does not leave
/// it just short and cost a whole further round.
const AIM: f64 = 0.9;
/// The shortest extension, in quanta (shorter ones barely move the interval).
const MIN_QUANTA: f64 = 4.0;

/// The relative interval expected after adding `added` weight to a point at `weight`.
fn expected_rel(ci_rel: f64, weight: f64, added: f64) -> f64 {
    ci_rel * (weight / (weight + added)).sqrt()
}

/// Decides the next piece of work for `p` under target `t` (`replicas_run`: replicas the
/// point has, including ones without an estimate).
pub fn decide(p: &PointState, t: &Target) -> Decision {
    let goal = t.ci95_rel();
    let can_replicate = (p.runs.len() as u32) < t.max_replicas;
    let Some(est) = p.estimate.filter(|e| e.ci95_rel().is_finite()) else {
        // Nothing to pool yet (every run clogged before measuring, say): only a replica helps.
        return if can_replicate {
            Decision::Work {
                work: Work::Replica {
                    to_s: p.replica_end_s,
                },
                ci_rel_before: None,
                ci_rel_expected: None,
                cost: p.replica_cost,
            }
        } else {
            Decision::Capped(format!(
                "no estimate after {} replica(s) (max_replicas)",
                p.runs.len()
            ))
        };
    };
    let ci = est.ci95_rel();
    if ci <= goal {
        return Decision::Met;
    }
    // Each option is compared by what one unit of weight (a block) costs through it, so a big
    // extension is not penalised against a small replica for the diminishing returns of its
    // size; the chosen one is then sized (an extension to the aim, a replica as it is).
    let mut options: Vec<(f64, Decision)> = Vec::new();
    // Run on the shortest run that can, far enough that the point is expected to reach the aim.
    let extendable = p
        .runs
        .iter()
        .filter(|r| r.not_extendable.is_none())
        .min_by(|a, b| a.end_s.total_cmp(&b.end_s).then(a.job_id.cmp(&b.job_id)));
    // An interval set by the replicas' spread shrinks only with more replicas.
    let spread = est.from == PooledFrom::ReplicaSpread;
    if let (Some(run), Some(max_s), false) = (extendable, t.max_time_s, spread) {
        let wanted_weight = p.weight * ((ci / (AIM * goal)).powi(2) - 1.0);
        let quanta = (wanted_weight / p.weight_per_s / p.quantum_s)
            .ceil()
            .max(MIN_QUANTA);
        let to_s = (run.end_s + quanta * p.quantum_s).min(max_s);
        if to_s > run.end_s + 1e-9 {
            let dt_s = to_s - run.end_s;
            let cost = dt_s * p.steps_per_s;
            let added = dt_s * p.weight_per_s;
            options.push((
                cost / added,
                Decision::Work {
                    work: Work::Extend {
                        job_id: run.job_id,
                        from_s: run.end_s,
                        to_s,
                    },
                    ci_rel_before: Some(ci),
                    ci_rel_expected: Some(expected_rel(ci, p.weight, added)),
                    cost,
                },
            ));
        }
    }
    if can_replicate && p.replica_weight > 0.0 {
        let r = est.replicas as f64;
        let after = if spread {
            ci * t_975(r) / t_975(r - 1.0) * (r / (r + 1.0)).sqrt()
        } else {
            expected_rel(ci, p.weight, p.replica_weight)
        };
        options.push((
            p.replica_cost / p.replica_weight,
            Decision::Work {
                work: Work::Replica {
                    to_s: p.replica_end_s,
                },
                ci_rel_before: Some(ci),
                ci_rel_expected: Some(after),
                cost: p.replica_cost,
            },
        ));
    }
    // Ties go to the first option: running on (no new seed, no new fill).
    let best = options
        .into_iter()
        .reduce(|a, b| if b.0 < a.0 { b } else { a });
    match best {
        Some((_, d)) => d,
        None => {
            let why_not_longer = match (extendable, t.max_time_s) {
                (_, None) => "no max_time_s".to_string(),
                (None, _) => p
                    .runs
                    .iter()
                    .filter_map(|r| r.not_extendable.clone())
                    .next()
                    .unwrap_or_else(|| "no run to extend".into()),
                (Some(_), Some(m)) if !spread => format!("max_time_s = {m} s reached"),
                (Some(_), Some(_)) => "the replicas' spread sets the interval".into(),
            };
            Decision::Capped(format!(
                "{} replica(s) (max_replicas) and {why_not_longer}",
                p.runs.len()
            ))
        }
    }
}

/// What a point is expected to need before its target holds (or a cap stops it).
#[derive(Clone, Debug, PartialEq)]
pub struct Forecast {
    /// Simulated seconds of running on, and replicas to add.
    pub extend_s: f64,
    pub replicas: u32,
    /// Particle-steps of all that work.
    pub particle_steps: f64,
    /// Rounds it takes.
    pub rounds: u32,
    /// The relative interval expected at the end, and whether it meets the target.
    pub ci_rel: Option<f64>,
    pub met: bool,
    /// Why it stops short (None when met).
    pub capped: Option<String>,
}

/// Plays the target's rounds forward on `p`, each piece of work taken at its expected effect,
/// for `rounds_left` rounds at most: the work the point is expected to need.
pub fn forecast(p: &PointState, t: &Target, rounds_left: u32) -> Forecast {
    let mut p = p.clone();
    let mut f = Forecast {
        extend_s: 0.0,
        replicas: 0,
        particle_steps: 0.0,
        rounds: 0,
        ci_rel: p.estimate.map(|e| e.ci95_rel()),
        met: false,
        capped: None,
    };
    loop {
        if f.rounds >= rounds_left {
            f.capped = Some(format!("max_rounds = {} reached", t.max_rounds));
            return f;
        }
        match decide(&p, t) {
            Decision::Met => {
                f.met = true;
                return f;
            }
            Decision::Capped(why) => {
                f.capped = Some(why);
                return f;
            }
            Decision::Work {
                work,
                ci_rel_expected,
                cost,
                ..
            } => {
                f.rounds += 1;
                f.particle_steps += cost;
                match work {
                    Work::Extend {
                        job_id,
                        from_s,
                        to_s,
                    } => {
                        f.extend_s += to_s - from_s;
                        p.weight += (to_s - from_s) * p.weight_per_s;
                        if let Some(r) = p.runs.iter_mut().find(|r| r.job_id == job_id) {
                            r.end_s = to_s;
                        }
                    }
                    Work::Replica { to_s } => {
                        f.replicas += 1;
                        p.weight += p.replica_weight;
                        p.runs.push(RunState {
                            job_id: -(p.runs.len() as i64) - 1,
                            end_s: to_s,
                            not_extendable: None,
                        });
                    }
                }
                // Without an estimate the first replica's effect is unknown: stop there.
                let (Some(rel), Some(mut e)) = (ci_rel_expected, p.estimate) else {
                    f.capped = Some("no estimate yet: known after the next round".into());
                    return f;
                };
                e.ci95 = rel * e.mean.abs();
                p.estimate = Some(e);
                f.ci_rel = Some(rel);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn target() -> Target {
        Target {
            q_ci95_rel: Some(0.03),
            d_ci95_rel: None,
            max_replicas: 3,
            max_time_s: Some(20.0),
            max_rounds: 8,
            claims: None,
            max_core_hours: None,
            max_particle_steps: None,
            allocation: Default::default(),
        }
    }

    fn point(ci_rel: f64, runs: Vec<RunState>) -> PointState {
        PointState {
            label: "p".into(),
            estimate: Some(Pooled {
                mean: 1.0,
                ci95: ci_rel,
                se: ci_rel / 2.0,
                dof: 7.0,
                replicas: runs.len(),
                from: PooledFrom::Blocks,
            }),
            weight: 8.0,
            weight_per_s: 4.0,
            runs,
            steps_per_s: 1e6,
            replica_cost: 3e6,
            replica_weight: 8.0,
            replica_end_s: 2.5,
            quantum_s: 0.25,
        }
    }

    fn run(id: i64, end_s: f64) -> RunState {
        RunState {
            job_id: id,
            end_s,
            not_extendable: None,
        }
    }

    #[test]
    fn a_forecast_plays_the_rounds_to_the_target() {
        let f = forecast(&point(0.06, vec![run(1, 2.5)]), &target(), 8);
        assert!(f.met, "{f:?}");
        assert!((f.extend_s - 8.0).abs() < 1e-9 && f.replicas == 0, "{f:?}");
        assert!((f.particle_steps - 8e6).abs() < 1e-3, "{f:?}");
        let f = forecast(&point(0.2, vec![run(1, 2.5)]), &target(), 8);
        assert!(!f.met && f.capped.is_some() && f.replicas == 2, "{f:?}");
    }

    #[test]
    fn a_met_point_gets_no_work() {
        assert_eq!(
            decide(&point(0.029, vec![run(1, 2.5)]), &target()),
            Decision::Met
        );
    }

    #[test]
    fn a_wide_point_runs_on_far_enough_to_reach_the_aim() {
        let d = decide(&point(0.06, vec![run(1, 2.5)]), &target());
        let Decision::Work {
            work:
                Work::Extend {
                    job_id,
                    from_s,
                    to_s,
                },
            ci_rel_expected: Some(after),
            ..
        } = d
        else {
            panic!("{d:?}")
        };
        assert_eq!((job_id, from_s), (1, 2.5));
        // (0.06 / 0.027)² = 4.94: 8 blocks → 39.5, i.e. 31.5 more = 7.9 s → 8 s.
        assert!((to_s - 10.5).abs() < 1e-9, "{to_s}");
        assert!(after <= 0.9 * 0.03 + 1e-12, "{after}");
    }

    #[test]
    fn a_capped_run_makes_way_for_a_replica() {
        let mut r = run(1, 20.0);
        r.not_extendable = None;
        let d = decide(&point(0.06, vec![r]), &target());
        assert!(
            matches!(
                d,
                Decision::Work {
                    work: Work::Replica { .. },
                    ..
                }
            ),
            "{d:?}"
        );
        let mut clogged = run(1, 4.0);
        clogged.not_extendable = Some("clogged for good".into());
        let d = decide(&point(0.06, vec![clogged]), &target());
        assert!(
            matches!(
                d,
                Decision::Work {
                    work: Work::Replica { .. },
                    ..
                }
            ),
            "{d:?}"
        );
    }

    #[test]
    fn with_every_cap_reached_the_point_says_why() {
        let runs = vec![run(1, 20.0), run(2, 20.0), run(3, 20.0)];
        match decide(&point(0.06, runs), &target()) {
            Decision::Capped(why) => assert!(why.contains("max_time_s"), "{why}"),
            d => panic!("{d:?}"),
        }
    }

    #[test]
    fn an_interval_set_by_the_replicas_spread_asks_for_a_replica() {
        let mut p = point(0.06, vec![run(1, 2.5), run(2, 2.5), run(3, 2.5)]);
        p.estimate = p.estimate.map(|e| Pooled {
            from: PooledFrom::ReplicaSpread,
            ..e
        });
        let mut t = target();
        t.max_replicas = 4;
        assert!(
            matches!(
                decide(&p, &t),
                Decision::Work {
                    work: Work::Replica { .. },
                    ..
                }
            ),
            "{:?}",
            decide(&p, &t)
        );
    }

    #[test]
    fn without_an_estimate_only_a_replica_helps() {
        let mut p = point(0.06, vec![run(1, 2.5)]);
        p.estimate = None;
        assert!(matches!(
            decide(&p, &target()),
            Decision::Work {
                work: Work::Replica { .. },
                ci_rel_before: None,
                ..
            }
        ));
    }
}
