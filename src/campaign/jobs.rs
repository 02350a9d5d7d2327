//! A campaign's jobs, held by point: each point of the sweep once (its replica 0, validated) and
//! its replicas made when asked for. A campaign of 10⁶ jobs that are 10³ points × 10³ replicas
//! holds 10³ job specs, not 10⁶; memory grows with the points, not with the replicas.

use super::job_spec::JobSpec;

/// The jobs of a campaign, in the file's order: point by point, each point's replicas 0, 1, ….
#[derive(Clone, Debug)]
pub struct Jobs {
    points: Vec<JobSpec>,
    replicas: u32,
}

impl Jobs {
    /// `points` (each its replica 0), each run `replicas` times.
    pub fn new(points: Vec<JobSpec>, replicas: u32) -> Self {
        Jobs { points, replicas }
    }

    /// Jobs in all: points × replicas.
    pub fn len(&self) -> usize {
        self.points.len() * self.replicas as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Replicas per point.
    pub fn replicas(&self) -> u32 {
        self.replicas
    }

    /// Each point's replica 0: what replicas share (scene, cost, memory, validity).
    pub fn points(&self) -> &[JobSpec] {
        &self.points
    }

    /// Job `k` in the file's order.
    ///
    /// # Panics
    /// `k >= len()`.
    pub fn get(&self, k: usize) -> JobSpec {
        let r = self.replicas as usize;
        self.points[k / r].replica((k % r) as u32)
    }

    /// Every job in the file's order, made one at a time.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = JobSpec> + '_ {
        (0..self.len()).map(|k| self.get(k))
    }

    /// Every job at once: for small campaigns and tests.
    pub fn to_vec(&self) -> Vec<JobSpec> {
        self.iter().collect()
    }
}
