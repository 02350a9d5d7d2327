//! Choosing the backend for a job: `--backend auto|gpu|cpu`, `--gpu N`, `--allow-software-gpu`
//! and the job's precision. `gpu` takes the best adapter (or adapter N as `sweep info` numbers
//! them) and refuses a software one (lavapipe, llvmpipe) unless `--allow-software-gpu` or
//! `SWEEP_ALLOW_SOFTWARE_GPU=1` allows it; `auto` takes the GPU only when it is a discrete or
//! integrated one and the job runs in f32, otherwise the CPU, and says why (`Fallback`), on
//! stderr once and in the job's record. Both scenes alike: the GPU kernels hold spheres and
//! spherocylinders.

pub use super::auto_choice::{
    announce_auto, auto_decision, auto_summary, describe, say_once, AdapterSummary, Fallback,
};
use super::auto_choice::{auto_note, check_index};
use super::gpu_batch::GpuBatches;
use crate::campaign::Precision;
use crate::engine::gpu::{enumerate_adapters, vulkan_driver_files, GpuDevice, GpuEngine};
use crate::engine::{Backend, CpuEngine, EngineConfig, State};

/// The environment variable that allows a software adapter as `--allow-software-gpu` does
/// (for Slurm scripts and CI): any value but empty, `0`, `false`, `no` or `off`.
pub const ALLOW_SOFTWARE_ENV: &str = "SWEEP_ALLOW_SOFTWARE_GPU";

/// Which GPU adapter a job may take (`--gpu N`, `--allow-software-gpu`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct GpuSelect {
    /// The adapter numbered N by `sweep info`; None: the best one.
    #[serde(default)]
    pub index: Option<usize>,
    /// `--backend gpu` may run on a software adapter.
    #[serde(default)]
    pub allow_software: bool,
}

impl GpuSelect {
    /// Whether a software adapter is allowed: the flag, or `SWEEP_ALLOW_SOFTWARE_GPU`.
    pub fn allows_software(&self) -> bool {
        self.allow_software || env_allows_software()
    }
}

fn env_allows_software() -> bool {
    std::env::var(ALLOW_SOFTWARE_ENV).is_ok_and(|v| {
        !matches!(
            v.trim().to_ascii_lowercase().as_str(),
            "" | "0" | "false" | "no" | "off"
        )
    })
}

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

fn cpu(
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Box<dyn Backend>> {
    Ok(match precision {
        Precision::F64 => Box::new(CpuEngine::<f64>::try_new(config, state.convert(), threads)?),
        Precision::F32 => Box::new(CpuEngine::<f32>::try_new(config, state.convert(), threads)?),
    })
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
        super::gpu_variants::gpu_options()?,
    )?))
}

/// The device `--backend gpu` runs on, and a note when it is a software adapter.
pub fn gpu_device(select: &GpuSelect) -> anyhow::Result<(GpuDevice, Option<String>)> {
    let adapters = enumerate_adapters();
    let k = match select.index {
        Some(n) => check_index(n, adapters.len())?,
        None => match adapters.iter().position(|(_, r)| r.unusable.is_none()) {
            Some(k) => k,
            None => {
                let summaries: Vec<AdapterSummary> = adapters
                    .iter()
                    .map(|(_, r)| AdapterSummary::of(r))
                    .collect();
                let files = vulkan_driver_files().len();
                let why = auto_decision(&summaries, Precision::F32, None, files)
                    .err()
                    .map_or_else(|| "no usable adapter".into(), |f| f.to_string());
                anyhow::bail!(
                    "--backend gpu: {why} (on Debian, `apt-get install mesa-vulkan-drivers` provides the lavapipe software adapter)"
                );
            }
        },
    };
    let (adapter, report) = &adapters[k];
    let name = describe(&report.info);
    if let Some(why) = &report.unusable {
        anyhow::bail!("--backend gpu: adapter [{k}] {name} cannot run the kernels: {why}");
    }
    let mut note = None;
    if !report.hardware {
        if !select.allows_software() {
            anyhow::bail!(
                "--backend gpu: adapter [{k}] {name} is a software adapter, correct but no faster than the CPU; pass --allow-software-gpu (or set {ALLOW_SOFTWARE_ENV}=1) to run on it anyway, or use --backend cpu"
            );
        }
        note = Some(format!(
            "--backend gpu: the software adapter [{k}] {name}, as allowed: correct but no faster than the CPU"
        ));
    }
    Ok((GpuDevice::from_adapter(adapter)?, note))
}

/// The device `--backend auto` runs an f32 job on, or why it takes the CPU.
///
/// # Errors
/// `--gpu N` out of range.
fn auto_device(
    select: &GpuSelect,
    precision: Precision,
) -> anyhow::Result<Result<GpuDevice, Fallback>> {
    if precision == Precision::F64 {
        return Ok(Err(Fallback::F64));
    }
    let adapters = enumerate_adapters();
    if let Some(n) = select.index {
        check_index(n, adapters.len())?;
    }
    let summaries: Vec<AdapterSummary> = adapters
        .iter()
        .map(|(_, r)| AdapterSummary::of(r))
        .collect();
    let files = if adapters.is_empty() {
        vulkan_driver_files().len()
    } else {
        0
    };
    Ok(
        auto_decision(&summaries, precision, select.index, files).and_then(|k| {
            GpuDevice::from_adapter(&adapters[k].0).map_err(|e| Fallback::Device(e.to_string()))
        }),
    )
}

