//! The WGSL contact law (shaders/law.wgsl) run alone on a table of contacts, so that a test can
//! hold it against the Rust law (`contact::contact_force`) contact by contact: the GPU engine's
//! runs only show the two laws agree on average.

use wgpu::util::DeviceExt;

use super::buffers::read;
use super::device::GpuDevice;
use super::layout::{prelude, LawGpu};
use crate::engine::contact::{ContactInput, LawKernel};
use crate::engine::real::V3;
use crate::engine::EngineError;

const PROBE: &str = concat!(
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/law.wgsl"),
    include_str!("shaders/law_probe.wgsl")
);

/// Words per contact in the probe's input and output (shaders/law_probe.wgsl).
const IN_WORDS: usize = 16;
const OUT_WORDS: usize = 8;

/// One contact for the probe: its law, its geometry and kinematics, the stored spring and the
/// step the spring advances by.
#[derive(Clone, Copy, Debug)]
pub struct ProbeContact {
    pub law: LawKernel<f32>,
    pub input: ContactInput<f32>,
    pub spring: V3<f32>,
    pub dt: f32,
}

/// What the WGSL law gives for one contact: the force on i, the new spring, and the elastic
/// energy of the contact with its stored spring.
#[derive(Clone, Copy, Debug)]
pub struct ProbeResult {
    pub force: V3<f32>,
    pub spring: V3<f32>,
    pub energy: f32,
}

/// Runs the WGSL law on every contact of `table`.
///
/// # Errors
/// A device error, or a failed read-back.
pub fn probe_law(dev: &GpuDevice, table: &[ProbeContact]) -> Result<Vec<ProbeResult>, EngineError> {
    let n = table.len().max(1);
    let mut laws: Vec<LawGpu> = table.iter().map(|c| LawGpu::from(c.law)).collect();
    if laws.is_empty() {
        laws.push(LawGpu::default());
    }
    let mut input = vec![0.0f32; n * IN_WORDS];
    for (k, c) in table.iter().enumerate() {
        let i = &c.input;
        let w = &mut input[k * IN_WORDS..(k + 1) * IN_WORDS];
        w[..4].copy_from_slice(&[i.overlap, i.r_eff, i.m_eff, c.dt]);
        for (at, v) in [(4, i.normal), (8, i.v_rel), (12, c.spring)] {
            w[at..at + 3].copy_from_slice(&[v.x, v.y, v.z]);
        }
    }
    let d = &dev.device;
    let init = |label, contents: &[u8], usage| {
        d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let law_buf = init(
        "probe laws",
        bytemuck::cast_slice(&laws),
        wgpu::BufferUsages::STORAGE,
    );
    let in_buf = init(
        "probe input",
        bytemuck::cast_slice(&input),
        wgpu::BufferUsages::STORAGE,
    );
    let out_bytes = (n * OUT_WORDS * 4) as u64;
    let out_buf = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe output"),
        size: out_bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("law probe"),
        source: wgpu::ShaderSource::Wgsl(format!("{}{PROBE}", prelude()).into()),
    });
    let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("law probe"),
        layout: None,
        module: &module,
        entry_point: Some("probe_law"),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    });
    let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("law probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 40,
                resource: law_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 41,
                resource: in_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 42,
                resource: out_buf.as_entire_binding(),
            },
        ],
    });
    let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("law probe"),
    });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(table.len().div_ceil(64) as u32, 1, 1);
    }
    dev.queue.submit([enc.finish()]);
    let bytes = read(dev, &[(&out_buf, out_bytes)])?.swap_remove(0);
    let out: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
    Ok(table
        .iter()
        .enumerate()
        .map(|(k, _)| {
            let w = &out[k * OUT_WORDS..(k + 1) * OUT_WORDS];
            ProbeResult {
                force: V3::new(w[0], w[1], w[2]),
                spring: V3::new(w[3], w[4], w[5]),
                energy: w[6],
            }
        })
        .collect())
}
