//! How many replicas a chute claims round adds to a point: sized to the interval it should
//! reach, over the share of the point's replicas that were steady, within `max_replicas`.

use crate::campaign::JobSpec;
use crate::observe::fits::t_975;

/// Replicas a point whose interval is its `r` replicas' spread needs for the interval to shrink
/// from `ci` to `goal` (relative): the t quantile falls with the degrees of freedom as the
/// standard error falls as 1/√r. At least one, at most `r` (a round at most doubles them).
pub(super) fn replicas_for_goal(ci: f64, goal: f64, r: f64) -> u32 {
    let most = r.max(1.0) as u32;
    (1..most)
        .find(|&k| after_replicas(ci, r, k as usize) <= goal)
        .unwrap_or(most)
}

/// The share of a chute point's `ran` replicas that were steady (`steady` of them), at least
/// [`MIN_STEADY_SHARE`]; 1 before any ran. A replica whose flow drifts while measured gives no
/// result, so a round that counted on every new replica being steady would fall short.
pub(super) fn steady_share(steady: f64, ran: usize) -> f64 {
    if ran == 0 {
        return 1.0;
    }
    (steady / ran as f64).clamp(MIN_STEADY_SHARE, 1.0)
}

/// The least steady share a round plans for: it starts at most three jobs per steady replica
/// wanted, so a point whose first replicas all drifted is not flooded with work.
pub(super) const MIN_STEADY_SHARE: f64 = 1.0 / 3.0;

/// The relative interval `ci` of `r` replicas' spread expected after `k` more.
pub(super) fn after_replicas(ci: f64, r: f64, k: usize) -> f64 {
    let k = k as f64;
    ci * t_975(r + k - 1.0) / t_975(r - 1.0) * (r / (r + k)).sqrt()
}

/// The replicas a round adds to a point whose next new replica is `next`: `wanted` of them (a
/// chute point's claims shrink only with replicas, and it has no result before three of them
/// are steady; finding them one per round would cost a round each), within `max_replicas` over
/// its `runs`. A silo point gets one.
pub(super) fn replicas_to_add(
    next: &JobSpec,
    wanted: u32,
    runs: usize,
    max_replicas: u32,
) -> Vec<JobSpec> {
    let room = max_replicas.saturating_sub(runs as u32).max(1);
    let mut out = vec![next.clone()];
    if let Some(first) = next.chute.as_ref().map(|c| c.replica) {
        out.extend((1..wanted.clamp(1, room)).map(|k| next.replica(first + k)));
    }
    out
}

/// Says that `max_replicas` let a round start only `added` of the `wanted` replicas at a point.
pub(super) fn cut_short(claim: &str, label: &str, max: u32, added: usize, wanted: u32) -> String {
    format!(
        "{claim} ({label}): max_replicas = {max} leaves room for {added} of the {wanted} replica(s) wanted"
    )
}

#[cfg(test)]
mod tests {
    use super::{replicas_for_goal, replicas_to_add, steady_share};
    use crate::campaign::{expand, CampaignFile, JobSpec};

    fn replica_of(scene: &str, replica: u32) -> JobSpec {
        let s = format!(r#"{{"name":"c","scene":"{scene}","base":{{}},"replicas":1}}"#);
        let file = CampaignFile::parse_str(&s, "c.json").expect("campaign");
        let jobs = expand(&file, "c.json").expect("jobs");
        jobs.get(0).replica(replica)
    }

    fn chute_replica(replica: u32) -> JobSpec {
        replica_of("chute", replica)
    }

    #[test]
    fn a_point_short_of_steady_replicas_gets_them_in_one_round() {
        let indices = |v: Vec<JobSpec>| -> Vec<u32> {
            v.iter()
                .map(|j| j.chute.as_ref().unwrap().replica)
                .collect()
        };
        let next = chute_replica(3);
        // 1 of 3 steady after 3 runs: two new replicas, numbered on from the next.
        assert_eq!(indices(replicas_to_add(&next, 2, 3, 6)), [3, 4]);
        // Not short (a silo point, or a chute point whose interval is wide): one.
        assert_eq!(indices(replicas_to_add(&next, 0, 3, 6)), [3]);
        // max_replicas leaves room for one only.
        assert_eq!(indices(replicas_to_add(&next, 3, 5, 6)), [3]);
        // A silo point's next replica is the one it names.
        let silo = replica_of("silo", 2);
        assert_eq!(replicas_to_add(&silo, 0, 2, 6), std::slice::from_ref(&silo));
    }

    #[test]
    fn a_round_plans_for_the_replicas_that_drift() {
        // 6 of 12 steady: two steady replicas wanted take four jobs.
        let share = steady_share(6.0, 12);
        assert_eq!(share, 0.5);
        assert_eq!((2.0 / share).ceil(), 4.0);
        // None ran yet, or all steady: as many jobs as replicas wanted.
        assert_eq!(steady_share(0.0, 0), 1.0);
        assert_eq!(steady_share(3.0, 3), 1.0);
        // None of four steady: at most three jobs per replica wanted.
        assert_eq!(steady_share(0.0, 4), 1.0 / 3.0);
    }

    #[test]
    fn replicas_are_sized_to_the_interval_they_should_reach() {
        // 3 replicas (2 degrees of freedom): one more brings ±25 % to 25 · t(3)/t(2) · √(3/4)
        // = ±16.0 %; two to ±12.5 %; three (all a round allows) to ±10.6 %.
        assert_eq!(replicas_for_goal(0.25, 0.17, 3.0), 1);
        assert_eq!(replicas_for_goal(0.25, 0.15, 3.0), 2);
        assert_eq!(replicas_for_goal(0.25, 0.12, 3.0), 3);
        assert_eq!(replicas_for_goal(0.25, 0.01, 3.0), 3);
        // Many replicas: the quantile barely moves, the error falls as 1/√r.
        let k = replicas_for_goal(0.10, 0.10 / 2f64.sqrt(), 40.0);
        assert!((38..=40).contains(&k), "{k}");
    }
}
