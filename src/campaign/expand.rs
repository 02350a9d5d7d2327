//! Expansion of a campaign into jobs: base ⊕ one point of the sweep, validated; the job's
//! identity is the SHA-256 of its resolved parameters (canonical JSON), and its seed derives from
//! the same parameters without the observers, so the same parameters always give the same job
//! and the same random packing, and jobs that differ only in how they are observed (a
//! coarse-graining width, a sampling interval) follow the same trajectory.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use sha2::{Digest, Sha256};

use super::error::{CampaignError, FieldProblem};
use super::file::{CampaignFile, JobBackend, Observers, Precision, SceneKind};
use crate::scene::{ChuteParams, SiloParams};

/// A job's identity: its resolved parameters as canonical JSON, their SHA-256 (hex) and the
/// seed of its random choices.
#[derive(Clone, Debug)]
pub struct Identity {
    pub resolved_json: String,
    pub hash: String,
    pub seed: u64,
}

/// The seed from a job's canonical parameters without its observers and its place.
fn seed_of(mut v: Value) -> u64 {
    if let Value::Object(m) = &mut v {
        m.remove("observers");
        // Where the scene sits is not physics: a moved scene starts from the same packing.
        for scene in ["silo", "chute"] {
            if let Some(Value::Object(p)) = m.get_mut(scene) {
                p.remove("origin_m");
            }
        }
    }
    let h = Sha256::digest(serde_json::to_string(&v).expect("serializable").as_bytes());
    u64::from_le_bytes(h[..8].try_into().expect("8 bytes"))
}

/// −0.0 written as 0.0: they are the same physics (a frequency of −0 Hz is a bottom at rest),
/// so they must be the same job.
fn canonical_zeros(v: &mut Value) {
    match v {
        Value::Number(n)
            if n.as_f64() == Some(0.0) && n.as_f64().is_some_and(f64::is_sign_negative) =>
        {
            *v = Value::from(0.0);
        }
        Value::Array(a) => a.iter_mut().for_each(canonical_zeros),
        Value::Object(m) => m.values_mut().for_each(canonical_zeros),
        _ => {}
    }
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
    None
}

/// A fully resolved job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobSpec {
    pub scene: SceneKind,
    /// The silo's parameters (silo jobs); serialised as before chutes existed, so silo job
    /// identities are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub silo: Option<SiloParams>,
    /// The chute's parameters (chute jobs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chute: Option<ChuteParams>,
    pub observers: Observers,
    pub precision: Precision,
    /// The engine the job must run on, when the campaign fixes it (absent: wherever `sweep
    /// launch --backend` puts it; absent from the identity of such jobs, so older job hashes
    /// are unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backend: Option<JobBackend>,
    /// Human-readable point of the sweep, e.g. "orifice_diameter_m=0.015,rotation_frequency_hz=0.5,replica=0".
    #[serde(skip)]
    pub label: String,
    /// Where each swept or zipped value came from: (parameter, JSON path such as
    /// `sweep.orifice_diameter_m[2]`); parameters not listed came from `base`.
    #[serde(skip)]
    pub sources: Vec<(String, String)>,
}

impl JobSpec {
    /// The JSON path in the campaign file of a parameter's value: `sweep.…[i]` or `zip.…[i]`
    /// when the point set it, else `base.…`.
    pub fn source(&self, field: &str) -> String {
        self.sources
            .iter()
            .find(|(k, _)| k == field)
            .map_or_else(|| format!("base.{field}"), |(_, s)| s.clone())
    }

    /// Canonical JSON of everything that determines the job's results.
    pub fn resolved_json(&self) -> String {
        serde_json::to_string(&self.canonical_value()).expect("serializable")
    }

    /// SHA-256 of the resolved parameters, hex.
    pub fn hash(&self) -> String {
        hex(&Sha256::digest(self.resolved_json().as_bytes()))
    }

