//! The DEM engine: particle state, contact laws, walls, neighbour search, integration and the
//! backends that run them. It never touches the store; observers read downloaded state.

pub mod backend;
pub mod config;
pub mod contact;
pub mod cpu;
pub mod effects;
mod force_gather;
pub mod gpu;
pub mod grid;
pub mod history;
mod kick;
mod kinematics;
pub mod memory;
mod oriented;
mod pair_lanes;
mod pair_pass;
mod particle;
pub mod periodic;
mod position;
pub mod real;
mod rod_kick;
mod rod_lanes;
mod rod_pass;
pub mod shape;
#[cfg(target_arch = "x86_64")]
mod simd;
mod skin;
pub mod state;
mod team;
pub mod translated;
mod verlet;
pub mod walls;
pub mod watchdog;

pub use backend::{
    Backend, BackendInfo, ChunkReport, DispatchCount, EngineError, PassTime, SinkEvent,
};
pub use config::EngineConfig;
pub use cpu::CpuEngine;
pub use effects::Effects;
pub use real::{Real, V3};
pub use state::State;
