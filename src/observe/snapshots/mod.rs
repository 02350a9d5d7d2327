//! Particle snapshots: the binary frame format (`frame`) and the observer that writes frames at
//! a job's chunk boundaries (`writer`).

mod frame;
mod writer;

pub use frame::{Frame, FrameError, FORMAT_VERSION};
pub use writer::{
    frame_path, list_frames, read_frame, snapshot_dir, SnapshotSettings, SnapshotWriter,
};
