//! `cargo bench --bench rapier --features rapier`: what a frame of hanging
//! cloth costs with this crate's defaults and with bevy_rapier3d's own
//! soft-body cloth at its defaults, in one run, each in a headless Bevy
//! `App`.
//!
//! **Scene.** A 1 m cloth of N × N particles standing in a vertical plane,
//! pinned at its two top corners, let go flat at rest.
//!
//! - **bevy_cloth**: `MinimalPlugins` and `ClothPlugin` with every default
//!   (cotton, backward Euler, one step per 1/60 s frame) but sleep, which is
//!   off so that the cloth steps every frame as rapier's does.
//! - **bevy_rapier3d 0.37**: `MinimalPlugins`, `TransformPlugin` and
//!   `RapierPhysicsPlugin` with every default (its variable timestep of at
//!   most 1/60 s, one substep), the cloth a `SoftBody::cloth` with the
//!   builder's defaults, its two top corners in `pinned_particles`.
//!
//! Both apps advance 1/60 s per `App::update`, the App's own cost included.
//! After 60 frames of warm-up, the two are timed in turns, a block of
//! frames each. Printed per size: the median and the range of the ms per
//! frame, the ratio of the medians, and the largest structural strain
//! (`ℓ/L − 1` of the links along the grid) at the end.
//!
//! `cargo bench --bench rapier --features rapier -- 15 32` limits the sizes.

#[path = "common/race.rs"]
mod race;

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_rapier3d::prelude::*;
use race::{Ours, Runner, race, sizes, structural_strain, summary};

/// Frames before timing starts.
const WARM_UP: usize = 60;

/// The sizes timed unless the command line names others.
const SIZES: [usize; 4] = [15, 32, 64, 128];

/// bevy_rapier3d's soft-body cloth with its defaults.
struct Theirs {
    app: App,
    /// The rapier context's entity.
    context: Entity,
    cloth: Entity,
    n: usize,
}

impl Theirs {
    fn new(n: usize) -> Self {
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            TransformPlugin,
            RapierPhysicsPlugin::<NoUserData>::default(),
        ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
            1.0 / 60.0,
        )));
        app.finish();
        app.update();
        // Particle (i, j) at `origin + i du + j dv` is number i n + j: the
        // top corners are (0, 0) and (n − 1, 0).
        let h = 1.0 / (n - 1) as f32;
        let cloth = SoftBody::cloth(
            Vec3::new(-0.5, 2.0, 0.0),
            Vec3::X * h,
            Vec3::NEG_Y * h,
            n,
            n,
        )
        .map(|b| b.pinned_particles([0, ((n - 1) * n) as u32]));
        let cloth = app.world_mut().spawn((Transform::IDENTITY, cloth)).id();
        app.update();
        let world = app.world_mut();
        let context = world
            .query_filtered::<Entity, With<RapierRigidBodySet>>()
            .single(world)
            .expect("one rapier context");
        Self {
            app,
            context,
            cloth,
            n,
        }
    }

    /// The particles' positions (m), or none if the cloth is gone.
    fn positions(&self) -> Option<Vec<Vec3>> {
        let set = self.app.world().get::<RapierRigidBodySet>(self.context)?;
        Some(set.soft_body_particle_positions(self.cloth)?.collect())
    }
}

impl Runner for Theirs {
    fn frame(&mut self) {
        self.app.update();
    }

    fn strain(&self) -> f32 {
        self.positions().map_or(f32::NAN, |x| {
            structural_strain(self.n, 1.0 / (self.n - 1) as f32, |p| x[p])
        })
    }
}

fn main() {
    println!(
        "| N × N | bevy_cloth ms/frame (range) | bevy_rapier3d soft body ms/frame (range) | ratio | strain bevy_cloth | strain rapier |"
    );
    println!("|---|---|---|---|---|---|");
    for n in sizes(&SIZES) {
        let frames = match n {
            0..=32 => 300,
            33..=64 => 120,
            _ => 40,
        };
        let mut ours = Ours::new(n);
        let mut theirs = Theirs::new(n);
        let count = theirs.positions().map_or(0, |x| x.len());
        assert_eq!(count, n * n, "rapier's cloth has N × N particles");
        for _ in 0..WARM_UP {
            ours.frame();
            theirs.frame();
        }
        let block = (frames / 8).max(1);
        let mut times = race(&mut [&mut ours, &mut theirs], frames, block);
        let (b, b_lo, b_hi) = summary(&mut times[1]);
        let (a, a_lo, a_hi) = summary(&mut times[0]);
        println!(
            "| {n} | {a:.3} ({a_lo:.3}–{a_hi:.3}) | {b:.2} ({b_lo:.2}–{b_hi:.2}) | {:.1}× | {:.2} % | {:.1} % |",
            b / a,
            100.0 * ours.strain(),
            100.0 * theirs.strain()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}
