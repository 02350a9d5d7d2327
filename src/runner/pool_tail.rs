//! A campaign's tail: its last jobs run while the rest of the pool's workers would idle (the
//! campaign's look or next round waits for all of them). A worker that finds no pending job of
//! its own campaign while some still run takes a job of the later campaigns (the pool's
//! `backfill` scopes, the next in turn first) and hands it back, paused at a checkpoint, as
//! soon as the campaign's own last job has ended: no core idles through the tail, and the look
//! or the round waits only for the lent job's current chunk. A job resumes bit for bit from its
//! checkpoint, so lending changes no result.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// What the pool's workers share about their own campaign's jobs.
#[derive(Default)]
pub(super) struct Tail {
    /// Own jobs being claimed or run.
    own: Arc<AtomicUsize>,
    /// A claim found no pending own job: none appears while the pool runs, so once the own
    /// jobs in flight have ended, lent jobs hand their cores back.
    exhausted: Arc<AtomicBool>,
}

/// One own claim, and the job it gave, in flight; ends when dropped (a panic included).
pub(super) struct OwnClaim<'a>(&'a Tail);

impl Drop for OwnClaim<'_> {
    fn drop(&mut self) {
        self.0.own.fetch_sub(1, Ordering::SeqCst);
    }
}

impl Tail {
    /// A worker is about to claim an own job: counted before the claim, so that a worker that
    /// finds none sees the other's claim in flight.
    pub(super) fn claiming(&self) -> OwnClaim<'_> {
        self.own.fetch_add(1, Ordering::SeqCst);
        OwnClaim(self)
    }

    /// The claim found no pending own job.
    pub(super) fn exhausted(&self) {
        self.exhausted.store(true, Ordering::SeqCst);
    }

    /// Whether another worker's own job is still running, so that an idle worker may take a
    /// lent one.
    pub(super) fn own_running(&self) -> bool {
        self.own.load(Ordering::SeqCst) > 0
    }

    /// Whether the own jobs have all ended: a lent job hands its core back.
    pub(super) fn over(&self) -> bool {
        over(&self.exhausted, &self.own)
    }

    /// The interrupt flag of a lent job: set on the run's interrupt or when the own jobs have
    /// ended. The returned guard stops its watcher when the job ends.
    pub(super) fn lent_interrupt(&self, run: Arc<AtomicBool>) -> (Arc<AtomicBool>, LentWatch) {
        let flag = Arc::new(AtomicBool::new(false));
        let finished = Arc::new(AtomicBool::new(false));
        let (f, fin) = (flag.clone(), finished.clone());
        let (exhausted, own) = (self.exhausted.clone(), self.own.clone());
        // Polled: the job itself looks at its flag only between chunks.
        let watcher = std::thread::spawn(move || {
            while !fin.load(Ordering::SeqCst) {
                if run.load(Ordering::SeqCst) || over(&exhausted, &own) {
                    f.store(true, Ordering::SeqCst);
                    return;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        });
        (
            flag,
            LentWatch {
                finished,
                watcher: Some(watcher),
            },
        )
    }
}

fn over(exhausted: &AtomicBool, own: &AtomicUsize) -> bool {
    exhausted.load(Ordering::SeqCst) && own.load(Ordering::SeqCst) == 0
}

/// Stops a lent job's watcher when dropped.
pub(super) struct LentWatch {
    finished: Arc<AtomicBool>,
    watcher: Option<std::thread::JoinHandle<()>>,
}

impl Drop for LentWatch {
    fn drop(&mut self) {
        self.finished.store(true, Ordering::SeqCst);
        if let Some(w) = self.watcher.take() {
            let _ = w.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Tail;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    fn raised_within(flag: &AtomicBool, limit: Duration) -> bool {
        let t0 = Instant::now();
        while t0.elapsed() < limit {
            if flag.load(Ordering::SeqCst) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        false
    }

    #[test]
    fn a_lent_job_is_handed_back_when_the_last_own_job_ends() {
        let tail = Tail::default();
        let running = tail.claiming();
        // Another worker's claim finds nothing while the first job runs.
        drop({
            let c = tail.claiming();
            tail.exhausted();
            c
        });
        assert!(tail.own_running() && !tail.over());
        let run = Arc::new(AtomicBool::new(false));
        let (flag, _watch) = tail.lent_interrupt(run);
        assert!(!raised_within(&flag, Duration::from_millis(150)));
        drop(running);
        assert!(!tail.own_running() && tail.over());
        assert!(raised_within(&flag, Duration::from_secs(2)));
    }

    #[test]
    fn own_jobs_ending_together_with_work_left_do_not_end_the_tail() {
        let tail = Tail::default();
        let (a, b) = (tail.claiming(), tail.claiming());
        drop(a);
        drop(b);
        // Both ended before either claimed again: a pending own job may be left.
        assert!(!tail.over());
        let c = tail.claiming();
        tail.exhausted();
        drop(c);
        assert!(tail.over());
    }

    #[test]
    fn a_panicking_own_job_still_ends_its_claim() {
        let tail = Tail::default();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let _claim = tail.claiming();
            panic!("a job's bookkeeping panicked");
        }));
        assert!(r.is_err());
        assert!(!tail.own_running());
    }

    #[test]
    fn a_lent_job_stops_on_the_runs_interrupt() {
        let tail = Tail::default();
        let _running = tail.claiming();
        let run = Arc::new(AtomicBool::new(false));
        let (flag, watch) = tail.lent_interrupt(run.clone());
        run.store(true, Ordering::SeqCst);
        assert!(raised_within(&flag, Duration::from_secs(2)));
        drop(watch);
        // A watcher whose job ended stops without raising anything.
        let (flag, watch) = tail.lent_interrupt(Arc::new(AtomicBool::new(false)));
        drop(watch);
        assert!(!raised_within(&flag, Duration::from_millis(150)));
    }
}
