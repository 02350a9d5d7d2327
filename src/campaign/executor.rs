//! Where a campaign's jobs run: the `run.executor` and `run.slurm` settings of a campaign file.
//! None of them is part of a job's identity (a job's hash covers only what changes its results),
//! so moving a campaign from this machine to a cluster keeps every job and its results. The
//! command line (`sweep launch --executor slurm --partition …`) overrides them.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Where jobs run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum ExecutorKind {
    /// On this machine, `--parallel` jobs at a time, results written as each job ends.
    #[default]
    Local,
    /// As Slurm job arrays, one task per job, on shared storage; results collected afterwards.
    Slurm,
}

impl ExecutorKind {
    pub fn name(self) -> &'static str {
        match self {
            ExecutorKind::Local => "local",
            ExecutorKind::Slurm => "slurm",
        }
    }
}

impl std::str::FromStr for ExecutorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "local" => Ok(Self::Local),
            "slurm" => Ok(Self::Slurm),
            _ => Err(format!("expected local or slurm, got {s:?}")),
        }
    }
}

/// How jobs are handed to Slurm (`executor: "slurm"`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SlurmSettings {
    /// Partition (`sbatch --partition`); unset: the cluster's default partition.
    pub partition: Option<String>,
    /// GPUs per job (`--gres=gpu:N`); 0 asks for none. One job uses one GPU.
    pub gpus_per_job: u32,
    /// CPU cores per job (`--cpus-per-task`), also the engine's threads. Default 1: a GPU job
    /// needs one core to drive it; raise it for CPU jobs.
    pub cpus_per_job: u32,
    /// Time limit of one task, `[D-]HH:MM:SS` or another `--time` form; unset: the partition's
    /// limit. A job that runs out of time is checkpointed and requeued (see `signal_grace_s`).
    pub time: Option<String>,
    /// At most this many tasks of an array run at once (`--array=…%K`); unset: no throttle.
    pub array_max: Option<u32>,
    /// Further `sbatch` options, one per entry, written into the script as `#SBATCH` lines
    /// (e.g. `--account=proj42`, `--constraint=a100`).
    pub sbatch_args: Vec<String>,
    /// Seconds before the time limit (or preemption) at which Slurm sends SIGUSR1
    /// (`--signal=B:USR1@N`): the task checkpoints and requeues itself. Default 120 s: a
    /// paper-scale checkpoint takes well under a second, and Slurm may deliver the signal up
    /// to a minute early or late.
    pub signal_grace_s: u32,
}

impl Default for SlurmSettings {
    fn default() -> Self {
        Self {
            partition: None,
            gpus_per_job: 0,
            cpus_per_job: 1,
            time: None,
            array_max: None,
            sbatch_args: Vec::new(),
            signal_grace_s: 120,
        }
    }
}

impl SlurmSettings {
    /// What is wrong with these settings, one message per field (empty when they are fine).
    pub fn problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(p) = &self.partition {
            if p.is_empty() || p.contains(char::is_whitespace) {
                out.push(format!(
                    "partition: expected a partition name without spaces, got {p:?}"
                ));
            }
        }
        if self.cpus_per_job == 0 {
            out.push("cpus_per_job: expected at least 1 core, got 0".into());
        }
        if let Some(t) = &self.time {
            match time_s(t) {
                None => out.push(format!(
                    "time: expected [D-]HH:MM:SS or minutes (e.g. 04:00:00, 1-12:00:00, 90), got {t:?}"
                )),
                // A warning at or before the start would requeue the task before it does anything.
                Some(limit) if u64::from(self.signal_grace_s) >= limit => out.push(format!(
                    "signal_grace_s: {} s is not shorter than the time limit {t} ({limit} s): a task would be told to stop as it starts; lower it or raise the time",
                    self.signal_grace_s
                )),
                Some(_) => {}
            }
        }
        if self.array_max == Some(0) {
            out.push("array_max: expected at least 1 task at a time, got 0".into());
        }
        for a in &self.sbatch_args {
            if !a.starts_with('-') || a.contains('\n') {
                out.push(format!(
                    "sbatch_args: expected one sbatch option such as --account=NAME, got {a:?}"
                ));
            }
        }
        if self.signal_grace_s == 0 {
            out.push("signal_grace_s: expected seconds > 0, got 0".into());
        }
        out
    }
}

/// Seconds of a time limit in the forms `sbatch --time` reads: minutes, MM:SS, HH:MM:SS, D-HH,
/// D-HH:MM, D-HH:MM:SS; None when it is none of them.
fn time_s(t: &str) -> Option<u64> {
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    let num = |p: &str| -> Option<u64> {
        (!p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
            .then(|| p.parse().ok())
            .flatten()
    };
    let parts: Vec<u64> = rest.split(':').map(num).collect::<Option<_>>()?;
    let hms = match (days.is_some(), parts.as_slice()) {
        (false, [m]) => m * 60,
        (false, [m, s]) => m * 60 + s,
        (_, [h, m, s]) => h * 3600 + m * 60 + s,
        (true, [h]) => h * 3600,
        (true, [h, m]) => h * 3600 + m * 60,
        _ => return None,
    };
    let d = match days {
        Some(d) => num(d)?,
        None => 0,
    };
    Some(d * 86_400 + hms)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_limits_in_slurm_forms() {
        for (ok, s) in [
            ("04:00:00", 14_400),
            ("1-12:00:00", 129_600),
            ("30:00", 1_800),
            ("1-0", 86_400),
            ("2-04:00", 187_200),
            ("90", 5_400),
        ] {
            assert_eq!(time_s(ok), Some(s), "{ok}");
        }
        for bad in ["", "4h", "1:2:3:4", "-04:00:00", "04::00", "x-01:00:00"] {
            assert_eq!(time_s(bad), None, "{bad}");
        }
    }

    #[test]
    fn problems_name_the_field() {
        let s = SlurmSettings {
            partition: Some("a b".into()),
            cpus_per_job: 0,
            time: Some("soon".into()),
            signal_grace_s: 0,
            array_max: Some(0),
            sbatch_args: vec!["account=x".into()],
            ..SlurmSettings::default()
        };
        let p = s.problems().join("\n");
        for f in [
            "partition:",
            "cpus_per_job:",
            "time:",
            "array_max:",
            "sbatch_args:",
            "signal_grace_s:",
        ] {
            assert!(p.contains(f), "{p}");
        }
        assert!(SlurmSettings::default().problems().is_empty());
        let short = SlurmSettings {
            time: Some("1".into()),
            ..SlurmSettings::default()
        };
        assert!(short.problems()[0].contains("not shorter than the time limit"));
    }
}
