//! GPU jobs that run at the same time share one engine (`--batch J`): each job keeps its own
//! lifecycle, thread, checkpoints and observers, and sees a `BatchMember`, a `Backend` whose
//! `advance` waits until every running member of its batch has asked for a chunk; then the
//! members that asked for the same number of steps advance together in the same dispatches (the
//! others are masked and go in the next round). A job's chunks, and so its bits, are exactly those
//! it has alone (`GpuEngine::batch`).

use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use crate::engine::contact::ContactRecord;
use crate::engine::gpu::{GpuDevice, GpuEngine};
use crate::engine::{
    Backend, BackendInfo, ChunkReport, DispatchCount, EngineConfig, EngineError, State,
};

/// The batches of one `sweep launch` or `resume`: jobs join the first batch that accepts them.
pub struct GpuBatches {
    /// Most jobs per batch.
    capacity: usize,
    device: Mutex<Option<(GpuDevice, Option<String>)>>,
    hubs: Mutex<Vec<Arc<Hub>>>,
    /// The most jobs any batch held.
    largest: std::sync::atomic::AtomicUsize,
}

/// One shared engine and its members' requests.
struct Hub {
    inner: Mutex<HubInner>,
    turn: Condvar,
}

struct HubInner {
    engine: GpuEngine,
    members: Vec<Slot>,
}

#[derive(Default)]
struct Slot {
    /// Still running (false once its job dropped the backend).
    live: bool,
    /// Steps asked for and not yet run.
    request: Option<u64>,
    result: Option<Result<ChunkReport, EngineError>>,
}

