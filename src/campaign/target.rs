//! A campaign's `target`: the confidence it wants on each point's result, and the caps on the
//! work it may add to get there (`runner::adaptive` adds it, `campaign::adaptive` chooses it).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::error::FieldProblem;
use super::scene_kind::SceneKind;

/// When a campaign's points are known well enough, and how far sweep may go to get there.
///
/// Each point (the jobs of one parameter set, its replicas) is combined as the figures combine
/// it (`observe::fits::pool`). A point whose 95 % interval is wider than asked gets more work:
/// its job runs on from its last checkpoint (longer discharge or measurement), or a replica
/// with a new seed is added, whichever shrinks the interval most per particle-step, until the
/// target holds or a cap is reached.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Target {
    /// Silo: the half-width of Q's 95 % confidence interval over Q, at every point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_ci95_rel: Option<f64>,
    /// Chute: the half-width of D's 95 % confidence interval over D, in every bulk block
    /// (0.2 H < z < 0.8 H) of every point, D pooled over the point's steady replicas.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub d_ci95_rel: Option<f64>,
    /// Replicas a point may have in all (the file's `replicas` included).
    #[serde(default = "default_max_replicas")]
    pub max_replicas: u32,
    /// Longest simulated time (s) a job may be run to: the silo's discharge, the chute's
    /// measurement. Absent: jobs are not run longer, only replicated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_time_s: Option<f64>,
    /// Rounds of added work at most (each round gives every point short of its target one
    /// piece of work, then evaluates again).
    #[serde(default = "default_max_rounds")]
    pub max_rounds: u32,
    /// "decided": instead of an interval per point, run until every claim of the file is
    /// supported or contradicted, adding work where a claim is least decided.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub claims: Option<ClaimsGoal>,
    /// The most core-hours (jobs' wall time × their threads) the campaign may spend in all,
    /// its first runs included: a look that finds them spent adds no round. The campaign's own
    /// jobs always run in full (`sweep plan` says when they alone exceed it); absent: no cap
    /// but the rounds'.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_core_hours: Option<f64>,
    /// The most particle-steps the campaign may spend in all, its first runs included, counted
    /// as `max_core_hours` is. Unlike core-hours (wall time × threads) it does not grow when
    /// jobs share their cores with other work, so a budget stated this way means the same on
    /// a loaded machine. With both caps set, the tighter one binds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_particle_steps: Option<f64>,
    /// How a claims target spreads its work: "adaptive" (default: the points whose uncertainty
    /// most keeps a claim undecided, cheapest decision first) or "uniform" (every point run on
    /// equally each round: the design to measure the adaptive one against).
    #[serde(default, skip_serializing_if = "Allocation::is_adaptive")]
    pub allocation: Allocation,
}

/// What a claims target runs until.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ClaimsGoal {
    /// Every claim supported or contradicted (or the budget spent).
    Decided,
}

/// How a claims target spreads its work over the points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Allocation {
    #[default]
    Adaptive,
    Uniform,
}

impl Allocation {
    pub fn name(self) -> &'static str {
        match self {
            Allocation::Adaptive => "adaptive",
            Allocation::Uniform => "uniform",
        }
    }

    pub fn is_adaptive(&self) -> bool {
        *self == Allocation::Adaptive
    }
}

fn default_max_replicas() -> u32 {
    8
}

fn default_max_rounds() -> u32 {
    8
}

impl Target {
    /// A campaign with claims and no target: its claims are looked at once, at 95 %, and no
    /// work is added.
    pub fn claims_looked_at_once() -> Target {
        Target {
            q_ci95_rel: None,
            d_ci95_rel: None,
            max_replicas: 1,
            max_time_s: None,
            max_rounds: 0,
            claims: None,
            max_core_hours: None,
            max_particle_steps: None,
            allocation: Allocation::Adaptive,
        }
    }

    /// Whether the target runs until the file's claims are decided.
    pub fn decides_claims(&self) -> bool {
        self.claims == Some(ClaimsGoal::Decided)
    }

    /// Whether a campaign that has spent `particle_steps` and `core_hours` has reached a cap.
    pub fn budget_spent(&self, particle_steps: f64, core_hours: f64) -> bool {
        self.max_core_hours.is_some_and(|h| core_hours >= h)
            || self.max_particle_steps.is_some_and(|s| particle_steps >= s)
    }

    /// The caps as text to follow what was spent, its unit after them: (particle-steps,
    /// core-hours), e.g. `(" of 2.000e11", " of 48")`, each "" when absent.
    pub fn budget_words(&self) -> (String, String) {
        (
            self.max_particle_steps
                .map_or(String::new(), |s| format!(" of {s:.3e}")),
            self.max_core_hours
                .map_or(String::new(), |h| format!(" of {h}")),
        )
    }

    /// How many times the claims are looked at in all: after the first runs and after each
    /// round. The error rate is split over these looks.
    pub fn looks(&self) -> u32 {
        self.max_rounds + 1
    }

    /// The relative half-width asked for the campaign's observable.
    pub fn ci95_rel(&self) -> f64 {
        self.q_ci95_rel.or(self.d_ci95_rel).unwrap_or(f64::NAN)
    }

