//! The process's interrupt: Ctrl-C or SIGTERM asks every running job to checkpoint and stop.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// First Ctrl-C (or SIGTERM): checkpoint and stop at the next chunk; second: exit at once.
/// One flag for the whole process: a signal handler can be set only once, and a target's
/// rounds run their jobs in later pools that must see the same interrupt.
pub fn interrupt_flag() -> Arc<AtomicBool> {
    static FLAG: std::sync::OnceLock<Arc<AtomicBool>> = std::sync::OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        let _ = ctrlc::set_handler(move || {
            if f.swap(true, Ordering::SeqCst) {
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
