//! `cargo bench --bench contention`: what a 64×64 cloth's frame costs
//! while two other threads of the process are busy, as a game's render
//! extraction, AI or physics are, against the same frame with the cores
//! idle.
//!
//! **Scene.** The hanging cloth of the `compare` bench (1 m, pinned at its
//! two top corners, released flat, every default but sleep), with the
//! implicit solve's helper thread on (the default) and off. The busy
//! threads spin on arithmetic while a runner's block runs under load and
//! sleep otherwise. After 60 frames of warm-up, the runs with the helper on
//! and off are timed in turns of 20 frames with the cores idle, then the
//! same with the busy threads on (a late helper is left alone for up to
//! 4 s, which would reach into idle turns taken in between). Printed: the
//! median and range of the ms per frame, and loaded over idle.
//!
//! `cargo bench --bench contention -- 32 64 128` sets the sizes.

#[path = "common/race.rs"]
mod race;

use std::hint::black_box;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use bevy_cloth::prelude::*;
use race::{Ours, Runner, race, sizes, summary};

/// Frames before timing starts.
const WARM_UP: usize = 60;
/// Frames timed per run.
const FRAMES: usize = 600;

/// Two threads that spin while `on` is set and sleep otherwise.
struct Busy {
    on: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Busy {
    fn start(count: usize) -> Self {
        let on = Arc::new(AtomicBool::new(false));
        let stop = Arc::new(AtomicBool::new(false));
        let threads = (0..count)
            .map(|k| {
                let (on, stop) = (on.clone(), stop.clone());
                std::thread::spawn(move || {
                    let mut x = k as f64 + 1.0;
                    while !stop.load(Ordering::Relaxed) {
                        if on.load(Ordering::Relaxed) {
                            for _ in 0..1000 {
                                x = black_box(x * 1.000_001 + 1e-9);
                            }
                        } else {
                            std::thread::sleep(Duration::from_micros(200));
                        }
                    }
                    black_box(x);
                })
            })
            .collect();
        Self { on, stop, threads }
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A cloth run, with the busy threads on or off during its frames.
struct Loaded {
    cloth: Ours,
    on: Arc<AtomicBool>,
    loaded: bool,
}

impl Runner for Loaded {
    fn frame(&mut self) {
        self.on.store(self.loaded, Ordering::Relaxed);
        self.cloth.frame();
    }

    fn strain(&self) -> f32 {
        self.cloth.strain()
    }
}

fn main() {
    let busy = Busy::start(2);
    println!(
        "| N×N | helper | idle ms (median, range) | two busy threads ms (median, range) | loaded / idle |"
    );
    println!("|---|---|---|---|---|");
    for n in sizes(&[32, 64, 128]) {
        let mut runs: Vec<Loaded> = [(true, false), (false, false), (true, true), (false, true)]
            .into_iter()
            .map(|(helper, loaded)| {
                let mut settings = SimSettings::default();
                settings.sleep.enabled = false;
                settings.implicit.helper_thread = helper;
                Loaded {
                    cloth: Ours::with_settings(n, settings),
                    on: busy.on.clone(),
                    loaded,
                }
            })
            .collect();
        for run in &mut runs {
            for _ in 0..WARM_UP {
                run.frame();
            }
        }
        let (idle, loaded) = runs.split_at_mut(2);
        let mut times = Vec::new();
        for phase in [idle, loaded] {
            let mut refs: Vec<&mut dyn Runner> =
                phase.iter_mut().map(|r| r as &mut dyn Runner).collect();
            times.extend(race(&mut refs, FRAMES, 20));
        }
        busy.on.store(false, Ordering::Relaxed);
        for (k, helper) in [(0, "on"), (1, "off")] {
            let (idle, i_lo, i_hi) = summary(&mut times[k]);
            let (load, l_lo, l_hi) = summary(&mut times[k + 2]);
            println!(
                "| {n}×{n} | {helper} | {idle:.2} ({i_lo:.2}–{i_hi:.2}) | {load:.2} ({l_lo:.2}–{l_hi:.2}) | {:.2}× |",
                load / idle
            );
        }
    }
}
