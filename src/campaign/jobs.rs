//! A campaign's jobs, held by point: each point of the sweep once (its replica 0, validated) and
//! its replicas made when asked for. A campaign of 10⁶ jobs that are 10³ points × 10³ replicas
//! holds 10³ job specs, not 10⁶; memory grows with the points, not with the replicas.

use super::job_spec::JobSpec;

/// The jobs of a campaign, in the file's order: point by point, each point's replicas
/// `first_replica`, `first_replica + 1`, ….
#[derive(Clone, Debug)]
pub struct Jobs {
    points: Vec<JobSpec>,
    replicas: u32,
    first_replica: u32,
}

impl Jobs {
    /// `points` (each its replica 0), each run `replicas` times, as replicas `first_replica`,
    /// `first_replica + 1`, ….
    pub fn new(points: Vec<JobSpec>, replicas: u32, first_replica: u32) -> Self {
        Jobs {
            points,
            replicas,
            first_replica,
        }
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

    /// The replica index of a point's `r`-th replica (0-based, `r < replicas()`).
    pub fn replica_index(&self, r: u32) -> u32 {
        self.first_replica + r
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
        self.points[k / r].replica(self.replica_index((k % r) as u32))
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
