-- sweep's store, at the version `SCHEMA_VERSION` in src/store/open.rs (PRAGMA user_version).
-- Every statement is idempotent (IF NOT EXISTS): migrating from an older version runs the whole
-- file again, which adds the new tables; open.rs adds the new columns of existing ones.
-- Units are in column names (SI). Results tables are meant for plain SQL use.

-- One row per launched version of a campaign: relaunching a changed file under the same name is
-- refused unless the user asks for a new version (`sweep launch --new-version`), which gets its
-- own row and its own jobs. Reports read the latest version unless told `NAME@vK`.
CREATE TABLE IF NOT EXISTS campaigns (
    id            INTEGER PRIMARY KEY,
    name          TEXT NOT NULL,
    version       INTEGER NOT NULL DEFAULT 1,
    file          TEXT NOT NULL,
    scene         TEXT NOT NULL,
    spec_json     TEXT NOT NULL,          -- the campaign file as parsed (normalised JSON)
    registered    INTEGER NOT NULL DEFAULT 1,  -- 0 while its jobs are being registered (chunk by chunk)
    looks_carried INTEGER NOT NULL DEFAULT 0,  -- claims' looks its earlier versions took
    alpha_carried REAL NOT NULL DEFAULT 0,     -- and the error rate they spent
    created_at    TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    UNIQUE (name, version)
);

