//! A claims target, one look at a time: once every job of the campaign has ended, each claim is
//! decided on the pooled results (`observe::claims`) at the look's level (α split over the
//! campaign's looks), the verdicts are stored, and for the undecided claims the next round of
//! work is registered: on the points whose uncertainty most keeps a claim undecided, per
//! particle-step, cheapest decision first ("adaptive"), or every point run on equally
//! ("uniform", the design the adaptive rounds are measured against). Decisions read only
//! finished results and seeded draws, so a killed and resumed campaign takes the same rounds.

use std::collections::BTreeSet;

use anyhow::Result;
use rusqlite::{Connection, TransactionBehavior};

use crate::campaign::adaptive::{decide as decide_work, Decision, PointState, Work};
use crate::campaign::claims::scene_results;
use crate::campaign::{Allocation, JobSpec, Target};
use crate::observe::claims::{
    decide, seed_of, spending_level, work_to_decide, Claim, Decision as Verdictum, PointData,
    Statistic, Verdict, ALPHA,
};
use crate::observe::fits::{Pooled, PooledFrom};
use crate::store::claims::{self, VerdictRow};
use crate::store::looks;
use crate::store::targets::WorkRow;

use super::claim_points::claim_points;
use super::claim_reach::{
    forecast_steps, out_of_reach, point_steady_share, steps_left, within_budget,
};
use super::claim_replicas::{after_replicas, cut_short, replicas_for_goal, replicas_to_add};
use super::evaluation::{register_work, Evaluation};

/// The smallest fraction of a point's variance one round aims to keep (a round at most
/// quadruples the point's measurement).
const MIN_KEEP: f64 = 0.25;

/// What the campaign has spent so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spent {
    pub particle_steps: f64,
    pub wall_s: f64,
    pub core_hours: f64,
}

impl Spent {
    /// (particle-steps, wall s, core-hours), as the store keeps them.
    pub fn triple(self) -> (f64, f64, f64) {
        (self.particle_steps, self.wall_s, self.core_hours)
    }
}

/// One look of a claims target and what followed it.
#[derive(Clone, Debug)]
pub struct ClaimsRound {
    /// The look (0: after the campaign's own jobs; k: after round k).
    pub look: u32,
    pub verdicts: Vec<VerdictRow>,
    /// The work added as round `look + 1` (empty: the campaign stops here).
    pub work: Vec<WorkRow>,
    /// Why no more work is added (None while working).
    pub stop: Option<String>,
    /// What the caps left out of the work added (a point capped, replicas cut short).
    pub limited: Vec<String>,
    /// A recorded look's claims whose data read today differ from the record (`Look::reread`).
    pub reread: Vec<String>,
    pub spent: Spent,
    /// The target's caps as text after what was spent (`Target::budget_words`).
    pub budget_words: (String, String),
}

/// The claims of a campaign decided at one look.
pub struct Look {
    pub look: u32,
    pub points: Vec<PointData>,
    pub claims: Vec<(Claim, Verdict, VerdictRow)>,
    pub spent: Spent,
    /// The campaign's throughput so far (particle-steps per wall second of its jobs).
    pub rate: Option<f64>,
    /// Earlier looks (of this version or earlier ones) spent all of every claim's α: nothing
    /// can be decided.
    pub no_alpha_left: bool,
    /// Claims of a look already recorded whose data read today give another reading: the
    /// record stands (`claims::recorded`), these lines say what changed.
    pub reread: Vec<String>,
}

