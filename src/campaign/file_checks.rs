//! What is wrong with a campaign file as a whole, before any job is made: unknown or doubly
//! set parameters, empty or unequal lists, and settings out of range (replicas, attempts,
//! intervals, observers, the name). Each problem names its JSON path.

use serde_json::{Map, Value};

use super::error::FieldProblem;
use super::file::{CampaignFile, SceneKind};
use crate::scene::{ChuteParams, SiloParams};

/// Campaign keys that set an observer setting by its path.
pub(super) const OBSERVER_PREFIX: &str = "observers.";

/// The scene's parameters by name, with their defaults.
pub(super) fn known_parameters(scene: SceneKind) -> Map<String, Value> {
    let defaults = match scene {
        SceneKind::Silo => serde_json::to_value(SiloParams::default()),
        SceneKind::Chute => serde_json::to_value(ChuteParams::default()),
    };
    let mut known: Map<String, Value> = match defaults {
        Ok(Value::Object(m)) => m,
        _ => Map::new(),
    };
    // Left out of the parameters at its default (`scene::at_origin`), still a parameter.
    known
        .entry("origin_m")
        .or_insert_with(|| Value::from(vec![0.0; 3]));
    // Chute parameters likewise left out at their defaults (older jobs keep their hashes).
    if scene == SceneKind::Chute {
        for k in ChuteParams::OMITTED_AT_DEFAULT {
            known.entry(k).or_insert(Value::Null);
        }
    }
    known
}

/// Every problem of the file that no single job shows.
pub(super) fn file_problems(c: &CampaignFile) -> Vec<FieldProblem> {
    let mut problems = key_problems(c);
    problems.extend(setting_problems(c));
    problems
}

