//! The sbatch script of one job array: `#SBATCH` lines from the executor settings, a table from
//! array index to sweep job id, and `exec sweep run-job`. The script is complete: it is kept in
//! the work directory and can be read (or resubmitted by hand) to see exactly what ran.

use std::path::Path;

use crate::campaign::SlurmSettings;
use crate::runner::backend::{BackendChoice, GpuSelect};

/// What one array's script is made of.
pub struct ScriptInput<'a> {
    pub campaign: &'a str,
    /// Absolute work directory on shared storage.
    pub work_dir: &'a Path,
    /// The sweep binary as the compute nodes reach it.
    pub sweep_bin: &'a Path,
    /// Array task `k` runs job `jobs[k]`.
    pub jobs: &'a [i64],
    pub settings: &'a SlurmSettings,
    pub backend: BackendChoice,
    /// Which GPU adapter (`--gpu N`, `--allow-software-gpu`).
    pub gpu: GpuSelect,
    /// Engine threads (0: the task's `--cpus-per-task`).
    pub threads: usize,
    /// This array is the `part.0`-th of `part.1` (a campaign larger than MaxArraySize is split).
    pub part: (usize, usize),
}

fn backend_name(b: BackendChoice) -> &'static str {
    match b {
        BackendChoice::Auto => "auto",
        BackendChoice::Gpu => "gpu",
        BackendChoice::Cpu => "cpu",
    }
}

/// A word for the shell, in single quotes.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The job name Slurm shows: `sweep-<campaign>` with anything but `[A-Za-z0-9._-]` as `_`.
pub fn job_name(campaign: &str) -> String {
    let clean: String = campaign
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("sweep-{clean}")
}

/// The `--array` value: every index, and the throttle.
pub fn array_spec(n: usize, max: Option<u32>) -> String {
    let range = if n <= 1 {
        "0".to_string()
    } else {
        format!("0-{}", n - 1)
    };
    match max {
        Some(k) => format!("{range}%{k}"),
        None => range,
    }
}

