//! The campaign file format (JSON, unknown keys refused). `sweep schema` prints its JSON Schema.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::error::{CampaignError, FieldProblem};
use super::executor::{ExecutorKind, SlurmSettings};
pub use super::scene_kind::SceneKind;
use crate::observe::chute::ChuteObserverSettings;
use crate::observe::discharge::DischargeSettings;
use crate::observe::silo_fields::SiloFieldSettings;
use crate::observe::snapshots::SnapshotSettings;

/// Floating-point precision of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// Reference precision (CPU only).
    #[default]
    F64,
    /// Fast precision (CPU and GPU).
    F32,
}

impl Precision {
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::F32 => "f32",
        }
    }
}

/// Which engine a job must run on, when the campaign says so (an accuracy study comparing CPU
/// and GPU f32); jobs without it run where `sweep launch --backend` puts them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobBackend {
    /// The CPU engine (rayon).
    Cpu,
    /// The GPU engine (wgpu; f32 only; a software adapter only with `--allow-software-gpu`).
    Gpu,
}

impl JobBackend {
    pub fn name(self) -> &'static str {
        match self {
            JobBackend::Cpu => "cpu",
            JobBackend::Gpu => "gpu",
        }
    }
}

/// Observers and their settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Observers {
    /// M(t), clogs and Q (silo).
    pub discharge: DischargeSettings,
    /// MSD, D(z), coarse-grained profiles, v_z statistics, C(r) (chute). Absent from a silo
    /// job's recorded parameters (so silo job identities do not depend on it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chute: Option<ChuteObserverSettings>,
    /// Particle snapshots every `interval_s` (for `sweep export --vtk`); absent: none. Absent
    /// from the recorded parameters of jobs without it (so their identities are unchanged).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapshots: Option<SnapshotSettings>,
    /// Coarse-grained fields of the silo (φ, P, V, σᵏ, σᶜ on request; fig6–fig11); absent:
    /// none. Absent from the recorded parameters of jobs without it (identities unchanged).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fields: Option<SiloFieldSettings>,
}

/// How jobs run (none of these change results except `precision`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RunSettings {
    /// Precision (part of a job's identity: it changes results).
    pub precision: Precision,
    /// A checkpoint is written every this many simulated seconds (and on SIGINT/SIGTERM).
    pub checkpoint_interval_s: f64,
    /// A failed job is retried by `sweep resume` up to this many attempts in all.
    pub max_attempts: u32,
    /// Where jobs run: "local" (this machine) or "slurm" (job arrays); `--executor` overrides.
    pub executor: ExecutorKind,
    /// How jobs are handed to Slurm (with executor "slurm"); command-line flags override.
    pub slurm: SlurmSettings,
}

impl Default for RunSettings {
    fn default() -> Self {
        Self {
            precision: Precision::F64,
            checkpoint_interval_s: 0.5,
            max_attempts: 3,
            executor: ExecutorKind::Local,
            slurm: SlurmSettings::default(),
        }
    }
}

fn one() -> u32 {
    1
}

fn is_zero(v: &u32) -> bool {
    *v == 0
}

/// A campaign file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    /// Unique name of the campaign in the database.
    pub name: String,
    pub scene: SceneKind,
    /// Free text, kept with the campaign.
    #[serde(default)]
    pub description: String,
    /// Parameters shared by every job (scene parameter names; unset ones take the paper's value).
    #[serde(default)]
    pub base: serde_json::Map<String, serde_json::Value>,
    /// Cartesian product: every combination of these lists is a job.
    #[serde(default)]
    pub sweep: BTreeMap<String, Vec<serde_json::Value>>,
    /// Lists of equal length that move together (the k-th values form one point), crossed
    /// with `sweep`.
    #[serde(default)]
    pub zip: BTreeMap<String, Vec<serde_json::Value>>,
    /// Independent replicas of every point (different seeds).
    #[serde(default = "one")]
    pub replicas: u32,
    /// The index of each point's first replica (replicas `first_replica`,
    /// `first_replica + 1`, …). A job's seed comes from its parameters and its replica index, so
    /// a campaign that repeats another's points with fresh random numbers (an independent
    /// experiment, with claims of its own) starts past the other's replicas.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub first_replica: u32,
    #[serde(default)]
    pub observers: Observers,
    #[serde(default)]
    pub run: RunSettings,
    /// The confidence each point's result must reach; sweep adds work (longer runs, replicas)
    /// until it does or a cap is reached. Absent: the jobs run as written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<super::target::Target>,
    /// The paper's statements this campaign decides, each with one test on pooled results
    /// (`compare`, `trend`, `minimum_inside`, `fit`). Part of the file's version, not of any
    /// job's identity. With `"target": {"claims": "decided"}` sweep adds work until each is
    /// supported or contradicted.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub claims: Vec<crate::observe::claims::Claim>,
}

impl CampaignFile {
    /// Parses a campaign from text; `file` names it in errors.
    ///
    /// # Errors
    /// Not JSON, a wrong type, a missing field, an unknown key or a key given twice in one
    /// object, with its JSON path.
    pub fn parse_str(text: &str, file: &str) -> Result<Self, CampaignError> {
        let repeated = super::duplicates::duplicate_keys(text);
        if !repeated.is_empty() {
            return Err(CampaignError::Invalid {
                file: file.to_string(),
                problems: repeated
                    .into_iter()
                    .map(|path| FieldProblem {
                        path,
                        message: "duplicate key: this object already has it, and JSON would \
                                  silently keep only the last value; expected each key once"
                            .into(),
                    })
                    .collect(),
            });
        }
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            let path = if path == "." {
                "(top level)".to_string()
            } else {
                path
            };
            CampaignError::Parse {
                file: file.to_string(),
                path,
                message: inner.to_string(),
            }
        })
    }
}
