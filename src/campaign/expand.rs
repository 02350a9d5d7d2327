//! Expansion of a campaign into jobs, in stages: the file's own problems (`file_checks`), the
//! points of the sweep (Cartesian product of `sweep`, crossed with `zip`), one validated job per
//! point (base ⊕ point), then what needs every point (the target, the claims). Replicas differ
//! only in their index and are made on demand by [`Jobs`].

use rayon::prelude::*;
use serde_json::Value;

use super::error::{CampaignError, FieldProblem};
use super::file::{CampaignFile, JobBackend, Observers, Precision, SceneKind};
use super::file_checks::{file_problems, zip_len, OBSERVER_PREFIX};
use super::job_spec::JobSpec;
use super::jobs::Jobs;
use crate::scene::{ChuteParams, SiloParams};

/// One value of a point: (parameter, value, its JSON path such as `sweep.orifice_diameter_m[2]`).
type PointValue = (String, Value, String);
/// A point of the sweep: the parameters it sets.
type Point = Vec<PointValue>;

/// Expands a parsed campaign into its jobs (in a fixed order), collecting every problem.
///
/// # Errors
/// Empty or unequal lists, unknown parameter names, wrong types and out-of-range values, each
/// with the JSON path it came from (`sweep.orifice_diameter_m[2]`).
pub fn expand(c: &CampaignFile, file: &str) -> Result<Jobs, CampaignError> {
    let invalid = |problems| CampaignError::Invalid {
        file: file.into(),
        problems,
    };
    let problems = file_problems(c);
    if !problems.is_empty() {
        return Err(invalid(problems));
    }
    // Points are independent: validated on every core, their problems kept in file order.
    let made: Vec<(Option<JobSpec>, Vec<FieldProblem>)> = sweep_points(c)
        .par_iter()
        .map(|p| {
            let mut problems = Vec::new();
            (point_job(c, p, &mut problems), problems)
        })
        .collect();
    let mut problems = Vec::new();
    let mut points = Vec::with_capacity(made.len());
    for (job, point_problems) in made {
        for p in point_problems {
            push_new(&mut problems, p);
        }
        points.extend(job);
    }
    problems.extend(campaign_problems(c, &points));
    if !problems.is_empty() {
        return Err(invalid(problems));
    }
    Ok(Jobs::new(points, c.replicas, c.first_replica))
}

/// The points of the sweep: the Cartesian product over `sweep` (keys in sorted order), crossed
/// with the zipped points.
fn sweep_points(c: &CampaignFile) -> Vec<Point> {
    let mut points: Vec<Point> = vec![Vec::new()];
    for (k, vals) in &c.sweep {
        let mut next = Vec::with_capacity(points.len() * vals.len());
        for p in &points {
            for (i, v) in vals.iter().enumerate() {
                let mut q = p.clone();
                q.push((k.clone(), v.clone(), format!("sweep.{k}[{i}]")));
                next.push(q);
            }
        }
        points = next;
    }
    if !c.zip.is_empty() {
        let mut next = Vec::new();
        for p in &points {
            for i in 0..zip_len(c) {
                let mut q = p.clone();
                for (k, vals) in &c.zip {
                    q.push((k.clone(), vals[i].clone(), format!("zip.{k}[{i}]")));
                }
                next.push(q);
            }
        }
        points = next;
    }
    points
}

/// `p` unless `problems` has it already (a bad base value is a problem of every point).
fn push_new(problems: &mut Vec<FieldProblem>, p: FieldProblem) {
    if !problems.contains(&p) {
        problems.push(p);
    }
}

/// The job of `point` (replica 0): base ⊕ point, parsed and validated. `None` where it cannot
/// be made; its problems, each with the path its value came from, go to `problems`.
fn point_job(c: &CampaignFile, point: &Point, problems: &mut Vec<FieldProblem>) -> Option<JobSpec> {
    let mut obj = c.base.clone();
    for (k, v, _) in point {
        obj.insert(k.clone(), v.clone());
    }
    obj.insert("replica".into(), Value::from(0));
    let source = |field: &str| -> String {
        point
            .iter()
            .find(|(k, _, _)| k == field)
            .map_or_else(|| format!("base.{field}"), |(_, _, s)| s.clone())
    };
    let precision = match obj.remove("precision") {
        None => c.run.precision,
        Some(v) => match serde_json::from_value::<Precision>(v.clone()) {
            Ok(p) => p,
            Err(_) => {
                problems.push(FieldProblem {
                    path: source("precision"),
                    message: format!("expected \"f64\" or \"f32\", got {v}"),
                });
                return None;
            }
        },
    };
    // null: wherever `sweep launch --backend` puts it (lets a zip fix it for some jobs).
    let backend = match obj.remove("backend") {
        None | Some(Value::Null) => None,
        Some(v) => match serde_json::from_value::<JobBackend>(v.clone()) {
            Ok(b) => Some(b),
            Err(_) => {
                problems.push(FieldProblem {
                    path: source("backend"),
                    message: format!("expected \"cpu\" or \"gpu\", got {v}"),
                });
                return None;
            }
        },
    };
    if backend == Some(JobBackend::Gpu) && precision == Precision::F64 {
        problems.push(FieldProblem {
            path: source("backend"),
            message:
                "the GPU engine runs f32: expected \"precision\": \"f32\" with \"backend\": \"gpu\""
                    .into(),
        });
        return None;
    }
    let observer_keys: Vec<String> = obj
        .keys()
        .filter(|k| k.starts_with(OBSERVER_PREFIX))
        .cloned()
        .collect();
    let observer_values: Vec<(String, Value)> = observer_keys
        .into_iter()
        .map(|k| {
            let v = obj.remove(&k).expect("listed");
            (k, v)
        })
        .collect();
    let (silo, chute) = scene_params(c.scene, obj, &source, problems)?;
    let mut observers = c.observers.clone();
    if c.scene == SceneKind::Chute && observers.chute.is_none() {
        observers.chute = Some(Default::default());
    }
    if !observer_values.is_empty() {
        match with_observer_values(&observers, &observer_values) {
            Ok(o) => observers = o,
            Err(p) => {
                push_new(
                    problems,
                    FieldProblem {
                        path: source(&p.path),
                        message: p.message,
                    },
                );
                return None;
            }
        }
    }
    if let (Some(f), Some(p)) = (&observers.fields, &silo) {
        for (field, message) in f.problems_with(p, &observers.discharge) {
            push_new(
                problems,
                FieldProblem {
                    path: format!("observers.fields.{field}"),
                    message,
                },
            );
        }
    }
    let mut label: Vec<String> = point.iter().map(|(k, v, _)| format!("{k}={v}")).collect();
    label.push("replica=0".into());
    Some(JobSpec {
        scene: c.scene,
        silo,
        chute,
        observers,
        precision,
        backend,
        label: label.join(","),
        sources: point
            .iter()
            .map(|(k, _, path)| (k.clone(), path.clone()))
            .collect(),
    })
}

