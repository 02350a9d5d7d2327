//! Where `--backend auto` puts a job, and why: the adapters as the choice sees them
//! (`AdapterSummary`), the reasons for the CPU (`Fallback`), the decision and the note said once
//! on stderr.

use std::collections::BTreeSet;
use std::sync::Mutex;

use crate::campaign::Precision;
use crate::engine::gpu::{list_adapters, vulkan_driver_files, AdapterReport, VULKAN_ICD_DIRS};

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
pub(super) fn check_index(n: usize, count: usize) -> anyhow::Result<usize> {
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
pub(super) fn auto_note(why: &Fallback) -> String {
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
}
