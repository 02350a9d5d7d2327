//! Slurm's own view of sweep's array tasks: `squeue` (every task, pending ones expanded, finished
//! ones while the controller remembers them), `scontrol show job` (restarts, exit codes), and
//! `sacct` for tasks the controller has forgotten, when accounting exists. Also the two commands
//! sweep sends: `scancel` and a task's `scontrol requeue` of itself.
//!
//! This view is shown beside sweep's and decides when a task has ended without a result; it
//! never decides that a job is done.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;

use super::error::SlurmError;

/// An array task as Slurm sees it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TaskView {
    /// JobState: PENDING, RUNNING, COMPLETED, TIMEOUT, NODE_FAIL, …
    pub state: String,
    /// Why it waits or ended (Slurm's Reason), or empty.
    pub reason: String,
    /// Times Slurm requeued it (preemption, node failure, `scontrol requeue`, its own request).
    pub restarts: u32,
    /// `exit:signal` of the batch script, when known.
    pub exit_code: String,
    /// Node it runs or ran on.
    pub node: String,
}

/// States in which a task is queued, running or about to be requeued: its job is not finished
/// with it yet.
const ALIVE: [&str; 16] = [
    "PENDING",
    "RUNNING",
    "CONFIGURING",
    "COMPLETING",
    "REQUEUED",
    "REQUEUE_FED",
    "REQUEUE_HOLD",
    "RESIZING",
    "SUSPENDED",
    "STOPPED",
    "SIGNALING",
    "STAGE_OUT",
    "PREEMPTED",
    "SPECIAL_EXIT",
    "RESV_DEL_HOLD",
    "POWER_UP_NODE",
];

impl TaskView {
    /// Queued, running, or on its way back to the queue.
    pub fn alive(&self) -> bool {
        ALIVE.contains(&self.state.as_str())
    }

    /// E.g. "RUNNING on node7, requeued 1×" or "PENDING (JobArrayTaskLimit)".
    pub fn describe(&self) -> String {
        let mut s = self.state.clone();
        if !self.node.is_empty() && !["PENDING", "REQUEUED"].contains(&self.state.as_str()) {
            s.push_str(&format!(" on {}", self.node));
        }
        if !self.reason.is_empty() && self.reason != "None" {
            s.push_str(&format!(" ({})", self.reason));
        }
        if self.restarts > 0 {
            s.push_str(&format!(", requeued {}×", self.restarts));
        }
        if !self.alive() && !self.exit_code.is_empty() {
            s.push_str(&format!(", exit code {}", self.exit_code));
        }
        s
    }
}

/// Every known task of some arrays, keyed by (array job id, task index).
#[derive(Clone, Debug, Default)]
pub struct SlurmView {
    pub tasks: BTreeMap<(String, u32), TaskView>,
    /// The commands that answered.
    pub sources: Vec<&'static str>,
}

impl SlurmView {
    pub fn get(&self, array: &str, task: u32) -> Option<&TaskView> {
        self.tasks.get(&(array.to_string(), task))
    }
}

/// The command's path, if it is on PATH.
pub fn which(command: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(command))
        .find(|p| p.is_file())
}

/// Runs a Slurm command; stdout on success.
fn run(command: &'static str, args: &[String]) -> Result<String, SlurmError> {
    if which(command).is_none() {
        return Err(SlurmError::NotInstalled { command });
    }
    let out = Command::new(command)
        .args(args)
        .output()
        .map_err(SlurmError::io(command))?;
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    } else {
        let text = String::from_utf8_lossy(&out.stderr);
        let mut stderr: Vec<&str> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect();
        let hint = text.contains("DNS SRV").then_some(
            "no slurm.conf found: set SLURM_CONF (or run this where Slurm is configured)",
        );
        stderr.extend(hint);
        Err(SlurmError::Command {
            command: format!("{command} {}", args.join(" ")),
            status: out.status.to_string(),
            stderr: stderr.join("; "),
        })
    }
}

/// A command that failed because none of the ids asked about exists (any more).
fn unknown_ids(e: &SlurmError) -> bool {
    matches!(e, SlurmError::Command { stderr, .. } if stderr.contains("Invalid job id"))
}

