//! A fully resolved job: its scene's parameters, observers, precision and backend, with the
//! label and value sources of its point of the sweep.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use sha2::{Digest, Sha256};

use super::file::{JobBackend, Observers, Precision, SceneKind};
use super::identity::{canonical_zeros, hex, seed_of, Identity};
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

/// A job's own directory (checkpoints, snapshots, its lock) under the work directory: the first
/// 16 hex digits of its hash.
pub fn job_dir(work: &std::path::Path, hash: &str) -> std::path::PathBuf {
    work.join("jobs").join(&hash[..16])
}
