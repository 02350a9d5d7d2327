//! Checkpoints: a versioned binary format with a header (magic, format version, job hash, step,
//! time, backend, precision) and a CRC-32 over the payload. Written to a temporary file, fsynced,
//! renamed; the last two are kept. A corrupt, truncated or mismatched file is refused with the
//! reason, and the previous one is tried.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::engine::real::V3;
use crate::engine::shape::Quat;
use crate::engine::State;

const MAGIC: &[u8; 8] = b"SWEEPCK\0";
/// Format version; bump on any layout change (older files are then refused, not misread).
pub const FORMAT_VERSION: u32 = 2;

/// Header fields, readable without the payload.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    pub job_hash: String,
    pub step: u64,
    pub time_s: f64,
    pub backend: String,
    pub precision: String,
}

/// Why a checkpoint was refused.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a sweep checkpoint (bad magic)")]
    Magic { path: String },
    #[error("{path}: format version {found}, this sweep reads version {FORMAT_VERSION}")]
    Version { path: String, found: u32 },
    #[error("{path}: truncated ({what})")]
    Truncated { path: String, what: String },
    #[error("{path}: checksum mismatch (stored {stored:08x}, computed {computed:08x}): the file is corrupt")]
    Checksum {
        path: String,
        stored: u32,
        computed: u32,
    },
    #[error("{path}: belongs to job {found}, not {expected}")]
    Mismatch {
        path: String,
        found: String,
        expected: String,
    },
}

struct W(Vec<u8>);
impl W {
    fn u32(&mut self, x: u32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }
    fn str(&mut self, s: &str) {
        self.bytes(s.as_bytes());
    }
    fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for &x in v {
            self.f64(x);
        }
    }
    fn v3s(&mut self, v: &[V3<f64>]) {
        self.u64(v.len() as u64);
        for x in v {
            self.f64(x.x);
            self.f64(x.y);
            self.f64(x.z);
        }
    }
}

struct Rd<'a> {
    b: &'a [u8],
    at: usize,
    path: &'a str,
}
impl<'a> Rd<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], CheckpointError> {
        if self.at + n > self.b.len() {
            return Err(CheckpointError::Truncated {
                path: self.path.into(),
                what: what.into(),
            });
        }
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u32(&mut self, w: &str) -> Result<u32, CheckpointError> {
        Ok(u32::from_le_bytes(self.take(4, w)?.try_into().expect("4")))
    }
    fn u64(&mut self, w: &str) -> Result<u64, CheckpointError> {
        Ok(u64::from_le_bytes(self.take(8, w)?.try_into().expect("8")))
    }
    fn f64(&mut self, w: &str) -> Result<f64, CheckpointError> {
        Ok(f64::from_le_bytes(self.take(8, w)?.try_into().expect("8")))
    }
    fn len(&mut self, w: &str, elem: usize) -> Result<usize, CheckpointError> {
        let n = self.u64(w)? as usize;
        if n.saturating_mul(elem) > self.b.len() - self.at {
            return Err(CheckpointError::Truncated {
                path: self.path.into(),
                what: w.into(),
            });
        }
        Ok(n)
    }
    fn bytes(&mut self, w: &str) -> Result<&'a [u8], CheckpointError> {
        let n = self.len(w, 1)?;
        self.take(n, w)
    }
    fn str(&mut self, w: &str) -> Result<String, CheckpointError> {
        Ok(String::from_utf8_lossy(self.bytes(w)?).into_owned())
    }
    fn f64s(&mut self, w: &str) -> Result<Vec<f64>, CheckpointError> {
        let n = self.len(w, 8)?;
        (0..n).map(|_| self.f64(w)).collect()
    }
    fn v3s(&mut self, w: &str) -> Result<Vec<V3<f64>>, CheckpointError> {
        let n = self.len(w, 24)?;
        (0..n)
            .map(|_| Ok(V3::new(self.f64(w)?, self.f64(w)?, self.f64(w)?)))
            .collect()
    }
}

