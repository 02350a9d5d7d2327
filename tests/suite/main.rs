//! The integration tests, one binary. One link instead of one per file, and the test threads
//! share the cores across every file's tests instead of waiting for each file's slowest one.
//! Each module was a test file of its own; run one with `cargo test --release --test suite
//! -- silo::` (or any part of a test's path).

mod common;

mod accuracy_replicas;
mod accuracy_report;
mod campaign_validation;
mod chute_cli;
mod chute_profiles;
mod chute_resume_compat;
mod chute_warm_start;
mod claims;
mod cli;
mod coarse_grain;
mod determinism;
mod engine_collisions;
mod engine_conservation;
mod engine_contacts;
mod engine_stability;
mod export;
mod faults;
mod gpu;
mod gpu_batch;
mod gpu_dispatch;
mod gpu_fused;
mod gpu_law;
mod gpu_rods;
mod gpu_translation;
mod gpu_validation;
mod integrity;
mod layers;
mod observe_chute;
mod plan_store;
mod precision;
mod report_chute;
mod report_chute_profiles;
mod resume_turns;
mod schema_migration;
mod silo;
mod silo_fields;
mod silo_pk_claims;
mod slurm;
mod spherocylinder;
mod spherocylinder_engine;
mod spherocylinder_impact;
mod stability;
mod target;
mod translation;
