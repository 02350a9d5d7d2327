//! A job's identity: the SHA-256 of its resolved parameters as canonical JSON (sorted keys,
//! −0.0 written as 0.0), and the seed of its random choices from the same parameters without
//! its observers and its place, so jobs that differ only in how they are observed follow the
//! same trajectory.

use serde_json::Value;
use sha2::{Digest, Sha256};

/// A job's identity: its resolved parameters as canonical JSON, their SHA-256 (hex) and the
/// seed of its random choices.
#[derive(Clone, Debug)]
pub struct Identity {
    pub resolved_json: String,
    pub hash: String,
    pub seed: u64,
}

/// The seed from a job's canonical parameters without its observers and its place.
pub(super) fn seed_of(mut v: Value) -> u64 {
    if let Value::Object(m) = &mut v {
        m.remove("observers");
        // Where the scene sits is not physics: a moved scene starts from the same packing.
        for scene in ["silo", "chute"] {
            if let Some(Value::Object(p)) = m.get_mut(scene) {
                p.remove("origin_m");
            }
        }
    }
    let h = Sha256::digest(serde_json::to_string(&v).expect("serializable").as_bytes());
    u64::from_le_bytes(h[..8].try_into().expect("8 bytes"))
}

/// −0.0 written as 0.0: they are the same physics (a frequency of −0 Hz is a bottom at rest),
/// so they must be the same job.
pub(super) fn canonical_zeros(v: &mut Value) {
    match v {
        Value::Number(n)
            if n.as_f64() == Some(0.0) && n.as_f64().is_some_and(f64::is_sign_negative) =>
        {
            *v = Value::from(0.0);
        }
        Value::Array(a) => a.iter_mut().for_each(canonical_zeros),
        Value::Object(m) => m.values_mut().for_each(canonical_zeros),
        _ => {}
    }
}

/// `key` made specific to `what` (a fill stage run on a particular GPU adapter): another key of
/// the same form.
pub fn key_with(key: &str, what: &str) -> String {
    hex(&Sha256::digest(format!("{key}\n{what}").as_bytes()))
}

pub(super) fn hex(b: &[u8]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    b.iter()
        .flat_map(|x| {
            [
                DIGITS[(x >> 4) as usize] as char,
                DIGITS[(x & 15) as usize] as char,
            ]
        })
        .collect()
}
