//! Batch membership: which jobs the batch holds and runs (a job added, replaced or stopped
//! leaves the others' bits unchanged).

use super::*;

impl GpuEngine {
    /// Replaces job j's particles (the others are read back and uploaded unchanged).
    ///
    /// # Errors
    /// As `new`.
    pub fn upload_job(&mut self, j: usize, state: &State<f64>) -> Result<(), EngineError> {
        let mut all = self.read_states()?;
        all[j] = state.clone();
        let refs: Vec<&State<f64>> = all.iter().collect();
        self.load(&refs)
    }

    /// Whether a job of `config` and `state` can join this batch: the same dt and compiled
    /// effects as its jobs, and room for it.
    pub fn accepts(&self, config: &EngineConfig, state: &State<f64>) -> bool {
        let c0 = &self.configs[0];
        self.jobs() < MAX_JOBS
            && config.dt_s == c0.dt_s
            && config.walls.len() <= MAX_WALLS
            && state.history.slots == self.slots
            && Specialization::of(config, state.rotation, state.oriented, state.history.slots)
                == self.pipes.spec
    }

    /// Adds a job to the batch (the others are read back and uploaded unchanged); returns its
    /// index.
    ///
    /// # Errors
    /// As `new`; the batch is then as it was.
    pub fn add_job(
        &mut self,
        config: EngineConfig,
        state: &State<f64>,
    ) -> Result<usize, EngineError> {
        if !self.accepts(&config, state) {
            return Err(EngineError::Device(
                "this job cannot share the batch (different dt or effects, or the batch is full)"
                    .into(),
            ));
        }
        let mut all = self.read_states()?;
        let j = all.len();
        let mut walls = [WallGpu::default(); MAX_WALLS];
        for (w, wall) in walls.iter_mut().zip(&config.walls) {
            *w = WallGpu::of(wall);
        }
        self.walls.extend(walls);
        self.configs.push(config);
        self.time.push(state.time);
        self.step.push(state.step);
        self.active.push(true);
        all.push(state.clone());
        let refs: Vec<&State<f64>> = all.iter().collect();
        if let Err(e) = self.load(&refs) {
            // Back to the batch without it.
            self.walls.truncate(j * MAX_WALLS);
            self.configs.pop();
            self.time.pop();
            self.step.pop();
            self.active.pop();
            all.pop();
            let refs: Vec<&State<f64>> = all.iter().collect();
            self.load(&refs)?;
            return Err(e);
        }
        Ok(j)
    }

    /// Stops (false) or restarts job j: a stopped job's particles stay as they are and its
    /// reports are empty, while the others go on.
    pub fn set_active(&mut self, j: usize, on: bool) {
        self.active[j] = on;
        if let Some(run) = &self.run {
            let offset = (j * std::mem::size_of::<Params>()) as u64
                + std::mem::offset_of!(Params, running) as u64;
            self.dev
                .queue
                .write_buffer(&run.bufs.params, offset, bytemuck::bytes_of(&(on as u32)));
        }
    }
}