/// Decides every claim of `ev`'s campaign on its finished results, without storing anything.
/// With `keep_recorded` a look already recorded on the same data stands (`claims::recorded`);
/// a dry run (`sweep plan` with another target) reads the data afresh.
///
/// # Errors
/// Database errors.
pub fn look(
    conn: &Connection,
    campaign_id: i64,
    ev: &Evaluation,
    keep_recorded: bool,
) -> Result<Look> {
    let (points, constants) = claim_points(conn, campaign_id, ev)?;
    let look = ev.look();
    let (steps, wall, core_hours) = claims::spent(conn, campaign_id)?;
    let rate = (wall > 0.0).then_some(steps / wall);
    let results = scene_results(ev.file.scene);
    // A claim decided at an earlier look of this campaign or an earlier version of it stays
    // decided (`kept_decision`), and a look already recorded stands (`recorded`).
    let decided = crate::store::claims::first_decisions(conn, campaign_id, look)?;
    let stored = if keep_recorded {
        claims::look_rows(conn, campaign_id, look)?
    } else {
        Default::default()
    };
    let mut reread = Vec::new();
    let mut out = Vec::new();
    let mut any_alpha_left = false;
    for (k, claim) in ev.file.claims.iter().enumerate() {
        // Each claim spends α only at the looks that tested it: a look where one of its
        // results was missing could not decide it, so it risked no false verdict.
        let before = looks::claim_levels_before(conn, campaign_id, &claim.id, look)?;
        let spending = spending_level(ev.looks(), look, ev.carried.alpha, &before);
        any_alpha_left |= spending.is_some();
        // No α left (earlier looks spent it): the claim is shown, not decided.
        let level = spending.unwrap_or(1.0);
        let path = format!("claims[{k}]");
        let test = claim.tests().first().map_or("none", |t| t.name());
        // `work`: the multiple of its points' work that would decide it, if it can be said.
        let (v, work) = match Statistic::resolve(claim, &path, &points, results, constants) {
            Ok(_) if spending.is_none() => (
                Verdict {
                    note: format!(
                        "no error rate left: the {} earlier look(s) spent α = {ALPHA}",
                        look
                    ),
                    ..Verdict::undecided(level, test)
                },
                None,
            ),
            Ok(stat) => {
                let seed = seed_of(&ev.file.name, &claim.id, look);
                let v = decide(&stat, &points, level, seed);
                let k = (v.decision == Verdictum::Undecided && v.lo.is_finite())
                    .then(|| work_to_decide(&stat, &points, level, seed))
                    .flatten();
                (v, k)
            }
            Err(e) => (
                Verdict {
                    note: format!("{}: {}", e.field, e.message),
                    ..Verdict::undecided(level, test)
                },
                None,
            ),
        };
        let used_steps: f64 = v.points.iter().map(|&i| points[i].particle_steps).sum();
        let used_wall: f64 = v
            .points
            .iter()
            .map(|&i| {
                ev.points[i]
                    .rate
                    .map_or(0.0, |r| points[i].particle_steps / r)
            })
            .sum();
        let forecast = (v.decision == Verdictum::Undecided)
            .then(|| forecast_steps(&v, work, &points, ev))
            .flatten();
        let row = VerdictRow {
            round: look,
            claim_id: claim.id.clone(),
            statement: claim.statement.clone(),
            paper: claim.paper.clone(),
            paper_value: claim.paper_value.clone(),
            test: test.into(),
            what: v.what.clone(),
            verdict: v.decision.name().into(),
            value: Some(v.value),
            lo: Some(v.lo),
            hi: Some(v.hi),
            level,
            bound: v.side.text(),
            points: v
                .points
                .iter()
                .map(|&i| points[i].label.clone())
                .collect::<Vec<_>>()
                .join("; "),
            note: v.note.clone(),
            particle_steps: used_steps,
            wall_s: used_wall,
            forecast_particle_steps: forecast,
            forecast_wall_s: forecast.and_then(|s| rate.map(|r| s / r)),
        };
        let (v, row) = match crate::store::claims::standing(&decided, &row) {
            Some(first) => {
                let kept = crate::store::claims::kept_decision(first, &row);
                let decision = Verdictum::parse(&kept.verdict).unwrap_or(v.decision);
                (Verdict { decision, ..v }, kept)
            }
            None => (v, row),
        };
        // A recorded look is met again only after its campaign stopped there; if a raised cap
        // lets the rounds go on, their work is sized on today's reading of the claims the
        // record leaves undecided, and the next look reads everything afresh.
        let (v, row) = match stored.get(&claim.id) {
            Some(before) => {
                let (kept, line) = claims::recorded(before, &row);
                reread.extend(line);
                let decision = Verdictum::parse(&kept.verdict).unwrap_or(v.decision);
                (Verdict { decision, ..v }, kept)
            }
            None => (v, row),
        };
        out.push((claim.clone(), v, row));
    }
    Ok(Look {
        look,
        points,
        claims: out,
        spent: Spent {
            particle_steps: steps,
            wall_s: wall,
            core_hours,
        },
        rate,
        no_alpha_left: !any_alpha_left,
        reread,
    })
}

