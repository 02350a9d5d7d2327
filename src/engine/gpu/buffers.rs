//! Device buffers of one run, filled from the packed particles (`packed.rs`), and the read-backs.
//! Scratch (lists, cells, scan runs, the axes derived from the orientations) lives here, not in
//! State.
//!
//! Oriented runs double two buffers instead of binding two more (the contact kernel already binds
//! WebGPU's default 8 storage buffers): `pos_r` holds n positions then n shape records (unit axis,
//! l/2), and `ref_pos` n reference positions then n reference axes for the skin criterion.

use wgpu::util::DeviceExt;

use super::device::GpuDevice;
use super::grid::GridSpec;
use super::layout::{binding, Params, WallGpu, MAX_JOBS, MAX_WALLS, STATUS_WORDS};
pub use super::packed::{block, concat, pack, unpack, Packed};
use crate::engine::backend::EngineError;

/// Every buffer of one run on the device.
pub struct GpuBuffers {
    pub n: usize,
    pub slots: usize,
    pub params: wgpu::Buffer,
    pub walls: wgpu::Buffer,
    pub pos_r: wgpu::Buffer,
    pub vel_im: wgpu::Buffer,
    pub omega: wgpu::Buffer,
    pub info: wgpu::Buffer,
    pub load: wgpu::Buffer,
    pub hist: wgpu::Buffer,
    pub nbr: wgpu::Buffer,
    /// Bytes of `hist` and `nbr` in their first binding (`split_binding`); the rest is bound as
    /// `HIST_HI` and `NBR_HI`.
    pub hist_split_bytes: u64,
    pub nbr_split_bytes: u64,
    /// What `HIST_HI` and `NBR_HI` bind when the whole buffer fits in the first binding.
    pub spare_hist: wgpu::Buffer,
    pub spare_nbr: wgpu::Buffer,
    pub ref_pos: wgpu::Buffer,
    pub status: wgpu::Buffer,
    pub events: wgpu::Buffer,
    pub cell_rank: wgpu::Buffer,
    pub cell_count: wgpu::Buffer,
    pub cell_start: wgpu::Buffer,
    pub chunk_sums: wgpu::Buffer,
    pub sorted: wgpu::Buffer,
    /// An energy per slot (kinetic from `finish`, elastic from `contact_energy`), then the
    /// fixed-point kinetic sums per workgroup (`energy_sum`), then the elastic (`elastic_sum`).
    pub energy: wgpu::Buffer,
    /// Contact records (`record_contacts`), grown when a call finds it short.
    pub records: wgpu::Buffer,
    /// `RodGpu` per particle; one zeroed record when the run is not oriented.
    pub rod: wgpu::Buffer,
    /// Each slot's packed record between `scatter` and `settle` (16 bytes when builds keep the
    /// order).
    pub scratch: wgpu::Buffer,
    /// The second copy of `pos_r`, `vel_im` and `omega`, for the one-dispatch step
    /// (`GpuOptions::fused_step`): it writes one copy while its forces read the other.
    pub second: Option<[wgpu::Buffer; 3]>,
    pub oriented: bool,
}

const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

/// The second copy of the positions (`blocks` + 1 blocks of n records), velocities and spins
/// (two blocks each) that the one-dispatch step writes while its forces read the first.
fn second_copy(dev: &GpuDevice, n: u64, blocks: u64) -> [wgpu::Buffer; 3] {
    [
        ("second positions", (blocks + 1) * n * 16),
        ("second velocities", 2 * n * 16),
        ("second spins", 2 * n * 16),
    ]
    .map(|(label, bytes)| {
        dev.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(32).next_multiple_of(4),
            usage: STORAGE,
            mapped_at_creation: false,
        })
    })
}

