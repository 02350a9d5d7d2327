//! Adapter discovery and device acquisition, kept apart from the work so that tests share one
//! device and `sweep info` can list what is there. The instance is built from the environment
//! (`WGPU_BACKEND`, `WGPU_ADAPTER_NAME`, …), so a user can pick a backend without a rebuild.
//! Device errors are not allowed to panic in wgpu's default handler: they are recorded here and
//! turned into `EngineError::Device` by the engine at the next chunk.

use std::sync::{Arc, Mutex};

use crate::engine::backend::EngineError;

/// Which adapters an acquisition accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdapterPolicy {
    /// Only a discrete or integrated GPU (what `--backend auto` wants).
    Hardware,
    /// Any adapter that can run the kernels, software rasterisers such as lavapipe included
    /// (what `--backend gpu` accepts).
    Any,
}

/// One adapter as `sweep info` shows it.
#[derive(Clone, Debug)]
pub struct AdapterReport {
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    /// Discrete or integrated GPU.
    pub hardware: bool,
    /// Why the engine cannot use it, if it cannot.
    pub unusable: Option<String>,
}

/// A device and queue with the adapter they came from.
#[derive(Clone)]
pub struct GpuDevice {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Limits the device was created with.
    pub limits: wgpu::Limits,
    errors: Arc<Mutex<Option<String>>>,
}

/// Keeps Mesa's Vulkan device-select layer quiet where there is no display session. The layer
/// orders the GPUs by the display's, and without one (a headless node, a batch job, a root shell:
/// no `XDG_RUNTIME_DIR`) it prints "error: XDG_RUNTIME_DIR is invalid or not set in the
/// environment." twice per wgpu instance, which users take for a failure. Sweep picks its
/// adapter itself, so there is nothing for the layer to select by; `NODEVICE_SELECT` is Mesa's
/// switch for it, left alone when the user set it. Call before any thread starts: it sets an
/// environment variable.
pub fn quiet_headless_device_select() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

/// The wgpu instance, configured from the environment. Indirect-call validation is off: the
/// engine dispatches nothing indirectly, and the flag would add a validation pass per indirect
/// dispatch if a kernel ever did (`WGPU_VALIDATION_INDIRECT_CALL=1` turns it back on).
pub fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.flags
        .remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    wgpu::Instance::new(desc.with_env())
}

/// Discrete or integrated GPU (not a software or virtual adapter).
pub fn is_hardware(info: &wgpu::AdapterInfo) -> bool {
    matches!(
        info.device_type,
        wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu
    )
}

/// Storage buffers the widest kernel binds (`scatter`, which packs every particle's record, its
/// history's two ranges included, when list builds sort by cell); every Vulkan, Metal and D3D12
/// GPU offers more than WebGPU's default 8 (lavapipe 32, its GL driver 16, Metal 31).
pub const STORAGE_BUFFERS_PER_KERNEL: u32 = 13;

/// Storage buffers the one-dispatch step binds (`fused_step`: the contact kernel's, the kick's
/// and the second copy of the state); requested where the adapter offers them.
pub const FUSED_STORAGE_BUFFERS: u32 = 17;

/// Bytes of immediates the one-dispatch step takes: its step index.
pub const FUSED_IMMEDIATE_BYTES: u32 = 4;

/// The limits the engine requests: WebGPU's defaults except the storage buffers per kernel and
/// the storage binding and buffer sizes, raised to what the adapter offers so that large runs fit.
pub fn required_limits(adapter: &wgpu::Limits) -> wgpu::Limits {
    wgpu::Limits {
        max_storage_buffer_binding_size: adapter.max_storage_buffer_binding_size,
        max_buffer_size: adapter.max_buffer_size,
        max_storage_buffers_per_shader_stage: STORAGE_BUFFERS_PER_KERNEL.max(
            adapter
                .max_storage_buffers_per_shader_stage
                .min(FUSED_STORAGE_BUFFERS),
        ),
        ..wgpu::Limits::default()
    }
}

fn unusable(adapter: &wgpu::Adapter) -> Option<String> {
    let caps = adapter.get_downlevel_capabilities();
    if !caps.flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) {
        return Some("no compute shaders".into());
    }
    let have = adapter.limits();
    let want = required_limits(&have);
    let mut missing = Vec::new();
    want.check_limits_with_fail_fn(&have, false, |name, w, h| {
        missing.push(format!("{name} {h} < {w}"));
    });
    if missing.is_empty() {
        None
    } else {
        Some(format!("limits too small: {}", missing.join(", ")))
    }
}

fn rank(info: &wgpu::AdapterInfo) -> u32 {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    // Prefer the native compute backends over GL at equal kind.
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    kind * 2 + backend
}

/// Every adapter the instance sees with its report, best first: usable before unusable, then
/// discrete, integrated, virtual, software; native compute backends before GL. The position in
/// this list is the adapter's number (`sweep info`, `--gpu N`).
pub fn enumerate_adapters() -> Vec<(wgpu::Adapter, AdapterReport)> {
    let inst = instance();
    let mut out: Vec<(wgpu::Adapter, AdapterReport)> =
        pollster::block_on(inst.enumerate_adapters(wgpu::Backends::all()))
            .into_iter()
            .map(|a| {
                let info = a.get_info();
                let report = AdapterReport {
                    hardware: is_hardware(&info),
                    limits: a.limits(),
                    unusable: unusable(&a),
                    info,
                };
                (a, report)
            })
            .collect();
    out.sort_by_key(|(_, r)| (r.unusable.is_some(), rank(&r.info)));
    out
}

