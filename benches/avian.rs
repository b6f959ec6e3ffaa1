//! `cargo bench --bench avian --features avian`: what the avian bridge
//! costs a cloth among many avian colliders.
//!
//! **Scene.** A 1 m, 32 × 32 cloth dropped onto five balls (0.12 m) under
//! it, and 195 more avian colliders (balls and boxes) spread 3–10 m away
//! around it, all static, in a headless `App` with avian's plugins:
//!
//! - **bridge**: `ClothAvianPlugin`; all 200 colliders are avian
//!   colliders, the five balls among them;
//! - **ClothColliders**: no bridge; the five balls are `ClothCollider`s,
//!   the 195 others avian colliders as before (avian's own cost is the same
//!   in both).
//!
//! One `App::update` is one 1/60 s frame. The two apps are dropped
//! together, run 40 frames (the cloth lands on the balls), then are timed
//! in turns, a block of frames each, while the cloth drapes. Printed: the
//! median and range of the ms per frame of each, and their ratio.

#[path = "common/race.rs"]
mod race;

use avian3d::prelude::*;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::plugin::bridges::avian::ClothAvianPlugin;
use bevy_cloth::prelude::*;
use race::{Runner, race, summary};

/// The five balls under the cloth: centres (m), radius 0.12 m.
const NEAR: [Vec3; 5] = [
    Vec3::new(0.0, 0.5, 0.0),
    Vec3::new(0.3, 0.45, 0.3),
    Vec3::new(-0.3, 0.45, 0.3),
    Vec3::new(0.3, 0.45, -0.3),
    Vec3::new(-0.3, 0.45, -0.3),
];
const RADIUS: f32 = 0.12;

struct Scene {
    app: App,
    cloth: Entity,
}

impl Scene {
    fn new(bridge: bool) -> Self {
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            TransformPlugin,
            bevy::asset::AssetPlugin::default(),
            PhysicsPlugins::default(),
            ClothPlugin::default(),
        ))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
        // Timed stepping: a cloth that comes to rest keeps stepping.
        let mut settings = SimSettings::default();
        settings.sleep.enabled = false;
        app.insert_resource(ClothSettingsDefaults(settings));
        if bridge {
            app.add_plugins(ClothAvianPlugin::default());
        }
        app.finish();
        app.update();
        let world = app.world_mut();
        for at in NEAR {
            let at = Transform::from_translation(at);
            if bridge {
                world.spawn((RigidBody::Static, Collider::sphere(RADIUS), at));
            } else {
                world.spawn((ClothCollider::sphere(RADIUS), at));
            }
        }
        // 195 far colliders on rings 3–10 m out, balls and boxes in turn.
        for k in 0..195 {
            let angle = k as f32 * 2.399;
            let distance = 3.0 + 7.0 * (k as f32 / 195.0);
            let at = Transform::from_xyz(distance * angle.cos(), 0.3, distance * angle.sin());
            let collider = if k % 2 == 0 {
                Collider::sphere(0.3)
            } else {
                Collider::cuboid(0.5, 0.6, 0.5)
            };
            world.spawn((RigidBody::Static, collider, at));
        }
        let cloth = ClothBuilder::new(32, 32)
            .size(1.0, 1.0)
            .position(Vec3::new(0.0, 0.8, 0.0))
            .build()
            .expect("valid");
        let cloth = world.spawn(cloth).id();
        Self { app, cloth }
    }
}

impl Runner for Scene {
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
    let mut bridge = Scene::new(true);
    let mut own = Scene::new(false);
    for _ in 0..40 {
        bridge.frame();
        own.frame();
    }
    let mut times = race(&mut [&mut bridge, &mut own], 400, 25);
    let (b, b_lo, b_hi) = summary(&mut times[0]);
    let (o, o_lo, o_hi) = summary(&mut times[1]);
    println!("| 32 × 32 cloth on 5 balls, 195 far colliders | ms/frame (range) | strain |");
    println!("|---|---|---|");
    println!(
        "| 200 avian colliders, bridge | {b:.3} ({b_lo:.3}–{b_hi:.3}) | {:.2} % |",
        100.0 * bridge.strain()
    );
    println!(
        "| 5 ClothColliders, 195 avian colliders | {o:.3} ({o_lo:.3}–{o_hi:.3}) | {:.2} % |",
        100.0 * own.strain()
    );
    println!("ratio of the medians: {:.2}×", b / o);
}