    /// Seed of the job's random choices (packing, re-insertion), from its parameters without
    /// the observers: observing differently must not change what is observed.
    pub fn seed(&self) -> u64 {
        seed_of(self.canonical_value())
    }

    /// The resolved JSON, its hash and the seed at once (one serialisation: registering 10⁶
    /// jobs spends most of its time here).
    pub fn identity(&self) -> Identity {
        let v = self.canonical_value();
        let resolved_json = serde_json::to_string(&v).expect("serializable");
        Identity {
            hash: hex(&Sha256::digest(resolved_json.as_bytes())),
            resolved_json,
            seed: seed_of(v),
        }
    }

    /// Every parameter as JSON, −0.0 written as 0.0; serde_json maps are sorted (no
    /// preserve_order feature), so its text is canonical.
    fn canonical_value(&self) -> Value {
        let mut v = serde_json::to_value(self).expect("serializable");
        canonical_zeros(&mut v);
        v
    }

    /// Where the job's scene sits in the lab frame (`origin_m` of its scene).
    pub fn origin_m(&self) -> [f64; 3] {
        match (&self.silo, &self.chute) {
            (Some(p), _) => p.origin_m,
            (_, Some(p)) => p.origin_m,
            _ => [0.0; 3],
        }
    }

    /// The silo parameters of a silo job.
    ///
    /// # Panics
    /// On a job of another scene (callers dispatch on `scene` first).
    pub fn silo(&self) -> &SiloParams {
        self.silo.as_ref().expect("a silo job")
    }

    /// The chute parameters of a chute job.
    ///
    /// # Panics
    /// On a job of another scene.
    pub fn chute(&self) -> &ChuteParams {
        self.chute.as_ref().expect("a chute job")
    }

    /// Simulated time the job runs at most (s): the progress bar's target.
    pub fn target_time_s(&self) -> f64 {
        match self.scene {
            SceneKind::Silo => self.silo().discharge_time_s,
            SceneKind::Chute => self.chute().max_time_s(),
        }
    }

    /// The time a target may extend (s): the silo's discharge, the chute's measurement.
    pub fn own_time_s(&self) -> f64 {
        match self.scene {
            SceneKind::Silo => self.silo().discharge_time_s,
            SceneKind::Chute => self.chute().measure_time_s,
        }
    }

    /// The same point's replica `replica`: its own seed, fill and label.
    pub fn replica(&self, replica: u32) -> JobSpec {
        let mut j = self.clone();
        if let Some(p) = j.silo.as_mut() {
            p.replica = replica;
        }
        if let Some(p) = j.chute.as_mut() {
            p.replica = replica;
        }
        j.label = match self.label.rsplit_once(",replica=") {
            Some((head, _)) => format!("{head},replica={replica}"),
            None if self.label.starts_with("replica=") || self.label.is_empty() => {
                format!("replica={replica}")
            }
            None => format!("{},replica={replica}", self.label),
        };
        j
    }

    /// Number of mobile particles at the start.
    pub fn particle_count(&self) -> usize {
        match self.scene {
            SceneKind::Silo => self.silo().particle_count,
            SceneKind::Chute => self.chute().count(),
        }
    }

    /// Seed and key of the filling stage, shared by jobs that agree on the fill parameters.
    pub fn fill_key(&self) -> (String, u64) {
        let v = serde_json::json!({ "scene": self.scene, "fill": self.silo().fill_stage(), "precision": self.precision });
        let h = Sha256::digest(serde_json::to_string(&v).expect("json").as_bytes());
        (
            hex(&h),
            u64::from_le_bytes(h[..8].try_into().expect("8 bytes")),
        )
    }
}

/// `key` made specific to `what` (a fill stage run on a particular GPU adapter): another key of
/// the same form.
pub fn key_with(key: &str, what: &str) -> String {
    hex(&Sha256::digest(format!("{key}\n{what}").as_bytes()))
}

fn hex(b: &[u8]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    b.iter()
        .flat_map(|x| {
            [
                DIGITS[(x >> 4) as usize] as char,
                DIGITS[(x & 15) as usize] as char,
            ]
        })
        .collect()
}

