//! The CPU time of threads: what a job's threads ran on a core. Unlike wall time × threads it
//! does not grow when other work shares the cores, so a job's account (`Ledger::cpu_time_s`)
//! says what it used, beside what it held. Linux only: elsewhere every reading is None, and a
//! job's CPU time is stored as unknown rather than as 0.

use std::sync::{Arc, Mutex};

/// CPU seconds the calling thread has run; None where the system cannot say.
pub fn this_thread_s() -> Option<f64> {
    #[cfg(target_os = "linux")]
    {
        clock_s(libc::CLOCK_THREAD_CPUTIME_ID)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

#[cfg(target_os = "linux")]
fn clock_s(id: libc::clockid_t) -> Option<f64> {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec the call writes; an invalid clock id returns an error.
    let ok = unsafe { libc::clock_gettime(id, &mut t) } == 0;
    ok.then_some(t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9)
}

#[cfg(target_os = "linux")]
type ClockId = libc::clockid_t;
#[cfg(not(target_os = "linux"))]
type ClockId = ();

/// The CPU clocks of an engine's worker threads, each registered by the thread itself as it
/// starts; read from any thread.
#[derive(Clone, Default)]
pub struct WorkerClocks {
    /// None for a thread whose clock the system would not give.
    ids: Arc<Mutex<Vec<Option<ClockId>>>>,
}

impl WorkerClocks {
    /// Adds the calling thread's clock.
    pub fn register_this_thread(&self) {
        #[cfg(target_os = "linux")]
        let id = {
            let mut id: libc::clockid_t = 0;
            // SAFETY: pthread_self is the calling thread; `id` is written on success only.
            let ok = unsafe { libc::pthread_getcpuclockid(libc::pthread_self(), &mut id) } == 0;
            ok.then_some(id)
        };
        #[cfg(not(target_os = "linux"))]
        let id = None;
        self.ids.lock().unwrap().push(id);
    }

    /// CPU seconds the registered threads have run; None when a thread's clock cannot be read.
    /// Read it while they live: the clock of an ended thread is gone (or, its thread id
    /// reused, another thread's).
    pub fn total_s(&self) -> Option<f64> {
        #[cfg(target_os = "linux")]
        {
            self.ids
                .lock()
                .unwrap()
                .iter()
                .map(|id| clock_s((*id)?))
                .sum()
        }
        #[cfg(not(target_os = "linux"))]
        {
            let none = self.ids.lock().unwrap().is_empty();
            none.then_some(0.0)
        }
    }

    /// Threads registered.
    pub fn threads(&self) -> usize {
        self.ids.lock().unwrap().len()
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::{this_thread_s, WorkerClocks};
    use std::hint::black_box;

    fn spin(s: f64) {
        let t0 = std::time::Instant::now();
        let mut x = 0u64;
        while t0.elapsed().as_secs_f64() < s {
            x = black_box(x.wrapping_add(1));
        }
    }

    #[test]
    fn a_busy_thread_counts_its_time_and_a_sleeping_one_does_not() {
        let t0 = this_thread_s().unwrap();
        spin(0.05);
        let busy = this_thread_s().unwrap() - t0;
        assert!(busy > 0.02 && busy < 1.0, "{busy}");
        let clocks = WorkerClocks::default();
        assert_eq!(clocks.total_s(), Some(0.0));
        let (go, wait) = std::sync::mpsc::channel::<()>();
        let (done, ended) = std::sync::mpsc::channel::<()>();
        let c = clocks.clone();
        let worker = std::thread::spawn(move || {
            c.register_this_thread();
            spin(0.05);
            done.send(()).unwrap();
            // Asleep until told to end: its clock stands still.
            wait.recv().unwrap();
        });
        ended.recv().unwrap();
        let a = clocks.total_s().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(50));
        let b = clocks.total_s().unwrap();
        assert_eq!(clocks.threads(), 1);
        assert!(a > 0.02, "{a}");
        assert!(b - a < 0.01, "a sleeping thread ran {} s", b - a);
        go.send(()).unwrap();
        worker.join().unwrap();
    }
}
