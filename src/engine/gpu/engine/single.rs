//! The GPU engine as a `Backend`: one job (job 0 of a batch of one).

use super::*;

impl Backend for GpuEngine {
    fn advance(&mut self, steps: u64) -> Result<ChunkReport, EngineError> {
        self.advance_batch(steps)?.swap_remove(0)
    }

    /// # Panics
    /// When the device fails while reading back (it is lost); `advance` reports device errors
    /// before that, so a checkpoint is never written from a failed device.
    fn download(&mut self) -> State<f64> {
        match self.download_job(0) {
            Ok(s) => s,
            Err(e) => panic!("GPU backend: {e}"),
        }
    }

    fn try_download(&mut self) -> Result<State<f64>, EngineError> {
        self.download_job(0)
    }

    fn upload(&mut self, state: &State<f64>) {
        let r = if self.jobs() == 1 {
            self.load(&[state])
        } else {
            self.upload_job(0, state)
        };
        if let Err(e) = r {
            self.pending = Some(e);
        }
    }

    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError> {
        self.contact_records_job(0)
    }

    /// Summed on the device at the last chunk's end (per workgroup, then in f64 here), so a
    /// chunk reads back a few hundred numbers instead of the state.
    fn kinetic_energy(&mut self) -> Result<f64, EngineError> {
        self.kinetic_energy_job(0)
    }

    fn dispatches(&self) -> Option<DispatchCount> {
        Some(self.dispatches)
    }

    fn profile_passes(
        &mut self,
        steps: u64,
    ) -> Result<Option<Vec<crate::engine::backend::PassTime>>, EngineError> {
        GpuEngine::profile_passes(self, steps)
    }

    fn describe(&self) -> BackendInfo {
        BackendInfo {
            kind: "gpu".into(),
            precision: "f32".into(),
            adapter: self.dev.info.name.clone(),
            threads: 0,
        }
    }
}
