//! `cargo bench --bench contention`: what a 64×64 cloth's frame costs
//! while two other threads of the process are busy, as a game's render
//! extraction, AI or physics are, against the same frame with the cores
//! idle.
//!
//! **Scene.** The hanging cloth of the `compare` bench (1 m, pinned at its
//! two top corners, released flat, every default but sleep), with the
//! implicit solve's helper thread on (the default) and off. The busy
//! threads spin on arithmetic while a runner's block runs under load and
//! sleep otherwise. After 60 frames of warm-up, each of [`ROUNDS`] rounds
//! rests the cores for [`REST`] (longer than a late helper is left alone,
//! so that the idle frames run as an idle game's do), runs each cloth
//! [`WARM_UP`] frames untimed, then times the runs with the helper on and
//! off in turns of 20 frames with the cores idle, then the same with the
//! busy threads on. A round's ratio is its loaded median
//! over its idle median, idle and loaded frames being timed seconds apart,
//! so that a change in what else the machine runs shifts both. Printed:
//! the median and range of the ms per frame over all rounds, and the
//! median and range of the rounds' ratios.
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
/// Rounds of idle then loaded frames.
const ROUNDS: usize = 6;
/// Frames timed per run, phase and round.
const FRAMES: usize = 100;
/// Rest before each round: longer than a late helper is left alone (4 s).
const REST: Duration = Duration::from_millis(4500);

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
        "| N×N | helper | idle ms (median, range) | two busy threads ms (median, range) | loaded / idle (median of {ROUNDS} rounds, range) |"
    );
    println!("|---|---|---|---|---|");
    for n in sizes(&[32, 64, 128]) {
        let mut runs: Vec<Loaded> = [true, false]
            .into_iter()
            .map(|helper| {
                let mut settings = SimSettings::default();
                settings.sleep.enabled = false;
                settings.implicit.helper_thread = helper;
                Loaded {
                    cloth: Ours::with_settings(n, settings),
                    on: busy.on.clone(),
                    loaded: false,
                }
            })
            .collect();
        for run in &mut runs {
            for _ in 0..WARM_UP {
                run.frame();
            }
        }
        // Per run: idle and loaded frames, and each round's ratio.
        let mut idle = vec![Vec::new(); runs.len()];
        let mut load = vec![Vec::new(); runs.len()];
        let mut ratios = vec![Vec::new(); runs.len()];
        for _ in 0..ROUNDS {
            std::thread::sleep(REST);
            for run in &mut runs {
                run.loaded = false;
                for _ in 0..WARM_UP {
                    run.frame();
                }
            }
            let mut medians = Vec::new();
            for loaded in [false, true] {
                for run in &mut runs {
                    run.loaded = loaded;
                }
                let mut refs: Vec<&mut dyn Runner> =
                    runs.iter_mut().map(|r| r as &mut dyn Runner).collect();
                let mut times = race(&mut refs, FRAMES, 20);
                busy.on.store(false, Ordering::Relaxed);
                let into = if loaded { &mut load } else { &mut idle };
                for (k, t) in times.iter_mut().enumerate() {
                    into[k].extend_from_slice(t);
                    medians.push(summary(t).0);
                }
            }
            for (k, ratio) in ratios.iter_mut().enumerate() {
                ratio.push(medians[runs.len() + k] / medians[k]);
            }
        }
        for (k, helper) in ["on", "off"].into_iter().enumerate() {
            let (i, i_lo, i_hi) = summary(&mut idle[k]);
            let (l, l_lo, l_hi) = summary(&mut load[k]);
            let (r, r_lo, r_hi) = summary(&mut ratios[k]);
            println!(
                "| {n}×{n} | {helper} | {i:.2} ({i_lo:.2}–{i_hi:.2}) | {l:.2} ({l_lo:.2}–{l_hi:.2}) | {r:.2}× ({r_lo:.2}–{r_hi:.2}) |"
            );
        }
    }
}
