//! The DEM engine: particle state, contact laws, walls, neighbour search, integration and the
//! backends that run them. It never touches the store; observers read downloaded state.

pub mod backend;
pub mod choice;
pub mod config;
pub mod contact;
pub mod cpu;
pub mod cpu_clock;
pub mod effects;
pub mod gpu;
pub mod grid;
pub mod history;
pub mod memory;
pub mod periodic;
mod position;
pub mod real;
pub mod shape;
pub mod state;
pub mod translated;
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