/// Serialises a checkpoint: header, then the payload (state and the job's own JSON `extra`:
/// phase, observers), then the payload's CRC-32.
pub fn encode(h: &Header, s: &State<f64>, extra: &str) -> Vec<u8> {
    let mut p = W(Vec::new());
    p.u64(s.id.len() as u64);
    for &i in &s.id {
        p.u32(i);
    }
    p.v3s(&s.pos);
    p.v3s(&s.vel);
    p.v3s(&s.force);
    p.f64s(&s.radius);
    p.f64s(&s.mass);
    p.f64s(&s.inv_mass);
    p.u32(s.rotation as u32);
    p.v3s(&s.omega);
    p.v3s(&s.torque);
    p.f64s(&s.inv_inertia);
    p.u32(s.oriented as u32);
    p.u64(s.orientation.len() as u64);
    for q in &s.orientation {
        for x in q.to_f64() {
            p.f64(x);
        }
    }
    p.v3s(&s.ang_mom);
    p.v3s(&s.inv_inertia_body);
    p.f64s(&s.half_length);
    p.u64(s.history.slots as u64);
    p.u64(s.history.partner.len() as u64);
    for &k in &s.history.partner {
        p.u32(k);
    }
    p.v3s(&s.history.spring);
    p.f64(s.time);
    p.u64(s.step);
    p.str(extra);
    let mut out = W(Vec::with_capacity(p.0.len() + 256));
    out.0.extend_from_slice(MAGIC);
    out.u32(FORMAT_VERSION);
    out.str(&h.job_hash);
    out.u64(h.step);
    out.f64(h.time_s);
    out.str(&h.backend);
    out.str(&h.precision);
    out.u32(crc32fast::hash(&p.0));
    out.bytes(&p.0);
    out.0
}

/// Parses and verifies a checkpoint. `expected_hash` refuses another job's file.
///
/// # Errors
/// Bad magic, another format version, truncation, a checksum mismatch, another job.
pub fn decode(
    bytes: &[u8],
    path: &str,
    expected_hash: Option<&str>,
) -> Result<(Header, State<f64>, String), CheckpointError> {
    let mut r = Rd {
        b: bytes,
        at: 0,
        path,
    };
    if r.take(8, "magic")
        .map_err(|_| CheckpointError::Magic { path: path.into() })?
        != MAGIC
    {
        return Err(CheckpointError::Magic { path: path.into() });
    }
    let v = r.u32("version")?;
    if v != FORMAT_VERSION {
        return Err(CheckpointError::Version {
            path: path.into(),
            found: v,
        });
    }
    let h = Header {
        job_hash: r.str("job hash")?,
        step: r.u64("step")?,
        time_s: r.f64("time")?,
        backend: r.str("backend")?,
        precision: r.str("precision")?,
    };
    if let Some(e) = expected_hash {
        if h.job_hash != e {
            return Err(CheckpointError::Mismatch {
                path: path.into(),
                found: h.job_hash,
                expected: e.into(),
            });
        }
    }
    let crc = r.u32("checksum")?;
    let payload = r.bytes("payload")?;
    let computed = crc32fast::hash(payload);
    if computed != crc {
        return Err(CheckpointError::Checksum {
            path: path.into(),
            stored: crc,
            computed,
        });
    }
    let mut p = Rd {
        b: payload,
        at: 0,
        path,
    };
    let n = p.len("ids", 4)?;
    let id = (0..n)
        .map(|_| p.u32("ids"))
        .collect::<Result<Vec<_>, _>>()?;
    let pos = p.v3s("positions")?;
    let vel = p.v3s("velocities")?;
    let force = p.v3s("forces")?;
    let radius = p.f64s("radii")?;
    let mass = p.f64s("masses")?;
    let inv_mass = p.f64s("inverse masses")?;
    let rotation = p.u32("rotation flag")? != 0;
    let omega = p.v3s("angular velocities")?;
    let torque = p.v3s("torques")?;
    let inv_inertia = p.f64s("inverse inertia")?;
    let oriented = p.u32("orientation flag")? != 0;
    let nq = p.len("orientations", 32)?;
    let mut orientation = Vec::with_capacity(nq);
    for _ in 0..nq {
        let q = [
            p.f64("orientations")?,
            p.f64("orientations")?,
            p.f64("orientations")?,
            p.f64("orientations")?,
        ];
        orientation.push(Quat::from_f64(q));
    }
    let ang_mom = p.v3s("angular momenta")?;
    let inv_inertia_body = p.v3s("inverse principal moments")?;
    let half_length = p.f64s("half lengths")?;
    let slots = p.u64("history slots")? as usize;
    let hn = p.len("history", 4)?;
    let partner = (0..hn)
        .map(|_| p.u32("history"))
        .collect::<Result<Vec<_>, _>>()?;
    let spring = p.v3s("history springs")?;
    let time = p.f64("time")?;
    let step = p.u64("step")?;
    let extra = p.str("extra")?;
    let mut s = State::new(rotation, slots);
    s.id = id;
    s.pos = pos;
    s.vel = vel;
    s.force = force;
    s.radius = radius;
    s.mass = mass;
    s.inv_mass = inv_mass;
    s.omega = omega;
    s.torque = torque;
    s.inv_inertia = inv_inertia;
    s.oriented = oriented;
    s.orientation = orientation;
    s.ang_mom = ang_mom;
    s.inv_inertia_body = inv_inertia_body;
    s.half_length = half_length;
    s.history.partner = partner;
    s.history.spring = spring;
    s.time = time;
    s.step = step;
    Ok((h, s, extra))
}

