//! What a campaign of many jobs costs the store: expanding the file, registering its jobs, and
//! claiming the next job once N are registered, with the process's peak memory and the WAL's
//! size. `scripts/bench-store-scale.sh` runs it for several N beside `sweep status` and `sweep
//! plan` on the database it leaves, for this build and another in the same run.
//!
//! `cargo bench --bench store_scale -- --jobs 100000 --dir DIR` writes DIR/scale.json (the
//! campaign: the tests' tiny silo, 1000 rotation frequencies × replicas) and DIR/scale.db, and
//! prints one JSON line.

use std::path::PathBuf;
use std::time::Instant;

use sweep::store::jobs::{self, Lease};

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

/// The tiny refilled silo with `n` jobs: `points` rotation frequencies, `n / points` replicas.
fn campaign(n: usize) -> serde_json::Value {
    let points = n.clamp(1, 1000);
    let freqs: Vec<f64> = (0..points).map(|i| 0.001 * i as f64).collect();
    serde_json::json!({
        "name": "scale",
        "scene": "silo",
        "description": "many tiny jobs: what registering and claiming cost",
        "base": {
            "cylinder_radius_m": 0.03, "cylinder_height_m": 0.2, "particle_count": 600,
            "orifice_diameter_m": 0.02, "youngs_modulus_pa": 3.0e6, "shear_modulus_pa": 1.0e5,
            "dt_s": null, "contact_steps": 20, "discharge_time_s": 0.1, "settle_max_time_s": 0.2
        },
        "sweep": { "rotation_frequency_hz": freqs },
        "replicas": n / points,
        "run": { "precision": "f64" }
    })
}

fn peak_rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        })
        .unwrap_or(0)
}

fn file_bytes(p: &std::path::Path) -> u64 {
    std::fs::metadata(p).map_or(0, |m| m.len())
}

fn main() -> anyhow::Result<()> {
    // `cargo bench` passes --bench; anything without --jobs is a listing run.
    let Some(n) = arg("--jobs").and_then(|s| s.parse::<f64>().ok()) else {
        println!("store_scale: give --jobs N --dir DIR");
        return Ok(());
    };
    let n = n as usize;
    let dir = PathBuf::from(arg("--dir").unwrap_or_else(|| "target/store-scale".into()));
    std::fs::create_dir_all(&dir)?;
    let file = dir.join("scale.json");
    let db = dir.join("scale.db");
    for p in ["scale.db", "scale.db-wal", "scale.db-shm"] {
        let _ = std::fs::remove_file(dir.join(p));
    }
    std::fs::write(&file, serde_json::to_string_pretty(&campaign(n))?)?;

    let t = Instant::now();
    let (c, specs) = sweep::campaign::load(&file)?;
    let expand_s = t.elapsed().as_secs_f64();

    let mut conn = sweep::store::open(&db)?;
    let t = Instant::now();
    let reg = jobs::register(&mut conn, &file.display().to_string(), &c, &specs, false)?;
    let register_s = t.elapsed().as_secs_f64();
    let registered = match reg {
        jobs::Registration::Registered { added, .. } => added,
        _ => anyhow::bail!("a fresh store was not registered whole"),
    };
    drop(specs);
    let wal_after_register = file_bytes(&dir.join("scale.db-wal"));

    // Claim the next job, as a launcher does between jobs, and hand it back done.
    let lease = Lease::new();
    let claims = 50;
    let mut claim_ms = Vec::with_capacity(claims);
    for _ in 0..claims {
        let t = Instant::now();
        let got = jobs::claim(&mut conn, jobs::JobScope::All, &lease, None, |_| {
            Ok(Some(()))
        })?;
        claim_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let Some((job, ())) = got else { break };
        jobs::release(&conn, job.id, &lease, "done", None)?;
    }
    claim_ms.sort_by(f64::total_cmp);
    let median = claim_ms[claim_ms.len() / 2];
    let worst = claim_ms[claim_ms.len() - 1];
    println!(
        "{}",
        serde_json::json!({
            "jobs": n,
            "registered": registered,
            "expand_s": expand_s,
            "register_s": register_s,
            "claim_median_ms": median,
            "claim_worst_ms": worst,
            "peak_rss_mib": peak_rss_kib() as f64 / 1024.0,
            "db_mib": file_bytes(&db) as f64 / 1048576.0,
            "wal_mib_after_register": wal_after_register as f64 / 1048576.0,
        })
    );
    Ok(())
}
