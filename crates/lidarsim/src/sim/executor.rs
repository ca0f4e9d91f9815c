//! An ordered parallel executor: numbered jobs run on several threads, their
//! results handed over strictly in job order by the calling thread, which
//! is itself one of the threads.
//!
//! Threads take jobs in order from a shared counter, at most `window` jobs
//! ahead of the last one handed over, so memory stays bounded whatever the
//! number of jobs. The calling thread hands over every result that is next
//! in order as soon as it has it, and runs a job itself whenever none is:
//! a run keeps exactly `threads` cores busy (one thread: no other thread at
//! all) and handing over is shared like the work. The results, and the
//! order in which they are handed over, do not depend on the number of
//! threads.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::sync::{Condvar, Mutex};

/// Where the results go, in job order.
pub trait InOrder<B> {
    /// The error that stops the run.
    type Error;

    /// Takes the result of job `index`; every job before it was taken.
    fn take(&mut self, index: usize, result: B) -> Result<(), Self::Error>;

    /// Called after one or more results were taken in a row (before the
    /// calling thread turns to other work or waits).
    fn caught_up(&mut self) {}
}

/// How many threads run and when they stop taking jobs.
#[derive(Clone, Copy)]
pub struct Executor<'a> {
    /// Threads, the calling one included (at least 1).
    pub threads: usize,
    /// Jobs a thread may start ahead of the last one taken.
    pub window: usize,
    /// Once true, no job is started (the jobs started are finished and
    /// taken as far as they follow each other).
    pub stop: &'a (dyn Fn() -> bool + Sync),
}

