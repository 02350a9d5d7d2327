//! A campaign's target, one round at a time: once every job of the campaign has ended, each
//! point's replicas are combined exactly as the figures combine them, the points short of the
//! target get their next piece of work (`campaign::adaptive::decide`), widest interval first,
//! and the work is registered (a done job set to run on, or a new replica job) for the
//! executor to run. Decisions read only finished results, so an interrupted and resumed
//! campaign takes the same decisions as an uninterrupted one.

use anyhow::Result;
use rusqlite::{Connection, TransactionBehavior};

use crate::campaign::adaptive::{decide, Decision};
use crate::campaign::JobSpec;
use crate::store::targets::{self, PointRow, WorkRow};

use super::evaluation::{evaluate, register_work, EvaluatedPoint};

/// What an evaluation of a campaign's target found.
#[derive(Debug)]
pub enum RoundOutcome {
    /// Jobs of the campaign have not ended yet (pending, running or paused): nothing decided.
    Unsettled(usize),
    /// No work added: every point met the target or reached a cap.
    Finished(Vec<PointRow>),
    /// Work was added as round `round` (the executor runs it next).
    Work {
        round: u32,
        work: Vec<WorkRow>,
        points: Vec<PointRow>,
    },
    /// A claims target's look: the verdicts, the work added for the undecided claims (none:
    /// finished), and why it stopped when it did.
    Claims(super::claim_rounds::ClaimsRound),
}

/// Evaluates campaign `campaign_id`'s target and, where points fall short, registers the next
/// round of work. Stores every point's state (`target_points`) and the work (`target_work`).
///
/// # Errors
/// Database errors, unreadable stored parameters, or a campaign without a target.
pub fn next_round(conn: &mut Connection, campaign_id: i64) -> Result<RoundOutcome> {
    let ev = evaluate(conn, campaign_id)?;
    if ev.open > 0 {
        return Ok(RoundOutcome::Unsettled(ev.open));
    }
    if ev.target.decides_claims() {
        return Ok(RoundOutcome::Claims(
            super::claim_rounds::next_claims_round(conn, campaign_id, ev)?,
        ));
    }
    let (file, target, rounds_done) = (ev.file, ev.target, ev.rounds_done);
    let out_of_rounds = rounds_done >= target.max_rounds;
    let mut rows_out = Vec::new();
    let mut planned: Vec<(f64, usize, Decision, JobSpec, String)> = Vec::new();
    for (k, p) in ev.points.into_iter().enumerate() {
        let EvaluatedPoint {
            state,
            mut row,
            next,
            ..
        } = p;
        let decision = decide(&state, &target);
        match &decision {
            Decision::Met => {
                row.met = true;
                row.status = "met".into();
            }
            Decision::Capped(why) => row.status = format!("capped: {why}"),
            Decision::Work { .. } if out_of_rounds => {
                row.status = format!("capped: max_rounds = {} reached", target.max_rounds)
            }
            Decision::Work { ci_rel_before, .. } => {
                row.status = "working".into();
                // Widest interval first (no estimate yet counts as the widest).
                planned.push((
                    ci_rel_before.unwrap_or(f64::INFINITY),
                    k,
                    decision.clone(),
                    next,
                    state.label.clone(),
                ));
            }
        }
        rows_out.push(row);
    }
    planned.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let round = rounds_done + 1;
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    targets::save_points(&tx, campaign_id, &rows_out)?;
    let planned = planned
        .into_iter()
        .map(|(_, _, decision, next, label)| (decision, next, label))
        .collect();
    let work = register_work(&tx, campaign_id, &file, round, planned)?;
    tx.commit()?;
    Ok(if work.is_empty() {
        RoundOutcome::Finished(rows_out)
    } else {
        RoundOutcome::Work {
            round,
            work,
            points: rows_out,
        }
    })
}