/// Work for one point: a target whose interval goal for the point is `goal` (relative), under
/// the campaign target's caps.
fn work_for(state: &PointState, target: &Target, goal: f64) -> Decision {
    let t = Target {
        q_ci95_rel: Some(goal),
        d_ci95_rel: None,
        ..target.clone()
    };
    decide_work(state, &t)
}

/// A chute point's claim results are replica means: only replicas shrink their intervals.
fn as_claims_see_it(state: &PointState, chute: bool) -> PointState {
    let mut s = state.clone();
    if chute {
        s.estimate = s.estimate.map(|e| Pooled {
            from: PooledFrom::ReplicaSpread,
            ..e
        });
    }
    s
}

/// The adaptive round: for each undecided claim within reach of the budget (`claim_reach`),
/// cheapest forecast first, the points whose share of the claim's variance per particle-step is
/// largest get work sized so the claim's interval is expected to clear its bound.
fn adaptive_work(l: &Look, ev: &Evaluation) -> (Vec<(Decision, JobSpec, String)>, Vec<String>) {
    let chute = ev.file.scene == crate::campaign::SceneKind::Chute;
    let mut order: Vec<usize> = (0..l.claims.len())
        .filter(|&k| l.claims[k].1.decision == Verdictum::Undecided)
        .collect();
    let cost = |k: usize| {
        l.claims[k]
            .2
            .forecast_particle_steps
            .unwrap_or(f64::INFINITY)
    };
    order.sort_by(|a, b| cost(*a).total_cmp(&cost(*b)).then(a.cmp(b)));
    let mut taken = BTreeSet::new();
    let mut planned = Vec::new();
    let mut capped = Vec::new();
    let left = steps_left(
        l.spent.particle_steps,
        l.spent.core_hours,
        ev.target.max_core_hours,
        ev.target.max_particle_steps,
    );
    for k in order {
        let (claim, v, row) = &l.claims[k];
        if let Some(why) = out_of_reach(&claim.id, row.forecast_particle_steps, left) {
            capped.push(why);
            continue;
        }
        let mut chosen: Vec<(usize, f64)> = Vec::new();
        if v.lo.is_finite() && v.hi.is_finite() {
            let total: f64 = v.variance_by_point.iter().map(|p| p.1).sum();
            let (gap, half) = (v.gap(), v.half_width());
            // On the bound: more work cannot be sized; give the noisiest point one doubling.
            let reduce = if gap > 0.0 && half > 0.0 {
                total * (1.0 - (gap / half).powi(2).min(1.0))
            } else {
                0.5 * total
            };
            let per_step = |&(i, var): &(usize, f64)| {
                let s = &ev.points[i].state;
                var / (s.steps_per_s / s.weight_per_s.max(1e-300))
            };
            let mut by_value = v.variance_by_point.clone();
            by_value.sort_by(|a, b| per_step(b).total_cmp(&per_step(a)).then(a.0.cmp(&b.0)));
            let mut acc = 0.0;
            for (i, var) in by_value {
                if var <= 0.0 {
                    continue;
                }
                chosen.push((i, var));
                acc += var;
                if acc >= reduce {
                    break;
                }
            }
            let sum: f64 = chosen.iter().map(|c| c.1).sum();
            // At most 4× a point's measurement per round: the value moves as data come in,
            // and a claim near its bound is settled for less by steps than by one leap.
            let keep = (1.0 - reduce / sum.max(1e-300)).max(MIN_KEEP);
            chosen = chosen.into_iter().map(|(i, _)| (i, keep)).collect();
        } else {
            for &i in &v.points {
                if l.points[i].results.is_empty() || l.points[i].missing.is_some() {
                    chosen.push((i, 0.5));
                }
            }
        }
        for (i, keep) in chosen {
            if !taken.insert(i) {
                continue;
            }
            let p = &ev.points[i];
            let state = as_claims_see_it(&p.state, chute);
            let ci = state.estimate.map_or(1.0, |e| e.ci95_rel());
            match work_for(&state, &ev.target, ci * keep.sqrt()) {
                Decision::Work {
                    work: Work::Replica { to_s },
                    ci_rel_before,
                    ci_rel_expected,
                    cost,
                } => {
                    // The steady replicas the claims pool (the estimate's own count may leave
                    // out a replica without a value in its block).
                    let r = p.row.replicas as f64;
                    let spread = state
                        .estimate
                        .map(|e| e.ci95_rel())
                        .filter(|c| c.is_finite());
                    let wanted = match spread {
                        Some(c) if chute => replicas_for_goal(c, ci * keep.sqrt(), r),
                        _ => 1,
                    }
                    .max(l.points[i].replicas_short);
                    let ran = p.state.runs.len();
                    let share = point_steady_share(ev, i);
                    let jobs = (f64::from(wanted) / share).ceil() as u32;
                    let max = ev.target.max_replicas;
                    let added = replicas_to_add(&p.next, jobs, ran, max);
                    if added.len() < jobs as usize {
                        capped.push(cut_short(&claim.id, &p.state.label, max, added.len(), jobs));
                    }
                    for (k, next) in added.into_iter().enumerate() {
                        // The steady replicas k + 1 new jobs are expected to give.
                        let steady = ((k + 1) as f64 * share).floor() as usize;
                        let expected = match spread {
                            Some(c) if chute && r >= 2.0 && steady > 0 => {
                                Some(after_replicas(c, r, steady))
                            }
                            Some(c) if chute && r >= 2.0 => Some(c),
                            _ => ci_rel_expected,
                        };
                        let d = Decision::Work {
                            work: Work::Replica { to_s },
                            ci_rel_before,
                            ci_rel_expected: expected,
                            cost,
                        };
                        planned.push((d, next, p.state.label.clone()));
                    }
                }
                d @ Decision::Work { .. } => {
                    planned.push((d, p.next.clone(), p.state.label.clone()))
                }
                Decision::Capped(why) => {
                    capped.push(format!("{} ({}): {why}", claim.id, p.state.label))
                }
                Decision::Met => {}
            }
        }
    }
    (planned, capped)
}

