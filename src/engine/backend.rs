//! The narrow interface every backend implements (CPU in `cpu/`, GPU in `gpu/`), and what a
//! chunk of steps reports. Observers only ever see a downloaded `State<f64>`.

use serde::{Deserialize, Serialize};

use super::contact::ContactRecord;
use super::state::State;

/// A particle removed by the sink.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SinkEvent {
    pub id: u32,
    pub mass_kg: f64,
    pub time_s: f64,
}

/// What a call to `advance` did.
#[derive(Clone, Debug, Default)]
pub struct ChunkReport {
    pub steps: u64,
    pub particle_steps: u64,
    pub removed: Vec<SinkEvent>,
    /// Largest overlap seen in the chunk, as a fraction of the smaller diameter.
    pub max_overlap_ratio: f64,
    /// Mean number of contacts per particle at the end of the chunk.
    pub contacts_per_particle: f64,
    pub list_builds: u64,
    /// K₁ / B of the energy watchdog (`watchdog::EnergyBudget`): the chunk's final kinetic
    /// energy over the most gravity, moving walls and stored elastic energy could supply. None
    /// when not measured (the check switched off).
    pub kinetic_growth: Option<f64>,
}

/// Which backend ran and with what.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BackendInfo {
    /// "cpu" or "gpu".
    pub kind: String,
    /// "f64" or "f32".
    pub precision: String,
    /// CPU: "rayon, T threads"; GPU: the adapter name.
    pub adapter: String,
    pub threads: usize,
}

/// The work a GPU engine recorded, counted as the device pays for it: each dispatch costs a
/// launch whatever it computes. A steady step is one without a list build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DispatchCount {
    /// Steps taken (a redone step counts once).
    pub steps: u64,
    /// Every dispatch recorded, voided ones included.
    pub dispatches: u64,
    pub steady_steps: u64,
    pub steady_dispatches: u64,
    /// The most dispatches any steady step recorded.
    pub max_steady_step: u64,
    /// List builds recorded: at chunk starts, where the engine predicted one, and after a stale step.
    pub builds: u64,
    /// Of those, builds that also sorted the particles by cell (GPU `reorder_by_cell`, when the
    /// scratch it needs binds).
    pub sorting_builds: u64,
    /// Steps recorded past a step whose lists were found stale: void on the device, redone.
    pub voided_steps: u64,
    /// Command buffers submitted.
    pub submissions: u64,
    /// Of the dispatches, one-dispatch steps (GPU `fused_step`: the forces of a step and the
    /// next kick and drift together), voided ones included.
    #[serde(default)]
    pub fused_steps: u64,
    /// Chunks that ended on the second copy of the state and copied it back (one dispatch each).
    #[serde(default)]
    pub copies_back: u64,
}

impl DispatchCount {
    /// Adds `other`'s counts (the work of several chunks or engines).
    pub fn add(&mut self, other: &DispatchCount) {
        self.steps += other.steps;
        self.dispatches += other.dispatches;
        self.steady_steps += other.steady_steps;
        self.steady_dispatches += other.steady_dispatches;
        self.max_steady_step = self.max_steady_step.max(other.max_steady_step);
        self.builds += other.builds;
        self.sorting_builds += other.sorting_builds;
        self.voided_steps += other.voided_steps;
        self.submissions += other.submissions;
        self.fused_steps += other.fused_steps;
        self.copies_back += other.copies_back;
    }
}

/// Errors a running simulation can end with.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    #[error("non-finite {what} of particle {id} at step {step} (t = {time_s:.6} s): the run diverged; lower dt or check the stiffness")]
    NonFinite {
        what: &'static str,
        id: u32,
        step: u64,
        time_s: f64,
    },
    #[error("overlap of {ratio:.3} d between particles at step {step} exceeds the limit {limit:.3} d: the time step or the stiffness is wrong for this scene{detail}")]
    Overlap {
        ratio: f64,
        limit: f64,
        step: u64,
        /// Which contact it was ("; deepest contact …"), where the engine can say; else empty.
        detail: String,
    },
    #[error("kinetic energy grew from {from_j:.3e} J to {to_j:.3e} J over steps {first_step}..={step}, {growth:.3e} times the {budget_j:.3e} J that gravity, moving walls and the stored elastic energy could supply (limit {limit}): the run is blowing up; lower dt well below t_c or check the stiffness")]
    EnergyBlowUp {
        from_j: f64,
        to_j: f64,
        budget_j: f64,
        growth: f64,
        limit: f64,
        first_step: u64,
        step: u64,
    },
    #[error("particle {id} has more than {slots} simultaneous contacts at step {step}: raise the history size")]
    HistoryFull { id: u32, slots: usize, step: u64 },
    #[error("GPU device: {0}")]
    Device(String),
}

/// A simulation backend.
pub trait Backend: Send {
    /// Advances `steps` time steps.
    ///
    /// # Errors
    /// A non-finite value, an overlap or a kinetic-energy growth beyond the watchdog limits, a
    /// full contact table, or a device failure; the state is then not to be checkpointed.
    fn advance(&mut self, steps: u64) -> Result<ChunkReport, EngineError>;
    /// Copies the state out, in f64. Panics if the device fails while reading back; runners
    /// use [`Backend::try_download`], which reports it instead.
    fn download(&mut self) -> State<f64>;
    /// Copies the state out, in f64, or says why the device could not.
    ///
    /// # Errors
    /// A device lost or failing during the read-back.
    fn try_download(&mut self) -> Result<State<f64>, EngineError> {
        Ok(self.download())
    }
    /// Kinetic energy, translational and rotational, of the free particles (J).
    ///
    /// # Errors
    /// A device failure while reading back.
    fn kinetic_energy(&mut self) -> Result<f64, EngineError> {
        Ok(self.try_download()?.kinetic_energy())
    }
    /// Replaces the state (a checkpoint being resumed, or particles inserted between chunks).
    fn upload(&mut self, state: &State<f64>);
    /// Every contact of the current state, each once, with its force (stress observers ask for
    /// it between chunks; the step loop never builds it).
    ///
    /// # Errors
    /// A backend that cannot provide it, or a device failure.
    fn contacts(&mut self) -> Result<Vec<ContactRecord>, EngineError>;
    fn describe(&self) -> BackendInfo;
    /// CPU seconds the engine's own worker threads have run since it was built (the CPU
    /// engine's pool and team; 0 for an engine that steps on the caller's thread or a device);
    /// None where a worker's clock cannot be read.
    fn workers_cpu_s(&self) -> Option<f64> {
        Some(0.0)
    }
    /// The dispatches recorded since the engine was built (GPU engines; None on the CPU).
    fn dispatches(&self) -> Option<DispatchCount> {
        None
    }
    /// The device time of each kernel over a chunk of `steps` steps, the state put back after
    /// (GPU engines whose device stamps passes; None otherwise).
    ///
    /// # Errors
    /// A failed dispatch or read-back.
    fn profile_passes(&mut self, _steps: u64) -> Result<Option<Vec<PassTime>>, EngineError> {
        Ok(None)
    }
}

/// One kernel's device time over a profiled chunk (`Backend::profile_passes`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassTime {
    /// The kernel's entry point.
    pub kernel: String,
    /// Dispatches of it in the chunk.
    pub calls: u64,
    /// Their device time together (ns), from the adapter's timestamps.
    pub ns: f64,
    /// Steps the chunk took before its lists went stale (later steps return at once).
    pub steps_timed: u64,
}