/// Writes `bytes` to `path` atomically: temp file, fsync, rename, fsync of the directory.
///
/// # Errors
/// Any I/O failure (the previous file is then untouched).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(dir)?;
    // The temp name carries the process id: two writers never share one.
    let tmp = path.with_extension(format!("tmp.{}", std::process::id()));
    let written = fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(bytes)?;
        f.sync_all()
    });
    if let Err(e) = written.and_then(|()| fs::rename(&tmp, path)) {
        // A full disk must not also keep the half-written file.
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    if let Ok(d) = fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// A job's checkpoints in its directory: `ckpt-<step>.bin`, newest last.
pub fn list(dir: &Path) -> Vec<PathBuf> {
    list_steps(dir).into_iter().map(|x| x.1).collect()
}

/// A job's checkpoints with their steps, newest last.
fn list_steps(dir: &Path) -> Vec<(u64, PathBuf)> {
    let mut v: Vec<(u64, PathBuf)> = fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let step = name
                .strip_prefix("ckpt-")?
                .strip_suffix(".bin")?
                .parse()
                .ok()?;
            Some((step, e.path()))
        })
        .collect();
    v.sort();
    v
}

/// Saves a checkpoint in `dir` and deletes all but the newest two, and any past it.
///
/// # Errors
/// I/O failures.
pub fn save(dir: &Path, h: &Header, s: &State<f64>, extra: &str) -> std::io::Result<PathBuf> {
    let path = dir.join(format!("ckpt-{:012}.bin", h.step));
    write_atomic(&path, &encode(h, s, extra))?;
    remove_leftovers(dir);
    // A checkpoint past this one belongs to a trajectory the run left: it was refused when the
    // run resumed (corrupt, past the job's end, written by an older rule). Kept, it would count
    // among the newest two and this run's own checkpoints would be deleted as they are written.
    let (own, later): (Vec<_>, Vec<_>) = list_steps(dir)
        .into_iter()
        .partition(|(step, _)| *step <= h.step);
    let older = own.len().saturating_sub(2);
    for (_, stale) in later.iter().chain(&own[..older]) {
        let _ = fs::remove_file(stale);
    }
    Ok(path)
}

/// Removes the temp files of checkpoint writes that never finished (a kill -9 between write and
/// rename). Only the holder of a directory's lock writes checkpoints in it, so any temp file
/// there but its own finished write is a leftover.
pub fn remove_leftovers(dir: &Path) {
    for e in fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with("ckpt-") && name.contains(".tmp.") {
            let _ = fs::remove_file(e.path());
        }
    }
}

/// A checkpoint read back: its path, header, state and the job's `extra` JSON.
pub type Loaded = (PathBuf, Header, State<f64>, String);

/// The newest valid checkpoint in `dir`, and a message for each refused one.
pub fn load_latest(dir: &Path, job_hash: &str) -> (Option<Loaded>, Vec<String>) {
    load_latest_where(dir, job_hash, |_| Ok(()))
}

/// As [`load_latest`], skipping valid checkpoints that `accept` turns down (Err says why, and
/// is reported like a refusal).
pub fn load_latest_where(
    dir: &Path,
    job_hash: &str,
    accept: impl Fn(&Loaded) -> Result<(), String>,
) -> (Option<Loaded>, Vec<String>) {
    let mut refused = Vec::new();
    for path in list(dir).into_iter().rev() {
        let p = path.display().to_string();
        match fs::read(&path)
            .map_err(|e| CheckpointError::Io {
                path: p.clone(),
                source: e,
            })
            .and_then(|b| decode(&b, &p, Some(job_hash)))
        {
            Ok((h, s, extra)) => {
                let loaded = (path, h, s, extra);
                match accept(&loaded) {
                    Ok(()) => return (Some(loaded), refused),
                    Err(why) => refused.push(format!("skipped checkpoint {p}: {why}")),
                }
            }
            Err(e) => refused.push(format!("refused checkpoint {e}")),
        }
    }
    (None, refused)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(step: u64) -> Header {
        Header {
            job_hash: "a".repeat(64),
            step,
            time_s: step as f64 * 1e-3,
            backend: "cpu".into(),
            precision: "f64".into(),
        }
    }

    /// A run that started over below refused checkpoints keeps its own: the later ones go at
    /// its first save, and from then on the newest two are its own.
    #[test]
    fn a_run_started_over_keeps_its_own_checkpoints() {
        let dir = tempfile::tempdir().unwrap();
        let s = State::<f64>::new(false, 0);
        for step in [5000, 6000] {
            save(dir.path(), &header(step), &s, "{}").unwrap();
        }
        for step in [100, 200, 300] {
            save(dir.path(), &header(step), &s, "{}").unwrap();
        }
        let names: Vec<String> = list(dir.path())
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["ckpt-000000000200.bin", "ckpt-000000000300.bin"]);
    }
}
