-- sweep's store. Version 1 (PRAGMA user_version = 1).
-- Units are in column names (SI). Results tables are meant for plain SQL use.

CREATE TABLE IF NOT EXISTS campaigns (
    id            INTEGER PRIMARY KEY,
    name          TEXT NOT NULL UNIQUE,
    file          TEXT NOT NULL,
    scene         TEXT NOT NULL,
    spec_json     TEXT NOT NULL,          -- the campaign file as parsed (normalised JSON)
    created_at    TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);

CREATE TABLE IF NOT EXISTS jobs (
    id              INTEGER PRIMARY KEY,
    hash            TEXT NOT NULL UNIQUE,  -- sha256 of the resolved parameters (canonical JSON)
    scene           TEXT NOT NULL,
    params_json     TEXT NOT NULL,         -- every physical and numerical parameter, resolved
    seed            INTEGER NOT NULL,      -- derived from the parameters
    status          TEXT NOT NULL DEFAULT 'pending'
                    CHECK (status IN ('pending', 'running', 'paused', 'done', 'failed')),
    attempts        INTEGER NOT NULL DEFAULT 0,
    last_error      TEXT,
    checkpoint_path TEXT,
    progress        REAL NOT NULL DEFAULT 0,   -- fraction of target simulated time
    sim_time_s      REAL NOT NULL DEFAULT 0,
    target_time_s   REAL NOT NULL,
    particles       INTEGER,
    particle_steps  INTEGER NOT NULL DEFAULT 0,
    wall_time_s     REAL NOT NULL DEFAULT 0,
    lease_owner     TEXT,
    heartbeat_at    REAL,                  -- unix seconds
    backend         TEXT,
    adapter         TEXT,
    precision       TEXT,
    program_version TEXT,
    created_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    finished_at     TEXT
);

-- A job may belong to several campaigns (same resolved parameters => same job).
CREATE TABLE IF NOT EXISTS campaign_jobs (
    campaign_id INTEGER NOT NULL REFERENCES campaigns(id),
    job_id      INTEGER NOT NULL REFERENCES jobs(id),
    label       TEXT NOT NULL,             -- e.g. "orifice_diameter_m=0.015,rotation_frequency_hz=0.5,replica=0"
    PRIMARY KEY (campaign_id, job_id)
);

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
    q_method                TEXT NOT NULL, -- how Q and its CI were obtained
    flowing_time_s          REAL NOT NULL,
    discharged_mass_kg      REAL NOT NULL,
    discharged_count        INTEGER NOT NULL,
    clogs                   INTEGER NOT NULL,
    clogged_time_s          REAL NOT NULL,
    permanently_clogged     INTEGER NOT NULL  -- 1 if the job stopped on a permanent clog
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
