//! A team of threads for the sphere step's two passes: the calling thread plus `threads − 1`
//! helpers that stay awake (spinning) between passes, so that each of the thousands of passes
//! per second does not pay a futex wake-up. rayon parks its idle workers within microseconds,
//! and waking them took a large share of the second core's time, leaving the workers unevenly
//! busy.
//!
//! `run(tasks, f)` evaluates f(0) … f(tasks − 1), each exactly once, on whichever thread claims
//! it, and returns the results in task order: what a task computes cannot depend on the thread
//! count, and callers reduce the results in order. Helpers that find no work for about 50 µs
//! park until the next `run`.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::engine::cpu_clock::WorkerClocks;

/// How long an idle helper spins before it parks.
const SPIN: Duration = Duration::from_micros(50);

/// A task body with its lifetime erased; see `Team::run` for why that is sound.
type Body = &'static (dyn Fn(usize) + Sync);

struct Shared {
    /// Per thread, (epoch << 32) | next unclaimed task of its home range (thread t's range is
    /// `home(t)`). A claim is a compare-and-swap that checks the epoch, so a helper holding a
    /// stale epoch can never run a newer body, and a body is only called for a claimed,
    /// unfinished task (while `run` still waits for it). Each thread takes its own range first
    /// and then the others': a block's data then stays in one core's cache from pass to pass
    /// and step to step, while a slow thread's work is still taken over.
    claim: Vec<Padded>,
    /// The current epoch's body and task count.
    job: Mutex<Option<(u32, Body, usize)>>,
    /// Tasks finished in the current epoch.
    done: AtomicUsize,
    /// The first panic of a task in the current epoch, re-raised by `run` once every task has
    /// finished (unwinding earlier would free what helpers may still be using).
    panic: Mutex<Option<Box<dyn std::any::Any + Send>>>,
    stop: AtomicBool,
}

/// A counter on its own cache lines, so that one thread's claims do not slow another's.
#[repr(align(128))]
struct Padded(AtomicU64);

pub struct Team {
    shared: Arc<Shared>,
    helpers: Vec<JoinHandle<()>>,
    epoch: u32,
}

impl Team {
    /// A team of `threads` (≥ 1) threads: this one and `threads − 1` helpers; or the system's refusal of a helper thread (a
    /// process limit, `ulimit -u`); the helpers already started are stopped.
    ///
    /// # Errors
    /// A helper thread cannot be spawned.
    pub fn try_new(threads: usize, clocks: &WorkerClocks) -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            claim: (0..threads.max(1))
                .map(|_| Padded(AtomicU64::new(0)))
                .collect(),
            job: Mutex::new(None),
            done: AtomicUsize::new(0),
            panic: Mutex::new(None),
            stop: AtomicBool::new(false),
        });
        let mut team = Self {
            shared,
            helpers: Vec::new(),
            epoch: 0,
        };
        for k in 1..threads.max(1) {
            let sh = team.shared.clone();
            let clocks = clocks.clone();
            let helper = std::thread::Builder::new()
                .name(format!("sweep-team-{k}"))
                .spawn(move || {
                    clocks.register_this_thread();
                    helper(&sh, k)
                })?;
            // Dropping `team` on an error stops the helpers started so far.
            team.helpers.push(helper);
        }
        Ok(team)
    }

    /// f(b, block b) for each of `blocks` (each a disjoint piece of the arrays a pass writes)
    /// on the team; the results in block order. Each block sits behind its own lock, taken
    /// only by the one task that owns it, so it is never contended.
    pub fn run_blocks<B: Send, T: Send>(
        &mut self,
        blocks: Vec<B>,
        f: impl Fn(usize, &mut B) -> T + Sync,
    ) -> Vec<T> {
        let cells: Vec<Mutex<B>> = blocks.into_iter().map(Mutex::new).collect();
        self.run(cells.len(), |b| f(b, &mut cells[b].lock().unwrap()))
    }

    /// f(0) … f(tasks − 1) on the team; the results in task order.
    pub fn run<T: Send>(&mut self, tasks: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
        let results: Vec<Mutex<Option<T>>> = (0..tasks).map(|_| Mutex::new(None)).collect();
        if self.helpers.is_empty() || tasks <= 1 {
            return (0..tasks).map(&f).collect();
        }
        let body = |k: usize| {
            let out = f(k);
            *results[k].lock().unwrap() = Some(out);
        };
        let body: &(dyn Fn(usize) + Sync) = &body;
        // SAFETY: the body is called only for a task claimed in this epoch (the claim checks the
        // epoch) and not yet finished, and this function returns only once every task of the
        // epoch has finished; so no call outlives the borrow the lifetime was erased from.
        let body: Body = unsafe { std::mem::transmute::<&(dyn Fn(usize) + Sync), Body>(body) };
        self.epoch = self.epoch.wrapping_add(1);
        let sh = &*self.shared;
        sh.done.store(0, Ordering::Relaxed);
        *sh.job.lock().unwrap() = Some((self.epoch, body, tasks));
        // Thread 0's counter last: a helper that sees the new epoch there sees every range.
        for (t, c) in sh.claim.iter().enumerate().rev() {
            let lo = home(t, sh.claim.len(), tasks).start as u64;
            c.0.store((u64::from(self.epoch) << 32) | lo, Ordering::Release);
        }
        for h in &self.helpers {
            h.thread().unpark();
        }
        work(sh, 0, self.epoch, body, tasks);
        // A helper still running a task may have been descheduled (more threads than cores):
        // after a short spin, give the core away instead of burning it.
        let mut spins = 0u32;
        while sh.done.load(Ordering::Acquire) < tasks {
            if spins < 4096 {
                spins += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        let panicked = sh.panic.lock().unwrap().take();
        if let Some(p) = panicked {
            std::panic::resume_unwind(p);
        }
        results
            .into_iter()
            .map(|m| m.into_inner().unwrap().expect("every task ran"))
            .collect()
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        for h in self.helpers.drain(..) {
            h.thread().unpark();
            let _ = h.join();
        }
    }
}

/// Thread t's home range of `tasks` split over `threads`.
fn home(t: usize, threads: usize, tasks: usize) -> std::ops::Range<usize> {
    t * tasks / threads..(t + 1) * tasks / threads
}

/// Thread `me` claims and runs tasks of `epoch`, its own range first, until none is left.
fn work(sh: &Shared, me: usize, epoch: u32, body: Body, tasks: usize) {
    let threads = sh.claim.len();
    for u in (0..threads).map(|k| (me + k) % threads) {
        work_range(sh, u, epoch, body, home(u, threads, tasks).end);
    }
}

/// Claims and runs the tasks of range `u` of `epoch` (which ends at `end`) until none is left.
fn work_range(sh: &Shared, u: usize, epoch: u32, body: Body, end: usize) {
    let claim = &sh.claim[u].0;
    let mut c = claim.load(Ordering::Acquire);
    loop {
        if (c >> 32) as u32 != epoch || (c & 0xffff_ffff) as usize >= end {
            return;
        }
        match claim.compare_exchange_weak(c, c + 1, Ordering::AcqRel, Ordering::Acquire) {
            Ok(_) => {
                let k = (c & 0xffff_ffff) as usize;
                if let Err(p) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| body(k))) {
                    sh.panic.lock().unwrap().get_or_insert(p);
                }
                sh.done.fetch_add(1, Ordering::Release);
                c = claim.load(Ordering::Acquire);
            }
            Err(now) => c = now,
        }
    }
}