impl GpuBatches {
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.clamp(1, crate::engine::gpu::MAX_JOBS),
            device: Mutex::new(None),
            hubs: Mutex::new(Vec::new()),
            largest: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// The most jobs one batch has held (0: no GPU job ran).
    pub fn largest(&self) -> usize {
        self.largest.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The batches' device, acquired by `acquire` at the first call; with the note that came
    /// with it.
    ///
    /// # Errors
    /// Whatever `acquire` fails with.
    pub fn device(
        &self,
        acquire: impl FnOnce() -> anyhow::Result<(GpuDevice, Option<String>)>,
    ) -> anyhow::Result<(GpuDevice, Option<String>)> {
        let mut d = lock(&self.device);
        if d.is_none() {
            *d = Some(acquire()?);
        }
        Ok(d.clone().expect("set above"))
    }

    /// A backend for a job of `config` and `state` in the first batch with room that can hold
    /// it, or in a new one on `dev`.
    ///
    /// # Errors
    /// The engine's (buffers beyond the device, kernels rejected).
    pub fn join(
        &self,
        dev: &GpuDevice,
        config: EngineConfig,
        state: &State<f64>,
    ) -> Result<Box<dyn Backend>, EngineError> {
        let mut hubs = lock(&self.hubs);
        // A batch whose jobs have all ended frees its device memory.
        hubs.retain(|h| lock(&h.inner).members.iter().any(|m| m.live));
        for hub in hubs.iter() {
            let mut inner = lock(&hub.inner);
            if inner.members.len() < self.capacity && inner.engine.accepts(&config, state) {
                // Buffers beyond the device's binding limit: the job starts a batch of its own.
                let Ok(j) = inner.engine.add_job(config.clone(), state) else {
                    continue;
                };
                inner.members.push(Slot {
                    live: true,
                    ..Slot::default()
                });
                debug_assert_eq!(j + 1, inner.members.len());
                self.largest
                    .fetch_max(j + 1, std::sync::atomic::Ordering::Relaxed);
                return Ok(Box::new(BatchMember {
                    hub: hub.clone(),
                    job: j,
                    pending: None,
                }));
            }
        }
        let options = super::gpu_variants::gpu_options()
            .map_err(|e| EngineError::Device(format!("{e:#}")))?;
        let engine = GpuEngine::batch(dev, vec![config], &[state], options)?;
        let hub = Arc::new(Hub {
            inner: Mutex::new(HubInner {
                engine,
                members: vec![Slot {
                    live: true,
                    ..Slot::default()
                }],
            }),
            turn: Condvar::new(),
        });
        hubs.push(hub.clone());
        self.largest
            .fetch_max(1, std::sync::atomic::Ordering::Relaxed);
        Ok(Box::new(BatchMember {
            hub,
            job: 0,
            pending: None,
        }))
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// One job's view of a shared engine.
pub struct BatchMember {
    hub: Arc<Hub>,
    job: usize,
    /// An upload that failed, reported by the next `advance`.
    pending: Option<EngineError>,
}

impl HubInner {
    /// Runs one round if every live member has asked: the largest group of equal requests
    /// (ties: the shorter chunk) advances, the rest are masked. Returns whether it ran.
    fn try_round(&mut self) -> bool {
        let live: Vec<usize> = (0..self.members.len())
            .filter(|&k| self.members[k].live)
            .collect();
        if live.is_empty() || live.iter().any(|&k| self.members[k].request.is_none()) {
            return false;
        }
        let mut sizes: Vec<u64> = live
            .iter()
            .filter_map(|&k| self.members[k].request)
            .collect();
        sizes.sort_unstable();
        let steps = *sizes
            .iter()
            .max_by_key(|&&s| {
                (
                    sizes.iter().filter(|&&x| x == s).count(),
                    std::cmp::Reverse(s),
                )
            })
            .expect("a live member");
        for k in 0..self.members.len() {
            let on = self.members[k].live && self.members[k].request == Some(steps);
            self.engine.set_active(k, on);
        }
        match self.engine.advance_batch(steps) {
            Ok(reports) => {
                for (k, r) in reports.into_iter().enumerate() {
                    let m = &mut self.members[k];
                    if m.live && m.request == Some(steps) {
                        m.request = None;
                        m.result = Some(r);
                    }
                }
            }
            Err(e) => {
                let msg = e.to_string();
                for m in &mut self.members {
                    if m.live && m.request == Some(steps) {
                        m.request = None;
                        m.result = Some(Err(EngineError::Device(msg.clone())));
                    }
                }
            }
        }
        true
    }
}

impl Backend for BatchMember {
    fn advance(&mut self, steps: u64) -> Result<ChunkReport, EngineError> {
        if let Some(e) = self.pending.take() {
            return Err(e);
        }
        let mut inner = lock(&self.hub.inner);
        inner.members[self.job].request = Some(steps);
        loop {
            if let Some(r) = inner.members[self.job].result.take() {
                return r;
            }
            if inner.try_round() {
                self.hub.turn.notify_all();
                continue;
            }
            inner = self.hub.turn.wait(inner).unwrap_or_else(|p| p.into_inner());
        }
    }

    /// # Panics
    /// When the device fails while reading back; runners use `try_download`.
    fn download(&mut self) -> State<f64> {
        match self.try_download() {
            Ok(s) => s,
            Err(e) => panic!("GPU backend: {e}"),
        }
    }

    fn try_download(&mut self) -> Result<State<f64>, EngineError> {
        lock(&self.hub.inner).engine.download_job(self.job)
    }

    fn kinetic_energy(&mut self) -> Result<f64, EngineError> {
        lock(&self.hub.inner).engine.kinetic_energy_job(self.job)
    }

    fn upload(&mut self, state: &State<f64>) {
        if let Err(e) = lock(&self.hub.inner).engine.upload_job(self.job, state) {
            self.pending = Some(e);
        }
    }

    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError> {
        lock(&self.hub.inner).engine.contact_records_job(self.job)
    }

    fn describe(&self) -> BackendInfo {
        lock(&self.hub.inner).engine.describe()
    }

    fn dispatches(&self) -> Option<DispatchCount> {
        lock(&self.hub.inner).engine.dispatches()
    }
}

impl Drop for BatchMember {
    fn drop(&mut self) {
        let mut inner = lock(&self.hub.inner);
        inner.members[self.job].live = false;
        inner.members[self.job].request = None;
        inner.engine.set_active(self.job, false);
        // The others may have been waiting for this member only.
        inner.try_round();
        self.hub.turn.notify_all();
    }
}
