//! Bevy's compute pool for the step: [`ComputePool`], the [`Workers`] a
//! step spreads its force bands over.
//!
//! What it may import: Bevy's task pools and `sim`'s workers.

use std::sync::Arc;

use bevy::tasks::ComputeTaskPool;

use crate::sim::workers::{Pool, Workers};

/// Bevy's compute task pool as the [`Workers`] a step spreads its force
/// bands over: what the plugin passes to every step, and what a headless
/// caller of [`step_guarded`](crate::sim::guard::step_guarded) can give its buffers with
/// [`StepBuffers::with_workers`](crate::sim::integrate::StepBuffers::with_workers).
#[derive(Clone, Copy, Debug)]
pub struct ComputePool(pub &'static ComputeTaskPool);

impl Workers for ComputePool {
    fn threads(&self) -> usize {
        self.0.thread_num()
    }

    fn run_all<'a>(&self, jobs: Vec<Box<dyn FnOnce() -> bool + Send + 'a>>) -> bool {
        self.0
            .scope(|s| {
                for job in jobs {
                    s.spawn(async move { job() });
                }
            })
            .into_iter()
            .all(|ok| ok)
    }
}

/// The compute pool, once Bevy has made one, as a step's [`Pool`].
pub(crate) fn compute_pool(pool: &mut Pool) -> &Pool {
    if pool.0.is_none()
        && let Some(compute) = ComputeTaskPool::try_get()
    {
        *pool = Pool::new(Arc::new(ComputePool(compute)));
    }
    pool
}
