//! [`Workers`]: the thread pool a step may spread its force bands over,
//! passed in by the caller (the plugin passes Bevy's compute pool).

use std::fmt;
use std::sync::Arc;

/// A pool of threads that runs a batch of jobs and waits for all of them.
pub trait Workers: Send + Sync {
    /// Threads the pool runs jobs on (1 or more).
    fn threads(&self) -> usize;

    /// Runs every job, in any order and on any thread, waits for all of
    /// them, and tells whether all returned `true`.
    fn run_all<'a>(&self, jobs: Vec<Box<dyn FnOnce() -> bool + Send + 'a>>) -> bool;
}

/// Runs every job on the calling thread, in order.
#[derive(Clone, Copy, Debug, Default)]
pub struct OneThread;

impl Workers for OneThread {
    fn threads(&self) -> usize {
        1
    }

    fn run_all<'a>(&self, jobs: Vec<Box<dyn FnOnce() -> bool + Send + 'a>>) -> bool {
        jobs.into_iter().fold(true, |all, job| job() & all)
    }
}

/// Runs the jobs on `threads` scoped threads of the standard library,
/// spawned for each batch: for tools and tests without a pool of their own
/// (a long-lived pool, such as Bevy's compute pool, spawns nothing per
/// batch). In a build without threads (WebAssembly) it runs every job on
/// the calling thread, as [`OneThread`] does.
#[derive(Clone, Copy, Debug)]
pub struct ScopedThreads(pub usize);

impl Workers for ScopedThreads {
    fn threads(&self) -> usize {
        self.0.max(1)
    }

    fn run_all<'a>(&self, jobs: Vec<Box<dyn FnOnce() -> bool + Send + 'a>>) -> bool {
        if !crate::sim::team::THREADS {
            return OneThread.run_all(jobs);
        }
        let threads = self.threads();
        let mut shares: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
        for (k, job) in jobs.into_iter().enumerate() {
            shares[k % threads].push(job);
        }
        std::thread::scope(|s| {
            let handles: Vec<_> = shares
                .into_iter()
                .map(|share| s.spawn(move || OneThread.run_all(share)))
                .collect();
            handles
                .into_iter()
                .fold(true, |all, h| h.join().unwrap_or(false) & all)
        })
    }
}

/// An optional shared [`Workers`], as the step's buffers keep it: `None`
/// (the default) steps on the calling thread alone.
#[derive(Clone, Default)]
pub struct Pool(pub Option<Arc<dyn Workers>>);

/// No pool: everything on the calling thread.
static NONE: Pool = Pool(None);

impl Pool {
    /// No pool, to borrow for as long as needed.
    pub fn none() -> &'static Pool {
        &NONE
    }

    /// The pool `workers`.
    pub fn new(workers: Arc<dyn Workers>) -> Self {
        Self(Some(workers))
    }

    /// The workers, if any.
    pub fn get(&self) -> Option<&dyn Workers> {
        self.0.as_deref()
    }

    /// Threads of the pool: 1 without one.
    pub fn threads(&self) -> usize {
        self.get().map_or(1, Workers::threads)
    }
}

impl fmt::Debug for Pool {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("Pool").field(&self.threads()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_thread_runs_every_job_even_after_a_failure() {
        let mut ran = [false; 3];
        let [a, b, c] = &mut ran;
        let jobs: Vec<Box<dyn FnOnce() -> bool + Send + '_>> = vec![
            Box::new(|| {
                *a = true;
                true
            }),
            Box::new(|| {
                *b = true;
                false
            }),
            Box::new(|| {
                *c = true;
                true
            }),
        ];
        assert!(!OneThread.run_all(jobs));
        assert_eq!(ran, [true; 3]);
        let counted = std::sync::atomic::AtomicUsize::new(0);
        let jobs = (0..7)
            .map(|k| {
                let counted = &counted;
                Box::new(move || {
                    counted.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    k != 5
                }) as Box<dyn FnOnce() -> bool + Send + '_>
            })
            .collect();
        assert!(!ScopedThreads(3).run_all(jobs));
        assert_eq!(counted.into_inner(), 7);
        assert_eq!(Pool::default().threads(), 1);
        assert_eq!(Pool::new(Arc::new(OneThread)).threads(), 1);
    }
}