/// Slurm's view of every task of `arrays`.
///
/// # Errors
/// `squeue` missing or failing for another reason than ids it no longer knows.
pub fn view(arrays: &[String]) -> Result<SlurmView, SlurmError> {
    let mut v = SlurmView::default();
    if arrays.is_empty() {
        return Ok(v);
    }
    let ids = arrays.join(",");
    match run(
        "squeue",
        &[
            "--noheader".into(),
            "--array".into(),
            "--states=all".into(),
            format!("--jobs={ids}"),
            "--format=%F|%K|%T|%r|%N".into(),
        ],
    ) {
        Ok(text) => {
            v.sources.push("squeue");
            for line in text.lines() {
                let f: Vec<&str> = line.trim().split('|').collect();
                if f.len() < 5 {
                    continue;
                }
                for task in expand_tasks(f[1]) {
                    v.tasks.insert(
                        (f[0].to_string(), task),
                        TaskView {
                            state: first_word(f[2]),
                            reason: f[3].to_string(),
                            node: f[4].to_string(),
                            ..TaskView::default()
                        },
                    );
                }
            }
        }
        Err(e) if unknown_ids(&e) => {}
        Err(e) => return Err(e),
    }
    // Only arrays the controller still knows (squeue listed them) have records to show.
    let known: Vec<String> = arrays
        .iter()
        .filter(|a| v.tasks.keys().any(|(x, _)| x == *a))
        .cloned()
        .collect();
    for a in &known {
        match run(
            "scontrol",
            &["--oneliner".into(), "show".into(), "job".into(), a.clone()],
        ) {
            Ok(text) => {
                if !v.sources.contains(&"scontrol") {
                    v.sources.push("scontrol");
                }
                for line in text.lines() {
                    merge_scontrol(&mut v, line);
                }
            }
            Err(e) if unknown_ids(&e) => {}
            // squeue answered; a failing scontrol only loses restart counts.
            Err(_) => {}
        }
    }
    let forgotten: Vec<String> = arrays
        .iter()
        .filter(|a| !v.tasks.keys().any(|(x, _)| x == *a))
        .cloned()
        .collect();
    if !forgotten.is_empty() && which("sacct").is_some() {
        // Fails without accounting (slurmdbd): then the controller's memory is all there is.
        if let Ok(text) = run(
            "sacct",
            &[
                "--noheader".into(),
                "--parsable2".into(),
                "--allocations".into(),
                format!("--jobs={}", forgotten.join(",")),
                "--format=JobID,State,ExitCode,NodeList".into(),
            ],
        ) {
            v.sources.push("sacct");
            for line in text.lines() {
                let f: Vec<&str> = line.split('|').collect();
                if f.len() < 4 {
                    continue;
                }
                let Some((array, task)) = f[0].split_once('_') else {
                    continue;
                };
                for t in expand_tasks(task.trim_matches(['[', ']'])) {
                    v.tasks.insert(
                        (array.to_string(), t),
                        TaskView {
                            state: first_word(f[1]),
                            exit_code: f[2].to_string(),
                            node: f[3].to_string(),
                            ..TaskView::default()
                        },
                    );
                }
            }
        }
    }
    Ok(v)
}

/// "CANCELLED by 0" → "CANCELLED".
fn first_word(s: &str) -> String {
    s.split_whitespace().next().unwrap_or("").to_string()
}

/// One `scontrol --oneliner show job` record merged into the view.
fn merge_scontrol(v: &mut SlurmView, line: &str) {
    let kv: BTreeMap<&str, &str> = line
        .split_whitespace()
        .filter_map(|w| w.split_once('='))
        .collect();
    let (Some(array), Some(tasks)) = (kv.get("ArrayJobId"), kv.get("ArrayTaskId")) else {
        return;
    };
    for t in expand_tasks(tasks) {
        let e = v.tasks.entry((array.to_string(), t)).or_default();
        if let Some(s) = kv.get("JobState") {
            e.state = first_word(s);
        }
        if let Some(r) = kv.get("Reason") {
            e.reason = r.to_string();
        }
        if let Some(n) = kv.get("Restarts").and_then(|n| n.parse().ok()) {
            e.restarts = n;
        }
        if let Some(x) = kv.get("ExitCode") {
            e.exit_code = x.to_string();
        }
        if let Some(n) = kv.get("NodeList").filter(|n| **n != "(null)") {
            e.node = n.to_string();
        }
    }
}

/// Task indices of an array expression: "3", "2-3%2", "0,4-6", "1-7:2".
fn expand_tasks(s: &str) -> Vec<u32> {
    let s = s.split('%').next().unwrap_or("");
    let mut out = Vec::new();
    for part in s.split(',') {
        let (range, step) = match part.split_once(':') {
            Some((r, st)) => (r, st.parse::<u32>().unwrap_or(1).max(1)),
            None => (part, 1),
        };
        match range.split_once('-') {
            Some((a, b)) => {
                if let (Ok(a), Ok(b)) = (a.parse::<u32>(), b.parse::<u32>()) {
                    out.extend((a..=b).step_by(step as usize));
                }
            }
            None => {
                if let Ok(a) = range.parse() {
                    out.push(a);
                }
            }
        }
    }
    out
}