impl GpuBuffers {
    /// Allocates and fills the buffers of the batch `p` (every job's block, one after the other)
    /// with one record and `MAX_WALLS` walls per job in `params` and `walls`, and `g` the sizes
    /// of the batch's grid (all jobs' cells, the widest list row), and with `fused` a second copy
    /// of the positions, velocities and spins. No binding exceeds `max_binding` bytes (the
    /// device's limit, or less to test the split bindings).
    ///
    /// # Errors
    /// A buffer larger than the device binds (`EngineError::Device`, naming it and the limit).
    pub fn new(
        dev: &GpuDevice,
        max_binding: u64,
        params: &[Params],
        walls: &[WallGpu],
        p: &Packed,
        g: &GridSpec,
        fused: bool,
    ) -> Result<Self, EngineError> {
        let jobs = params.len();
        debug_assert!(jobs <= MAX_JOBS && walls.len() == jobs * MAX_WALLS);
        let n = p.pos_r.len();
        let slots = params[0].slots as usize;
        let max = max_binding;
        let align = dev.limits.min_storage_buffer_offset_alignment as u64;
        let nbr_words = n as u64 * (g.stride as u64 + 1);
        let (hist_bytes, nbr_bytes) = ((n * slots * 16) as u64, nbr_words * 4);
        let hist_split_bytes = split_binding(hist_bytes, max, align);
        let nbr_split_bytes = split_binding(nbr_bytes, max, align);
        let mut records = params.to_vec();
        for r in &mut records {
            r.hist_split = (hist_split_bytes / 16) as u32;
            r.nbr_split = (nbr_split_bytes / 4) as u32;
        }
        records.resize(MAX_JOBS, Params::default());
        let mut all_walls = walls.to_vec();
        all_walls.resize(MAX_WALLS * MAX_JOBS, WallGpu::default());
        let oriented = p.oriented();
        // Oriented runs: a second block of n records in pos_r and ref_pos (module doc); every
        // run: a last block of n position rests in pos_r.
        let blocks: u64 = if oriented { 2 } else { 1 };
        let check = |what: &str, bytes: u64| -> Result<(), EngineError> {
            if bytes > max {
                return Err(EngineError::Device(format!(
                    "{n} particles need {:.0} MiB for the {what} buffer; {} binds at most {:.0} MiB",
                    bytes as f64 / 1048576.0,
                    dev.info.name,
                    max as f64 / 1048576.0
                )));
            }
            Ok(())
        };
        // The history and the lists may take two bindings each, within one buffer.
        let check_split = |what: &str, bytes: u64, split: u64| -> Result<(), EngineError> {
            let limit = max.min(dev.limits.max_buffer_size);
            if bytes - split > max || bytes > dev.limits.max_buffer_size {
                return Err(EngineError::Device(format!(
                    "{n} particles need {:.0} MiB for the {what} buffer; {} holds at most {:.0} MiB in one buffer and binds it in two ranges of at most {:.0} MiB",
                    bytes as f64 / 1048576.0,
                    dev.info.name,
                    dev.limits.max_buffer_size as f64 / 1048576.0,
                    limit as f64 / 1048576.0
                )));
            }
            Ok(())
        };
        check_split("history", hist_bytes, hist_split_bytes)?;
        check_split("neighbour list", nbr_bytes, nbr_split_bytes)?;
        check("load", n as u64 * 32)?;
        check("position", (blocks + 1) * n as u64 * 16)?;
        check("velocity", 2 * n as u64 * 16)?;
        check("rod", p.rod.len() as u64 * 48)?;
        let reorder = params[0].reorder != 0;
        let scratch = if reorder {
            super::layout::scratch_bytes(n, oriented, slots)
        } else {
            16
        };
        check("cell-order scratch", scratch)?;
        let d = &dev.device;
        let init = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            // Zero-length bindings are invalid: every buffer holds at least one record (48 bytes
            // covers the largest, `RodGpu`).
            let mut data = bytes.to_vec();
            if data.len() < 48 {
                data.resize(48, 0);
            }
            d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &data,
                usage,
            })
        };
        let zeroed = |label: &str, bytes: u64, usage: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(32).next_multiple_of(4),
                usage,
                mapped_at_creation: false,
            })
        };
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        Ok(Self {
            n,
            slots,
            params: init("params", bytemuck::cast_slice(&records), uniform),
            walls: init("walls", bytemuck::cast_slice(&all_walls), uniform),
            pos_r: {
                let mut data = p.pos_r.clone();
                data.extend(p.shapes());
                data.extend(&p.pos_lo);
                data.resize(((blocks + 1) as usize) * n, [0.0; 4]);
                init("pos_r", bytemuck::cast_slice(&data), STORAGE)
            },
            vel_im: {
                let mut data = p.vel_im.clone();
                data.extend(&p.vel_lo);
                data.resize(2 * n, [0.0; 4]);
                init("vel_im", bytemuck::cast_slice(&data), STORAGE)
            },
            omega: {
                let mut data = p.omega.clone();
                data.extend(&p.spin_lo);
                data.resize(2 * n, [0.0; 4]);
                init("omega", bytemuck::cast_slice(&data), STORAGE)
            },
            info: init("info", bytemuck::cast_slice(&p.info), STORAGE),
            load: init("load", bytemuck::cast_slice(&p.load), STORAGE),
            hist: init("history", bytemuck::cast_slice(&p.hist), STORAGE),
            nbr: zeroed("neighbour lists", nbr_words * 4, STORAGE),
            hist_split_bytes,
            nbr_split_bytes,
            spare_hist: zeroed("spare history range", 256, STORAGE),
            spare_nbr: zeroed("spare list range", 256, STORAGE),
            ref_pos: zeroed(
                "list reference positions (and axes)",
                blocks * n as u64 * 16,
                STORAGE,
            ),
            status: zeroed("status", (jobs * STATUS_WORDS) as u64 * 4, STORAGE),
            events: zeroed("sink events", n as u64 * 8, STORAGE),
            cell_rank: zeroed("cell and rank", n as u64 * 8, STORAGE),
            cell_count: zeroed("cell counts", g.ncell as u64 * 4, STORAGE),
            cell_start: zeroed("cell starts", (g.ncell as u64 + 1) * 4, STORAGE),
            chunk_sums: zeroed("scan run totals", g.n_chunks as u64 * 4, STORAGE),
            sorted: zeroed("cell-sorted indices", n as u64 * 4, STORAGE),
            energy: zeroed(
                "energy per slot and per workgroup",
                (n as u64 + 4 * (n as u64).div_ceil(super::layout::WORKGROUP_SIZE as u64)) * 4,
                STORAGE,
            ),
            rod: init("rods", bytemuck::cast_slice(&p.rod), STORAGE),
            scratch: zeroed("cell-order scratch", scratch, wgpu::BufferUsages::STORAGE),
            records: records_buffer(dev, 1),
            second: fused.then(|| second_copy(dev, n as u64, blocks)),
            oriented,
        })
    }

    /// The buffer at a binding number (layout.rs `binding`).
    pub fn get(&self, b: u32) -> &wgpu::Buffer {
        match b {
            binding::PARAMS => &self.params,
            binding::WALLS => &self.walls,
            binding::POS_R => &self.pos_r,
            binding::VEL_IM => &self.vel_im,
            binding::OMEGA => &self.omega,
            binding::INFO => &self.info,
            binding::LOAD => &self.load,
            binding::HIST => &self.hist,
            binding::NBR => &self.nbr,
            binding::REF_POS => &self.ref_pos,
            binding::STATUS => &self.status,
            binding::EVENTS => &self.events,
            binding::CELL_RANK => &self.cell_rank,
            binding::CELL_COUNT => &self.cell_count,
            binding::CELL_START => &self.cell_start,
            binding::CHUNK_SUMS => &self.chunk_sums,
            binding::SORTED => &self.sorted,
            binding::ENERGY => &self.energy,
            binding::RECORDS => &self.records,
            binding::ROD => &self.rod,
            binding::SCRATCH => &self.scratch,
            _ => unreachable!("no buffer at binding {b}"),
        }
    }

    /// What binding `b` binds: the whole buffer, or for the history and the lists the range of
    /// their first or second binding (`split_binding`).
    pub fn resource(&self, b: u32) -> wgpu::BindingResource<'_> {
        fn range(buf: &wgpu::Buffer, offset: u64, size: Option<u64>) -> wgpu::BindingResource<'_> {
            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: buf,
                offset,
                size: size.and_then(std::num::NonZeroU64::new),
            })
        }
        let hist = (self.n * self.slots * 16) as u64;
        let nbr = self.nbr.size();
        match b {
            binding::HIST if self.hist_split_bytes < hist => {
                range(&self.hist, 0, Some(self.hist_split_bytes))
            }
            binding::HIST_HI if self.hist_split_bytes < hist => {
                range(&self.hist, self.hist_split_bytes, None)
            }
            binding::HIST_HI => self.spare_hist.as_entire_binding(),
            binding::NBR if self.nbr_split_bytes < nbr => {
                range(&self.nbr, 0, Some(self.nbr_split_bytes))
            }
            binding::NBR_HI if self.nbr_split_bytes < nbr => {
                range(&self.nbr, self.nbr_split_bytes, None)
            }
            binding::NBR_HI => self.spare_nbr.as_entire_binding(),
            _ => self.get(b).as_entire_binding(),
        }
    }

    /// What binding `b` binds in the bind groups of parity `odd` (`BindGroups::at`): the
    /// even ones read the first copy of the state and write the second, the odd ones the
    /// other way round.
    pub fn resource_of(&self, b: u32, odd: bool) -> wgpu::BindingResource<'_> {
        let first = [binding::POS_R, binding::VEL_IM, binding::OMEGA];
        let second = [binding::POS_W, binding::VEL_W, binding::OMEGA_W];
        let copy = first
            .iter()
            .position(|&x| x == b)
            .map(|c| (c, odd))
            .or_else(|| second.iter().position(|&x| x == b).map(|c| (c, !odd)));
        match (copy, &self.second) {
            (Some((c, true)), Some(other)) => other[c].as_entire_binding(),
            (Some((c, _)), _) => self.get(first[c]).as_entire_binding(),
            (None, _) => self.resource(b),
        }
    }

    /// The block of pos_r that holds the position rests (after the shapes of oriented runs).
    fn rest_block(&self) -> u64 {
        if self.oriented {
            2
        } else {
            1
        }
    }

    /// Reads the particle buffers back.
    ///
    /// # Errors
    /// A failed map or poll (`EngineError::Device`).
    pub fn read_particles(&self, dev: &GpuDevice) -> Result<Packed, EngineError> {
        let n = self.n as u64;
        let parts = read(
            dev,
            &[
                (&self.pos_r, self.rest_block() * n * 16 + n * 16),
                (&self.vel_im, 2 * n * 16),
                (&self.omega, 2 * n * 16),
                (&self.info, n * 16),
                (&self.load, n * 32),
                (&self.hist, n * self.slots as u64 * 16),
                (&self.rod, if self.oriented { n * 48 } else { 0 }),
            ],
        )?;
        Ok(Packed {
            pos_r: bytemuck::pod_collect_to_vec(&parts[0][..self.n * 16]),
            pos_lo: bytemuck::pod_collect_to_vec(
                &parts[0][self.rest_block() as usize * self.n * 16..],
            ),
            vel_im: bytemuck::pod_collect_to_vec(&parts[1][..self.n * 16]),
            vel_lo: bytemuck::pod_collect_to_vec(&parts[1][self.n * 16..]),
            omega: bytemuck::pod_collect_to_vec(&parts[2][..self.n * 16]),
            spin_lo: bytemuck::pod_collect_to_vec(&parts[2][self.n * 16..]),
            info: bytemuck::pod_collect_to_vec(&parts[3]),
            load: bytemuck::pod_collect_to_vec(&parts[4]),
            hist: bytemuck::pod_collect_to_vec(&parts[5]),
            rod: bytemuck::pod_collect_to_vec(&parts[6]),
        })
    }
}

