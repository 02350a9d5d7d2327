//! A campaign's `claims`, checked against its points: every claim must resolve (its points
//! exist, its results are the scene's, its fit parameters the model's), ids are unique, and a
//! chute claim rests on at least [`CHUTE_MIN_REPLICAS`] replicas per point. Claims are part of
//! the file (its version) but not of any job's identity.

use std::collections::{BTreeMap, BTreeSet};

use super::error::FieldProblem;
use super::file::{CampaignFile, SceneKind};
use super::job_spec::JobSpec;
use super::point::{label_without_replica, point_key, point_params};
use crate::observe::claims::{PointData, Statistic, CHUTE_RESULTS, SILO_RESULTS};

/// Independent replicas (different seeds) a chute point needs before a claim reads it: two runs
/// of one chute that differ only in round-off differed by up to 14 % in V_x, more than one
/// run's block error says, so a chute result's interval is the spread between replicas.
pub const CHUTE_MIN_REPLICAS: u32 = 3;

/// The results a scene's points give to claims.
pub fn scene_results(scene: SceneKind) -> &'static [&'static str] {
    match scene {
        SceneKind::Silo => SILO_RESULTS,
        SceneKind::Chute => CHUTE_RESULTS,
    }
}

/// The campaign's points (replicas merged) with their parameters and no results yet, in the
/// order of their first job.
pub fn points_of(jobs: &[JobSpec]) -> Vec<(String, PointData)> {
    let mut out: Vec<(String, PointData)> = Vec::new();
    for j in jobs {
        let key = point_key(&j.resolved_json());
        if out.iter().any(|(k, _)| *k == key) {
            continue;
        }
        out.push((
            key,
            PointData {
                label: label_without_replica(&j.label),
                params: point_params(&j.resolved_json()),
                results: BTreeMap::new(),
                missing: None,
                clogged: false,
                replicas_short: 0,
                particle_steps: 0.0,
            },
        ));
    }
    out
}

fn id_ok(id: &str) -> bool {
    !id.is_empty()
        && id.len() <= 64
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

/// What is wrong with the campaign's claims, by field.
pub fn problems(c: &CampaignFile, jobs: &[JobSpec]) -> Vec<FieldProblem> {
    let mut out = Vec::new();
    if c.claims.is_empty() {
        return out;
    }
    let points: Vec<PointData> = points_of(jobs).into_iter().map(|(_, p)| p).collect();
    let mut seen = BTreeSet::new();
    for (k, claim) in c.claims.iter().enumerate() {
        let path = format!("claims[{k}]");
        if !id_ok(&claim.id) {
            out.push(FieldProblem {
                path: format!("{path}.id"),
                message: format!(
                    "expected 1–64 letters, digits, '_', '-' or '.', got {:?}",
                    claim.id
                ),
            });
        } else if !seen.insert(claim.id.clone()) {
            out.push(FieldProblem {
                path: format!("{path}.id"),
                message: format!(
                    "'{}' is the id of an earlier claim; expected unique ids",
                    claim.id
                ),
            });
        }
        if claim.statement.trim().is_empty() {
            out.push(FieldProblem {
                path: format!("{path}.statement"),
                message: "expected the paper's words, got nothing".into(),
            });
        }
        if let Err(e) = Statistic::resolve(claim, &path, &points, scene_results(c.scene), None) {
            // The Beverloo law's constants come from the store's results; the rest resolves here.
            if !e.message.contains("needs the particle diameter") {
                out.push(FieldProblem {
                    path: e.field,
                    message: e.message,
                });
            }
        }
    }
    if c.scene == SceneKind::Chute && c.replicas < CHUTE_MIN_REPLICAS {
        out.push(FieldProblem {
            path: "replicas".into(),
            message: format!(
                "chute claims need at least {CHUTE_MIN_REPLICAS} replicas per point (the spread between runs is part of their interval), got {}",
                c.replicas
            ),
        });
    }
    out
}
