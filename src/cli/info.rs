//! `sweep info`: the GPU adapters wgpu finds, their limits, and what `--backend auto` and
//! `--backend gpu` would choose here.

use sweep::engine::gpu::{enumerate_adapters, required_limits, GpuDevice};
use sweep::runner::backend::{auto_summary, describe, ALLOW_SOFTWARE_ENV};

#[derive(clap::Args)]
pub struct Arguments {}

pub fn run(_a: Arguments) -> anyhow::Result<i32> {
    let found = enumerate_adapters();
    let adapters: Vec<_> = found.iter().map(|(_, r)| r.clone()).collect();
    println!(
        "GPU adapters (instance from the environment: WGPU_BACKEND, WGPU_ADAPTER_NAME; --gpu N takes [N]): {}",
        adapters.len()
    );
    for (k, a) in adapters.iter().enumerate() {
        let l = &a.limits;
        println!(
            "  [{k}] {} — {:?}, {:?}, driver {} {}",
            a.info.name, a.info.backend, a.info.device_type, a.info.driver, a.info.driver_info
        );
        println!(
            "      storage buffers per stage {}, storage binding {} MiB, buffer {} MiB, workgroup invocations {}, workgroups per dimension {}",
            l.max_storage_buffers_per_shader_stage,
            l.max_storage_buffer_binding_size >> 20,
            l.max_buffer_size >> 20,
            l.max_compute_invocations_per_workgroup,
            l.max_compute_workgroups_per_dimension
        );
        let use_ = match &a.unusable {
            Some(why) => format!("unusable: {why}"),
            None if a.hardware => "usable: hardware (auto and gpu)".into(),
            None => "usable: software or virtual (gpu with --allow-software-gpu only)".into(),
        };
        println!("      {use_}");
    }
    if let Some(a) = adapters.iter().find(|a| a.unusable.is_none()) {
        let r = required_limits(&a.limits);
        println!(
            "requested limits: WebGPU defaults ({} storage buffers per stage) with storage binding {} MiB and buffer {} MiB raised to the adapter's",
            r.max_storage_buffers_per_shader_stage,
            r.max_storage_buffer_binding_size >> 20,
            r.max_buffer_size >> 20
        );
    }
    println!("--backend auto: {}", auto_summary(None));
    match found
        .iter()
        .enumerate()
        .find(|(_, (_, r))| r.unusable.is_none())
    {
        Some((k, (adapter, r))) => {
            let name = describe(&r.info);
            if !r.hardware {
                println!(
                    "--backend gpu: [{k}] {name}, a software adapter: refused unless --allow-software-gpu (or {ALLOW_SOFTWARE_ENV}=1)"
                );
            } else {
                match GpuDevice::from_adapter(adapter) {
                    Ok(_) => println!("--backend gpu: [{k}] {name}"),
                    Err(e) => println!("--backend gpu: unavailable: {e}"),
                }
            }
        }
        None => println!("--backend gpu: unavailable: no usable adapter"),
    }
    Ok(0)
}