/// Parameters of `base`, `sweep` and `zip` the scene does not have, set twice, or with empty
/// or unequal lists.
fn key_problems(c: &CampaignFile) -> Vec<FieldProblem> {
    let known = known_parameters(c.scene);
    let mut problems = Vec::new();
    // `precision` may also be swept (an accuracy study compares f64 with f32); it overrides
    // `run.precision` for its jobs. So may `backend` ("cpu" or "gpu"), and observer settings
    // named by their path ("observers.chute.cg_width_over_length").
    let check_key = |section: &str, k: &str, problems: &mut Vec<FieldProblem>| {
        if k == "replica" {
            problems.push(FieldProblem {
                path: format!("{section}.{k}"),
                message: "a job's replica index is set by the file's `replicas` and \
                          `first_replica` (first_replica, first_replica + 1, …), not by a value"
                    .into(),
            });
        } else if !known.contains_key(k)
            && k != "precision"
            && k != "backend"
            && !k.starts_with(OBSERVER_PREFIX)
        {
            let mut names: Vec<&String> = known.keys().collect();
            names.sort();
            problems.push(FieldProblem {
                path: format!("{section}.{k}"),
                message: format!(
                    "unknown {:?} parameter; expected one of: {}",
                    c.scene.name(),
                    names
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        }
    };
    for k in c.base.keys() {
        check_key("base", k, &mut problems);
    }
    for (k, v) in &c.sweep {
        check_key("sweep", k, &mut problems);
        if v.is_empty() {
            problems.push(FieldProblem {
                path: format!("sweep.{k}"),
                message: "expected a non-empty list of values".into(),
            });
        }
        if c.base.contains_key(k) {
            problems.push(FieldProblem {
                path: format!("sweep.{k}"),
                message: "also set in base: a swept parameter must not have a base value".into(),
            });
        }
    }
    let zip_len = zip_len(c);
    for (k, v) in &c.zip {
        check_key("zip", k, &mut problems);
        if v.is_empty() {
            problems.push(FieldProblem {
                path: format!("zip.{k}"),
                message: "expected a non-empty list of values".into(),
            });
        } else if v.len() != zip_len {
            problems.push(FieldProblem {
                path: format!("zip.{k}"),
                message: format!(
                    "expected {zip_len} values like the other zipped lists, got {}",
                    v.len()
                ),
            });
        }
        if c.sweep.contains_key(k) || c.base.contains_key(k) {
            problems.push(FieldProblem {
                path: format!("zip.{k}"),
                message: "also set in base or sweep".into(),
            });
        }
    }
    problems
}

/// The length of the zipped lists (that of the first; the others are checked against it).
pub(super) fn zip_len(c: &CampaignFile) -> usize {
    c.zip.values().next().map_or(0, |v| v.len())
}

/// Replicas, the name, attempts, intervals and observer settings out of range.
fn setting_problems(c: &CampaignFile) -> Vec<FieldProblem> {
    let mut problems = Vec::new();
    let mut push = |path: String, message: String| problems.push(FieldProblem { path, message });
    if c.replicas == 0 {
        push(
            "replicas".into(),
            "expected at least 1 replica, got 0".into(),
        );
    }
    // Rounds add replicas up to the target's max_replicas, numbered on from the largest.
    let most = c
        .target
        .as_ref()
        .map_or(c.replicas, |t| t.max_replicas.max(c.replicas));
    if c.first_replica.checked_add(most).is_none() {
        push(
            "first_replica".into(),
            format!(
                "expected first_replica + replicas (or the target's max_replicas) to fit in 32 \
                 bits, got {} + {most}",
                c.first_replica
            ),
        );
    }
    if let Some(message) = name_problem(&c.name) {
        push("name".into(), message);
    }
    if c.run.max_attempts == 0 {
        push(
            "run.max_attempts".into(),
            "expected at least 1 attempt per job (0 would register jobs that never run), got 0"
                .into(),
        );
    }
    if !(c.run.checkpoint_interval_s > 0.0) {
        push(
            "run.checkpoint_interval_s".into(),
            format!("expected seconds > 0, got {}", c.run.checkpoint_interval_s),
        );
    }
    let d = &c.observers.discharge;
    for (name, v) in [
        ("sample_interval_s", d.sample_interval_s),
        ("clog_after_s", d.clog_after_s),
        ("permanent_clog_after_s", d.permanent_clog_after_s),
        ("block_s", d.block_s),
    ] {
        if !(v > 0.0) {
            push(
                format!("observers.discharge.{name}"),
                format!("expected seconds > 0, got {v}"),
            );
        }
    }
    if let Some(sn) = &c.observers.snapshots {
        for (field, message) in sn.problems() {
            push(format!("observers.snapshots.{field}"), message);
        }
    }
    if let Some(f) = &c.observers.fields {
        if c.scene != SceneKind::Silo {
            push(
                "observers.fields".into(),
                format!(
                    "the fields observer is for silo campaigns, this one is {:?}",
                    c.scene.name()
                ),
            );
        }
        for (field, message) in f.problems() {
            push(format!("observers.fields.{field}"), message);
        }
    }
    if let Some(ch) = &c.observers.chute {
        for p in ch.problems() {
            push(format!("observers.chute.{}", p.field), p.message);
        }
    }
    problems
}

/// Why a campaign name is unusable, if it is: it names the campaign in the store, in reports
/// (`--campaign NAME`) and in work-directory paths.
fn name_problem(name: &str) -> Option<String> {
    if name.trim().is_empty() {
        return Some("expected a name (it names the campaign in the database and in `--campaign NAME`), got an empty one".into());
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Some(format!(
            "expected printable characters, got the control character {:?} in {name:?}",
            c
        ));
    }
    if name.contains('@') || name.contains('/') {
        return Some(format!(
            "expected no '@' (it separates a version: NAME@v2) and no '/', got {name:?}"
        ));
    }
    // It also names files: the work directory and `report --claims`' NAME.md.
    if name.starts_with('.') {
        return Some(format!(
            "expected a name that does not start with '.' (it names a directory and files, which would be hidden), got {name:?}"
        ));
    }
    if name.len() > MAX_NAME_BYTES {
        return Some(format!(
            "expected at most {MAX_NAME_BYTES} bytes (it names files, and file names are limited), got {}",
            name.len()
        ));
    }
    None
}

/// Room for ".md" and a version suffix within a file system's 255-byte file names.
const MAX_NAME_BYTES: usize = 200;

#[cfg(test)]
mod tests {
    use super::name_problem;

    #[test]
    fn names_that_cannot_name_a_campaign_are_refused() {
        assert_eq!(name_problem("chute_reproduction"), None);
        assert_eq!(name_problem(&"x".repeat(200)), None);
        for bad in ["", " ", "a\tb", "a@v2", "a/b", ".hidden", &"x".repeat(201)] {
            assert!(name_problem(bad).is_some(), "{bad:?} accepted");
        }
    }
}
