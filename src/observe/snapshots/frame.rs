//! One particle snapshot ("frame", particles in id order) and its binary file format. This file owns the layout and its
//! integrity checks; when frames are written is `writer`'s business, what they become on export
//! is `export`'s.
//!
//! Layout (little-endian; f64 throughout, so a frame holds the run's values exactly, whatever the
//! run's precision, and a frame rewritten after a resume compares bitwise):
//!
//! ```text
//! magic          8 bytes  "SWEEPSN\0"
//! version        u32      FORMAT_VERSION
//! hash length    u32, then the job hash (UTF-8)
//! chunk          u64      chunk index of the job (the frame's name)
//! step           u64      engine step
//! sim time       f64      simulated time of the state (s)
//! job time       f64      the job's clock (s): since the orifice opened (silo), since the pour (chute)
//! n              u64      particles
//! flags          u32      bit 0: angular velocities present, bit 1: orientations present
//! id             u32 × n
//! position       f64 × 3n (m)
//! velocity       f64 × 3n (m/s)
//! [angular vel.  f64 × 3n (rad/s), lab frame]                        if bit 0
//! radius         f64 × n  (m)
//! fixed          u8 × n   (1: fixed particle, e.g. the chute's rough base)
//! [orientation   f64 × 4n (x, y, z, w), body → lab, body z = axis]  if bit 1
//! [half length   f64 × n  (m), l/2 of the axis segment]             if bit 1
//! crc32          u32      over every byte before it
//! ```
//!
//! About 85 bytes per particle (125 with orientations). The length is fixed by `n` and the
//! flags, so a truncated file is refused before its checksum is even computed.

use crate::engine::State;

const MAGIC: &[u8; 8] = b"SWEEPSN\0";
/// Format version; bump on any layout change (older frames are then refused, not misread).
pub const FORMAT_VERSION: u32 = 1;

const HAS_OMEGA: u32 = 1;
const HAS_ORIENTATION: u32 = 2;

/// One snapshot of every particle (fixed ones included) at a chunk boundary.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The job's parameter hash (a frame of another job is refused).
    pub job_hash: String,
    /// Chunk index of the job at which the frame was taken.
    pub chunk: u64,
    pub step: u64,
    /// Simulated time of the state (s).
    pub sim_time_s: f64,
    /// The job's own clock (s): since the orifice opened (silo), since the pour (chute).
    pub job_time_s: f64,
    pub id: Vec<u32>,
    pub pos: Vec<[f64; 3]>,
    pub vel: Vec<[f64; 3]>,
    /// Lab angular velocity (rad/s); empty when the run has no rotation.
    pub omega: Vec<[f64; 3]>,
    pub radius: Vec<f64>,
    /// Fixed particles (infinite mass): the chute's rough base.
    pub fixed: Vec<bool>,
    /// Orientation quaternion `[x, y, z, w]` (body → lab); empty for spheres.
    pub orientation: Vec<[f64; 4]>,
    /// Half the axis segment, l/2 (m); empty for spheres.
    pub half_length: Vec<f64>,
}

/// Why a frame was refused.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a sweep snapshot frame (bad magic)")]
    Magic { path: String },
    #[error("{path}: frame format version {found}, this sweep reads version {FORMAT_VERSION}")]
    Version { path: String, found: u32 },
    #[error(
        "{path}: truncated frame ({found} bytes, expected {expected}): delete it or rerun the job"
    )]
    Truncated {
        path: String,
        found: usize,
        expected: usize,
    },
    #[error("{path}: checksum mismatch (stored {stored:08x}, computed {computed:08x}): the frame is corrupt")]
    Checksum {
        path: String,
        stored: u32,
        computed: u32,
    },
    #[error("{path}: frame of job {found}, not {expected}")]
    Mismatch {
        path: String,
        found: String,
        expected: String,
    },
}

