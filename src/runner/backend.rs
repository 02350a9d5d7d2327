//! Choosing the backend for a job: `--backend auto|gpu|cpu`, `--gpu N`, `--allow-software-gpu`
//! and the job's precision. `gpu` takes the best adapter (or adapter N as `sweep info` numbers
//! them) and refuses a software one (lavapipe, llvmpipe) unless `--allow-software-gpu` or
//! `SWEEP_ALLOW_SOFTWARE_GPU=1` allows it; `auto` takes the GPU only when it is a discrete or
//! integrated one and the job runs in f32, otherwise the CPU, and says why (`Fallback`), on
//! stderr once and in the job's record. Both scenes alike: the GPU kernels hold spheres and
//! spherocylinders.

use std::collections::BTreeSet;
use std::sync::Mutex;

use super::gpu_batch::GpuBatches;
use crate::campaign::Precision;
use crate::engine::gpu::{
    enumerate_adapters, list_adapters, vulkan_driver_files, AdapterReport, GpuDevice, GpuEngine,
    VULKAN_ICD_DIRS,
};
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

/// An adapter as the backend choice sees it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Name, API and kind: "llvmpipe (LLVM 15.0.7, 256 bits) (Vulkan, Cpu)".
    pub name: String,
    /// Discrete or integrated GPU.
    pub hardware: bool,
    /// Why the engine cannot use it, if it cannot.
    pub unusable: Option<String>,
}

impl AdapterSummary {
    pub fn of(r: &AdapterReport) -> Self {
        Self {
            name: describe(&r.info),
            hardware: r.hardware,
            unusable: r.unusable.clone(),
        }
    }
}

/// An adapter's name, API and kind, as messages give it.
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}

/// Why `--backend auto` runs a job on the CPU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Fallback {
    /// The job runs in f64; the GPU backend runs f32.
    F64,
    /// No adapter, and no Vulkan driver manifest where the loader looks.
    NoDriver,
    /// No adapter, though this many Vulkan driver manifests exist.
    NoAdapter { driver_files: usize },
    /// The usable adapters are all software or virtual ones (named).
    OnlySoftware(Vec<String>),
    /// `--gpu N` names a software or virtual adapter.
    NotHardware { index: usize, name: String },
    /// No adapter can run the kernels ("name: why" each).
    Unusable(Vec<String>),
    /// The device could not be created (wgpu's message).
    Device(String),
}

impl std::fmt::Display for Fallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::F64 => write!(f, "the job runs in f64 and the GPU backend runs f32"),
            Self::NoDriver => write!(
                f,
                "no GPU adapter and no Vulkan driver: no ICD file in VK_DRIVER_FILES / VK_ICD_FILENAMES or {} (install the GPU's Vulkan driver)",
                VULKAN_ICD_DIRS.join(", ")
            ),
            Self::NoAdapter { driver_files } => write!(
                f,
                "no GPU adapter, though {driver_files} Vulkan driver file(s) are installed (`sweep info` lists what wgpu sees)"
            ),
            Self::OnlySoftware(names) => write!(
                f,
                "only a software adapter ({}): `--backend gpu --allow-software-gpu` runs on it",
                names.join("; ")
            ),
            Self::NotHardware { index, name } => write!(
                f,
                "--gpu {index} is a software adapter ({name}), which auto does not take"
            ),
            Self::Unusable(why) => write!(f, "no GPU adapter can run the kernels: {}", why.join("; ")),
            Self::Device(e) => write!(f, "the GPU device could not be created: {e}"),
        }
    }
}

/// What `--backend auto` does with a job: the number of the adapter it runs on, or why it runs
/// on the CPU. `adapters` best first (as `list_adapters` gives them), `index` the `--gpu N`
/// asked for (in range), `driver_files` the Vulkan driver manifests found (read when
/// `adapters` is empty).
///
/// # Errors
/// The reason for the CPU.
pub fn auto_decision(
    adapters: &[AdapterSummary],
    precision: Precision,
    index: Option<usize>,
    driver_files: usize,
) -> Result<usize, Fallback> {
    if precision == Precision::F64 {
        return Err(Fallback::F64);
    }
    if adapters.is_empty() {
        return Err(if driver_files == 0 {
            Fallback::NoDriver
        } else {
            Fallback::NoAdapter { driver_files }
        });
    }
    let candidates: Vec<(usize, &AdapterSummary)> = match index {
        Some(n) => adapters.get(n).map(|a| (n, a)).into_iter().collect(),
        None => adapters.iter().enumerate().collect(),
    };
    if let Some((k, _)) = candidates
        .iter()
        .find(|(_, a)| a.hardware && a.unusable.is_none())
    {
        return Ok(*k);
    }
    let software: Vec<&AdapterSummary> = candidates
        .iter()
        .map(|(_, a)| *a)
        .filter(|a| a.unusable.is_none())
        .collect();
    match (index, software.first()) {
        (Some(n), Some(a)) => Err(Fallback::NotHardware {
            index: n,
            name: a.name.clone(),
        }),
        (None, Some(_)) => Err(Fallback::OnlySoftware(
            software.iter().map(|a| a.name.clone()).collect(),
        )),
        (_, None) => Err(Fallback::Unusable(
            candidates
                .iter()
                .map(|(_, a)| {
                    format!(
                        "{}: {}",
                        a.name,
                        a.unusable.as_deref().unwrap_or("unusable")
                    )
                })
                .collect(),
        )),
    }
}