fn helper(sh: &Shared, me: usize) {
    let mut seen = 0u32;
    let mut idle_since = Instant::now();
    loop {
        if sh.stop.load(Ordering::Acquire) {
            return;
        }
        let epoch = (sh.claim[0].0.load(Ordering::Acquire) >> 32) as u32;
        if epoch != seen {
            seen = epoch;
            let job = *sh.job.lock().unwrap();
            if let Some((e, body, tasks)) = job {
                if e == epoch {
                    work(sh, me, e, body, tasks);
                }
            }
            idle_since = Instant::now();
            continue;
        }
        if idle_since.elapsed() < SPIN {
            std::hint::spin_loop();
        } else {
            std::thread::park_timeout(Duration::from_millis(10));
            idle_since = Instant::now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_task_runs_once_and_results_come_in_task_order() {
        for threads in [1, 2, 3] {
            let mut team = Team::try_new(threads, &WorkerClocks::default()).unwrap();
            for round in 0..200 {
                let counts: Vec<AtomicUsize> = (0..37).map(|_| AtomicUsize::new(0)).collect();
                let out = team.run(37, |k| {
                    counts[k].fetch_add(1, Ordering::Relaxed);
                    k * round
                });
                assert_eq!(out, (0..37).map(|k| k * round).collect::<Vec<_>>());
                assert!(counts.iter().all(|c| c.load(Ordering::Relaxed) == 1));
            }
        }
    }

    #[test]
    fn a_panicking_task_is_reraised_after_the_others_finish() {
        let mut team = Team::try_new(2, &WorkerClocks::default()).unwrap();
        let finished = AtomicUsize::new(0);
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            team.run(16, |k| {
                if k == 3 {
                    panic!("task 3");
                }
                // Some work, so that other tasks are still running when task 3 panics.
                let mut x = 0u64;
                for i in 0..100_000u64 {
                    x = std::hint::black_box(x.wrapping_add(i));
                }
                finished.fetch_add(1, Ordering::Relaxed);
            })
        }));
        assert!(r.is_err());
        assert_eq!(finished.load(Ordering::Relaxed), 15);
        // The team still works afterwards.
        assert_eq!(team.run(4, |k| k), vec![0, 1, 2, 3]);
    }
}
