//! `cargo bench --bench compare`: what a frame of cloth costs with this
//! crate's defaults and with rapier-cloth-core's, in one run, in two scenes
//! of a 1 m cloth of N × N particles:
//!
//! - **hanging** (the easy case): standing in a vertical plane, pinned at
//!   its two top corners, let go flat at rest; it hangs still;
//! - **motion** (the case a player sees): laid horizontal at 1 m, pinned at
//!   the two corners of one edge, let go; it falls and swings.
//!
//! Runners:
//!
//! - **bevy_cloth**: a headless `App` (`MinimalPlugins`, `ClothPlugin`) with
//!   every default (cotton, backward Euler, one step per 1/60 s frame); in
//!   the hanging scene sleep is off, so that the cloth steps every frame as
//!   the other does. One `App::update` is one frame, the App's own cost
//!   included; the motion table also times an empty `App` (`MinimalPlugins`
//!   alone) in the same turns and gives the cloth's cost over it.
//! - **rapier-cloth-core 0.3** (XPBD): its defaults, 4 substeps of 1/240 s
//!   per frame with 8 iterations each (`SolverSettings::default`, the
//!   substep of its README), its default material; its solver alone, no
//!   App.
//!
//! After 60 frames of warm-up, the runners are timed in turns, a block of
//! frames each, so that all see the same state of a shared, noisy machine.
//! Printed per size: the median and the range of the ms per frame, the
//! ratio of the medians, the implicit solve's mean iterations (motion) and
//! the largest structural strain (`ℓ/L − 1` of the links along the grid)
//! at the end.
//!
//! `cargo bench --bench compare -- 15 32` limits the sizes.

#[path = "common/race.rs"]
mod race;

use std::time::Duration;

use bevy::math::Vec3;

use bevy_cloth::prelude::SimSettings;
use race::{Empty, Ours, Runner, Scene, race, sizes, structural_strain, summary};
use rapier_cloth_core as rc;

/// Frames before timing starts.
const WARM_UP: usize = 60;

/// The sizes timed unless the command line names others.
const SIZES: [usize; 5] = [15, 32, 64, 128, 256];

/// rapier-cloth-core with its defaults.
struct Theirs {
    cloth: rc::Cloth,
    solver: rc::solver::Solver,
    settings: rc::solver::SolverSettings,
    n: usize,
}

impl Theirs {
    fn new(n: usize, scene: Scene) -> Self {
        let grid = rc::GridBuilder::new(n, n).size(1.0, 1.0);
        let grid = match scene {
            Scene::Hanging => grid
                .origin(rc::Vec3::new(-0.5, 2.0, 0.0))
                .axes(rc::Vec3::X, -rc::Vec3::Y),
            Scene::Motion => grid
                .origin(rc::Vec3::new(-0.5, 1.0, -0.5))
                .axes(rc::Vec3::X, rc::Vec3::Z),
        };
        let mesh = grid.build().expect("valid grid");
        let mut cloth = rc::Cloth::new(mesh, rc::ClothMaterial::default()).expect("valid cloth");
        for i in [0, n as u32 - 1] {
            let at = cloth.positions()[i as usize];
            cloth.pin(i, at).expect("a particle of the grid");
        }
        Self {
            cloth,
            solver: rc::solver::Solver::new(),
            settings: rc::solver::SolverSettings::default(),
            n,
        }
    }
}

impl Runner for Theirs {
    fn frame(&mut self) {
        for _ in 0..4 {
            self.solver
                .step(
                    &mut self.cloth,
                    1.0 / 240.0,
                    rc::Vec3::new(0.0, -9.81, 0.0),
                    &self.settings,
                )
                .expect("a valid step");
        }
    }

    fn strain(&self) -> f32 {
        let x = self.cloth.positions();
        structural_strain(self.n, 1.0 / (self.n - 1) as f32, |p| {
            Vec3::new(x[p].x, x[p].y, x[p].z)
        })
    }
}

/// This crate's cloth, counting the implicit solve's iterations.
struct Counted {
    ours: Ours,
    iterations: u64,
    frames: u64,
}

impl Runner for Counted {
    fn frame(&mut self) {
        self.ours.frame();
        self.iterations += self.ours.iterations() as u64;
        self.frames += 1;
    }

    fn strain(&self) -> f32 {
        self.ours.strain()
    }
}

fn main() {
    let sizes = sizes(&SIZES);
    hanging(&sizes);
    println!();
    motion(&sizes);
}