/// Expands a parsed campaign into its jobs (in a fixed order), collecting every problem.
///
/// # Errors
/// Empty or unequal lists, unknown parameter names, wrong types and out-of-range values, each
/// with the JSON path it came from (`sweep.orifice_diameter_m[2]`).
pub fn expand(c: &CampaignFile, file: &str) -> Result<Vec<JobSpec>, CampaignError> {
    let mut problems = Vec::new();
    let defaults = match c.scene {
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
    if c.scene == SceneKind::Chute {
        for k in ChuteParams::OMITTED_AT_DEFAULT {
            known.entry(k).or_insert(Value::Null);
        }
    }
    // `precision` may also be swept (an accuracy study compares f64 with f32); it overrides
    // `run.precision` for its jobs. So may `backend` ("cpu" or "gpu"), and observer settings
    // named by their path ("observers.chute.cg_width_over_length").
    let check_key = |section: &str, k: &str, problems: &mut Vec<FieldProblem>| {
        if !known.contains_key(k)
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
    let zip_len = c.zip.values().next().map_or(0, |v| v.len());
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
    if c.replicas == 0 {
        problems.push(FieldProblem {
            path: "replicas".into(),
            message: "expected at least 1 replica, got 0".into(),
        });
    }
    if let Some(message) = name_problem(&c.name) {
        problems.push(FieldProblem {
            path: "name".into(),
            message,
        });
    }
    if c.run.max_attempts == 0 {
        problems.push(FieldProblem {
            path: "run.max_attempts".into(),
            message:
                "expected at least 1 attempt per job (0 would register jobs that never run), got 0"
                    .into(),
        });
    }
    if !(c.run.checkpoint_interval_s > 0.0) {
        problems.push(FieldProblem {
            path: "run.checkpoint_interval_s".into(),
            message: format!("expected seconds > 0, got {}", c.run.checkpoint_interval_s),
        });
    }
    let d = &c.observers.discharge;
    for (name, v) in [
        ("sample_interval_s", d.sample_interval_s),
        ("clog_after_s", d.clog_after_s),
        ("permanent_clog_after_s", d.permanent_clog_after_s),
        ("block_s", d.block_s),
    ] {
        if !(v > 0.0) {
            problems.push(FieldProblem {
                path: format!("observers.discharge.{name}"),
                message: format!("expected seconds > 0, got {v}"),
            });
        }
    }
    if let Some(sn) = &c.observers.snapshots {
        for (field, message) in sn.problems() {
            problems.push(FieldProblem {
                path: format!("observers.snapshots.{field}"),
                message,
            });
        }
    }
    if let Some(f) = &c.observers.fields {
        if c.scene != SceneKind::Silo {
            problems.push(FieldProblem {
                path: "observers.fields".into(),
                message: format!(
                    "the fields observer is for silo campaigns, this one is {:?}",
                    c.scene.name()
                ),
            });
        }
        for (field, message) in f.problems() {
            problems.push(FieldProblem {
                path: format!("observers.fields.{field}"),
                message,
            });
        }
    }
    if let Some(ch) = &c.observers.chute {
        for p in ch.problems() {
            problems.push(FieldProblem {
                path: format!("observers.chute.{}", p.field),
                message: p.message,
            });
        }
    }
    if !problems.is_empty() {
        return Err(CampaignError::Invalid {
            file: file.into(),
            problems,
        });
    }

    // Points of the sweep: Cartesian product over `sweep` (keys in sorted order), crossed with
    // the zipped points. Each point remembers where each value came from, for error paths.
    type Point = Vec<(String, Value, String)>;
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
            for i in 0..zip_len {
                let mut q = p.clone();
                for (k, vals) in &c.zip {
                    q.push((k.clone(), vals[i].clone(), format!("zip.{k}[{i}]")));
                }
                next.push(q);
            }
        }
        points = next;
    }

    let mut jobs = Vec::new();
    for point in &points {
        for replica in 0..c.replicas {
            let mut obj = c.base.clone();
            for (k, v, _) in point {
                obj.insert(k.clone(), v.clone());
            }
            obj.insert("replica".into(), Value::from(replica));
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
                        continue;
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
                        continue;
                    }
                },
            };
            if backend == Some(JobBackend::Gpu) && precision == Precision::F64 {
                problems.push(FieldProblem {
                    path: source("backend"),
                    message: "the GPU engine runs f32: expected \"precision\": \"f32\" with \"backend\": \"gpu\"".into(),
                });
                continue;
            }
            let observer_keys: Vec<String> = obj
                .keys()
                .filter(|k| k.starts_with(OBSERVER_PREFIX))
                .cloned()
                .collect();
            let mut observer_values = Vec::new();
            for k in observer_keys {
                let v = obj.remove(&k).expect("listed");
                observer_values.push((k, v));
            }
            let problem = |e: serde_path_to_error::Error<serde_json::Error>| {
                let field = e.path().to_string();
                let field = field.split('.').next().unwrap_or("").to_string();
                FieldProblem {
                    path: source(&field),
                    message: e.into_inner().to_string(),
                }
            };
            let (silo, chute, field_errors) = match c.scene {
                SceneKind::Silo => {
                    match serde_path_to_error::deserialize::<_, SiloParams>(Value::Object(obj)) {
                        Ok(p) => {
                            let e = p.validate();
                            (Some(p), None, e)
                        }
                        Err(e) => {
                            problems.push(problem(e));
                            continue;
                        }
                    }
                }
                SceneKind::Chute => {
                    match serde_path_to_error::deserialize::<_, ChuteParams>(Value::Object(obj)) {
                        Ok(p) => {
                            let e = p.validate();
                            (None, Some(p), e)
                        }
                        Err(e) => {
                            problems.push(problem(e));
                            continue;
                        }
                    }
                }
            };
            for fe in field_errors {
                let p = FieldProblem {
                    path: source(&fe.field),
                    message: fe.message,
                };
                if !problems.contains(&p) {
                    problems.push(p);
                }
            }
            let mut label: Vec<String> = point.iter().map(|(k, v, _)| format!("{k}={v}")).collect();
            label.push(format!("replica={replica}"));
            let mut observers = c.observers.clone();
            if c.scene == SceneKind::Chute && observers.chute.is_none() {
                observers.chute = Some(Default::default());
            }
            if !observer_values.is_empty() {
                match with_observer_values(&observers, &observer_values) {
                    Ok(o) => observers = o,
                    Err(p) => {
                        let p = FieldProblem {
                            path: source(&p.path),
                            message: p.message,
                        };
                        if !problems.contains(&p) {
                            problems.push(p);
                        }
                        continue;
                    }
                }
            }
            if let (Some(f), Some(p)) = (&observers.fields, &silo) {
                for (field, message) in f.problems_with(p, &observers.discharge) {
                    let p = FieldProblem {
                        path: format!("observers.fields.{field}"),
                        message,
                    };
                    if !problems.contains(&p) {
                        problems.push(p);
                    }
                }
            }
            jobs.push(JobSpec {
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
            });
        }
    }
    if let Some(t) = &c.target {
        let own = jobs.iter().map(JobSpec::own_time_s).fold(0.0, f64::max);
        problems.extend(t.problems(c.scene, c.replicas, own));
        if t.decides_claims() && c.claims.is_empty() {
            problems.push(FieldProblem {
                path: "target.claims".into(),
                message: "\"decided\" needs claims: expected a non-empty top-level `claims` list"
                    .into(),
            });
        }
    }
    problems.extend(super::claims::problems(c, &jobs));
    if !problems.is_empty() {
        return Err(CampaignError::Invalid {
            file: file.into(),
            problems,
        });
    }
    Ok(jobs)
}

/// Campaign keys that set an observer setting by its path.
const OBSERVER_PREFIX: &str = "observers.";

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