/// The uniform round: every point's shortest run goes on by the campaign's own time (a point
/// that cannot run on gets a replica).
fn uniform_work(l: &Look, ev: &Evaluation) -> (Vec<(Decision, JobSpec, String)>, Vec<String>) {
    let chute = ev.file.scene == crate::campaign::SceneKind::Chute;
    let mut planned = Vec::new();
    let mut capped = Vec::new();
    for (i, p) in ev.points.iter().enumerate() {
        let s = &p.state;
        let run = s
            .runs
            .iter()
            .filter(|r| r.not_extendable.is_none())
            .min_by(|a, b| a.end_s.total_cmp(&b.end_s).then(a.job_id.cmp(&b.job_id)));
        // A uniform round runs each point on by the campaign file's own time.
        let step_s = p.next.own_time_s();
        let to = run.map(|r| (r.end_s + step_s).min(ev.target.max_time_s.unwrap_or(0.0)));
        let d = match (run, to) {
            (Some(r), Some(to_s)) if to_s > r.end_s + 1e-9 => Decision::Work {
                work: Work::Extend {
                    job_id: r.job_id,
                    from_s: r.end_s,
                    to_s,
                },
                ci_rel_before: s.estimate.map(|e| e.ci95_rel()),
                ci_rel_expected: None,
                cost: (to_s - r.end_s) * s.steps_per_s,
            },
            _ if (s.runs.len() as u32) < ev.target.max_replicas => Decision::Work {
                work: Work::Replica {
                    to_s: s.replica_end_s,
                },
                ci_rel_before: s.estimate.map(|e| e.ci95_rel()),
                ci_rel_expected: None,
                cost: s.replica_cost,
            },
            _ => Decision::Capped("max_time_s and max_replicas reached".into()),
        };
        match d {
            Decision::Capped(why) => capped.push(format!("{}: {why}", s.label)),
            // A chute point short of steady replicas gets all it lacks, as in the adaptive
            // round (it has no result before then).
            d @ Decision::Work {
                work: Work::Replica { .. },
                ..
            } if chute => {
                let short = l.points[i].replicas_short.max(1);
                let jobs = (f64::from(short) / point_steady_share(ev, i)).ceil() as u32;
                let max = ev.target.max_replicas;
                let added = replicas_to_add(&p.next, jobs, s.runs.len(), max);
                if added.len() < jobs as usize {
                    capped.push(cut_short("its claims", &s.label, max, added.len(), jobs));
                }
                for next in added {
                    planned.push((d.clone(), next, s.label.clone()));
                }
            }
            d => planned.push((d, p.next.clone(), s.label.clone())),
        }
    }
    (planned, capped)
}