CREATE TABLE IF NOT EXISTS jobs (
    id              INTEGER PRIMARY KEY,
    hash            TEXT NOT NULL UNIQUE,  -- sha256 of the resolved parameters (canonical JSON)
    scene           TEXT NOT NULL,
    params_json     TEXT NOT NULL,         -- every physical and numerical parameter, resolved
    seed            INTEGER NOT NULL,      -- derived from the parameters
    status          TEXT NOT NULL DEFAULT 'pending'
                    CHECK (status IN ('pending', 'running', 'paused', 'done', 'failed')),
    attempts        INTEGER NOT NULL DEFAULT 0,   -- claims that did not end in a clean pause
    max_attempts    INTEGER NOT NULL DEFAULT 3,   -- from the campaign's run.max_attempts
    stage           TEXT,                  -- what the job was doing last: 'claimed', 'fill', 'discharge', 'flow', 'measure'
    last_error      TEXT,
    checkpoint_path TEXT,
    progress        REAL NOT NULL DEFAULT 0,   -- fraction of target simulated time
    sim_time_s      REAL NOT NULL DEFAULT 0,
    target_time_s   REAL NOT NULL,
    particles       INTEGER,
    particle_steps  INTEGER NOT NULL DEFAULT 0,
    wall_time_s     REAL NOT NULL DEFAULT 0,
    lease_owner     TEXT,                  -- 'local:HOST:PID:T' (an OS lock in the job's directory says whether it lives) or 'slurm:…'
    heartbeat_at    REAL,                  -- unix seconds
    backend         TEXT,
    adapter         TEXT,
    precision       TEXT,
    backend_note    TEXT,                  -- why this backend: auto's reason for the CPU, a software adapter allowed
    threads         INTEGER,               -- engine threads it ran with (core-hours = wall_time_s × threads)
    cpu_time_s      REAL,                  -- CPU time its threads ran (NULL: part of it ran before sweep counted it)
    program_version TEXT,
    created_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    finished_at     TEXT
);

-- A job may belong to several campaigns (same resolved parameters => same job).
CREATE TABLE IF NOT EXISTS campaign_jobs (
    campaign_id INTEGER NOT NULL REFERENCES campaigns(id),
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    label       TEXT NOT NULL,             -- e.g. "orifice_diameter_m=0.015,rotation_frequency_hz=0.5,replica=0"
    origin      TEXT,                      -- NULL: the campaign file; 'target': added by its target
    PRIMARY KEY (campaign_id, job_id)
);
-- A job's label and first campaign are looked up per job (claims, resume, Slurm submission):
-- without this index each lookup reads the whole table, and a launch of N jobs costs N².
CREATE INDEX IF NOT EXISTS campaign_jobs_job ON campaign_jobs (job_id);
-- The next pending job, and the jobs in one state, without reading every job.
CREATE INDEX IF NOT EXISTS jobs_status ON jobs (status, id);

-- Silo discharge: M(t) sampled at a fixed interval after the orifice opens.
CREATE TABLE IF NOT EXISTS discharge_series (
    job_id    INTEGER NOT NULL REFERENCES jobs(id),
    t_s       REAL NOT NULL,               -- time since the orifice opened
    mass_kg   REAL NOT NULL,               -- cumulative discharged mass
    count     INTEGER NOT NULL,            -- cumulative discharged particles
    PRIMARY KEY (job_id, t_s)
);

-- Silo discharge summary, one row per job. Swept parameters repeated for easy SQL.
CREATE TABLE IF NOT EXISTS discharge_summary (
    job_id                  INTEGER PRIMARY KEY REFERENCES jobs(id),
    orifice_diameter_m      REAL NOT NULL,
    rotation_frequency_hz   REAL NOT NULL,
    particle_diameter_m     REAL NOT NULL,
    bulk_density_kg_per_m3  REAL NOT NULL,
    q_kg_per_s              REAL,          -- NULL when no flowing interval long enough
    q_ci95_kg_per_s         REAL,          -- half-width of the 95 % confidence interval
    q_method                TEXT NOT NULL, -- how Q was obtained, a code: blocks:dt=,skip=,clog=,exit=,mfrac,t_end=,drift=,n=
    flowing_time_s          REAL NOT NULL,
    discharged_mass_kg      REAL NOT NULL,
    discharged_count        INTEGER NOT NULL,
    clogs                   INTEGER NOT NULL,
    clogged_time_s          REAL NOT NULL,
    permanently_clogged     INTEGER NOT NULL, -- 1 if the job stopped on a permanent clog
    q_blocks                INTEGER           -- blocks Q is the mean of (NULL before schema 8)
);

CREATE TABLE IF NOT EXISTS clogs (
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    start_s     REAL NOT NULL,
    duration_s  REAL NOT NULL,
    permanent   INTEGER NOT NULL,
    PRIMARY KEY (job_id, start_s)
);

-- Throughput measured by `sweep bench`, used by `sweep plan` for estimates.
CREATE TABLE IF NOT EXISTS bench_runs (
    id                      INTEGER PRIMARY KEY,
    scene                   TEXT NOT NULL,
    backend                 TEXT NOT NULL,
    precision               TEXT NOT NULL,
    threads                 INTEGER NOT NULL,
    particles               INTEGER NOT NULL,
    steps                   INTEGER NOT NULL,
    dt_s                    REAL NOT NULL,
    particle_steps_per_s    REAL NOT NULL,
    contacts_per_particle   REAL NOT NULL,
    state_checksum          TEXT NOT NULL,
    machine                 TEXT NOT NULL,
    created_at              TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);

-- Chute flow of spherocylinders (Soft Matter 2022), one row per job. z is the height above the
-- centres of the rough base's spheres (m); blocks are layers of height L (the particle length).
CREATE TABLE IF NOT EXISTS chute_summary (
    job_id                  INTEGER PRIMARY KEY REFERENCES jobs(id),
    aspect_ratio            REAL NOT NULL,          -- xi = L/d
    inclination_deg         REAL NOT NULL,          -- alpha
    total_length_m          REAL NOT NULL,          -- L = l + d
    diameter_m              REAL NOT NULL,          -- d
    particles               INTEGER NOT NULL,       -- flowing particles (base excluded)
    bed_height_m            REAL NOT NULL,          -- height where the time-averaged density falls to half its bulk value
    steady_time_s           REAL,                   -- when the steady state was detected; NULL if never
    steady_stress_ratio     REAL,                   -- bulk sigma_xz/sigma_zz at that time (-> tan alpha)
    measure_start_s         REAL NOT NULL,
    measure_end_s           REAL NOT NULL,
    samples                 INTEGER NOT NULL,       -- snapshots used for the profiles
    msd_fit_min_lag_s       REAL NOT NULL,          -- D is fitted to MSD_z = 2 D tau + c on this lag range
    msd_fit_max_lag_s       REAL NOT NULL,
    mean_cos_theta          REAL NOT NULL,          -- <cos theta>, theta between the axis and the plane normal to the flow
    d_perp_m                REAL NOT NULL,          -- sqrt(4/pi (d l <cos theta> + pi d^2/4))
    cg_width_m              REAL NOT NULL,          -- coarse-graining width w (cutoff 4 w)
    steady                  INTEGER NOT NULL        -- 1 if the criteria held when measurement started
);

-- Per block of height L: D(z), shear rate and fields averaged over the block, v_z statistics.
CREATE TABLE IF NOT EXISTS chute_blocks (
    job_id                  INTEGER NOT NULL REFERENCES jobs(id),
    block                   INTEGER NOT NULL,       -- k: MSD of particles whose whole trajectory's mean height is in [k L, (k+1) L) (msd_blocks "window": pairs by their lag window's mean height)
    z_m                     REAL NOT NULL,          -- block centre
    diffusion_m2_per_s      REAL,                   -- D_z from the MSD fit over the whole measurement; NULL if too few particles
    diffusion_stderr_m2_per_s REAL,                 -- standard error of D_z from msd_error_windows time windows: std of their D / sqrt(M) (data-weighted); NULL if a window is shorter than the longest fitted lag
    msd_fit_r               REAL,                   -- correlation coefficient of the MSD fit
    shear_rate_per_s        REAL NOT NULL,          -- dV_x/dz averaged over the block
    velocity_x_m_per_s      REAL NOT NULL,
    solid_fraction          REAL NOT NULL,
    mean_particles          REAL NOT NULL,          -- particles per snapshot in the block
    vz_std_m_per_s          REAL,
    vz_skewness             REAL,
    correlation_length_m    REAL,                   -- from the fit ln C(r)/C(0) = -r/l
    -- Schema 13 (NULL in older rows, and for a job resumed from a checkpoint written before):
    nematic_order_s2        REAL,                   -- largest eigenvalue of Q = <(3 u u - I)/2> over the rods centred in the block, Q averaged over snapshots; NULL for spheres (no axis)
    mean_abs_cos_flow       REAL,                   -- <|cos theta|>, theta between a rod's axis and the flow direction x; NULL for spheres
    diffusion_y_m2_per_s    REAL,                   -- D_y from the MSD of y (unwrapped across the periodic box), fitted as D_z: same lags, blocks, windows
    diffusion_y_stderr_m2_per_s REAL,               -- its standard error from the msd_error_windows time windows, as D_z's
    PRIMARY KEY (job_id, block)
);