impl Frame {
    /// The frame of `s` taken at `chunk` of the job `job_hash`, whose clock reads `job_time_s`.
    /// Particles are in id order, whatever order the engine keeps them in, so a frame does not
    /// depend on how the engine sorted its arrays.
    pub fn of_state(s: &State<f64>, job_hash: &str, chunk: u64, job_time_s: f64) -> Self {
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by_key(|&k| s.id[k]);
        let v3 = |v: &[crate::engine::V3<f64>]| -> Vec<[f64; 3]> {
            if v.is_empty() {
                Vec::new()
            } else {
                order.iter().map(|&k| v[k].to_f64()).collect()
            }
        };
        Self {
            job_hash: job_hash.to_string(),
            chunk,
            step: s.step,
            sim_time_s: s.time,
            job_time_s,
            id: pick(&s.id, &order),
            pos: v3(&s.pos),
            vel: v3(&s.vel),
            omega: v3(&s.omega),
            radius: pick(&s.radius, &order),
            fixed: order.iter().map(|&k| s.inv_mass[k] == 0.0).collect(),
            orientation: if s.oriented {
                order.iter().map(|&k| s.orientation[k].to_f64()).collect()
            } else {
                Vec::new()
            },
            half_length: if s.oriented {
                pick(&s.half_length, &order)
            } else {
                Vec::new()
            },
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// Whether the frame holds no particle.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Whether orientations (spherocylinders) are present.
    pub fn oriented(&self) -> bool {
        !self.orientation.is_empty()
    }

    /// The unit axis (body z in the lab frame) of particle k, from its quaternion.
    pub fn axis(&self, k: usize) -> [f64; 3] {
        let [x, y, z, w] = self.orientation[k];
        // Third column of the rotation matrix of a unit quaternion.
        [
            2.0 * (x * z + w * y),
            2.0 * (y * z - w * x),
            1.0 - 2.0 * (x * x + y * y),
        ]
    }

    /// Serialises the frame (layout in the module header).
    ///
    /// # Panics
    /// When the arrays' lengths disagree (a programming error, not bad input).
    pub fn encode(&self) -> Vec<u8> {
        let n = self.len();
        let flags = self.flags();
        for (what, len) in [
            ("positions", self.pos.len()),
            ("velocities", self.vel.len()),
            ("radii", self.radius.len()),
            ("fixed flags", self.fixed.len()),
        ] {
            assert_eq!(len, n, "frame {}: {what}", self.chunk);
        }
        assert!(self.omega.is_empty() || self.omega.len() == n);
        assert_eq!(self.orientation.len(), self.half_length.len());
        assert!(self.orientation.is_empty() || self.orientation.len() == n);
        let mut b = Vec::with_capacity(encoded_len(self.job_hash.len(), n, flags));
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        b.extend_from_slice(&(self.job_hash.len() as u32).to_le_bytes());
        b.extend_from_slice(self.job_hash.as_bytes());
        b.extend_from_slice(&self.chunk.to_le_bytes());
        b.extend_from_slice(&self.step.to_le_bytes());
        b.extend_from_slice(&self.sim_time_s.to_le_bytes());
        b.extend_from_slice(&self.job_time_s.to_le_bytes());
        b.extend_from_slice(&(n as u64).to_le_bytes());
        b.extend_from_slice(&flags.to_le_bytes());
        for &i in &self.id {
            b.extend_from_slice(&i.to_le_bytes());
        }
        let f64s = |b: &mut Vec<u8>, v: &[f64]| {
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
        };
        f64s(&mut b, self.pos.as_flattened());
        f64s(&mut b, self.vel.as_flattened());
        f64s(&mut b, self.omega.as_flattened());
        f64s(&mut b, &self.radius);
        b.extend(self.fixed.iter().map(|&f| u8::from(f)));
        f64s(&mut b, self.orientation.as_flattened());
        f64s(&mut b, &self.half_length);
        let crc = crc32fast::hash(&b);
        b.extend_from_slice(&crc.to_le_bytes());
        debug_assert_eq!(b.len(), encoded_len(self.job_hash.len(), n, flags));
        b
    }

    /// Parses and verifies a frame; `path` names it in errors, `expected_hash` refuses another
    /// job's frame.
    ///
    /// # Errors
    /// Bad magic, another format version, a truncated file, a checksum mismatch, another job.
    pub fn decode(
        bytes: &[u8],
        path: &str,
        expected_hash: Option<&str>,
    ) -> Result<Self, FrameError> {
        let truncated = |expected: usize| FrameError::Truncated {
            path: path.into(),
            found: bytes.len(),
            expected,
        };
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            return Err(FrameError::Magic { path: path.into() });
        }
        let mut r = Reader { b: bytes, at: 8 };
        // The fixed part of the header: version and hash length, then after the hash 5 × 8
        // bytes, n and the flags.
        let version = r.u32().ok_or_else(|| truncated(16))?;
        if version != FORMAT_VERSION {
            return Err(FrameError::Version {
                path: path.into(),
                found: version,
            });
        }
        let hash_len = r.u32().ok_or_else(|| truncated(16))? as usize;
        let header_len = 16 + hash_len + 5 * 8 + 8 + 4;
        let hash = r.take(hash_len).ok_or_else(|| truncated(header_len))?;
        let job_hash = String::from_utf8_lossy(hash).into_owned();
        let chunk = r.u64().ok_or_else(|| truncated(header_len))?;
        let step = r.u64().ok_or_else(|| truncated(header_len))?;
        let sim_time_s = r.f64().ok_or_else(|| truncated(header_len))?;
        let job_time_s = r.f64().ok_or_else(|| truncated(header_len))?;
        let n = r.u64().ok_or_else(|| truncated(header_len))?;
        let flags = r.u32().ok_or_else(|| truncated(header_len))?;
        // A corrupt count must not overflow the length computation.
        let n = usize::try_from(n)
            .ok()
            .filter(|&n| n <= bytes.len())
            .ok_or_else(|| truncated(usize::MAX))?;
        let expected = encoded_len(hash_len, n, flags);
        if bytes.len() != expected {
            return Err(truncated(expected));
        }
        let stored = u32::from_le_bytes(bytes[expected - 4..].try_into().expect("4 bytes"));
        let computed = crc32fast::hash(&bytes[..expected - 4]);
        if stored != computed {
            return Err(FrameError::Checksum {
                path: path.into(),
                stored,
                computed,
            });
        }
        if let Some(e) = expected_hash {
            if job_hash != e {
                return Err(FrameError::Mismatch {
                    path: path.into(),
                    found: job_hash,
                    expected: e.into(),
                });
            }
        }
        // Lengths are verified: the reads below cannot fail.
        let id = (0..n).map(|_| r.u32().expect("length checked")).collect();
        let pos = r.v3s(n);
        let vel = r.v3s(n);
        let omega = r.v3s(if flags & HAS_OMEGA != 0 { n } else { 0 });
        let radius = r.f64s(n);
        let fixed = r
            .take(n)
            .expect("length checked")
            .iter()
            .map(|&f| f != 0)
            .collect();
        let m = if flags & HAS_ORIENTATION != 0 { n } else { 0 };
        let orientation = (0..m)
            .map(|_| {
                let q = r.f64s(4);
                [q[0], q[1], q[2], q[3]]
            })
            .collect();
        let half_length = r.f64s(m);
        Ok(Self {
            job_hash,
            chunk,
            step,
            sim_time_s,
            job_time_s,
            id,
            pos,
            vel,
            omega,
            radius,
            fixed,
            orientation,
            half_length,
        })
    }

    fn flags(&self) -> u32 {
        let mut f = 0;
        if !self.omega.is_empty() {
            f |= HAS_OMEGA;
        }
        if !self.orientation.is_empty() {
            f |= HAS_ORIENTATION;
        }
        f
    }
}

/// `v` in the order `order`.
fn pick<T: Copy>(v: &[T], order: &[usize]) -> Vec<T> {
    order.iter().map(|&k| v[k]).collect()
}

/// Bytes of a frame with a hash of `hash_len` bytes, `n` particles and `flags`.
fn encoded_len(hash_len: usize, n: usize, flags: u32) -> usize {
    let mut per = 4 + 3 * 8 + 3 * 8 + 8 + 1;
    if flags & HAS_OMEGA != 0 {
        per += 3 * 8;
    }
    if flags & HAS_ORIENTATION != 0 {
        per += 4 * 8 + 8;
    }
    16 + hash_len + 5 * 8 + 4 + n.saturating_mul(per) + 4
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.b.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f64s(&mut self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|_| self.f64().expect("length checked"))
            .collect()
    }
    fn v3s(&mut self, n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|_| {
                let v = self.f64s(3);
                [v[0], v[1], v[2]]
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(oriented: bool) -> Frame {
        Frame {
            job_hash: "abc123".into(),
            chunk: 40,
            step: 4000,
            sim_time_s: 1.25,
            job_time_s: 0.4,
            id: vec![7, 3],
            pos: vec![[0.1, 0.2, 0.3], [-1.0, 2.0, 1e-9]],
            vel: vec![[1.0, 0.0, -0.5], [0.0, 0.0, 0.0]],
            omega: vec![[0.0, 3.0, 0.0], [1.0, 1.0, 1.0]],
            radius: vec![0.002, 0.003],
            fixed: vec![false, true],
            orientation: if oriented {
                vec![
                    [0.0, 0.0, 0.0, 1.0],
                    [0.5f64.sqrt(), 0.0, 0.0, 0.5f64.sqrt()],
                ]
            } else {
                Vec::new()
            },
            half_length: if oriented {
                vec![0.01, 0.0]
            } else {
                Vec::new()
            },
        }
    }

    #[test]
    fn round_trips_spheres_and_rods_bitwise() {
        for oriented in [false, true] {
            let f = frame(oriented);
            let b = f.encode();
            assert_eq!(b.len(), encoded_len(6, 2, f.flags()));
            assert_eq!(Frame::decode(&b, "f", Some("abc123")).unwrap(), f);
        }
    }

    #[test]
    fn refuses_truncation_corruption_and_another_job() {
        let b = frame(true).encode();
        for cut in [3, 20, 60, b.len() - 1] {
            let e = Frame::decode(&b[..cut], "f.snap", None).unwrap_err();
            assert!(
                matches!(e, FrameError::Truncated { .. } | FrameError::Magic { .. }),
                "cut at {cut}: {e}"
            );
        }
        let mut bad = b.clone();
        let k = bad.len() - 20;
        bad[k] ^= 1;
        assert!(matches!(
            Frame::decode(&bad, "f", None),
            Err(FrameError::Checksum { .. })
        ));
        assert!(matches!(
            Frame::decode(&b, "f", Some("other")),
            Err(FrameError::Mismatch { .. })
        ));
    }

    #[test]
    fn axis_of_a_quarter_turn_about_x_is_minus_y() {
        let f = frame(true);
        let a = f.axis(1);
        assert!((a[0]).abs() < 1e-15 && (a[1] + 1.0).abs() < 1e-15 && a[2].abs() < 1e-15);
        assert_eq!(f.axis(0), [0.0, 0.0, 1.0]);
    }
}
