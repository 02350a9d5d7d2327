//! The chute results a figure reads (Soft Matter 2022 study): the summaries of a campaign's done
//! jobs, their per-block rows, and the per-block curves MSD_z(τ), v_z PDF and C(r), plus the
//! coarse-grained shear-rate profile. Values are returned in the database's SI units; scaling by
//! L is the figures' business. The queries live in `store::chute_reads`; here, which job a
//! figure draws. Read-only; no plotting here.

pub use crate::store::chute_reads::{
    block_curves, blocks, chute_profile, done_campaign_jobs, done_chute_jobs, done_without_summary,
    drawable_chute_jobs, left_out_chute_jobs, shear_profile, BlockRow, ChuteJob, CurveTable,
};

use crate::pooled::silo::same_value;

/// The value of `values` closest to `target` (ties: the smaller one); None when empty.
pub fn closest(values: impl Iterator<Item = f64>, target: f64) -> Option<f64> {
    values.filter(|v| v.is_finite()).min_by(|a, b| {
        (a - target)
            .abs()
            .total_cmp(&(b - target).abs())
            .then(a.total_cmp(b))
    })
}

/// The job whose ξ is closest to `xi` and, among those, whose α is closest to `alpha_deg`
/// (ties: an ended job before one a round runs on, then the lower job id).
pub fn closest_job(jobs: &[ChuteJob], xi: f64, alpha_deg: f64) -> Option<&ChuteJob> {
    let xi = closest(jobs.iter().map(|j| j.aspect_ratio), xi)?;
    let at_xi = jobs.iter().filter(|j| same_value(j.aspect_ratio, xi));
    let alpha = closest(at_xi.clone().map(|j| j.inclination_deg), alpha_deg)?;
    at_xi
        .filter(|j| same_value(j.inclination_deg, alpha))
        .min_by_key(|j| (j.running_on_to_s.is_some(), j.job_id))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(id: i64, xi: f64, alpha: f64) -> ChuteJob {
        ChuteJob {
            job_id: id,
            label: format!("j{id}"),
            aspect_ratio: xi,
            inclination_deg: alpha,
            total_length_m: 0.125,
            bed_height_m: 2.5,
            steady: true,
            flow_state: Some("steady".into()),
            msd_fit_lags_s: (1.0, 10.0),
            d_perp_m: 0.1,
            params_json: "{}".into(),
            measure_s: 240.0,
            layering: None,
            running_on_to_s: None,
        }
    }

    #[test]
    fn closest_prefers_the_smaller_on_ties_and_skips_nan() {
        let v = [1.0, 1.5, 2.0, f64::NAN];
        assert_eq!(closest(v.into_iter(), 1.25), Some(1.0));
        assert_eq!(closest(v.into_iter(), 1.3), Some(1.5));
        assert_eq!(closest(std::iter::empty(), 1.3), None);
    }

    #[test]
    fn closest_job_picks_xi_first_then_alpha_then_id() {
        let jobs = vec![
            job(1, 1.0, 27.0),
            job(2, 1.5, 26.0),
            job(3, 1.5, 28.0),
            job(4, 1.5, 28.0),
            job(5, 2.5, 30.0),
        ];
        assert_eq!(closest_job(&jobs, 1.3, 27.5).map(|j| j.job_id), Some(3));
        assert_eq!(closest_job(&jobs, 2.5, 0.0).map(|j| j.job_id), Some(5));
        assert!(closest_job(&[], 1.3, 27.0).is_none());
        // A job a round runs on stands in only where no replica has ended.
        let mut run_on = jobs.clone();
        run_on[2].running_on_to_s = Some(400.0);
        assert_eq!(closest_job(&run_on, 1.3, 27.5).map(|j| j.job_id), Some(4));
    }
}
