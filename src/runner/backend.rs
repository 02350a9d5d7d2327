//! Choosing the backend for a job: `--backend auto|gpu|cpu` and the job's precision. `gpu` takes
//! any adapter that can run the kernels (a software one such as lavapipe too, said on stderr);
//! `auto` takes the GPU only when a discrete or integrated one exists and the job runs in f32,
//! otherwise the CPU. Both scenes alike: the GPU kernels hold spheres and spherocylinders.

use crate::campaign::Precision;
use crate::engine::gpu::{list_adapters, AdapterPolicy, GpuDevice, GpuEngine, GpuOptions};
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

/// The backend a job runs on: the one its campaign fixes (`"backend": "cpu" | "gpu"`, part of
/// its identity), else the one `sweep launch --backend` asked for.
pub fn for_job(spec: &crate::campaign::JobSpec, asked: BackendChoice) -> BackendChoice {
    match spec.backend {
        Some(crate::campaign::JobBackend::Cpu) => BackendChoice::Cpu,
        Some(crate::campaign::JobBackend::Gpu) => BackendChoice::Gpu,
        None => asked,
    }
}

/// What `--backend auto` resolves to on this machine, in words (for launch and `sweep info`).
pub fn auto_summary() -> String {
    match list_adapters()
        .into_iter()
        .find(|a| a.hardware && a.unusable.is_none())
    {
        Some(a) => format!(
            "GPU {} ({:?}) for f32 jobs, the CPU for f64 jobs",
            a.info.name, a.info.backend
        ),
        None => "no discrete or integrated GPU adapter: every job runs on the CPU".into(),
    }
}

fn cpu(
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> Box<dyn Backend> {
    match precision {
        Precision::F64 => Box::new(CpuEngine::<f64>::new(config, state.convert(), threads)),
        Precision::F32 => Box::new(CpuEngine::<f32>::new(config, state.convert(), threads)),
    }
}

fn gpu(
    dev: &GpuDevice,
    config: EngineConfig,
    state: &State<f64>,
) -> anyhow::Result<Box<dyn Backend>> {
    Ok(Box::new(GpuEngine::new(
        dev,
        config,
        state,
        GpuOptions::default(),
    )?))
}

/// Builds the backend for a job.
///
/// # Errors
/// `gpu` with an f64 job (the GPU backend runs f32), no usable adapter, or a device failure.
pub fn build(
    choice: BackendChoice,
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Box<dyn Backend>> {
    match choice {
        BackendChoice::Cpu => Ok(cpu(precision, config, state, threads)),
        BackendChoice::Gpu => {
            if precision == Precision::F64 {
                anyhow::bail!(
                    "the GPU backend runs f32, this job asks for f64: use \"run\": {{\"precision\": \"f32\"}} in the campaign (--precision f32 for sweep bench), or --backend cpu"
                );
            }
            let dev = GpuDevice::acquire(AdapterPolicy::Any)?;
            if !dev.is_hardware() {
                eprintln!(
                    "sweep: --backend gpu: using the software adapter {} ({:?}, {:?}): correct but no faster than the CPU",
                    dev.info.name, dev.info.backend, dev.info.device_type
                );
            }
            gpu(&dev, config, state)
        }
        BackendChoice::Auto => {
            if precision == Precision::F32 {
                if let Ok(dev) = GpuDevice::acquire(AdapterPolicy::Hardware) {
                    return gpu(&dev, config, state);
                }
            }
            Ok(cpu(precision, config, state, threads))
        }
    }
}