-- MSD_z(tau) per block.
CREATE TABLE IF NOT EXISTS chute_msd (
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    block       INTEGER NOT NULL,
    lag_s       REAL NOT NULL,
    msd_m2      REAL NOT NULL,
    pairs       INTEGER NOT NULL,                   -- (particle, origin) pairs averaged, assigned as in chute_blocks.block
    PRIMARY KEY (job_id, block, lag_s)
);

-- Coarse-grained z profiles (time averaged), on a grid finer than the blocks.
CREATE TABLE IF NOT EXISTS chute_fields (
    job_id               INTEGER NOT NULL REFERENCES jobs(id),
    z_m                  REAL NOT NULL,
    density_kg_per_m3    REAL NOT NULL,
    velocity_x_m_per_s   REAL NOT NULL,
    shear_rate_per_s     REAL NOT NULL,
    stress_xz_pa         REAL NOT NULL,             -- kinetic + contact, compressive positive
    stress_zz_pa         REAL NOT NULL,
    PRIMARY KEY (job_id, z_m)
);

-- Standardised v_z PDF per block: (v_z - <v_z>)/std, histogram normalised to unit area.
CREATE TABLE IF NOT EXISTS chute_vz_pdf (
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    block       INTEGER NOT NULL,
    x           REAL NOT NULL,                      -- bin centre, in standard deviations
    density     REAL NOT NULL,
    PRIMARY KEY (job_id, block, x)
);

-- Spatial correlation of v_z fluctuations per block, bins of width L/4.
CREATE TABLE IF NOT EXISTS chute_correlation (
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    block       INTEGER NOT NULL,
    r_m         REAL NOT NULL,                      -- bin centre
    c_m2_per_s2 REAL NOT NULL,
    pairs       INTEGER NOT NULL,
    PRIMARY KEY (job_id, block, r_m)
);