/// A buffer of `n` contact records.
pub fn records_buffer(dev: &GpuDevice, n: usize) -> wgpu::Buffer {
    dev.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("contact records"),
        size: (n.max(1) * std::mem::size_of::<super::layout::RecordGpu>()) as u64,
        usage: STORAGE,
        mapped_at_creation: false,
    })
}

/// The `bytes` of `buffer` from `offset`.
///
/// # Errors
/// As `read`.
pub fn read_at(
    dev: &GpuDevice,
    buffer: &wgpu::Buffer,
    offset: u64,
    bytes: u64,
) -> Result<Vec<u8>, EngineError> {
    read_ranges(dev, &[(buffer, offset, bytes)]).map(|mut v| v.swap_remove(0))
}

/// Copies `(buffer, bytes)` ranges into one MAP_READ buffer and returns their bytes.
///
/// # Errors
/// A failed map or poll, or an error the device reported meanwhile (`EngineError::Device`).
pub fn read(dev: &GpuDevice, parts: &[(&wgpu::Buffer, u64)]) -> Result<Vec<Vec<u8>>, EngineError> {
    let ranges: Vec<(&wgpu::Buffer, u64, u64)> = parts.iter().map(|&(b, n)| (b, 0, n)).collect();
    read_ranges(dev, &ranges)
}

