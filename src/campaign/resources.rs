//! What a job needs of the machine, checked before anything runs: its memory, estimated from
//! its particle count (`engine::memory`) plus the observers that keep per-particle state, against
//! the memory this process may take (the least of `MemTotal`, its cgroup's limit and `ulimit
//! -v`; or `SWEEP_MEMORY_LIMIT_BYTES`).

use super::file::{Precision, SceneKind};
use super::job_spec::JobSpec;
use crate::engine::memory::{address_space_limit, bytes_per_particle};

/// Environment variable that sets the memory limit (bytes) instead of `MemTotal`.
pub const MEMORY_LIMIT_ENV: &str = "SWEEP_MEMORY_LIMIT_BYTES";

/// The memory a job may take, and where that number came from (for messages).
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryLimit {
    pub bytes: u64,
    pub source: String,
}

/// The limit: `SWEEP_MEMORY_LIMIT_BYTES` when set, else the least of this machine's `MemTotal`,
/// the process's cgroup limit and its address-space limit; None when none can be read (no check
/// then).
///
/// # Errors
/// `SWEEP_MEMORY_LIMIT_BYTES` set to something other than a whole number of bytes.
pub fn memory_limit() -> Result<Option<MemoryLimit>, String> {
    if let Ok(v) = std::env::var(MEMORY_LIMIT_ENV) {
        return match v.trim().parse::<u64>() {
            Ok(bytes) => Ok(Some(MemoryLimit {
                bytes,
                source: MEMORY_LIMIT_ENV.to_string(),
            })),
            Err(_) => Err(format!(
                "{MEMORY_LIMIT_ENV} = {v:?}: expected a whole number of bytes"
            )),
        };
    }
    // The tightest of the machine's memory and the process's own limits: a job under a cgroup
    // limit or `ulimit -v` is killed (or fails to allocate) long before MemTotal.
    let mut limits: Vec<MemoryLimit> = Vec::new();
    if let Some(bytes) = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| mem_total(&t))
    {
        limits.push(MemoryLimit {
            bytes,
            source: "this machine's memory (MemTotal in /proc/meminfo)".into(),
        });
    }
    for (path, what) in [
        (
            "/sys/fs/cgroup/memory.max",
            "this process's cgroup (memory.max)",
        ),
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes",
            "this process's cgroup (memory.limit_in_bytes)",
        ),
    ] {
        // "max" (cgroup v2) or a huge number (v1) means no limit.
        if let Some(bytes) = std::fs::read_to_string(path)
            .ok()
            .and_then(|t| t.trim().parse::<u64>().ok())
        {
            limits.push(MemoryLimit {
                bytes,
                source: format!("{what}, {path}"),
            });
        }
    }
    if let Some(bytes) = address_space_limit() {
        limits.push(MemoryLimit {
            bytes,
            source: "this process's address-space limit (ulimit -v)".into(),
        });
    }
    Ok(limits.into_iter().min_by_key(|l| l.bytes))
}

/// `MemTotal` of /proc/meminfo's text, in bytes.
fn mem_total(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut words = line["MemTotal:".len()..].split_whitespace();
    let n: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => n.checked_mul(1024),
        None => Some(n),
        Some(_) => None,
    }
}

/// A job's estimated memory and its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryEstimate {
    /// Particles the engine holds: the flowing ones and the chute's fixed base.
    pub particles: f64,
    pub bytes_per_particle: u64,
    /// Observers' per-particle state (the chute's MSD rings), in all.
    pub observer_bytes: f64,
    /// The whole (f64: a count past u64 must still compare).
    pub bytes: f64,
}

/// Bytes of the chute observer's MSD per flowing particle: a ring of W = max_lag / interval + 1
/// heights (f64), its slot, fill count and last-seen index, and the ring again as JSON text
/// (about 24 characters a number) while a checkpoint is written.
fn msd_bytes_per_particle(max_lag_s: f64, interval_s: f64) -> f64 {
    let window = (max_lag_s / interval_s).round() + 1.0;
    window * (8.0 + 24.0) + 48.0
}

