//! `sweep bench`'s arguments (shared by one engine's runs and a batch's).

use sweep::runner::backend::BackendChoice;

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// silo-bed, chute-bed or chute-rods.
    #[arg(long, default_value = "silo-bed")]
    pub scene: String,
    #[arg(long, default_value_t = 30_000)]
    pub particles: usize,
    /// Timed steps (after 100 untimed warm-up steps).
    #[arg(long, default_value_t = 200)]
    pub steps: u64,
    /// Repeat the timed steps (in chunks of --steps) until the timed window lasts at least this
    /// many seconds; later --repeat runs time as many steps as the first. The steps reported
    /// are those timed. Not with --lammps, whose input runs --steps.
    #[arg(long, default_value_t = 0.0, conflicts_with = "lammps")]
    pub min_seconds: f64,
    #[arg(long, default_value = "cpu")]
    pub backend: BackendChoice,
    #[command(flatten)]
    pub gpu: super::run_args::GpuArgs,
    #[arg(long, default_value = "f32")]
    pub precision: String,
    /// Engine threads (0: all cores).
    #[arg(long, default_value_t = 0, value_parser = super::run_args::bounded(0, super::run_args::MAX_THREADS))]
    pub threads: usize,
    /// Runs from the same start (each with its own warm-up): the median is reported and stored,
    /// with the best and every run. On a shared or virtual machine single runs scatter by tens
    /// of per cent; every run must end in the same state (checked through the checksum).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,
    /// Time the runs from a representative state instead of the lattice start, made on the CPU
    /// in f32 (all cores) and kept in `bench-beds/` beside the database for reuse (so every
    /// backend and precision starts from the same bed). silo-bed: the lattice collapses into a
    /// random bed and comes to rest (kinetic energy below 10⁻⁴ m g d per particle, the silo
    /// study's criterion; about 4·10⁴ steps, a minute at N = 3·10⁴ on two cores), stored as
    /// scene `silo-bed/settled`. chute-bed: 20 √(L/g) of flow (about 2·10⁵ steps, a few minutes
    /// at 3·10⁴), stored as `chute-bed/flowing`.
    #[arg(long)]
    pub settle: bool,
    /// The most steps `--settle` may take to bring silo-bed to rest before giving up.
    #[arg(long, default_value_t = 400_000)]
    pub settle_max_steps: u64,
    /// Also write the scene as it is timed (settled with `--settle`) for LAMMPS into this
    /// directory: `data.SCENE` and `in.SCENE` (same spheres, law constants, walls, gravity,
    /// periodic axes, skin, dt and steps), to measure LAMMPS beside sweep on this machine with
    /// `mpirun -np 2 lmp -in in.SCENE`.
    #[arg(long, value_name = "DIR")]
    pub lammps: Option<std::path::PathBuf>,
    /// Advance this many copies of the scene together on the GPU (one batch, 1 to 32 jobs) and
    /// report their aggregate rate (not stored).
    #[arg(long, value_name = "J", value_parser = clap::value_parser!(u32).range(1..=32))]
    pub batch: Option<u32>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Do not store the result in the database.
    #[arg(long)]
    pub no_store: bool,
    #[command(flatten)]
    pub db: DbArg,
}
