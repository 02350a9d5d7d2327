//! The scene kinds a campaign can run.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Scene kinds a campaign can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SceneKind {
    /// Silo with a rotating bottom (PRE 2020); parameters: see `SiloParams`.
    Silo,
    /// Chute flow of spherocylinders (Soft Matter 2022); parameters: see `ChuteParams`.
    Chute,
}

impl SceneKind {
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Silo => "silo",
            SceneKind::Chute => "chute",
        }
    }
}
