//! Expansion of a campaign into jobs: base ⊕ one point of the sweep, validated; the job's
//! identity is the SHA-256 of its resolved parameters (canonical JSON), and its seed derives from
//! that hash, so the same parameters always give the same job and the same random packing.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use sha2::{Digest, Sha256};

use super::error::{CampaignError, FieldProblem};
use super::file::{CampaignFile, Observers, Precision, SceneKind};
use crate::scene::{ChuteParams, SiloParams};

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
    /// Human-readable point of the sweep, e.g. "orifice_diameter_m=0.015,rotation_frequency_hz=0.5,replica=0".
    #[serde(skip)]
    pub label: String,
}

impl JobSpec {
    /// Canonical JSON of everything that determines the job's results.
    pub fn resolved_json(&self) -> String {
        // serde_json maps are sorted (no preserve_order feature), so this is canonical.
        let v = serde_json::to_value(self).expect("serializable");
        serde_json::to_string(&v).expect("serializable")
    }

    /// SHA-256 of the resolved parameters, hex.
    pub fn hash(&self) -> String {
        hex(&Sha256::digest(self.resolved_json().as_bytes()))
    }

    /// Seed of the job's random choices (packing), from its parameters.
    pub fn seed(&self) -> u64 {
        let h = Sha256::digest(self.resolved_json().as_bytes());
        u64::from_le_bytes(h[..8].try_into().expect("8 bytes"))
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

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
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
    let known: Map<String, Value> = match defaults {
        Ok(Value::Object(m)) => m,
        _ => Map::new(),
    };
    // `precision` may also be swept (an accuracy study compares f64 with f32); it overrides
    // `run.precision` for its jobs.
    let check_key = |section: &str, k: &str, problems: &mut Vec<FieldProblem>| {
        if !known.contains_key(k) && k != "precision" {
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
            jobs.push(JobSpec {
                scene: c.scene,
                silo,
                chute,
                observers,
                precision,
                label: label.join(","),
            });
        }
    }
    if !problems.is_empty() {
        return Err(CampaignError::Invalid {
            file: file.into(),
            problems,
        });
    }
    Ok(jobs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Vec<JobSpec>, CampaignError> {
        let c = CampaignFile::parse_str(s, "t.json")?;
        expand(&c, "t.json")
    }

    #[test]
    fn cartesian_product_and_stable_hashes() {
        let s = r#"{"name":"a","scene":"silo","base":{"particle_count":100},
            "sweep":{"orifice_diameter_m":[0.02,0.03],"rotation_frequency_hz":[0,0.5,1]},"replicas":2}"#;
        let jobs = parse(s).unwrap();
        assert_eq!(jobs.len(), 12);
        let again = parse(s).unwrap();
        assert_eq!(
            jobs.iter().map(|j| j.hash()).collect::<Vec<_>>(),
            again.iter().map(|j| j.hash()).collect::<Vec<_>>()
        );
        let mut hashes: Vec<String> = jobs.iter().map(|j| j.hash()).collect();
        hashes.sort();
        hashes.dedup();
        assert_eq!(hashes.len(), 12, "every job distinct");
        // Fill stage shared across D and f, not across replicas.
        let keys: std::collections::BTreeSet<String> =
            jobs.iter().map(|j| j.fill_key().0).collect();
        assert_eq!(keys.len(), 2);
    }

    #[test]
    fn errors_name_the_path() {
        let e = parse(
            r#"{"name":"a","scene":"silo","sweep":{"orifice_diameter_m":[0.02,0.03,-0.01]}}"#,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("sweep.orifice_diameter_m[2]") && e.contains("expected metres > 0"),
            "{e}"
        );
        let e = parse(r#"{"name":"a","scene":"silo","sweep":{"orifice_diameter_m":[]}}"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sweep.orifice_diameter_m") && e.contains("non-empty"),
            "{e}"
        );
        let e = parse(r#"{"name":"a","scene":"silo","base":{"orifice_diameter_m":"big"}}"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("base.orifice_diameter_m") && e.contains("invalid type"),
            "{e}"
        );
        let e = parse(r#"{"name":"a","scene":"silo","bogus":1}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `bogus`"), "{e}");
        let e = parse(r#"{"scene":"silo"}"#).unwrap_err().to_string();
        assert!(e.contains("missing field `name`"), "{e}");
        let e = parse(r#"{"name":"a","scene":"silo","base":{"orifice_diam":0.1}}"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("base.orifice_diam") && e.contains("unknown"),
            "{e}"
        );
    }
}
