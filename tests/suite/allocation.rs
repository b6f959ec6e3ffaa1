//! A cloth step allocates nothing once warm, even while a crease edits rest
//! lengths every step (which rebuilds the explicit force streams).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use bevy_cloth::lab::accuracy::scene;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::integrate::StepBuffers;
use bevy_cloth::sim::step::step_cloth;

/// Counts the allocations made on a thread while it is counting.
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

// SAFETY: every call is passed on to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as for `alloc`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Allocations on this thread during `f`.
fn allocations(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.load(Ordering::Relaxed) - before
}

#[test]
fn steps_under_a_changing_crease_allocate_nothing() {
    for integrator in Integrator::ALL {
        let dt = if integrator.is_implicit() {
            1.0 / 60.0
        } else {
            1e-4
        };
        let mut cloth = scene(15);
        let settings = ClothSettings::default().with_integrator(integrator, 1);
        let mut buffers = StepBuffers::new(cloth.particles.len());
        let mut step = |cloth: &mut ClothBundle, k: usize| {
            // A fold tightening: some Type 2 rest lengths shrink each step.
            for l in cloth.connections.bend.iter_mut().skip(k % 3).step_by(3) {
                l.rest_length *= 0.999;
            }
            step_cloth(
                &mut cloth.particles,
                &cloth.connections,
                &settings,
                &[],
                &mut buffers,
                dt,
            );
        };
        for k in 0..3 {
            step(&mut cloth, k);
        }
        let count = allocations(|| {
            for k in 3..23 {
                step(&mut cloth, k);
            }
        });
        assert_eq!(count, 0, "{integrator:?}: {count} allocations in 20 steps");
        assert!(cloth.particles.is_finite());
    }
}

/// A 48×48 implicit cloth, whose solve shares its iterations with the
/// helper thread, allocates nothing once warm either.
#[test]
fn implicit_steps_shared_with_the_helper_allocate_nothing() {
    for integrator in [Integrator::BackwardEuler, Integrator::Bdf2] {
        let mut cloth = scene(48);
        let settings = ClothSettings::default().with_integrator(integrator, 1);
        let mut buffers = StepBuffers::new(cloth.particles.len());
        let mut step = |cloth: &mut ClothBundle| {
            step_cloth(
                &mut cloth.particles,
                &cloth.connections,
                &settings,
                &[],
                &mut buffers,
                1.0 / 60.0,
            );
        };
        // Warm: buffers sized, the helper spawned, sharing timed both ways.
        for _ in 0..4 {
            step(&mut cloth);
        }
        let count = allocations(|| {
            for _ in 0..10 {
                step(&mut cloth);
            }
        });
        assert_eq!(count, 0, "{integrator:?}: {count} allocations in 10 steps");
        assert!(cloth.particles.is_finite());
    }
}
