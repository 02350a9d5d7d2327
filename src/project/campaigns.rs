//! The project's campaigns: registering a launched file, finding a campaign, and what its
//! target and claims have said.

use std::collections::BTreeMap;

use super::{
    CampaignRef, CampaignRow, FlowVerdict, PointRow, Project, Registration, VerdictRow, WorkRow,
};
use crate::campaign::{CampaignFile, Jobs};
use crate::store::{campaign_reads, chute_reads, claims, jobs, targets};

impl Project {
    /// Registers a launched campaign file (`path` as given) and its jobs, asking `stop`
    /// between chunks (`store::jobs::register_until`).
    ///
    /// # Errors
    /// Database errors.
    pub fn register(
        &mut self,
        path: &str,
        file: &CampaignFile,
        jobs: &Jobs,
        new_version: bool,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> anyhow::Result<Registration> {
        jobs::register_until(&mut self.conn, path, file, jobs, new_version, stop)
    }

    /// The id of the campaign named `name` (its first version), if any.
    ///
    /// # Errors
    /// Database errors.
    pub fn campaign_id(&self, name: &str) -> anyhow::Result<Option<i64>> {
        jobs::campaign_id(&self.conn, name)
    }

    /// Every campaign (version), or those named `name`.
    ///
    /// # Errors
    /// Database errors.
    pub fn campaigns(&self, name: Option<&str>) -> anyhow::Result<Vec<CampaignRow>> {
        jobs::campaigns(&self.conn, name)
    }

    /// The campaign named `name` at `version` (the latest when None).
    ///
    /// # Errors
    /// Database errors.
    pub fn campaign_named(
        &self,
        name: &str,
        version: Option<i64>,
    ) -> anyhow::Result<Option<CampaignRef>> {
        campaign_reads::campaign_named(&self.conn, name, version)
    }

    /// The file campaign `cid` was launched with (None: no such campaign).
    ///
    /// # Errors
    /// Database errors, or a stored file this sweep cannot read.
    pub fn campaign_file(&self, cid: i64) -> anyhow::Result<Option<CampaignFile>> {
        targets::campaign_file(&self.conn, cid)
    }

    /// Campaigns whose file has a target (their rounds go on in `sweep resume`).
    ///
    /// # Errors
    /// Database errors.
    pub fn campaigns_with_target(&self) -> anyhow::Result<Vec<i64>> {
        targets::campaigns_with_target(&self.conn)
    }

    /// Campaigns with claims and no target (their claims are looked at once).
    ///
    /// # Errors
    /// Database errors.
    pub fn campaigns_with_claims_only(&self) -> anyhow::Result<Vec<i64>> {
        targets::campaigns_with_claims_only(&self.conn)
    }

    /// How many jobs campaign `cid` has, those its target added included.
    ///
    /// # Errors
    /// Database errors.
    pub fn campaign_job_count(&self, cid: i64) -> anyhow::Result<usize> {
        Ok(targets::campaign_jobs(&self.conn, cid)?.len())
    }

    /// The verdicts of the claims' latest look.
    ///
    /// # Errors
    /// Database errors.
    pub fn latest_verdicts(&self, cid: i64) -> anyhow::Result<Vec<VerdictRow>> {
        claims::latest_verdicts(&self.conn, cid)
    }

    /// What the campaign's jobs have cost: (particle-steps, wall seconds, core-hours).
    ///
    /// # Errors
    /// Database errors.
    pub fn spent(&self, cid: i64) -> anyhow::Result<(f64, f64, f64)> {
        claims::spent(&self.conn, cid)
    }

    /// The CPU hours the campaign's jobs used beside the core-hours they held.
    ///
    /// # Errors
    /// Database errors.
    pub fn cpu_use(&self, cid: i64) -> anyhow::Result<claims::CpuUse> {
        claims::cpu_use(&self.conn, cid)
    }

    /// The work the campaign's target added, in order.
    ///
    /// # Errors
    /// Database errors.
    pub fn target_work(&self, cid: i64) -> anyhow::Result<Vec<WorkRow>> {
        targets::work(&self.conn, cid)
    }

    /// The target's points after its latest evaluation.
    ///
    /// # Errors
    /// Database errors.
    pub fn target_points(&self, cid: i64) -> anyhow::Result<Vec<PointRow>> {
        targets::points(&self.conn, cid)
    }

    /// The chute flow verdicts of the campaign's jobs, by job id.
    ///
    /// # Errors
    /// Database errors.
    pub fn flow_verdicts(&self, cid: i64) -> anyhow::Result<BTreeMap<i64, FlowVerdict>> {
        chute_reads::flow_verdicts(&self.conn, cid)
    }
}
