//! A chute campaign's flow verdicts as read: each job's stored verdict under today's rule
//! (`FlowState::rejudged`: a stored "drifted" whose measurement window shows no drift reads as
//! steady). Every reader of `chute_flow_state` goes through it (`chute_reads`).

use std::collections::BTreeMap;

use anyhow::Result;
use rusqlite::{params, Connection};

use crate::observe::chute::{FlowState, MeasuredWindow, TrendTolerances};

/// Each chute job of the campaign with a stored verdict: that verdict read under today's rule
/// (the stored name when it is not one `FlowState` knows), by job id.
///
/// # Errors
/// On a database error.
pub fn judged_flow_states(conn: &Connection, campaign_id: i64) -> Result<BTreeMap<i64, String>> {
    let mut stmt = conn.prepare(
        "SELECT f.job_id, f.state, m.ratio_ok, m.ke_change, m.ke_t, m.vx_change, m.vx_t, \
                m.t_critical, \
                json_extract(j.params_json, '$.chute.steady_kinetic_tolerance'), \
                json_extract(j.params_json, '$.chute.steady_velocity_tolerance') \
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id \
         JOIN chute_flow_state f ON f.job_id = j.id \
         LEFT JOIN chute_stationarity m ON m.job_id = f.job_id AND m.phase = 'measurement' \
         WHERE cj.campaign_id = ?1",
    )?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            let stored: String = r.get(1)?;
            let window = r
                .get::<_, Option<i64>>(2)?
                .map(|ratio_ok| -> rusqlite::Result<_> {
                    Ok(MeasuredWindow {
                        ratio_ok: ratio_ok != 0,
                        ke_change: r.get(3)?,
                        ke_t: r.get(4)?,
                        vx_change: r.get(5)?,
                        vx_t: r.get(6)?,
                        t_critical: r.get(7)?,
                    })
                });
            let window = window.transpose()?;
            let tolerances = match (r.get::<_, Option<f64>>(8)?, r.get::<_, Option<f64>>(9)?) {
                (Some(kinetic), Some(velocity)) => Some(TrendTolerances { kinetic, velocity }),
                _ => None,
            };
            let state = match FlowState::parse(&stored) {
                Some(s) => s.rejudged(window.as_ref(), tolerances).as_str().to_string(),
                None => stored,
            };
            Ok((r.get::<_, i64>(0)?, state))
        })?
        .collect::<rusqlite::Result<BTreeMap<_, _>>>()?;
    Ok(rows)
}
