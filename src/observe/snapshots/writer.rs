//! The snapshot observer: writes a frame of every particle every `interval_s` of simulated time,
//! at the job's chunk boundaries, into `<job dir>/snapshots/frame-<chunk>.snap`. Frames are
//! named by chunk index and written atomically, so a resumed run that passes a chunk again
//! rewrites the same frame with the same bytes (the run itself is exact on resume). It only
//! reads the state; the frame layout is `frame`'s.

use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::frame::{Frame, FrameError};
use crate::engine::{EngineError, State};

/// Settings of the snapshot observer (campaign `observers.snapshots`; absent: no frames).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SnapshotSettings {
    /// Simulated seconds between frames (s), rounded to a whole number of the job's chunks
    /// (its sampling interval), at least one. `sweep export --vtk` turns the frames into ParaView
    /// files. Each frame is about 85 bytes per particle (125 for spherocylinders).
    pub interval_s: f64,
}

impl SnapshotSettings {
    /// Problems with the settings, as (field, expectation) for campaign errors.
    pub fn problems(&self) -> Vec<(String, String)> {
        let mut p = Vec::new();
        if !(self.interval_s > 0.0 && self.interval_s.is_finite()) {
            p.push((
                "interval_s".into(),
                format!("expected seconds > 0, got {}", self.interval_s),
            ));
        }
        p
    }
}

/// The directory of a job's frames, under its job directory.
pub fn snapshot_dir(job_dir: &Path) -> PathBuf {
    job_dir.join("snapshots")
}

/// Writes a job's frames at chunk boundaries; does nothing when the job has no snapshot settings.
pub struct SnapshotWriter {
    dir: PathBuf,
    job_hash: String,
    /// A frame every this many chunks; 0 = off.
    every_chunks: u64,
}

impl SnapshotWriter {
    /// The writer of the job `job_hash` (directory `job_dir`) whose chunks last `chunk_dt_s`.
    pub fn new(
        settings: Option<&SnapshotSettings>,
        job_dir: &Path,
        job_hash: &str,
        chunk_dt_s: f64,
    ) -> Self {
        let every_chunks =
            settings.map_or(0, |s| ((s.interval_s / chunk_dt_s).round() as u64).max(1));
        Self {
            dir: snapshot_dir(job_dir),
            job_hash: job_hash.to_string(),
            every_chunks,
        }
    }

    /// Chunks between frames (0 when off).
    pub fn every_chunks(&self) -> u64 {
        self.every_chunks
    }

    /// Writes the frame of chunk `chunk` (the job's clock reading `job_time_s`) if one is due
    /// there; `state` is called only then (a download from the engine). Returns the file
    /// written.
    ///
    /// # Errors
    /// The download failed, or the frame could not be written.
    pub fn at_chunk(
        &self,
        chunk: u64,
        job_time_s: f64,
        state: impl FnOnce() -> Result<State<f64>, EngineError>,
    ) -> anyhow::Result<Option<PathBuf>> {
        if self.every_chunks == 0 || !chunk.is_multiple_of(self.every_chunks) {
            return Ok(None);
        }
        let s = state().map_err(|e| anyhow::anyhow!("snapshot at chunk {chunk}: {e}"))?;
        let path = frame_path(&self.dir, chunk);
        let frame = Frame::of_state(&s, &self.job_hash, chunk, job_time_s);
        crate::checkpoint::write_atomic(&path, &frame.encode()).map_err(|e| {
            anyhow::anyhow!("{}: cannot write the snapshot frame: {e}", path.display())
        })?;
        Ok(Some(path))
    }
}

/// The file of the frame at `chunk` in the snapshot directory `dir`.
pub fn frame_path(dir: &Path, chunk: u64) -> PathBuf {
    dir.join(format!("frame-{chunk:012}.snap"))
}

/// The frames in the snapshot directory `dir`, by chunk (no file read; temporary files skipped).
pub fn list_frames(dir: &Path) -> Vec<(u64, PathBuf)> {
    let mut v: Vec<(u64, PathBuf)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let chunk = name
                .strip_prefix("frame-")?
                .strip_suffix(".snap")?
                .parse()
                .ok()?;
            Some((chunk, e.path()))
        })
        .collect();
    v.sort();
    v
}

/// Reads and verifies the frame at `path` (of the job `job_hash`, when given).
///
/// # Errors
/// As `Frame::decode`, or the file cannot be read.
pub fn read_frame(path: &Path, job_hash: Option<&str>) -> Result<Frame, FrameError> {
    let p = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| FrameError::Io {
        path: p.clone(),
        source: e,
    })?;
    Frame::decode(&bytes, &p, job_hash)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_fall_on_whole_chunks_and_read_back() {
        let dir = tempfile::TempDir::new().unwrap();
        let settings = SnapshotSettings { interval_s: 0.1 };
        let w = SnapshotWriter::new(Some(&settings), dir.path(), "h", 0.05);
        assert_eq!(w.every_chunks(), 2);
        let mut s = State::<f64>::new(true, 0);
        s.push_sphere(9, [0.0, 0.0, 1.0], [0.5, 0.0, 0.0], 0.01, 2500.0, false);
        let mut downloads = 0;
        for chunk in 0..5 {
            w.at_chunk(chunk, chunk as f64 * 0.05, || {
                downloads += 1;
                Ok(s.clone())
            })
            .unwrap();
        }
        assert_eq!(downloads, 3, "frames at chunks 0, 2, 4 only");
        let frames = list_frames(&snapshot_dir(dir.path()));
        assert_eq!(
            frames.iter().map(|f| f.0).collect::<Vec<_>>(),
            vec![0, 2, 4]
        );
        let f = read_frame(&frames[2].1, Some("h")).unwrap();
        assert_eq!(f.chunk, 4);
        assert_eq!(f.job_time_s, 0.2);
        assert_eq!(f.pos, vec![[0.0, 0.0, 1.0]]);
        assert_eq!(f.vel, vec![[0.5, 0.0, 0.0]]);
        let off = SnapshotWriter::new(None, dir.path(), "h", 0.05);
        assert!(off
            .at_chunk(0, 0.0, || panic!("no download"))
            .unwrap()
            .is_none());
    }

    #[test]
    fn a_zero_or_nan_interval_is_a_problem() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let p = SnapshotSettings { interval_s: bad }.problems();
            assert_eq!(p.len(), 1, "{bad}");
            assert_eq!(p[0].0, "interval_s");
        }
        assert!(SnapshotSettings { interval_s: 0.5 }.problems().is_empty());
    }
}
