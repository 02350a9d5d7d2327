//! Choosing the backend for a job: `--backend auto|gpu|cpu` and the job's precision.

use crate::campaign::Precision;
use crate::engine::{Backend, CpuEngine, EngineConfig, State};

/// What the user asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BackendChoice {
    Auto,
    Gpu,
    Cpu,
}

impl std::str::FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "gpu" => Ok(Self::Gpu),
            "cpu" => Ok(Self::Cpu),
            _ => Err(format!("expected auto, gpu or cpu, got {s:?}")),
        }
    }
}

/// Builds the backend for a job.
///
/// # Errors
/// `gpu` was asked for but this build has no GPU backend yet.
pub fn build(
    choice: BackendChoice,
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Box<dyn Backend>> {
    match choice {
        BackendChoice::Gpu => anyhow::bail!(
            "the GPU backend is not available in this build yet; run with --backend cpu (or auto)"
        ),
        BackendChoice::Auto | BackendChoice::Cpu => Ok(match precision {
            Precision::F64 => Box::new(CpuEngine::<f64>::new(config, state.convert(), threads)),
            Precision::F32 => Box::new(CpuEngine::<f32>::new(config, state.convert(), threads)),
        }),
    }
}
