//! Explicit bind-group layouts and compute pipelines of the kernels (kernels.rs), built once per
//! engine; bind groups are rebuilt whenever the buffers are (each upload). Every kernel binds only
//! the buffers it uses, at most `STORAGE_BUFFERS_PER_KERNEL` storage buffers (device.rs; the
//! one-dispatch step `FUSED_STORAGE_BUFFERS`), in group 0 with the binding numbers of layout.rs.

use std::num::NonZeroU64;

use super::buffers::GpuBuffers;
use super::device::{GpuDevice, FUSED_IMMEDIATE_BYTES};
use super::layout::{
    binding as b, prelude, Params, RecordGpu, RodGpu, WallGpu, MAX_JOBS, MAX_WALLS, STATUS_WORDS,
};
use crate::engine::config::EngineConfig;

use super::kernels::TWO_DISPATCH_KERNELS;
pub use super::kernels::{dispatch_size, kernel, Module, KERNELS};

/// Smallest valid binding size of each buffer: one record.
fn min_size(binding: u32) -> u64 {
    match binding {
        b::PARAMS => (std::mem::size_of::<Params>() * MAX_JOBS) as u64,
        b::WALLS => (std::mem::size_of::<WallGpu>() * MAX_WALLS * MAX_JOBS) as u64,
        b::LOAD => 32,
        b::STATUS => STATUS_WORDS as u64 * 4,
        b::EVENTS | b::CELL_RANK => 8,
        b::SCRATCH => 16,
        b::NBR
        | b::NBR_HI
        | b::CELL_COUNT
        | b::CELL_START
        | b::CHUNK_SUMS
        | b::SORTED
        | b::ENERGY => 4,
        b::ROD => std::mem::size_of::<RodGpu>() as u64,
        b::RECORDS => std::mem::size_of::<RecordGpu>() as u64,
        _ => 16,
    }
}

/// The effects a run switches on, compiled into the kernels as WGSL pipeline-overridable
/// constants (common.wgsl): a branch an effect does not need is removed by the shader compiler,
/// not tested at run time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Specialization {
    /// Angular velocities are integrated and enter contacts.
    pub rotation: bool,
    /// Particles are spherocylinders with orientations (segment contacts, the free rotor, the
    /// rotational skin criterion); a sphere run compiles none of it.
    pub oriented: bool,
    /// Tangential springs are kept per contact.
    pub history: bool,
    /// Some contact law is Hertz–Mindlin; some is linear.
    pub any_hertz: bool,
    pub any_linear: bool,
    pub walls: bool,
    pub periodic_x: bool,
    pub periodic_y: bool,
    pub sink: bool,
}

impl Specialization {
    /// The effects of `config` with particles carrying `rotation`, orientations (`oriented`) and
    /// `history_slots`.
    pub fn of(config: &EngineConfig, rotation: bool, oriented: bool, history_slots: usize) -> Self {
        let laws = if config.walls.is_empty() {
            vec![config.particle_law]
        } else {
            vec![config.particle_law, config.wall_law]
        };
        let hertz = |l: &crate::engine::contact::ContactLaw| {
            matches!(l.normal, crate::engine::contact::NormalModel::Hertz(_))
        };
        Self {
            rotation: rotation || oriented,
            oriented,
            history: history_slots > 0,
            any_hertz: laws.iter().any(hertz),
            any_linear: laws.iter().any(|l| !hertz(l)),
            walls: !config.walls.is_empty(),
            periodic_x: config.periodic_x.is_some(),
            periodic_y: config.periodic_y.is_some(),
            sink: config.sink_z.is_some(),
        }
    }