    /// The observable's name in the store ('q' or 'd').
    pub fn observable(&self) -> &'static str {
        if self.q_ci95_rel.is_some() {
            "q"
        } else {
            "d"
        }
    }

    /// What is wrong with it for a campaign of `scene` with `replicas` replicas whose jobs run
    /// `own_time_s` (each job's own discharge or measurement time, the longest).
    pub fn problems(&self, scene: SceneKind, replicas: u32, own_time_s: f64) -> Vec<FieldProblem> {
        let mut out = Vec::new();
        let mut bad = |field: &str, message: String| {
            out.push(FieldProblem {
                path: format!("target.{field}"),
                message,
            })
        };
        if let Some(h) = self.max_core_hours {
            if !(h > 0.0 && h.is_finite()) {
                bad(
                    "max_core_hours",
                    format!("expected core-hours > 0, got {h}"),
                );
            }
        }
        if let Some(s) = self.max_particle_steps {
            if !(s > 0.0 && s.is_finite()) {
                bad(
                    "max_particle_steps",
                    format!("expected particle-steps > 0, got {s}"),
                );
            }
        }
        if self.decides_claims() {
            for (field, v) in [
                ("q_ci95_rel", self.q_ci95_rel),
                ("d_ci95_rel", self.d_ci95_rel),
            ] {
                if v.is_some() {
                    bad(field, "a target runs either until its claims are decided or until each point's interval is met; expected one of claims and this".into());
                }
            }
        } else if self.max_core_hours.is_some()
            || self.max_particle_steps.is_some()
            || !self.allocation.is_adaptive()
        {
            bad("claims", "max_core_hours, max_particle_steps and allocation belong to a claims target; expected \"claims\": \"decided\"".into());
        }
        match scene {
            _ if self.decides_claims() => {}
            SceneKind::Silo => {
                if self.q_ci95_rel.is_none() {
                    bad(
                        "q_ci95_rel",
                        "a silo target needs q_ci95_rel (the relative half-width of Q's 95 % CI, e.g. 0.03)".into(),
                    );
                }
                if self.d_ci95_rel.is_some() {
                    bad(
                        "d_ci95_rel",
                        "is a chute target; a silo campaign sets q_ci95_rel".into(),
                    );
                }
            }
            SceneKind::Chute => {
                if self.d_ci95_rel.is_none() {
                    bad(
                        "d_ci95_rel",
                        "a chute target needs d_ci95_rel (the relative half-width of D's 95 % CI in the bulk blocks, e.g. 0.1)".into(),
                    );
                }
                if self.q_ci95_rel.is_some() {
                    bad(
                        "q_ci95_rel",
                        "is a silo target; a chute campaign sets d_ci95_rel".into(),
                    );
                }
            }
        }
        for (field, v) in [
            ("q_ci95_rel", self.q_ci95_rel),
            ("d_ci95_rel", self.d_ci95_rel),
        ] {
            if let Some(v) = v {
                if !(v > 0.0 && v < 1.0) {
                    bad(
                        field,
                        format!("expected a fraction in (0, 1), e.g. 0.03, got {v}"),
                    );
                }
            }
        }
        if self.max_replicas < replicas.max(1) {
            bad(
                "max_replicas",
                format!(
                    "expected at least the file's replicas ({}), got {}",
                    replicas.max(1),
                    self.max_replicas
                ),
            );
        }
        if let Some(t) = self.max_time_s {
            if !(t >= own_time_s) {
                bad(
                    "max_time_s",
                    format!("expected seconds >= the jobs' own time ({own_time_s} s), got {t}"),
                );
            }
        }
        if self.max_rounds == 0 {
            bad("max_rounds", "expected at least 1 round".into());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn claims_target() -> Target {
        Target {
            claims: Some(ClaimsGoal::Decided),
            max_rounds: 2,
            ..Target::claims_looked_at_once()
        }
    }

    #[test]
    fn a_particle_step_cap_is_checked_and_binds_like_the_core_hours_one() {
        let paths = |t: &Target| -> Vec<String> {
            t.problems(SceneKind::Chute, 1, 1.0)
                .into_iter()
                .map(|p| p.path)
                .collect()
        };
        let mut t = claims_target();
        assert!(paths(&t).is_empty(), "{:?}", paths(&t));
        t.max_particle_steps = Some(0.0);
        t.max_core_hours = Some(f64::NAN);
        assert_eq!(
            paths(&t),
            vec!["target.max_core_hours", "target.max_particle_steps"]
        );
        // Not a claims target: the caps belong to one.
        let q = Target {
            q_ci95_rel: Some(0.03),
            max_rounds: 2,
            max_particle_steps: Some(1e9),
            ..Target::claims_looked_at_once()
        };
        assert!(paths(&q).contains(&"target.claims".to_string()));

        t.max_core_hours = Some(10.0);
        t.max_particle_steps = Some(1e9);
        assert!(!t.budget_spent(5e8, 5.0));
        assert!(t.budget_spent(1e9, 5.0), "particle-steps spent");
        assert!(t.budget_spent(5e8, 10.0), "core-hours spent");
        assert_eq!(
            t.budget_words(),
            (" of 1.000e9".to_string(), " of 10".to_string())
        );
        assert!(!claims_target().budget_spent(1e20, 1e9), "no cap");
    }
}