impl Executor<'_> {
    /// Runs jobs `0..jobs`, each as `work(index, state)` with a state made
    /// by `state` once per thread, and gives the results to `out` in job
    /// order. Returns the number of jobs taken (all of them unless stopped
    /// or `out` failed); a failure of `out` stops the other threads and is
    /// returned.
    pub fn run<S, B, O>(
        &self,
        jobs: usize,
        state: impl Fn() -> S + Sync,
        work: impl Fn(usize, &mut S) -> B + Sync,
        out: &mut O,
    ) -> Result<usize, O::Error>
    where
        B: Send,
        O: InOrder<B>,
    {
        let threads = self.threads.max(1);
        let window = self.window.max(1);
        let stopped = self.stop;
        let next_job = AtomicUsize::new(0);
        let abort = AtomicBool::new(false);
        let taken = (Mutex::new(0usize), Condvar::new());
        let (tx, rx) = mpsc::channel::<(usize, B)>();
        std::thread::scope(|scope| {
            for _ in 1..threads {
                let tx = tx.clone();
                let (next_job, abort, taken) = (&next_job, &abort, &taken);
                let (state, work) = (&state, &work);
                scope.spawn(move || {
                    let mut s = state();
                    loop {
                        if stopped() || abort.load(Ordering::SeqCst) {
                            return;
                        }
                        let j = next_job.fetch_add(1, Ordering::SeqCst);
                        if j >= jobs {
                            return;
                        }
                        // Wait until the hand-over is within the window.
                        {
                            let (lock, cv) = taken;
                            let mut t = lock.lock().unwrap_or_else(|e| e.into_inner());
                            while j >= *t + window && !abort.load(Ordering::SeqCst) {
                                t = cv.wait(t).unwrap_or_else(|e| e.into_inner());
                            }
                        }
                        if tx.send((j, work(j, &mut s))).is_err() {
                            return;
                        }
                    }
                });
            }
            drop(tx);
            let mut s = state();
            let mut pending = std::collections::BTreeMap::new();
            let mut done = 0usize;
            let mut workers_left = threads > 1;
            loop {
                while let Ok((j, result)) = rx.try_recv() {
                    pending.insert(j, result);
                }
                let before = done;
                while let Some(result) = pending.remove(&done) {
                    if let Err(e) = out.take(done, result) {
                        let (lock, cv) = &taken;
                        let _held = lock.lock().unwrap_or_else(|e| e.into_inner());
                        abort.store(true, Ordering::SeqCst);
                        cv.notify_all();
                        return Err(e);
                    }
                    done += 1;
                    let (lock, cv) = &taken;
                    *lock.lock().unwrap_or_else(|e| e.into_inner()) = done;
                    cv.notify_all();
                }
                if done > before {
                    out.caught_up();
                }
                // Take the next job when it is within the window (the
                // calling thread cannot wait for itself). A job the other
                // threads still run is then handed over after this one.
                let j = next_job.load(Ordering::SeqCst);
                if !stopped() && j < jobs && j < done + window {
                    // Another thread may take job `j` first: then look again.
                    if next_job
                        .compare_exchange(j, j + 1, Ordering::SeqCst, Ordering::SeqCst)
                        .is_ok()
                    {
                        pending.insert(j, work(j, &mut s));
                    }
                    continue;
                }
                // Nothing to run here: wait for another thread's result, or
                // end once every thread has ended and the results in order
                // are taken (a gap left by a stop stays untaken).
                if !workers_left {
                    return Ok(done);
                }
                match rx.recv() {
                    Ok((j, result)) => {
                        pending.insert(j, result);
                    }
                    Err(_) => workers_left = false,
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::thread::ThreadId;

    /// Records what it takes; fails at `fail_at`; raises `stop` after
    /// `stop_after` results.
    struct Record<'a> {
        taken: Vec<(usize, u64)>,
        batches: usize,
        fail_at: Option<usize>,
        stop_after: Option<(usize, &'a AtomicBool)>,
    }

    impl InOrder<(u64, ThreadId)> for Record<'_> {
        type Error = String;

        fn take(&mut self, index: usize, (value, _): (u64, ThreadId)) -> Result<(), String> {
            if self.fail_at == Some(index) {
                return Err(format!("failed at {index}"));
            }
            self.taken.push((index, value));
            if let Some((n, stop)) = self.stop_after
                && self.taken.len() == n
            {
                stop.store(true, Ordering::SeqCst);
            }
            Ok(())
        }

        fn caught_up(&mut self) {
            self.batches += 1;
        }
    }

    fn record<'a>() -> Record<'a> {
        Record {
            taken: Vec::new(),
            batches: 0,
            fail_at: None,
            stop_after: None,
        }
    }

    /// A job whose cost varies a lot from one to the next, so that threads
    /// finish out of order.
    fn job(j: usize) -> u64 {
        let n = 1 + (j * 7919) % 20_000;
        (0..n as u64).fold(j as u64, |a, x| a.wrapping_mul(31).wrapping_add(x))
    }

    #[test]
    fn results_come_in_job_order_for_any_thread_count() {
        let never = || false;
        let want: Vec<(usize, u64)> = (0..300).map(|j| (j, job(j))).collect();
        for threads in 1..=4 {
            for window in [1, 3, 16] {
                let ex = Executor {
                    threads,
                    window,
                    stop: &never,
                };
                let mut out = record();
                let done = ex
                    .run(
                        300,
                        || (),
                        |j, _| (job(j), std::thread::current().id()),
                        &mut out,
                    )
                    .unwrap();
                assert_eq!(done, 300);
                assert_eq!(out.taken, want, "{threads} threads, window {window}");
                assert!(out.batches >= 1 && out.batches <= 300);
            }
        }
    }

    #[test]
    fn one_thread_runs_everything_on_the_caller_with_one_state() {
        let never = || false;
        let ex = Executor {
            threads: 1,
            window: 4,
            stop: &never,
        };
        let me = std::thread::current().id();
        let states = AtomicUsize::new(0);
        let mut out = record();
        ex.run(
            50,
            || states.fetch_add(1, Ordering::SeqCst),
            |j, _| {
                assert_eq!(std::thread::current().id(), me);
                (j as u64, me)
            },
            &mut out,
        )
        .unwrap();
        assert_eq!(states.load(Ordering::SeqCst), 1);
        // One job at a time: each is taken as soon as it is done.
        assert_eq!(out.batches, 50);
    }

    #[test]
    fn no_job_starts_more_than_the_window_ahead() {
        let never = || false;
        for threads in [2, 3] {
            let window = 2;
            let taken = AtomicUsize::new(0);
            let ahead = AtomicUsize::new(0);
            struct Count<'a>(&'a AtomicUsize);
            impl InOrder<()> for Count<'_> {
                type Error = ();
                fn take(&mut self, _: usize, _: ()) -> Result<(), ()> {
                    self.0.fetch_add(1, Ordering::SeqCst);
                    Ok(())
                }
            }
            let ex = Executor {
                threads,
                window,
                stop: &never,
            };
            ex.run(
                200,
                || (),
                |j, _| {
                    let t = taken.load(Ordering::SeqCst);
                    ahead.fetch_max(j - t.min(j), Ordering::SeqCst);
                    job(j);
                },
                &mut Count(&taken),
            )
            .unwrap();
            // `taken` is read after the job started: it can only have grown
            // since the start was allowed.
            assert!(ahead.load(Ordering::SeqCst) < window, "{threads} threads");
        }
    }

    #[test]
    fn a_stop_leaves_a_prefix_taken() {
        for threads in 1..=3 {
            let stop = AtomicBool::new(false);
            let stopped = || stop.load(Ordering::SeqCst);
            let ex = Executor {
                threads,
                window: 8,
                stop: &stopped,
            };
            let mut out = record();
            out.stop_after = Some((10, &stop));
            let done = ex
                .run(
                    1000,
                    || (),
                    |j, _| (job(j), std::thread::current().id()),
                    &mut out,
                )
                .unwrap();
            assert_eq!(done, out.taken.len());
            // Jobs started before the stop lie within the window of the 10
            // taken; each other thread may have started one more.
            assert!((10..=10 + 8 + 2 * threads).contains(&done), "{done}");
            assert!(out.taken.iter().enumerate().all(|(i, (j, _))| i == *j));
        }
    }

    #[test]
    fn a_failure_to_take_stops_the_run_and_is_returned() {
        let never = || false;
        for threads in 1..=3 {
            let ex = Executor {
                threads,
                window: 4,
                stop: &never,
            };
            let mut out = record();
            out.fail_at = Some(7);
            let e = ex
                .run(
                    500,
                    || (),
                    |j, _| (job(j), std::thread::current().id()),
                    &mut out,
                )
                .unwrap_err();
            assert_eq!(e, "failed at 7");
            assert_eq!(out.taken.len(), 7);
        }
    }
}
