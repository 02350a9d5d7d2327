//! Helpers the subcommands share: exit statuses, registering a launched campaign, and
//! reporting collected Slurm results.

use sweep::project::{Project, Registration};
use sweep::runner::slurm::CollectReport;

use super::run_args::Arguments;

/// Exit status of a run that stopped on an interrupt (or left jobs paused): 75, EX_TEMPFAIL,
/// as `sweep run-job`; `sweep resume` continues it.
pub const EXIT_PAUSED: i32 = 75;

/// Registers a launched campaign, or explains why not: a file changed since the version
/// launched under its name is refused with the fields that differ. Ok(Err(code)) is the exit
/// code of a refusal.
pub fn register(
    project: &mut Project,
    a: &Arguments,
    file: &sweep::campaign::CampaignFile,
    jobs: &sweep::campaign::Jobs,
) -> anyhow::Result<Result<(i64, i64, usize), i32>> {
    let path = a.file.display().to_string();
    let stop = super::interrupt::interrupt_flag();
    let stop = || stop.load(std::sync::atomic::Ordering::SeqCst);
    match project.register(&path, file, jobs, a.new_version, &stop)? {
        Registration::Interrupted { added, .. } => {
            println!(
                "interrupted while registering: {added} of {} job(s) registered; launch the same file again to register the rest",
                jobs.len()
            );
            Ok(Err(EXIT_PAUSED))
        }
        Registration::Registered {
            campaign_id,
            version,
            added,
        } => Ok(Ok((campaign_id, version, added))),
        Registration::Changed { version, changes } => {
            eprintln!(
                "sweep: error: {path}: campaign '{}' was launched before (version {version}) with other jobs or claims; this file changes:",
                file.name
            );
            for c in &changes {
                eprintln!("  {c}");
            }
            eprintln!(
                "nothing registered. Launch it as version {} with `--new-version` (version {version} and its results stay apart), or give it another \"name\".",
                version + 1
            );
            Ok(Err(2))
        }
    }
}

/// One line per job whose state changed, and a warning when Slurm could not be asked.
pub fn print_report(r: &CollectReport) {
    for id in &r.ingested {
        println!("job {id} done: its result verifies and is collected");
    }
    for (id, why) in &r.failed {
        println!("job {id} failed {why}");
    }
    for (id, why) in &r.ended {
        println!("job {id} paused: {why}");
    }
    for (id, why) in &r.refused {
        println!("job {id}: result not collected: {why}");
    }
    if let Some(e) = &r.slurm_error {
        eprintln!(
            "sweep: cannot ask Slurm ({e}): jobs handed to it without a result are left as they are"
        );
    }
}