/// The particle-steps a planned item is expected to cost (0 for anything but work).
fn work_cost(d: &Decision) -> f64 {
    match d {
        Decision::Work { cost, .. } => *cost,
        _ => 0.0,
    }
}

/// Looks at the claims of a campaign whose jobs have all ended, stores the verdicts, and adds
/// the next round of work unless every claim is decided or a cap is reached.
///
/// # Errors
/// Database errors.
pub fn next_claims_round(
    conn: &mut Connection,
    campaign_id: i64,
    ev: Evaluation,
) -> Result<ClaimsRound> {
    let l = look(conn, campaign_id, &ev, true)?;
    let undecided = l
        .claims
        .iter()
        .filter(|c| c.1.decision == Verdictum::Undecided)
        .count();
    let t = &ev.target;
    let mut stop = if undecided == 0 {
        Some("every claim is decided".to_string())
    } else if l.no_alpha_left {
        Some(format!(
            "no error rate is left: the {} earlier look(s) spent α = {ALPHA}",
            l.look
        ))
    } else if ev.rounds_done >= t.max_rounds {
        Some(format!(
            "max_rounds = {} reached with {undecided} claim(s) undecided",
            t.max_rounds
        ))
    } else if t.budget_spent(l.spent.particle_steps, l.spent.core_hours) {
        let (steps_cap, hours_cap) = t.budget_words();
        Some(format!(
            "the budget is spent ({:.3e}{steps_cap} particle-steps, {:.3}{hours_cap} core-hours) with {undecided} claim(s) undecided",
            l.spent.particle_steps,
            l.spent.core_hours,
        ))
    } else {
        None
    };
    let mut limited = Vec::new();
    let planned = if stop.is_none() {
        let (planned, mut capped) = match t.allocation {
            Allocation::Adaptive => adaptive_work(&l, &ev),
            Allocation::Uniform => uniform_work(&l, &ev),
        };
        // A cap bounds the rounds, not only the looks: a round may not spend past it.
        let left = steps_left(
            l.spent.particle_steps,
            l.spent.core_hours,
            t.max_core_hours,
            t.max_particle_steps,
        );
        let (planned, cut) = within_budget(planned, |p| work_cost(&p.0), |p| p.2.clone(), left);
        capped.extend(cut);
        if planned.is_empty() {
            stop = Some(format!(
                "no work can be added for the {undecided} undecided claim(s): {}",
                capped.join("; ")
            ));
        } else {
            limited = capped;
        }
        planned
    } else {
        Vec::new()
    };
    let rows: Vec<VerdictRow> = l.claims.iter().map(|c| c.2.clone()).collect();
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    claims::save_look_spent(&tx, campaign_id, l.look, l.spent.triple())?;
    claims::save_verdicts(&tx, campaign_id, &rows)?;
    let work = register_work(&tx, campaign_id, &ev.file, ev.rounds_done + 1, planned)?;
    tx.commit()?;
    Ok(ClaimsRound {
        look: l.look,
        verdicts: rows,
        work,
        stop,
        limited,
        reread: l.reread,
        spent: l.spent,
        budget_words: t.budget_words(),
    })
}

/// A campaign with claims and no target: once its jobs have ended, its claims are looked at
/// once (at 95 %) and the verdicts stored as look 0 (with `Look::reread`). None while jobs are
/// open.
///
/// # Errors
/// Database errors.
pub fn look_once(
    conn: &mut Connection,
    campaign_id: i64,
) -> Result<Option<(Vec<VerdictRow>, Vec<String>)>> {
    let ev = super::evaluation::evaluate(conn, campaign_id)?;
    if ev.open > 0 || ev.file.claims.is_empty() {
        return Ok(None);
    }
    let l = look(conn, campaign_id, &ev, true)?;
    let rows: Vec<VerdictRow> = l.claims.into_iter().map(|c| c.2).collect();
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    claims::save_look_spent(&tx, campaign_id, l.look, l.spent.triple())?;
    claims::save_verdicts(&tx, campaign_id, &rows)?;
    tx.commit()?;
    Ok(Some((rows, l.reread)))
}