/// A backend and what is to be said about the choice (why `auto` took the CPU, a software
/// adapter allowed): printed once on stderr, kept in the job's record.
pub struct Built {
    pub engine: Box<dyn Backend>,
    pub note: Option<String>,
}

/// Builds the backend for a job, on the best adapter (`SWEEP_ALLOW_SOFTWARE_GPU` alone decides
/// on a software one); the note, if any, is printed once on stderr.
///
/// # Errors
/// As [`build_on`].
pub fn build(
    choice: BackendChoice,
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Box<dyn Backend>> {
    build_with(
        choice,
        &GpuSelect::default(),
        precision,
        config,
        state,
        threads,
    )
}

/// [`build_on`] with the note, if any, printed once on stderr.
///
/// # Errors
/// As [`build_on`].
pub fn build_with(
    choice: BackendChoice,
    select: &GpuSelect,
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Box<dyn Backend>> {
    let b = build_on(choice, select, precision, config, state, threads)?;
    if let Some(n) = &b.note {
        say_once(n, &|s| eprintln!("{s}"));
    }
    Ok(b.engine)
}

/// Builds the backend for a job on the adapter `select` allows; the note is the caller's to
/// show and keep.
///
/// # Errors
/// `gpu` with an f64 job (the GPU backend runs f32), a software adapter not allowed, no usable
/// adapter, `--gpu N` out of range, or a device failure.
pub fn build_on(
    choice: BackendChoice,
    select: &GpuSelect,
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Built> {
    build_shared(choice, select, None, precision, config, state, threads)
}

/// Where a job runs: a GPU, or the CPU with `auto`'s reason.
enum Placement {
    Gpu(Box<GpuDevice>, Option<String>),
    Cpu(Option<String>),
}

/// Resolves `choice` for a job of `precision` to a device (its batches' when given; a batch
/// keeps the first device auto found, a later job's own is dropped).
fn place(
    choice: BackendChoice,
    select: &GpuSelect,
    batches: Option<&GpuBatches>,
    precision: Precision,
) -> anyhow::Result<Placement> {
    match choice {
        BackendChoice::Cpu => Ok(Placement::Cpu(None)),
        BackendChoice::Gpu => {
            if precision == Precision::F64 {
                anyhow::bail!(
                    "the GPU backend runs f32, this job asks for f64: use \"run\": {{\"precision\": \"f32\"}} in the campaign (--precision f32 for sweep bench), or --backend cpu"
                );
            }
            let (dev, note) = match batches {
                Some(b) => b.device(|| gpu_device(select))?,
                None => gpu_device(select)?,
            };
            Ok(Placement::Gpu(Box::new(dev), note))
        }
        BackendChoice::Auto => Ok(match (auto_device(select, precision)?, batches) {
            (Ok(dev), Some(b)) => Placement::Gpu(Box::new(b.device(|| Ok((dev, None)))?.0), None),
            (Ok(dev), None) => Placement::Gpu(Box::new(dev), None),
            (Err(why), _) => Placement::Cpu(Some(auto_note(&why))),
        }),
    }
}

/// The GPU a job runs on (its batches' when given), or None where it runs on the CPU: what its
/// fill stage runs on too.
///
/// # Errors
/// As [`build_on`].
pub fn job_device(
    choice: BackendChoice,
    select: &GpuSelect,
    batches: Option<&GpuBatches>,
    precision: Precision,
) -> anyhow::Result<Option<GpuDevice>> {
    Ok(match place(choice, select, batches, precision)? {
        Placement::Gpu(dev, _) => Some(*dev),
        Placement::Cpu(_) => None,
    })
}

/// [`build_on`], and a GPU job joins one of `batches` (one device, engines shared by the jobs
/// running at the same time) when given.
///
/// # Errors
/// As [`build_on`].
pub fn build_shared(
    choice: BackendChoice,
    select: &GpuSelect,
    batches: Option<&GpuBatches>,
    precision: Precision,
    config: EngineConfig,
    state: &State<f64>,
    threads: usize,
) -> anyhow::Result<Built> {
    Ok(match place(choice, select, batches, precision)? {
        Placement::Gpu(dev, note) => Built {
            engine: match batches {
                Some(b) => b.join(&dev, config, state)?,
                None => gpu(&dev, config, state)?,
            },
            note,
        },
        Placement::Cpu(note) => Built {
            engine: cpu(precision, config, state, threads)?,
            note,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_environment_variable_allows_software() {
        // Only the parsing: the variable itself is the process's, shared by parallel tests.
        let off = GpuSelect::default();
        let on = GpuSelect {
            allow_software: true,
            ..off
        };
        assert!(on.allows_software());
        assert_eq!(off.allows_software(), env_allows_software());
    }
}