/// Cancels whole arrays (`scancel ARRAY…`): their running tasks get SIGTERM, checkpoint and
/// exit; their pending tasks never start.
///
/// # Errors
/// `scancel` missing or failing.
pub fn cancel(arrays: &[String]) -> Result<(), SlurmError> {
    if arrays.is_empty() {
        return Ok(());
    }
    run("scancel", arrays)
        .map(|_| ())
        .or_else(|e| if unknown_ids(&e) { Ok(()) } else { Err(e) })
}

/// Asks Slurm to requeue the calling task (`scontrol requeue ARRAY_TASK`): a task that
/// checkpointed on SIGUSR1 starts again, from that checkpoint, when Slurm next schedules it.
///
/// # Errors
/// Not inside a Slurm job, or `scontrol` refused.
pub fn requeue_self() -> Result<String, SlurmError> {
    // NOTE: an array's last pending task runs under the array's own job id, so SLURM_JOB_ID
    // may name the whole array: requeueing that would requeue every task. `array_task` names
    // exactly this one.
    let id = match (
        std::env::var("SLURM_ARRAY_JOB_ID"),
        std::env::var("SLURM_ARRAY_TASK_ID"),
    ) {
        (Ok(a), Ok(t)) => format!("{a}_{t}"),
        _ => std::env::var("SLURM_JOB_ID").map_err(|_| SlurmError::Command {
            command: "scontrol requeue".into(),
            status: "not run".into(),
            stderr: "SLURM_JOB_ID is not set: not inside a Slurm job".into(),
        })?,
    };
    // While another task of the array is being requeued, the array is "in a transitional
    // state" for a few seconds: try again within the grace time.
    let mut tries = 0;
    loop {
        match run("scontrol", &["requeue".into(), id.clone()]) {
            Ok(_) => return Ok(id),
            Err(e) if tries < 10 && matches!(&e, SlurmError::Command { .. }) => {
                tries += 1;
                eprintln!("sweep run-job: scontrol requeue {id}: {e}; trying again");
                std::thread::sleep(std::time::Duration::from_secs(2));
            }
            Err(e) => return Err(e),
        }
    }
}

/// The largest array Slurm accepts (`MaxArraySize`: indices 0 … MaxArraySize − 1); 1001, Slurm's
/// default, when `scontrol show config` does not say.
pub fn max_array_size() -> usize {
    run("scontrol", &["show".into(), "config".into()])
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.trim_start().starts_with("MaxArraySize"))
                .and_then(|l| l.split('=').nth(1))
                .and_then(|n| n.trim().parse().ok())
        })
        .unwrap_or(1001)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_expressions() {
        assert_eq!(expand_tasks("3"), vec![3]);
        assert_eq!(expand_tasks("2-3%2"), vec![2, 3]);
        assert_eq!(expand_tasks("0,4-6"), vec![0, 4, 5, 6]);
        assert_eq!(expand_tasks("1-7:3"), vec![1, 4, 7]);
        assert_eq!(expand_tasks("N/A"), Vec::<u32>::new());
    }

    #[test]
    fn scontrol_records_merge_per_task() {
        let mut v = SlurmView::default();
        merge_scontrol(&mut v, "JobId=2 ArrayJobId=1 ArrayTaskId=0 JobState=RUNNING Reason=None Requeue=1 Restarts=1 ExitCode=0:0 NodeList=vm");
        merge_scontrol(&mut v, "JobId=1 ArrayJobId=1 ArrayTaskId=2-3%2 JobState=PENDING Reason=JobArrayTaskLimit Restarts=0 ExitCode=0:0 NodeList=");
        let t0 = v.get("1", 0).unwrap();
        assert_eq!(t0.state, "RUNNING");
        assert_eq!(t0.restarts, 1);
        assert!(t0.alive());
        assert_eq!(t0.describe(), "RUNNING on vm, requeued 1×");
        let t3 = v.get("1", 3).unwrap();
        assert_eq!(t3.describe(), "PENDING (JobArrayTaskLimit)");
        let ended = TaskView {
            state: "TIMEOUT".into(),
            exit_code: "0:15".into(),
            node: "vm".into(),
            ..TaskView::default()
        };
        assert!(!ended.alive());
        assert_eq!(ended.describe(), "TIMEOUT on vm, exit code 0:15");
    }
}