/// The memory a job would take on the CPU engine (`engine::memory`), observers included.
pub fn memory_estimate(job: &JobSpec) -> MemoryEstimate {
    let real = match job.precision {
        Precision::F64 => 8,
        Precision::F32 => 4,
    };
    let (particles, oriented, observer_bytes) = match job.scene {
        SceneKind::Silo => (job.silo().particle_count as f64, false, 0.0),
        SceneKind::Chute => {
            let p = job.chute();
            let flowing = match p.particle_count {
                Some(n) => n as f64,
                None => {
                    let (lx, ly) = p.box_size();
                    let h = p.bed_height_lengths * p.particle_length_m;
                    p.flowing_solid_fraction * lx * ly * h / p.shape().volume()
                }
            };
            let (lx, ly) = p.box_size();
            let rb = p.base_radius_lengths * p.particle_length_m;
            let base = p.base_coverage * lx * ly / (std::f64::consts::PI * rb * rb);
            let msd = job.observers.chute.as_ref().map_or(0.0, |c| {
                flowing * msd_bytes_per_particle(c.max_lag_s, c.sample_interval_s)
            });
            (flowing + base, !p.spheres(), msd)
        }
    };
    let per = bytes_per_particle(real, oriented);
    MemoryEstimate {
        particles,
        bytes_per_particle: per,
        observer_bytes,
        bytes: particles * per as f64 + observer_bytes,
    }
}

/// Bytes as text with a binary unit ("3.2 GiB").
pub fn human_bytes(b: f64) -> String {
    const UNITS: [&str; 7] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = b;
    let mut k = 0;
    while v >= 1024.0 && k + 1 < UNITS.len() {
        v /= 1024.0;
        k += 1;
    }
    if k == 0 {
        format!("{b:.0} B")
    } else {
        format!("{v:.1} {}", UNITS[k])
    }
}

/// Every job whose memory estimate exceeds `limit`, as a problem at the campaign field that sets
/// its particle count (`base.particle_count`, `sweep.particle_count[3]`; a chute without one: its
/// `bed_height_lengths`); one problem per field.
pub fn memory_problems(jobs: &[JobSpec], limit: &MemoryLimit) -> Vec<super::FieldProblem> {
    let mut problems: Vec<super::FieldProblem> = Vec::new();
    for job in jobs {
        let est = memory_estimate(job);
        if est.bytes <= limit.bytes as f64 {
            continue;
        }
        let (field, value) = match job.scene {
            SceneKind::Silo => ("particle_count", job.silo().particle_count.to_string()),
            SceneKind::Chute => match job.chute().particle_count {
                Some(n) => ("particle_count", n.to_string()),
                None => (
                    "bed_height_lengths",
                    job.chute().bed_height_lengths.to_string(),
                ),
            },
        };
        let path = job.source(field);
        if problems.iter().any(|p| p.path == path) {
            continue;
        }
        let per = est.bytes / est.particles.max(1.0);
        let observers = if est.observer_bytes > 0.0 {
            format!(
                ", plus {} for the chute observer's MSD (observers.chute.max_lag_s / sample_interval_s heights per particle)",
                human_bytes(est.observer_bytes)
            )
        } else {
            String::new()
        };
        let fit = (limit.bytes as f64 / per).floor();
        problems.push(super::FieldProblem {
            path,
            message: format!(
                "{field} = {value}: the job would need about {} of memory ({:.0} particles × {} B: \
                 the {} state, neighbour lists, contact history and checkpoint copies{observers}), \
                 more than the limit of {} ({} bytes, {}); expected at most about {fit:.0} particles",
                human_bytes(est.bytes),
                est.particles,
                est.bytes_per_particle,
                job.precision.name(),
                human_bytes(limit.bytes as f64),
                limit.bytes,
                limit.source
            ),
        });
    }
    problems
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_total_reads_kilobytes() {
        let text = "MemTotal:       16318480 kB\nMemFree:         1000 kB\n";
        assert_eq!(mem_total(text), Some(16_318_480 * 1024));
        assert_eq!(mem_total("MemFree: 1 kB"), None);
        assert_eq!(human_bytes(1536.0), "1.5 KiB");
        assert_eq!(human_bytes(12.0), "12 B");
    }
}
