//! The process's interrupt: Ctrl-C, SIGTERM or the end of `--time-limit` asks every running job
//! to checkpoint and stop.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// First Ctrl-C (or SIGTERM): checkpoint and stop at the next chunk; second: exit at once.
/// `--time-limit` raises the same flag (`stop_after`) without counting as a signal.
/// One flag for the whole process: a signal handler can be set only once, and a target's
/// rounds run their jobs in later pools that must see the same interrupt.
pub fn interrupt_flag() -> Arc<AtomicBool> {
    static FLAG: std::sync::OnceLock<Arc<AtomicBool>> = std::sync::OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        // Signals are counted apart from the flag: after `--time-limit` has raised it, the
        // user's first Ctrl-C still only asks for the checkpoints.
        let signalled = AtomicBool::new(false);
        let _ = ctrlc::set_handler(move || {
            f.store(true, Ordering::SeqCst);
            if signalled.swap(true, Ordering::SeqCst) {
                eprintln!("sweep: second interrupt, exiting without checkpoint");
                std::process::exit(130);
            }
            eprintln!(
                "sweep: interrupt: writing checkpoints, then stopping (again to exit at once)"
            );
        });
        flag
    })
    .clone()
}

/// Raises the interrupt once `limit` of wall time has passed since this call, as a first Ctrl-C
/// would: the running jobs checkpoint and pause, and no new job or round starts.
pub fn stop_after(limit: std::time::Duration) {
    let flag = interrupt_flag();
    std::thread::spawn(move || {
        std::thread::sleep(limit);
        if !flag.swap(true, Ordering::SeqCst) {
            eprintln!(
                "sweep: time limit of {} reached: writing checkpoints, then stopping",
                humantime::format_duration(limit)
            );
        }
    });
}
