//! sweep: parameter studies of granular flow. Campaign files are expanded into jobs, each job runs
//! a DEM scene on a backend, observers sample the state, results land in SQLite and reports
//! redraw the papers' figures from them.

// `!(x > 0.0)` is how parameter checks reject NaN along with non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bench;
pub mod campaign;
pub mod checkpoint;
pub mod engine;
pub mod export;
pub mod lammps;
pub mod observe;
pub mod pooled;
pub mod project;
pub mod report;
pub mod runner;
pub mod scene;
pub mod store;
