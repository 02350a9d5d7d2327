//! The project's jobs: how many are done or pending, the state of each, what a resume does
//! with those that stopped, and forgetting some.

use super::{
    Decision, ForgetPlan, JobScope, JobStatus, JobTotals, Liveness, OpenJob, Project, StateTotal,
    StoredJob,
};
use crate::store::{forget, job_counts, jobs};

impl Project {
    /// Done jobs of campaign `cid`.
    ///
    /// # Errors
    /// Database errors.
    pub fn done_count(&self, cid: i64) -> anyhow::Result<i64> {
        job_counts::campaign_done_count(&self.conn, cid)
    }

    /// Pending jobs of campaign `cid`, by id.
    ///
    /// # Errors
    /// Database errors.
    pub fn pending_ids(&self, cid: i64) -> anyhow::Result<Vec<i64>> {
        job_counts::pending_job_ids(&self.conn, cid)
    }

    /// Pending jobs of the whole store.
    ///
    /// # Errors
    /// Database errors.
    pub fn pending_count(&self) -> anyhow::Result<i64> {
        job_counts::pending_count(&self.conn)
    }

    /// Failed jobs of the whole store.
    ///
    /// # Errors
    /// Database errors.
    pub fn failed_count(&self) -> anyhow::Result<i64> {
        job_counts::failed_count(&self.conn)
    }

    /// Jobs of the whole store, and how many are done.
    ///
    /// # Errors
    /// Database errors.
    pub fn totals(&self) -> anyhow::Result<JobTotals> {
        job_counts::job_totals(&self.conn)
    }

    /// Campaign `cid`'s jobs counted by state.
    ///
    /// # Errors
    /// Database errors.
    pub fn state_totals(&self, cid: i64) -> anyhow::Result<Vec<StateTotal>> {
        jobs::state_totals(&self.conn, cid)
    }

    /// At most `limit` jobs of campaign `cid` by id, only those in `statuses` when given.
    ///
    /// # Errors
    /// Database errors.
    pub fn jobs_of(
        &self,
        cid: i64,
        statuses: Option<&[&str]>,
        limit: i64,
    ) -> anyhow::Result<Vec<JobStatus>> {
        jobs::campaign_jobs_in(&self.conn, cid, statuses, limit)
    }

    /// Jobs not ended (running, paused, pending), of `scope`.
    ///
    /// # Errors
    /// Database errors.
    pub fn open_jobs(&self, scope: JobScope) -> anyhow::Result<Vec<OpenJob>> {
        jobs::open_jobs(&self.conn, scope)
    }

    /// The job whose parameters hash to `hash` (any campaign's), or `None`.
    ///
    /// # Errors
    /// Database errors.
    pub fn job_by_hash(&self, hash: &str) -> anyhow::Result<Option<StoredJob>> {
        jobs::job_by_hash(&self.conn, hash)
    }

    /// Job `id`'s label (its hash when it belongs to no campaign); None: no such job.
    ///
    /// # Errors
    /// Database errors.
    pub fn job_label(&self, id: i64) -> anyhow::Result<Option<String>> {
        jobs::job_label(&self.conn, id)
    }

    /// Puts stopped jobs (of `scope`) back to pending (or failed, without attempts
    /// left) as `liveness` judges each; returns what was decided for every open job.
    ///
    /// # Errors
    /// Database errors.
    pub fn requeue(
        &mut self,
        scope: JobScope,
        max_attempts: Option<i64>,
        liveness: impl FnMut(&OpenJob) -> Liveness,
    ) -> anyhow::Result<Vec<Decision>> {
        jobs::requeue(&mut self.conn, scope, max_attempts, liveness)
    }

    /// What forgetting job `id` would remove.
    ///
    /// # Errors
    /// Database errors, or no such job.
    pub fn plan_forget_job(&self, id: i64) -> anyhow::Result<ForgetPlan> {
        forget::plan_job(&self.conn, id)
    }

    /// What forgetting campaign `name` (one version, or all) would remove.
    ///
    /// # Errors
    /// Database errors, or no such campaign.
    pub fn plan_forget_campaign(
        &self,
        name: &str,
        version: Option<i64>,
    ) -> anyhow::Result<ForgetPlan> {
        forget::plan_campaign(&self.conn, name, version)
    }

    /// Removes what `plan` lists, in one transaction.
    ///
    /// # Errors
    /// Database errors.
    pub fn forget(&mut self, plan: &ForgetPlan) -> anyhow::Result<()> {
        forget::forget(&mut self.conn, plan)
    }

    /// The campaigns no later version of the same name replaces.
    ///
    /// # Errors
    /// Database errors.
    pub fn latest_campaign_ids(&self) -> anyhow::Result<Vec<i64>> {
        crate::store::scope::latest_campaign_ids(&self.conn)
    }
}