/// The hanging scene's table.
fn hanging(sizes: &[usize]) {
    println!("Hanging (let go at rest, sleep off):\n");
    println!(
        "| N × N | bevy_cloth ms/frame (range) | rapier-cloth-core ms/frame (range) | ratio | strain bevy_cloth | strain rapier |"
    );
    println!("|---|---|---|---|---|---|");
    for &n in sizes {
        // Enough frames for a stable median within about a minute a size.
        let frames = match n {
            0..=32 => 300,
            33..=64 => 120,
            65..=128 => 40,
            _ => 16,
        };
        let mut ours = Ours::new(n);
        // rapier-cloth-core takes ~0.2 s a frame at 128 × 128: time it up
        // to 128 only.
        let mut theirs = (n <= 128).then(|| Theirs::new(n, Scene::Hanging));
        for _ in 0..WARM_UP {
            ours.frame();
            if let Some(t) = theirs.as_mut() {
                t.frame();
            }
        }
        let block = (frames / 8).max(1);
        let (mut ours_ms, theirs_ms) = match theirs.as_mut() {
            Some(t) => {
                let mut times = race(&mut [&mut ours, t], frames, block);
                let theirs_ms = times.pop();
                (times.pop().unwrap(), theirs_ms)
            }
            None => (race(&mut [&mut ours], frames, block).remove(0), None),
        };
        let (a, a_lo, a_hi) = summary(&mut ours_ms);
        let ours_strain = ours.strain();
        match (theirs_ms, theirs) {
            (Some(mut ms), Some(t)) => {
                let (b, b_lo, b_hi) = summary(&mut ms);
                println!(
                    "| {n} | {a:.3} ({a_lo:.3}–{a_hi:.3}) | {b:.2} ({b_lo:.2}–{b_hi:.2}) | {:.0}× | {:.2} % | {:.2} % |",
                    b / a,
                    100.0 * ours_strain,
                    100.0 * t.strain()
                );
            }
            _ => println!(
                "| {n} | {a:.3} ({a_lo:.3}–{a_hi:.3}) | — | — | {:.2} % | — |",
                100.0 * ours_strain
            ),
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The motion scene's table: frames 60–360 (60–180 at 256 × 256), every
/// default, beside an empty App and rapier-cloth-core (up to 64 × 64).
fn motion(sizes: &[usize]) {
    println!(
        "Motion (laid horizontal, pinned at two corners of one edge, let go; every default):\n"
    );
    println!(
        "| N × N | empty app ms | bevy_cloth ms/frame (range) | over the empty app | iterations | rapier-cloth-core ms/frame (range) | ratio | strain bevy_cloth | strain rapier |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for &n in sizes {
        let frames = if n <= 128 { 300 } else { 120 };
        let ours = Ours::in_scene(n, Scene::Motion, SimSettings::default());
        let mut ours = Counted {
            ours,
            iterations: 0,
            frames: 0,
        };
        let mut empty = Empty::new();
        // rapier-cloth-core takes ~60 ms a frame at 64 × 64.
        let mut theirs = (n <= 64).then(|| Theirs::new(n, Scene::Motion));
        for _ in 0..WARM_UP {
            ours.frame();
            empty.frame();
            if let Some(t) = theirs.as_mut() {
                t.frame();
            }
        }
        (ours.iterations, ours.frames) = (0, 0);
        let block = (frames / 10).max(1);
        let mut times = match theirs.as_mut() {
            Some(t) => race(&mut [&mut ours, &mut empty, t], frames, block),
            None => race(&mut [&mut ours, &mut empty], frames, block),
        };
        let (a, a_lo, a_hi) = summary(&mut times[0]);
        let (e, _, _) = summary(&mut times[1]);
        let iterations = ours.iterations as f64 / ours.frames.max(1) as f64;
        let ours_strain = ours.strain();
        let (theirs_cells, ratio, theirs_strain) = match (times.get_mut(2), theirs) {
            (Some(ms), Some(t)) => {
                let (b, b_lo, b_hi) = summary(ms);
                (
                    format!("{b:.2} ({b_lo:.2}–{b_hi:.2})"),
                    format!("{:.0}×", b / a),
                    format!("{:.2} %", 100.0 * t.strain()),
                )
            }
            _ => ("—".into(), "—".into(), "—".into()),
        };
        println!(
            "| {n} | {e:.3} | {a:.3} ({a_lo:.3}–{a_hi:.3}) | {:.3} | {iterations:.1} | {theirs_cells} | {ratio} | {:.2} % | {theirs_strain} |",
            a - e,
            100.0 * ours_strain,
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}