    fn constants(&self, record: bool) -> [(&'static str, f64); 10] {
        let b = |x: bool| if x { 1.0 } else { 0.0 };
        [
            ("RECORD", b(record)),
            ("ROTATION", b(self.rotation)),
            ("ORIENTED", b(self.oriented)),
            ("HISTORY", b(self.history)),
            ("ANY_HERTZ", b(self.any_hertz)),
            ("ANY_LINEAR", b(self.any_linear)),
            ("WALLS", b(self.walls)),
            ("PERIODIC_X", b(self.periodic_x)),
            ("PERIODIC_Y", b(self.periodic_y)),
            ("SINK", b(self.sink)),
        ]
    }
}

/// Layouts and pipelines of every kernel (the one-dispatch step's only when it was asked for).
pub struct Pipelines {
    layouts: Vec<wgpu::BindGroupLayout>,
    pub pipelines: Vec<wgpu::ComputePipeline>,
    /// The effects the kernels were compiled for.
    pub spec: Specialization,
    /// Whether the one-dispatch step's kernels were built.
    pub fused: bool,
}

/// The bind groups of one set of buffers, one per kernel: `even` binds the first copy of the
/// state as the one kernels read (and the one-dispatch step's second as the one it writes),
/// `odd` the other way round (empty unless the one-dispatch step was built).
pub struct BindGroups {
    pub even: Vec<wgpu::BindGroup>,
    pub odd: Vec<wgpu::BindGroup>,
}

impl BindGroups {
    /// Kernel k's bind group for the copy of the state of parity `odd`.
    pub fn at(&self, odd: bool, k: usize) -> &wgpu::BindGroup {
        if odd {
            &self.odd[k]
        } else {
            &self.even[k]
        }
    }
}

impl Pipelines {
    /// Compiles the modules and builds the pipelines, specialised for `spec`; the one-dispatch
    /// step's with `fused`.
    pub fn new(dev: &GpuDevice, spec: Specialization, fused: bool) -> Self {
        let constants = spec.constants(false);
        let recording = spec.constants(true);
        let d = &dev.device;
        let pre = prelude();
        let kernels = if fused {
            &KERNELS[..]
        } else {
            &KERNELS[..TWO_DISPATCH_KERNELS]
        };
        let modules: Vec<Option<wgpu::ShaderModule>> = Module::ALL
            .iter()
            .map(|&m| {
                kernels.iter().any(|k| k.module == m).then(|| {
                    d.create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(m.label()),
                        source: wgpu::ShaderSource::Wgsl(format!("{pre}{}", m.source()).into()),
                    })
                })
            })
            .collect();
        let mut layouts = Vec::new();
        let mut pipelines = Vec::new();
        for k in kernels {
            let entries: Vec<wgpu::BindGroupLayoutEntry> = k
                .bindings
                .iter()
                .map(|&n| wgpu::BindGroupLayoutEntry {
                    binding: n,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: if n == b::PARAMS || n == b::WALLS {
                            wgpu::BufferBindingType::Uniform
                        } else {
                            wgpu::BufferBindingType::Storage {
                                read_only: k.module.read_only(n),
                            }
                        },
                        has_dynamic_offset: false,
                        min_binding_size: NonZeroU64::new(min_size(n)),
                    },
                    count: None,
                })
                .collect();
            let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(k.entry),
                entries: &entries,
            });
            let pl = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(k.entry),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: if k.module == Module::Fused {
                    FUSED_IMMEDIATE_BYTES
                } else {
                    0
                },
            });
            let Some(module) =
                &modules[Module::ALL.iter().position(|&m| m == k.module).unwrap_or(0)]
            else {
                unreachable!("every kernel's module is compiled");
            };
            pipelines.push(d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(k.entry),
                layout: Some(&pl),
                module,
                entry_point: Some(k.entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: if matches!(k.entry, "record_contacts" | "contact_energy") {
                        &recording
                    } else {
                        &constants
                    },
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            }));
            layouts.push(layout);
        }
        Self {
            layouts,
            pipelines,
            spec,
            fused,
        }
    }

    /// Bind groups of every kernel over `bufs`, of both parities when the one-dispatch step
    /// was built.
    pub fn bind(&self, dev: &GpuDevice, bufs: &GpuBuffers) -> BindGroups {
        let groups = |odd: bool| -> Vec<wgpu::BindGroup> {
            KERNELS
                .iter()
                .zip(&self.layouts)
                .map(|(k, layout)| {
                    let entries: Vec<wgpu::BindGroupEntry> = k
                        .bindings
                        .iter()
                        .map(|&n| wgpu::BindGroupEntry {
                            binding: n,
                            resource: bufs.resource_of(n, odd),
                        })
                        .collect();
                    dev.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some(k.entry),
                        layout,
                        entries: &entries,
                    })
                })
                .collect()
        };
        BindGroups {
            even: groups(false),
            odd: if self.fused { groups(true) } else { Vec::new() },
        }
    }
}
