//! A campaign's tail: its last jobs run while the rest of the pool's workers would idle (the
//! campaign's look or next round waits for all of them). A worker that finds no pending job of
//! its own campaign while some still run takes a job of the later campaigns (the pool's
//! `backfill` scope) and hands it back, paused at a checkpoint, as soon as the campaign's own
//! last job has ended: no core idles through the tail, and the look or the round is not
//! delayed. A job resumes bit for bit from its checkpoint, so lending changes no result.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// What the pool's workers share about their own campaign's jobs.
#[derive(Default)]
pub(super) struct Tail {
    /// Own jobs being claimed or run.
    own: AtomicUsize,
    /// Set when the own jobs have all ended: lent jobs hand their cores back.
    over: Arc<AtomicBool>,
}

impl Tail {
    /// A worker is about to claim an own job (counted before the claim, so that a worker that
    /// finds none sees the other's claim in flight).
    pub(super) fn claiming(&self) {
        self.own.fetch_add(1, Ordering::SeqCst);
    }

    /// The claim, or the job it gave, has ended. When no own job is left running, lent jobs
    /// are asked to hand back (the own scope holds no pending job once a claim has found none).
    pub(super) fn ended(&self) {
        if self.own.fetch_sub(1, Ordering::SeqCst) == 1 {
            self.over.store(true, Ordering::SeqCst);
        }
    }

    /// Whether an own job is still running, so that an idle worker may take a lent one.
    pub(super) fn own_running(&self) -> bool {
        self.own.load(Ordering::SeqCst) > 0 && !self.over.load(Ordering::SeqCst)
    }

    /// The interrupt flag of a lent job: set on the run's interrupt or when the own jobs have
    /// ended. The returned guard stops its watcher when the job ends.
    pub(super) fn lent_interrupt(&self, run: Arc<AtomicBool>) -> (Arc<AtomicBool>, LentWatch) {
        let flag = Arc::new(AtomicBool::new(false));
        let finished = Arc::new(AtomicBool::new(false));
        let (f, fin, over) = (flag.clone(), finished.clone(), self.over.clone());
        // Polled: the job itself looks at its flag only between chunks.
        let watcher = std::thread::spawn(move || {
            while !fin.load(Ordering::SeqCst) {
                if run.load(Ordering::SeqCst) || over.load(Ordering::SeqCst) {
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
        tail.claiming();
        tail.claiming();
        // One worker's claim found nothing: the other's job still runs.
        tail.ended();
        assert!(tail.own_running());
        let run = Arc::new(AtomicBool::new(false));
        let (flag, _watch) = tail.lent_interrupt(run);
        assert!(!raised_within(&flag, Duration::from_millis(150)));
        tail.ended();
        assert!(!tail.own_running());
        assert!(raised_within(&flag, Duration::from_secs(2)));
    }

    #[test]
    fn a_lent_job_stops_on_the_runs_interrupt() {
        let tail = Tail::default();
        tail.claiming();
        let run = Arc::new(AtomicBool::new(false));
        let (flag, watch) = tail.lent_interrupt(run.clone());
        run.store(true, Ordering::SeqCst);
        assert!(raised_within(&flag, Duration::from_secs(2)));
        drop(watch);
        // A watcher whose job ended stops without raising anything.
        let (flag, watch) = tail.lent_interrupt(Arc::new(AtomicBool::new(false)));
        drop(watch);
        tail.ended();
        assert!(!raised_within(&flag, Duration::from_millis(150)));
    }
}