/// Every adapter the instance sees, best first (numbered as `--gpu N` counts them).
pub fn list_adapters() -> Vec<AdapterReport> {
    enumerate_adapters().into_iter().map(|(_, r)| r).collect()
}

/// The directories the Vulkan loader looks in for driver (ICD) manifests when neither
/// `VK_DRIVER_FILES` nor `VK_ICD_FILENAMES` is set.
pub const VULKAN_ICD_DIRS: [&str; 3] = [
    "/usr/share/vulkan/icd.d",
    "/etc/vulkan/icd.d",
    "/usr/local/share/vulkan/icd.d",
];

/// The Vulkan driver manifests the loader would find: the existing files (or `*.json` of the
/// directories) named by `VK_DRIVER_FILES` or `VK_ICD_FILENAMES` when set, else the `*.json` of
/// `VULKAN_ICD_DIRS`. Empty: no Vulkan driver is installed (or the variables point nowhere).
pub fn vulkan_driver_files() -> Vec<std::path::PathBuf> {
    fn json_in(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
        let mut v: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
            .map(|d| {
                d.filter_map(Result::ok)
                    .map(|e| e.path())
                    .filter(|p| p.extension().is_some_and(|x| x == "json") && p.is_file())
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    }
    let named = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"]
        .iter()
        .find_map(|k| std::env::var_os(k).filter(|v| !v.is_empty()));
    match named {
        Some(list) => std::env::split_paths(&list)
            .flat_map(|p| {
                if p.is_dir() {
                    json_in(&p)
                } else if p.is_file() {
                    vec![p]
                } else {
                    Vec::new()
                }
            })
            .collect(),
        None => VULKAN_ICD_DIRS
            .iter()
            .flat_map(|d| json_in(std::path::Path::new(d)))
            .collect(),
    }
}

impl GpuDevice {
    /// The best usable adapter under `policy`, as a device.
    ///
    /// # Errors
    /// `EngineError::Device` when no adapter fits the policy or the device cannot be created.
    pub fn acquire(policy: AdapterPolicy) -> Result<Self, EngineError> {
        let inst = instance();
        let mut adapters = pollster::block_on(inst.enumerate_adapters(wgpu::Backends::all()));
        adapters.retain(|a| {
            unusable(a).is_none() && (policy == AdapterPolicy::Any || is_hardware(&a.get_info()))
        });
        adapters.sort_by_key(|a| rank(&a.get_info()));
        let Some(adapter) = adapters.into_iter().next() else {
            return Err(EngineError::Device(match policy {
                AdapterPolicy::Hardware => "no discrete or integrated GPU adapter found".into(),
                AdapterPolicy::Any => "no GPU adapter found (on Debian, `apt-get install mesa-vulkan-drivers` provides the lavapipe software adapter); `sweep info` lists what wgpu sees".into(),
            }));
        };
        Self::from_adapter(&adapter)
    }

    /// A device on `adapter` with `required_limits`.
    ///
    /// # Errors
    /// `EngineError::Device` when the device cannot be created.
    pub fn from_adapter(adapter: &wgpu::Adapter) -> Result<Self, EngineError> {
        let info = adapter.get_info();
        let mut limits = required_limits(&adapter.limits());
        // Timestamps time the passes in `sweep bench` where the adapter has them; immediates
        // carry the one-dispatch step's index.
        let features =
            adapter.features() & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::IMMEDIATES);
        if features.contains(wgpu::Features::IMMEDIATES) {
            limits.max_immediate_size = adapter
                .limits()
                .max_immediate_size
                .min(FUSED_IMMEDIATE_BYTES);
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sweep device"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| EngineError::Device(format!("{}: cannot create a device: {e}", info.name)))?;
        let errors = Arc::new(Mutex::new(None::<String>));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| e.to_string());
        }));
        let sink = errors.clone();
        device.set_device_lost_callback(move |reason, msg| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| format!("device lost ({reason:?}): {msg}"));
        });
        Ok(Self {
            device,
            queue,
            info,
            limits,
            errors,
        })
    }

    /// Why this device cannot run the one-dispatch step (`GpuOptions::fused_step`), if it cannot.
    pub fn fused_step_unsupported(&self) -> Option<String> {
        let immediates = self.device.features().contains(wgpu::Features::IMMEDIATES)
            && self.limits.max_immediate_size >= FUSED_IMMEDIATE_BYTES;
        let buffers = self.limits.max_storage_buffers_per_shader_stage;
        if !immediates {
            Some(format!(
                "{} offers no immediates (push constants), which carry its step index",
                self.info.name
            ))
        } else if buffers < FUSED_STORAGE_BUFFERS {
            Some(format!(
                "{} binds {buffers} storage buffers per kernel; it binds {FUSED_STORAGE_BUFFERS}",
                self.info.name
            ))
        } else {
            None
        }
    }

    /// Whether this is a discrete or integrated GPU.
    pub fn is_hardware(&self) -> bool {
        is_hardware(&self.info)
    }

    /// The first device error since the last call, if any.
    pub fn take_error(&self) -> Option<String> {
        self.errors.lock().unwrap_or_else(|p| p.into_inner()).take()
    }

    /// Records an error found by the host side (a failed map, a failed poll).
    pub fn record_error(&self, e: String) {
        self.errors
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get_or_insert(e);
    }
}