/// Copies `(buffer, offset, bytes)` ranges into one MAP_READ buffer and returns their bytes.
///
/// # Errors
/// As `read`.
pub fn read_ranges(
    dev: &GpuDevice,
    parts: &[(&wgpu::Buffer, u64, u64)],
) -> Result<Vec<Vec<u8>>, EngineError> {
    let total: u64 = parts.iter().map(|p| p.2).sum();
    let staging = dev.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: total.max(4),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = dev
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("readback"),
        });
    let mut off = 0;
    for &(b, from, bytes) in parts {
        if bytes > 0 {
            enc.copy_buffer_to_buffer(b, from, &staging, off, bytes);
        }
        off += bytes;
    }
    dev.queue.submit([enc.finish()]);
    let sizes: Vec<u64> = parts.iter().map(|p| p.2).collect();
    map_all(dev, &staging, &sizes)
}

/// Maps `staging` once the device is done and splits it into pieces of `sizes` bytes.
fn map_all(
    dev: &GpuDevice,
    staging: &wgpu::Buffer,
    sizes: &[u64],
) -> Result<Vec<Vec<u8>>, EngineError> {
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    dev.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| EngineError::Device(format!("waiting for the device: {e}")))?;
    let mapped = rx
        .recv()
        .map_err(|e| EngineError::Device(format!("readback never completed: {e}")))?;
    mapped.map_err(|e| EngineError::Device(format!("reading results back: {e}")))?;
    if let Some(e) = dev.take_error() {
        return Err(EngineError::Device(e));
    }
    let view = staging
        .get_mapped_range(..)
        .map_err(|e| EngineError::Device(format!("reading results back: {e}")))?;
    let mut out = Vec::with_capacity(sizes.len());
    let mut off = 0usize;
    for &bytes in sizes {
        out.push(view[off..off + bytes as usize].to_vec());
        off += bytes as usize;
    }
    drop(view);
    staging.unmap();
    Ok(out)
}

/// Bytes of a buffer of `bytes` in its first binding: all of it when it fits in `max`, else the
/// most that fits at a multiple of `align` (the second binding's offset must be aligned; 256
/// bytes, a multiple of the 16-byte history record).
pub fn split_binding(bytes: u64, max: u64, align: u64) -> u64 {
    if bytes <= max {
        bytes
    } else {
        max / align.max(16) * align.max(16)
    }
}