-- The approach to steady state: kinetic energy and bulk stress ratio over time.
CREATE TABLE IF NOT EXISTS chute_series (
    job_id              INTEGER NOT NULL REFERENCES jobs(id),
    t_s                 REAL NOT NULL,
    kinetic_energy_j    REAL NOT NULL,
    stress_ratio        REAL,                       -- bulk sigma_xz/sigma_zz; NULL when not sampled
    mean_vx_m_per_s     REAL,                       -- mass-weighted mean V_x of the flowing particles (NULL before schema 7)
    PRIMARY KEY (job_id, t_s)
);

-- The verdict on a chute job's flow (observe/chute/flow_state.rs). Jobs done before schema 7
-- have no row: their chute_summary.steady says only whether the transient's criteria held.
CREATE TABLE IF NOT EXISTS chute_flow_state (
    job_id                      INTEGER PRIMARY KEY REFERENCES jobs(id),
    state                       TEXT NOT NULL CHECK (state IN ('steady', 'drifted', 'not_steady', 'not_flowing')),
    measured                    INTEGER NOT NULL,   -- 1 if profiles and D(z) were measured and stored
    min_flow_velocity_m_per_s   REAL NOT NULL       -- below this mean V_x the bed is not flowing
);

-- The stationarity criteria (observe/stationarity.rs, observe/steady.rs) on the transient's last
-- window and on the measurement window. Trends: |slope| T / |mean| (change; T the window's span,
-- or for the transient the measurement's length when longer: the change the trend would make
-- while measured) and |slope| / se of the batch-means fit (t), passed when change <= the job's
-- tolerance and t <= t_critical.
CREATE TABLE IF NOT EXISTS chute_stationarity (
    job_id              INTEGER NOT NULL REFERENCES jobs(id),
    phase               TEXT NOT NULL CHECK (phase IN ('transient', 'measurement')),
    start_s             REAL NOT NULL,
    end_s               REAL NOT NULL,
    ke_mean_j           REAL,
    ke_change           REAL,
    ke_t                REAL,
    vx_mean_m_per_s     REAL NOT NULL,
    vx_change           REAL,
    vx_t                REAL,
    t_critical          REAL,
    stress_ratio        REAL,                       -- mean bulk -sigma_xz/sigma_zz (-> tan alpha)
    ratio_ok            INTEGER NOT NULL,
    flowing             INTEGER NOT NULL,
    steady              INTEGER NOT NULL,
    PRIMARY KEY (job_id, phase)
);

-- Slurm executor: one row per job handed to Slurm (a job that `sweep resume` resubmits gets a new
-- row). `state` is sweep's view; Slurm's own view is asked live (squeue, scontrol show job).
-- A job is done when its task's result file verifies and is ingested, never on Slurm's word.
CREATE TABLE IF NOT EXISTS slurm_tasks (
    id              INTEGER PRIMARY KEY,
    job_id          INTEGER NOT NULL REFERENCES jobs(id),
    campaign_id     INTEGER REFERENCES campaigns(id),
    array_job_id    TEXT NOT NULL,          -- what `sbatch --parsable` printed (before any ';cluster')
    array_task_id   INTEGER NOT NULL,       -- SLURM_ARRAY_TASK_ID of the job's task
    script_path     TEXT NOT NULL,          -- the sbatch script, kept for provenance
    settings_json   TEXT NOT NULL,          -- executor settings of the submission (resume reuses them)
    state           TEXT NOT NULL DEFAULT 'active'
                    CHECK (state IN ('active', 'done', 'failed', 'ended', 'cancelled')),
    note            TEXT,                   -- how it ended: Slurm state and exit code, or the error
    submitted_at    TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    UNIQUE (array_job_id, array_task_id)
);
CREATE INDEX IF NOT EXISTS slurm_tasks_job ON slurm_tasks (job_id);

-- How hard a job was numerically, for the accuracy–cost map: one row per finished job.
CREATE TABLE IF NOT EXISTS job_numerics (
    job_id                   INTEGER PRIMARY KEY REFERENCES jobs(id),
    dt_s                     REAL NOT NULL,
    steps                    INTEGER NOT NULL,
    max_overlap_ratio        REAL NOT NULL,   -- largest overlap over the run, as a fraction of d
    mean_contacts            REAL NOT NULL,   -- contacts per particle, averaged over chunks
    list_builds              INTEGER NOT NULL -- neighbour-list rebuilds
);