/// `--gpu N` checked against the adapters there are.
fn check_index(n: usize, count: usize) -> anyhow::Result<usize> {
    if n < count {
        return Ok(n);
    }
    match count {
        0 => anyhow::bail!("--gpu {n}: wgpu sees no GPU adapter here (`sweep info` lists them)"),
        _ => anyhow::bail!(
            "--gpu {n}: there is no adapter {n}: wgpu sees {count} adapter(s), numbered 0 to {} as `sweep info` lists them",
            count - 1
        ),
    }
}

/// The adapters here, and what `--backend auto` does with an f32 job on them.
fn auto_here(index: Option<usize>) -> (Vec<AdapterSummary>, Result<usize, Fallback>) {
    let adapters: Vec<AdapterSummary> = list_adapters().iter().map(AdapterSummary::of).collect();
    // Driver files matter only to say why no adapter was found.
    let files = if adapters.is_empty() {
        vulkan_driver_files().len()
    } else {
        0
    };
    let decision = auto_decision(&adapters, Precision::F32, index, files);
    (adapters, decision)
}

/// What `--backend auto` resolves to on this machine, in words (for launch and `sweep info`).
pub fn auto_summary(index: Option<usize>) -> String {
    let (adapters, decision) = auto_here(index);
    if let Some(n) = index {
        if let Err(e) = check_index(n, adapters.len()) {
            return format!("{e:#}");
        }
    }
    match decision {
        Ok(k) => format!(
            "GPU [{k}] {} for f32 jobs, the CPU for f64 jobs",
            adapters[k].name
        ),
        Err(why) => format!("every job runs on the CPU: {why}"),
    }
}

/// The note of a job `--backend auto` runs on the CPU.
fn auto_note(why: &Fallback) -> String {
    format!("--backend auto: the CPU, because {why}")
}

/// Says on stderr what `--backend auto` does with f32 jobs here (a launch's first line): the
/// GPU it takes, or why every job runs on the CPU (then said once only, not again per job).
pub fn announce_auto(index: Option<usize>) {
    let (adapters, decision) = auto_here(index);
    if index.is_some_and(|n| n >= adapters.len()) {
        return; // Each job fails with the reason.
    }
    match decision {
        Ok(k) => eprintln!(
            "sweep: --backend auto: GPU [{k}] {} for f32 jobs, the CPU for f64 jobs",
            adapters[k].name
        ),
        Err(why) => {
            say_once(&auto_note(&why), &|s| eprintln!("{s}"));
        }
    }
}

/// Prints `note` on stderr (through `print`) unless this process printed it already; returns
/// whether it printed.
pub fn say_once(note: &str, print: &dyn Fn(String)) -> bool {
    static SAID: Mutex<BTreeSet<String>> = Mutex::new(BTreeSet::new());
    let first = SAID
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .insert(note.to_string());
    if first {
        print(format!("sweep: {note}"));
    }
    first
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

    fn a(name: &str, hardware: bool, unusable: Option<&str>) -> AdapterSummary {
        AdapterSummary {
            name: name.into(),
            hardware,
            unusable: unusable.map(String::from),
        }
    }

    #[test]
    fn auto_says_why_it_takes_the_cpu() {
        let lavapipe = a(
            "llvmpipe (LLVM 15.0.7, 256 bits) (Vulkan, Cpu)",
            false,
            None,
        );
        let card = a("NVIDIA H100 (Vulkan, DiscreteGpu)", true, None);
        let small = a(
            "Old iGPU (Gl, IntegratedGpu)",
            true,
            Some("no compute shaders"),
        );
        let f32 = Precision::F32;
        assert_eq!(
            auto_decision(std::slice::from_ref(&card), f32, None, 0),
            Ok(0)
        );
        assert_eq!(
            auto_decision(&[card.clone(), lavapipe.clone()], f32, Some(1), 0),
            Err(Fallback::NotHardware {
                index: 1,
                name: lavapipe.name.clone()
            })
        );
        assert_eq!(
            auto_decision(std::slice::from_ref(&card), Precision::F64, None, 0),
            Err(Fallback::F64)
        );
        assert_eq!(auto_decision(&[], f32, None, 0), Err(Fallback::NoDriver));
        assert_eq!(
            auto_decision(&[], f32, None, 2),
            Err(Fallback::NoAdapter { driver_files: 2 })
        );
        let only_soft = auto_decision(&[lavapipe.clone(), small.clone()], f32, None, 1);
        assert_eq!(
            only_soft,
            Err(Fallback::OnlySoftware(vec![lavapipe.name.clone()]))
        );
        let text = only_soft.unwrap_err().to_string();
        assert!(
            text.starts_with("only a software adapter (llvmpipe")
                && text.contains("--allow-software-gpu"),
            "{text}"
        );
        assert_eq!(
            auto_decision(std::slice::from_ref(&small), f32, None, 1),
            Err(Fallback::Unusable(vec![format!(
                "{}: no compute shaders",
                small.name
            )]))
        );
        assert!(Fallback::NoDriver.to_string().contains("/etc/vulkan/icd.d"));
        assert!(Fallback::F64.to_string().contains("f64"));
    }

    #[test]
    fn gpu_numbers_out_of_range_are_refused_with_the_count() {
        assert_eq!(check_index(1, 2).unwrap(), 1);
        let e = check_index(99, 2).unwrap_err().to_string();
        assert!(
            e.contains("--gpu 99") && e.contains("2 adapter(s)") && e.contains("0 to 1"),
            "{e}"
        );
        let e = check_index(0, 0).unwrap_err().to_string();
        assert!(e.contains("no GPU adapter"), "{e}");
    }

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
