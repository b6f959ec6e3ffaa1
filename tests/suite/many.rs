//! Many cloths in one app step as each would alone. On a pool of one
//! thread (a 2-core machine's default) the calling thread and the pool's
//! thread share the cloths; this binary holds one test, so that it alone
//! sets up Bevy's process-wide pools, with one compute thread.

use bevy::app::{TaskPoolOptions, TaskPoolPlugin, TaskPoolThreadAssignmentPolicy};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::wind::Wind;

/// An app whose compute pool has one thread, and whose every `update()`
/// after the first runs one 60 Hz fixed step.
fn app() -> App {
    let mut options = TaskPoolOptions::default();
    options.compute = TaskPoolThreadAssignmentPolicy {
        min_threads: 1,
        max_threads: 1,
        ..options.compute
    };
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(TaskPoolPlugin {
            task_pool_options: options,
        }),
        TransformPlugin,
        ClothPlugin::default(),
    ))
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
    .insert_resource(ClothWind(Wind {
        velocity: Vec3::new(6.0, 0.0, 2.0),
        gust_amplitude: 0.5,
        ..default()
    }));
    app.update();
    app
}

/// Cloth `k` of the scene: sizes from 3×3 to 56×56 (one large enough to
/// share its solve with the helper thread), each pinned along its top edge
/// at its own place.
fn cloth(k: usize) -> ClothBundle {
    let n = [3, 9, 15, 24, 56, 12][k];
    ClothBuilder::new(n, n)
        .size(1.0, 1.0)
        .position(Vec3::new(2.0 * k as f32, 2.0, 0.0))
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .pin_edge(GridEdge::Top)
        .build()
        .expect("valid")
}

/// The positions (m) of `cloths` after `frames` frames, with particle 0
/// (a pinned top corner) of cloth `grabbed` pulled for the first 30.
fn run(app: &mut App, cloths: &[Entity], grabbed: Option<Entity>, frames: usize) -> Vec<Vec<Vec3>> {
    for frame in 0..frames {
        if let Some(e) = grabbed
            && frame < 30
        {
            let mut grabs = app.world_mut().get_mut::<ClothGrabs>(e).unwrap();
            let target = Vec3::new(0.3, 1.5, 0.4 + 0.01 * frame as f32);
            grabs.grab(0, target, GrabMode::Kinematic);
        }
        app.update();
    }
    cloths
        .iter()
        .map(|&e| {
            app.world()
                .get::<ClothParticles>(e)
                .unwrap()
                .positions
                .clone()
        })
        .collect()
}

/// The cloth of the scene that is grabbed.
const GRABBED: usize = 1;

#[test]
fn cloths_stepped_together_move_exactly_as_each_alone() {
    let mut together = app();
    let all: Vec<Entity> = (0..6)
        .map(|k| together.world_mut().spawn(cloth(k)).id())
        .collect();
    let shared = run(&mut together, &all, Some(all[GRABBED]), 90);
    for (k, shared) in shared.iter().enumerate() {
        let mut alone = app();
        let e = alone.world_mut().spawn(cloth(k)).id();
        let own = run(&mut alone, &[e], (k == GRABBED).then_some(e), 90).remove(0);
        assert!(own.iter().all(|x| x.is_finite()), "cloth {k}");
        assert_eq!(*shared, own, "cloth {k} stepped with the others");
    }
}