/// The script's text.
pub fn script(i: &ScriptInput<'_>) -> String {
    let s = i.settings;
    let work = i.work_dir.display().to_string();
    let logs = super::files::slurm_dir(i.work_dir).join("logs");
    let threads = if i.threads > 0 {
        i.threads
    } else {
        s.cpus_per_job as usize
    };
    let mut o = String::new();
    o.push_str("#!/bin/bash\n");
    o.push_str(&format!(
        "# sweep {}: campaign {:?}, {} job(s) as one Slurm job array (part {} of {}).\n",
        env!("CARGO_PKG_VERSION"),
        i.campaign,
        i.jobs.len(),
        i.part.0,
        i.part.1
    ));
    o.push_str(
        "# Array task k runs sweep job JOBS[k] in that job's directory under the work directory:\n\
         # checkpoints, then result.db + result.json when done. `sweep collect` (also run by\n\
         # `sweep status` and `sweep resume`) verifies those and marks the job done in the database.\n\
         # On SIGUSR1 (time limit or preemption near) the task checkpoints and requeues itself; on\n\
         # SIGTERM it checkpoints and exits (a requeued or preempted job resumes from there).\n",
    );
    let mut sb = |line: String| o.push_str(&format!("#SBATCH {line}\n"));
    sb(format!("--job-name={}", job_name(i.campaign)));
    sb(format!("--array={}", array_spec(i.jobs.len(), s.array_max)));
    sb("--requeue".into());
    sb(format!("--signal=B:USR1@{}", s.signal_grace_s));
    sb("--open-mode=append".into());
    sb(format!("--output={}/%A_%a.out", logs.display()));
    sb(format!("--chdir={work}"));
    sb("--ntasks=1".into());
    sb(format!("--cpus-per-task={}", s.cpus_per_job));
    if let Some(p) = &s.partition {
        sb(format!("--partition={p}"));
    }
    if s.gpus_per_job > 0 {
        sb(format!("--gres=gpu:{}", s.gpus_per_job));
    }
    if let Some(t) = &s.time {
        sb(format!("--time={t}"));
    }
    for a in &s.sbatch_args {
        sb(a.clone());
    }
    let ids: Vec<String> = i.jobs.iter().map(|j| j.to_string()).collect();
    o.push_str(&format!("JOBS=({})\n", ids.join(" ")));
    let mut gpu = String::new();
    if let Some(n) = i.gpu.index {
        gpu.push_str(&format!(" --gpu {n}"));
    }
    if i.gpu.allow_software {
        gpu.push_str(" --allow-software-gpu");
    }
    o.push_str(&format!(
        "exec {} run-job --db-dir {} --job \"${{JOBS[$SLURM_ARRAY_TASK_ID]}}\" --backend {}{gpu} --threads {}\n",
        shell_quote(&i.sweep_bin.display().to_string()),
        shell_quote(&work),
        backend_name(i.backend),
        threads
    ));
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_has_the_requests_and_the_job_table() {
        let settings = SlurmSettings {
            partition: Some("gpu".into()),
            gpus_per_job: 1,
            cpus_per_job: 4,
            time: Some("04:00:00".into()),
            array_max: Some(8),
            sbatch_args: vec!["--account=proj42".into()],
            signal_grace_s: 90,
        };
        let t = script(&ScriptInput {
            campaign: "silo QvsF",
            work_dir: Path::new("/scratch/me/sweep-work/paper"),
            sweep_bin: Path::new("/home/me/bin/sweep"),
            jobs: &[4, 9, 10],
            settings: &settings,
            backend: BackendChoice::Auto,
            gpu: GpuSelect::default(),
            threads: 0,
            part: (1, 1),
        });
        for want in [
            "#!/bin/bash\n",
            "#SBATCH --job-name=sweep-silo_QvsF\n",
            "#SBATCH --array=0-2%8\n",
            "#SBATCH --requeue\n",
            "#SBATCH --signal=B:USR1@90\n",
            "#SBATCH --output=/scratch/me/sweep-work/paper/slurm/logs/%A_%a.out\n",
            "#SBATCH --cpus-per-task=4\n",
            "#SBATCH --partition=gpu\n",
            "#SBATCH --gres=gpu:1\n",
            "#SBATCH --time=04:00:00\n",
            "#SBATCH --account=proj42\n",
            "JOBS=(4 9 10)\n",
            "exec '/home/me/bin/sweep' run-job --db-dir '/scratch/me/sweep-work/paper' --job \"${JOBS[$SLURM_ARRAY_TASK_ID]}\" --backend auto --threads 4\n",
        ] {
            assert!(t.contains(want), "missing {want:?} in\n{t}");
        }
        // sbatch reads #SBATCH lines only before the first command.
        let first_cmd = t.find("JOBS=").unwrap();
        assert!(t.rfind("#SBATCH").unwrap() < first_cmd);
    }

    #[test]
    fn the_script_passes_the_gpu_choice_on() {
        let settings = SlurmSettings::default();
        let t = script(&ScriptInput {
            campaign: "c",
            work_dir: Path::new("/w"),
            sweep_bin: Path::new("/b/sweep"),
            jobs: &[1],
            settings: &settings,
            backend: BackendChoice::Gpu,
            gpu: GpuSelect {
                index: Some(1),
                allow_software: true,
            },
            threads: 2,
            part: (1, 1),
        });
        assert!(
            t.contains("--backend gpu --gpu 1 --allow-software-gpu --threads 2\n"),
            "{t}"
        );
    }

    #[test]
    fn arrays_and_quotes() {
        assert_eq!(array_spec(1, None), "0");
        assert_eq!(array_spec(4, Some(2)), "0-3%2");
        assert_eq!(shell_quote("a'b"), r"'a'\''b'");
    }
}
