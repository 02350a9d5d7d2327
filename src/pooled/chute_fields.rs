//! The coarse-grained V_x(z) and φ(z) of a chute point (`chute_fields`, the time-averaged
//! profiles on the observer's fine grid), its replicas combined at each height: their mean and,
//! from 2 replicas on, a Student-t interval (the replicas' spread). φ = ρ/ρ_p with each job's
//! particle density. What the chute paper's Fig. 1(b) draws.

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::chute::OverReplicas;
use crate::pooled::chute_jobs::{chute_profile, ChuteJob};
use crate::pooled::silo::same_value;
use crate::scene::ChuteParams;

/// One height of a point's profiles.
#[derive(Debug, Clone, Copy)]
pub struct FieldPoint {
    /// Height above the base spheres' centres, m.
    pub z_m: f64,
    /// V_x, m/s.
    pub velocity_x: OverReplicas,
    /// Solid fraction φ = ρ/ρ_p.
    pub solid_fraction: OverReplicas,
}

/// A number at any depth of a job's parameters (`key`), e.g. its particle density.
pub(crate) fn param_number(params_json: &str, key: &str) -> Option<f64> {
    fn find(v: &serde_json::Value, key: &str) -> Option<f64> {
        let serde_json::Value::Object(map) = v else {
            return None;
        };
        map.get(key)
            .and_then(serde_json::Value::as_f64)
            .or_else(|| map.values().find_map(|v| find(v, key)))
    }
    find(&serde_json::from_str(params_json).ok()?, key)
}

/// The V_x and φ profiles of `pooled` (one point's replicas) for 0 ≤ z ≤ `z_max_over_h` · H
/// (H each job's bed height), combined at each grid height; empty when no replica has field
/// rows. Heights are the grid's, the same for replicas of one point.
///
/// # Errors
/// On a database error.
pub fn field_profiles(
    conn: &Connection,
    pooled: &[&ChuteJob],
    z_max_over_h: f64,
) -> Result<Vec<FieldPoint>> {
    let mut rows: Vec<(f64, f64, f64)> = Vec::new();
    for j in pooled {
        let rho_p = param_number(&j.params_json, "particle_density_kg_per_m3")
            .filter(|r| *r > 0.0)
            .unwrap_or(ChuteParams::default().particle_density_kg_per_m3);
        let top = z_max_over_h * j.bed_height_m;
        rows.extend(
            chute_profile(conn, j.job_id)?
                .into_iter()
                .filter(|r| r.z_m >= 0.0 && r.z_m <= top)
                .map(|r| (r.z_m, r.velocity_x_m_per_s, r.density_kg_per_m3 / rho_p)),
        );
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out = Vec::new();
    let mut rest = rows.as_slice();
    while let Some(&(z, _, _)) = rest.first() {
        let n = rest.iter().take_while(|r| same_value(r.0, z)).count();
        let (here, tail) = rest.split_at(n);
        rest = tail;
        let vx: Vec<f64> = here.iter().map(|r| r.1).collect();
        let phi: Vec<f64> = here.iter().map(|r| r.2).collect();
        if let (Some(velocity_x), Some(solid_fraction)) =
            (OverReplicas::of(&vx), OverReplicas::of(&phi))
        {
            out.push(FieldPoint {
                z_m: z,
                velocity_x,
                solid_fraction,
            });
        }
    }
    Ok(out)
}