-- A job's kinetic energy over its measurement window (silo: after skip_initial_s; chute: the
-- measurement phase), sampled at every chunk: its mean and its least-squares trend. A steady flow
-- has no trend; a numerical setting that heats or cools the flow shows one (the accuracy map).
CREATE TABLE IF NOT EXISTS job_energy (
    job_id                   INTEGER PRIMARY KEY REFERENCES jobs(id),
    t_start_s                REAL NOT NULL,
    t_end_s                  REAL NOT NULL,
    samples                  INTEGER NOT NULL,
    mean_kinetic_j           REAL,
    drift_per_s              REAL             -- (dE/dt) / mean E
);

-- Coarse-grained fields (silo observer; truncated Gaussian kernel of width w, cutoff c w). One set
-- is one grid and one time window (a snapshot average around a map time, the whole-run mean, the
-- profile across the orifice); its arrays are the fields on that grid. In 'rz' sets (fields averaged
-- over θ) vectors and tensors are in the cylindrical basis (r, θ, z), in 'xyz' sets in (x, y, z).
-- Stresses are compressive positive; kinetic_pressure = tr(kinetic_stress) (the paper's p^k).
CREATE TABLE IF NOT EXISTS field_sets (
    id              INTEGER PRIMARY KEY,
    job_id          INTEGER NOT NULL REFERENCES jobs(id),
    name            TEXT NOT NULL,     -- e.g. 'map_t3.000', 'mean', 'orifice_profile'
    grid_kind       TEXT NOT NULL CHECK (grid_kind IN ('z', 'rz', 'xyz')),
    grid_json       TEXT NOT NULL,     -- {"origin_m":[..3],"spacing_m":[..3],"shape":[..3]}; rz: axis 0 = r, axis 1 = z, axis 2 has n = 1; z: axes 0,1 have n = 1
    kernel_width_m  REAL NOT NULL,
    cutoff_widths   REAL NOT NULL,
    t_start_s       REAL NOT NULL,
    t_end_s         REAL NOT NULL,
    samples         INTEGER NOT NULL,
    UNIQUE (job_id, name)
);
CREATE TABLE IF NOT EXISTS field_arrays (
    set_id      INTEGER NOT NULL REFERENCES field_sets(id),
    field       TEXT NOT NULL,     -- 'phi', 'density', 'momentum', 'velocity', 'kinetic_stress', 'kinetic_pressure', 'contact_stress', ...
    units       TEXT NOT NULL,     -- SI, e.g. 'kg/m^3', 'm/s', 'Pa', '1'
    components  INTEGER NOT NULL,  -- 1 scalar, 3 vector, 9 tensor (row-major)
    data        BLOB NOT NULL,     -- f64 little-endian; point index = (k*ny + j)*nx + i (axis 0 fastest, as VTK), then components
    PRIMARY KEY (set_id, field)
);

-- Scalar time series of a field observer, one value per sample (e.g. the kinetic pressure
-- averaged over the cylinder of radius and height D/2 above the orifice: fig11's <p^k>).
CREATE TABLE IF NOT EXISTS silo_field_series (
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    name        TEXT NOT NULL,     -- e.g. 'orifice_kinetic_pressure'
    t_s         REAL NOT NULL,     -- time since the orifice opened
    value       REAL NOT NULL,
    units       TEXT NOT NULL,
    flowing     INTEGER,           -- 1 flowing, 0 inside a clog, NULL not recorded (schema < 6)
    PRIMARY KEY (job_id, name, t_s)
);

-- Facts about the store itself, e.g. 'work_dir': the absolute path of the directory that holds
-- its checkpoints and shared stages (so a renamed or copied database still finds them).
CREATE TABLE IF NOT EXISTS store_meta (
    key     TEXT PRIMARY KEY,
    value   TEXT NOT NULL
);

-- Campaigns with a `target` (schema 8): each point's state after the latest round, and every
-- piece of work the target added (a job run longer, or a new replica), in the order chosen.
CREATE TABLE IF NOT EXISTS target_points (
    campaign_id     INTEGER NOT NULL REFERENCES campaigns(id),
    point           TEXT NOT NULL,     -- the point's label without its replica index
    observable      TEXT NOT NULL,     -- 'q' (silo) or 'd' (chute, the widest bulk block)
    mean            REAL,              -- pooled over the point's replicas (SI)
    ci95_rel        REAL,              -- half-width of its 95 % CI / |mean|; NULL: no estimate
    ci_from         TEXT,              -- 'pooled blocks' or 'replica spread'
    replicas        INTEGER NOT NULL,  -- replicas with an estimate
    runs            INTEGER NOT NULL,  -- replicas run (some may have none: clogged)
    measured_s      REAL NOT NULL,     -- simulated time of the point's jobs, summed
    particle_steps  INTEGER NOT NULL,  -- what the point cost, fills included
    met             INTEGER NOT NULL,  -- 1 when ci95_rel <= the target
    status          TEXT NOT NULL,     -- 'met', 'working', 'capped: ...', 'no estimate: ...'
    rounds          INTEGER NOT NULL,
    PRIMARY KEY (campaign_id, point)
);
CREATE TABLE IF NOT EXISTS target_work (
    id              INTEGER PRIMARY KEY,
    campaign_id     INTEGER NOT NULL REFERENCES campaigns(id),
    round           INTEGER NOT NULL,
    point           TEXT NOT NULL,
    job_id          INTEGER NOT NULL REFERENCES jobs(id),
    action          TEXT NOT NULL,     -- 'extend' (the job runs on to to_s) or 'replica' (a new job)
    from_s          REAL NOT NULL,     -- the job's end before (0 for a new replica)
    to_s            REAL NOT NULL,     -- the job's end after
    ci95_rel_before REAL,
    ci95_rel_expected REAL,            -- what the work should bring the point to
    particle_steps_expected REAL NOT NULL,
    created_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);

-- A campaign's claims, decided at each look: after its first runs (round 0) and after each
-- round of added work. Intervals are at `level` (α split over the campaign's looks).
CREATE TABLE IF NOT EXISTS claim_verdicts (
    campaign_id     INTEGER NOT NULL REFERENCES campaigns(id),
    round           INTEGER NOT NULL,
    claim_id        TEXT NOT NULL,
    statement       TEXT NOT NULL,
    paper           TEXT NOT NULL,     -- where the paper says it
    paper_value     TEXT NOT NULL,     -- the paper's number, as text
    test            TEXT NOT NULL,     -- 'compare', 'trend', 'minimum_inside', 'fit'
    what            TEXT NOT NULL,     -- what the value is ("q ratio", "janda d_min_m")
    verdict         TEXT NOT NULL CHECK (verdict IN ('supported', 'contradicted', 'undecided')),
    value           REAL,              -- at the pooled means; NULL: not computable yet
    lo              REAL,              -- interval at `level`; NULL: unknown
    hi              REAL,
    level           REAL NOT NULL,     -- two-sided confidence of [lo, hi] at this look
    bound           TEXT NOT NULL,     -- what supports the claim: '< 1', '> 0', 'in [a, b]'
    points          TEXT NOT NULL,     -- the points read, '; '-separated labels
    note            TEXT NOT NULL,     -- why undecided without an interval; a reversed step
    particle_steps  REAL NOT NULL,     -- spent on the points read, fills included
    wall_s          REAL NOT NULL,     -- their jobs' wall time
    forecast_particle_steps REAL,      -- still needed to decide (undecided only; NULL: unknown)
    forecast_wall_s REAL,
    created_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    PRIMARY KEY (campaign_id, round, claim_id)
);

-- What a campaign had spent when each look was taken (every job's work then, the claims'
-- own points or not), so that a claims table printed later still says the look's cost.
CREATE TABLE IF NOT EXISTS claim_looks (
    campaign_id     INTEGER NOT NULL REFERENCES campaigns(id),
    round           INTEGER NOT NULL,
    particle_steps  REAL NOT NULL,
    wall_s          REAL NOT NULL,
    core_hours      REAL NOT NULL,
    created_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    PRIMARY KEY (campaign_id, round)
);
