//! `cargo bench --bench motion`: what a cloth in motion costs, frame by
//! frame, and how many iterations its implicit solve takes.
//!
//! **Scenes**, every default, sleep and level of detail aside (there is no
//! camera, and a moving cloth does not sleep), in a headless `App` with
//! meshes; one `App::update` is one 1/60 s frame:
//! - `grid N`: a 1 m, N×N cotton sheet let go horizontal, pinned at two
//!   corners, falling and swinging for 3 s (N = 32, 64, 128, 256);
//! - `disc`: a 1 m mesh disc of 3,997 particles let go horizontal, pinned
//!   at two opposite points of its rim, for 3 s;
//! - `gusty 64`: the 64×64 sheet pinned along an edge in a 15 m/s wind
//!   gusting by ±40 %, for 3 s.
//!
//! Printed per scene: the median, 95th percentile and largest ms per
//! frame, the mean and largest iteration count of the solve, the frames
//! that ended at the iteration cap, the largest structural strain over
//! the run, and the heap the cloth holds at the end of it, in bytes a
//! particle (everything allocated since just before the spawn and not yet
//! freed: its components, its solver's buffers, its render mesh). `cargo
//! bench --bench motion -- 32 64` limits the grid sizes.

mod common;
#[path = "common/race.rs"]
mod race;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use bevy::prelude::*;
use bevy_cloth::plugin::spawn::disc_mesh;
use bevy_cloth::prelude::*;
use common::headless;
use race::sizes;

/// Counts the bytes allocated and not yet freed.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is passed on to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract is the system allocator's.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_add(new_size, Ordering::Relaxed);
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as for `alloc`.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Grid sizes timed unless the command line names others.
const SIZES: [usize; 4] = [32, 64, 128, 256];

/// Frames per run: 3 s.
const FRAMES: usize = 180;

/// One run's figures.
struct Run {
    ms: Vec<f64>,
    iterations: Vec<u32>,
    cap: u32,
    strain: f32,
    /// Heap held at the end for each particle, bytes.
    bytes_per_particle: f64,
}

/// Runs the cloth `build` makes for 3 s in an app with every default
/// (`wind` blowing).
fn run<B: Bundle>(build: impl FnOnce() -> B, wind: Option<Wind>) -> Run {
    let mut app = headless(ClothSettings::default());
    if let Some(wind) = wind {
        app.insert_resource(ClothWind(wind));
    }
    let cap = app
        .world()
        .resource::<ClothSettingsDefaults>()
        .0
        .implicit
        .max_iterations;
    let mut out = Run {
        ms: Vec::with_capacity(FRAMES),
        iterations: Vec::with_capacity(FRAMES),
        cap,
        strain: 0.0,
        bytes_per_particle: 0.0,
    };
    // The app's own heap, settled, before the cloth exists.
    app.update();
    app.update();
    let before = LIVE.load(Ordering::Relaxed);
    let e = app.world_mut().spawn(build()).id();
    app.update();
    for _ in 0..FRAMES {
        let start = Instant::now();
        app.update();
        out.ms.push(start.elapsed().as_secs_f64() * 1e3);
        let stats = app.world().get::<ClothStats>(e).expect("a cloth");
        assert!(stats.finite, "the cloth blew up");
        out.iterations.push(stats.solver_iterations);
        out.strain = out.strain.max(stats.max_strain);
    }
    let held = LIVE.load(Ordering::Relaxed).saturating_sub(before);
    let particles = app.world().get::<ClothParticles>(e).expect("a cloth").len();
    out.bytes_per_particle = held as f64 / particles as f64;
    out
}

fn report(name: &str, mut run: Run) {
    run.ms.sort_by(f64::total_cmp);
    let at = |q: f64| run.ms[((run.ms.len() - 1) as f64 * q).round() as usize];
    let mean = run.iterations.iter().sum::<u32>() as f64 / run.iterations.len() as f64;
    let most = run.iterations.iter().max().copied().unwrap_or(0);
    let capped = run.iterations.iter().filter(|&&k| k >= run.cap).count();
    println!(
        "| {name} | {:.2} | {:.2} | {:.2} | {mean:.1} | {most} | {capped} | {:.1} % | {:.0} |",
        at(0.5),
        at(0.95),
        at(1.0),
        100.0 * run.strain,
        run.bytes_per_particle
    );
}

/// A 1 m `n`×`n` cotton sheet let go horizontal at y = 2 m, pinned at two
/// corners (or along an edge).
fn sheet(n: usize, edge: bool) -> ClothBundle {
    let builder = ClothBuilder::new(n as u32, n as u32)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 2.0, 0.0));
    let builder = if edge {
        builder.pin_edge(GridEdge::Top)
    } else {
        builder
            .pin_corner(GridCorner::TopLeft)
            .pin_corner(GridCorner::TopRight)
    };
    builder.build().expect("valid")
}

fn main() {
    println!(
        "| scene | median ms | p95 ms | max ms | mean iterations | most | at the cap | strain | heap bytes a particle |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in sizes(&SIZES) {
        report(&format!("grid {n}×{n}"), run(|| sheet(n, false), None));
    }
    let disc = || {
        ClothBuilder::from_mesh(&disc_mesh(0.5, 36))
            .position(Vec3::new(0.0, 2.0, 0.0))
            .pin_where(|x| x.z.abs() < 0.01 && x.x.abs() > 0.49)
            .build()
            .expect("valid")
    };
    let particles = disc().particles.len();
    report(&format!("disc, {particles} particles"), run(disc, None));
    let gusty = Wind {
        velocity: Vec3::new(0.0, 0.0, 15.0),
        gust_amplitude: 0.4,
        gust_frequency: 0.5,
        ..default()
    };
    report(
        "grid 64×64, 15 m/s gusts",
        run(|| sheet(64, true), Some(gusty)),
    );
}
