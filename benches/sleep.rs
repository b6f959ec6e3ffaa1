//! `cargo bench --bench sleep`: what a frame of a cloth at rest costs
//! awake (sleep off, the cloth keeps stepping) and asleep (the default).
//!
//! **Scene.** An N × N, 1 m cotton sheet let go 1 cm over a floor
//! (`ClothCollider::plane`, friction 0.8), every other default, in a headless
//! `App` with meshes: one `App::update` is one 1/60 s frame with the mesh
//! sync. Both Apps run until the sheet is at rest (the sleeping one until it
//! sleeps), then are timed in turns of 20 frames so that both see the same
//! state of a shared, noisy machine, with a third App that has the floor and
//! no cloth (the frame's cost without any cloth). Printed per size: the
//! median and the range of the ms per frame of each, and what the sleeping
//! cloth adds to the empty frame as a share of what the awake one adds.
//!
//! `cargo bench --bench sleep -- 32 64` limits the sizes.

mod common;
#[path = "common/race.rs"]
mod race;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::headless;
use race::{Runner, race, sizes, summary};

/// The sizes timed unless the command line names others.
const SIZES: [usize; 3] = [32, 64, 128];

/// Frames timed per App.
const FRAMES: usize = 600;

/// A sheet on the floor, sleeping or kept awake, or the floor alone.
struct Sheet {
    app: App,
    cloth: Entity,
}

impl Sheet {
    fn empty() -> Self {
        let mut app = headless(ClothSettings::default());
        app.world_mut().spawn((
            ClothCollider::plane().with_friction(0.8),
            Transform::default(),
        ));
        let cloth = app.world_mut().spawn_empty().id();
        app.update();
        Self { app, cloth }
    }

    fn new(n: usize, sleep: bool) -> Self {
        let mut settings = ClothSettings::default();
        settings.sleep.enabled = sleep;
        let mut app = headless(settings);
        app.world_mut().spawn((
            ClothCollider::plane().with_friction(0.8),
            Transform::default(),
        ));
        let cloth = ClothBuilder::new(n as u32, n as u32)
            .size(1.0, 1.0)
            .position(Vec3::new(0.0, 0.01, 0.0))
            .build()
            .expect("valid");
        let cloth = app.world_mut().spawn(cloth).id();
        let mut sheet = Self { app, cloth };
        for _ in 0..1800 {
            sheet.frame();
            let stats = sheet.app.world().get::<ClothStats>(cloth).expect("a cloth");
            let asleep = sheet.app.world().get::<ClothSleep>(cloth).expect("a cloth");
            if stats.resting && asleep.is_asleep() == sleep {
                return sheet;
            }
        }
        panic!("the {n}×{n} sheet never came to rest");
    }
}

impl Runner for Sheet {
    fn frame(&mut self) {
        self.app.update();
    }

    fn strain(&self) -> f32 {
        self.app
            .world()
            .get::<ClothStats>(self.cloth)
            .map_or(f32::NAN, |s| s.max_strain)
    }
}

fn main() {
    println!(
        "| N×N | no cloth ms (median, range) | awake ms | asleep ms | asleep / awake, cloth's share |"
    );
    println!("|---|---|---|---|---|");
    for n in sizes(&SIZES) {
        let mut awake = Sheet::new(n, false);
        let mut asleep = Sheet::new(n, true);
        let mut empty = Sheet::empty();
        let mut times = race(&mut [&mut awake, &mut asleep, &mut empty], FRAMES, 20);
        assert!(
            asleep
                .app
                .world()
                .get::<ClothSleep>(asleep.cloth)
                .is_some_and(ClothSleep::is_asleep),
            "it slept throughout"
        );
        let (a, a_lo, a_hi) = summary(&mut times[0]);
        let (s, s_lo, s_hi) = summary(&mut times[1]);
        let (e, e_lo, e_hi) = summary(&mut times[2]);
        println!(
            "| {n}×{n} | {e:.4} ({e_lo:.4}–{e_hi:.4}) | {a:.3} ({a_lo:.3}–{a_hi:.3}) | {s:.4} ({s_lo:.4}–{s_hi:.4}) | {:.1} % |",
            100.0 * (s - e).max(0.0) / (a - e)
        );
    }
}
