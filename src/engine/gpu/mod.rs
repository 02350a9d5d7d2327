//! The GPU backend (wgpu compute passes, WGSL in `shaders/`): device acquisition, buffers, grid
//! choices, pipelines and the engine implementing `Backend` in f32.

mod buffers;
mod device;
mod engine;
mod grid;
mod kernels;
mod law_probe;
mod layout;
mod packed;
mod pipelines;
mod schedule;
mod status;

pub use device::{
    enumerate_adapters, instance, is_hardware, list_adapters, quiet_headless_device_select,
    required_limits, vulkan_driver_files, AdapterPolicy, AdapterReport, GpuDevice, VULKAN_ICD_DIRS,
};
pub use engine::{GpuEngine, GpuOptions};
pub use grid::{list_capacity, plan_grid, GridSpec};
pub use law_probe::{probe_law, ProbeContact, ProbeResult};
pub use layout::{MAX_JOBS, MAX_WALLS, WORKGROUP_SIZE};
pub use packed::{pack, unpack, Packed};
