//! Compaction: particles the sink removed stay in their slots, flagged dead, until they pass
//! 1/8 of the slots; then a download and an upload pack the live ones.

use super::*;

impl GpuEngine {
    /// At a chunk's start: the removed particles dropped once they fill more than 1/8 of some
    /// job's slots (builds that sort by cell move them to the end of the job's block, but the
    /// dispatches still cover them).
    pub(super) fn compact(&mut self) -> Result<(), EngineError> {
        let Some(run) = &self.run else {
            return Ok(());
        };
        if run.jobs.iter().any(|j| (j.loaded - j.alive) * 8 > j.loaded) {
            let all = self.read_states()?;
            let refs: Vec<&State<f64>> = all.iter().collect();
            self.load(&refs)?;
        }
        Ok(())
    }
}