/// The scene's parameters from `obj`, validated; `None` where they do not parse. A value out of
/// range is a problem, but the job is still made (its other problems are found too).
fn scene_params(
    scene: SceneKind,
    obj: serde_json::Map<String, Value>,
    source: &dyn Fn(&str) -> String,
    problems: &mut Vec<FieldProblem>,
) -> Option<(Option<SiloParams>, Option<ChuteParams>)> {
    let problem = |e: serde_path_to_error::Error<serde_json::Error>| {
        let field = e.path().to_string();
        let field = field.split('.').next().unwrap_or("").to_string();
        FieldProblem {
            path: source(&field),
            message: e.into_inner().to_string(),
        }
    };
    let (params, field_errors) = match scene {
        SceneKind::Silo => {
            match serde_path_to_error::deserialize::<_, SiloParams>(Value::Object(obj)) {
                Ok(p) => {
                    let e = p.validate();
                    ((Some(p), None), e)
                }
                Err(e) => {
                    problems.push(problem(e));
                    return None;
                }
            }
        }
        SceneKind::Chute => {
            match serde_path_to_error::deserialize::<_, ChuteParams>(Value::Object(obj)) {
                Ok(p) => {
                    let e = p.validate();
                    ((None, Some(p)), e)
                }
                Err(e) => {
                    problems.push(problem(e));
                    return None;
                }
            }
        }
    };
    for fe in field_errors {
        push_new(
            problems,
            FieldProblem {
                path: source(&fe.field),
                message: fe.message,
            },
        );
    }
    Some(params)
}

/// Problems that need every point: the target's (against the longest job) and the claims'.
fn campaign_problems(c: &CampaignFile, points: &[JobSpec]) -> Vec<FieldProblem> {
    let mut problems = Vec::new();
    if let Some(t) = &c.target {
        let own = points.iter().map(JobSpec::own_time_s).fold(0.0, f64::max);
        problems.extend(t.problems(c.scene, c.replicas, own));
        if t.decides_claims() && c.claims.is_empty() {
            problems.push(FieldProblem {
                path: "target.claims".into(),
                message: "\"decided\" needs claims: expected a non-empty top-level `claims` list"
                    .into(),
            });
        }
    }
    problems.extend(super::claims::problems(c, points));
    problems
}

/// `observers` with each (path, value) set, e.g. ("observers.chute.sample_interval_s", 0.1),
/// re-validated. The problem's `path` is the key that caused it (for `source`).
fn with_observer_values(
    observers: &Observers,
    values: &[(String, Value)],
) -> Result<Observers, FieldProblem> {
    let mut tree = serde_json::to_value(observers).expect("serializable");
    for (key, v) in values {
        let segments: Vec<&str> = key[OBSERVER_PREFIX.len()..].split('.').collect();
        let (last, parents) = segments.split_last().expect("split yields one");
        let mut node = &mut tree;
        for seg in parents {
            node = match node.get_mut(*seg) {
                Some(n) if n.is_object() => n,
                _ => {
                    return Err(FieldProblem {
                        path: key.clone(),
                        message: format!(
                            "no observer section {seg:?} here: expected a path like observers.chute.sample_interval_s to an observer this campaign has"
                        ),
                    })
                }
            };
        }
        node.as_object_mut()
            .expect("checked object")
            .insert((*last).to_string(), v.clone());
    }
    let parsed: Observers = serde_path_to_error::deserialize(tree).map_err(|e| {
        let field = e.path().to_string();
        FieldProblem {
            path: values
                .iter()
                .map(|(k, _)| k.clone())
                .find(|k| k.ends_with(&field))
                .unwrap_or_else(|| values[0].0.clone()),
            message: format!("{}: {}", field, e.into_inner()),
        }
    })?;
    if let Some(sn) = &parsed.snapshots {
        if let Some((field, message)) = sn.problems().into_iter().next() {
            return Err(FieldProblem {
                path: format!("observers.snapshots.{field}"),
                message,
            });
        }
    }
    if let Some(ch) = &parsed.chute {
        if let Some(p) = ch.problems().into_iter().next() {
            return Err(FieldProblem {
                path: format!("observers.chute.{}", p.field),
                message: p.message,
            });
        }
    }
    Ok(parsed)
}

#[cfg(test)]
mod tests;
