//! Sleep: a cloth at rest stops stepping, stays exactly where it was, and
//! wakes in the same fixed step on everything that could move it.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::plugin::collision::ClothContactLayers;
use bevy_cloth::prelude::*;
use common::{app, particles};

/// Every rest and wake event seen on the cloths, in order.
#[derive(Resource, Default)]
struct Seen(Vec<&'static str>);

/// A small sheet lying on a floor (the floor's entity too), watched for
/// rest and wake events.
fn on_floor(app: &mut App) -> (Entity, Entity) {
    let floor = app
        .world_mut()
        .spawn((
            ClothCollider::plane().with_friction(0.8),
            Transform::default(),
        ))
        .id();
    let cloth = ClothBuilder::new(9, 9)
        .size(0.5, 0.5)
        .position(Vec3::new(0.0, 0.01, 0.0))
        .build()
        .unwrap();
    (watched(app, cloth), floor)
}

/// Spawns `cloth` with observers recording its rest and wake events.
fn watched(app: &mut App, cloth: impl Bundle) -> Entity {
    app.init_resource::<Seen>();
    app.world_mut()
        .spawn(cloth)
        .observe(|_: On<ClothAtRest>, mut seen: ResMut<Seen>| seen.0.push("rest"))
        .observe(|_: On<ClothWoke>, mut seen: ResMut<Seen>| seen.0.push("woke"))
        .id()
}

fn seen(app: &mut App) -> Vec<&'static str> {
    std::mem::take(&mut app.world_mut().resource_mut::<Seen>().0)
}

fn asleep(app: &App, cloth: Entity) -> bool {
    app.world().get::<ClothSleep>(cloth).unwrap().is_asleep()
}

fn steps(app: &App, cloth: Entity) -> u64 {
    app.world().get::<ClothStats>(cloth).unwrap().steps
}

/// Runs until `cloth` sleeps (at most `limit` fixed steps); the steps taken.
fn until_asleep(app: &mut App, cloth: Entity, limit: usize) -> usize {
    for k in 1..=limit {
        app.update();
        if asleep(app, cloth) {
            return k;
        }
    }
    panic!(
        "not asleep after {limit} steps: {:?}",
        app.world().get::<ClothStats>(cloth)
    );
}

#[test]
fn a_cloth_at_rest_sleeps_and_stands_exactly_still() {
    let mut app = app();
    let (cloth, _) = on_floor(&mut app);
    let k = until_asleep(&mut app, cloth, 300);
    assert!(k >= 30, "rest needs half a second of calm, slept after {k}");
    assert_eq!(seen(&mut app), ["rest"], "one rest event, when it sleeps");
    let before = particles(&app, cloth).clone();
    let count = steps(&app, cloth);
    for _ in 0..120 {
        app.update();
    }
    let after = particles(&app, cloth);
    assert!(asleep(&app, cloth));
    assert_eq!(after.positions, before.positions, "no drift while asleep");
    assert_eq!(after.velocities, before.velocities);
    assert_eq!(steps(&app, cloth), count, "its step counter stands still");
    assert!(seen(&mut app).is_empty());
    let stats = app.world().get::<ClothStats>(cloth).unwrap();
    assert_eq!(
        (stats.step_micros, stats.solver_iterations),
        (0.0, 0),
        "a sleeping cloth costs no step time in its stats and diagnostics"
    );
}

/// Counts the fixed steps in which a cloth's particles were written.
#[derive(Resource, Default)]
struct Written(usize);

#[test]
fn nothing_writes_a_sleeping_cloth() {
    // Anchors, wind, a skin-less frame and mesh colliders all run their
    // systems; none of them may touch a sleeping cloth's particles, or it
    // would be re-meshed (and woken) every step.
    let mut app = app();
    app.init_resource::<Written>().add_systems(
        FixedPostUpdate,
        |cloths: Query<(), Changed<ClothParticles>>, mut written: ResMut<Written>| {
            written.0 += cloths.iter().count();
        },
    );
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(0.0, -0.5, 0.0),
        ..default()
    }));
    let post = app.world_mut().spawn(Transform::default()).id();
    let (cloth, _) = on_floor(&mut app);
    app.world_mut().entity_mut(cloth).insert((
        ClothAnchors::default().with(0, post),
        ClothInertia::new(post, 0.5, 0.5),
    ));
    until_asleep(&mut app, cloth, 400);
    app.world_mut().resource_mut::<Written>().0 = 0;
    for _ in 0..60 {
        app.update();
    }
    assert!(asleep(&app, cloth));
    assert_eq!(app.world().resource::<Written>().0, 0);
}

/// One way to disturb a sleeping cloth on the floor.
type Trigger = fn(&mut App, Entity, Entity);

#[test]
fn everything_that_could_move_a_sleeping_cloth_wakes_it_in_the_same_step() {
    let triggers: [(&str, Trigger); 15] = [
        ("WakeCloth", |app, cloth, _| {
            app.world_mut().commands().entity(cloth).queue(WakeCloth);
        }),
        ("a collider appearing", |app, _, _| {
            // Within the margin, not yet touching.
            app.world_mut().spawn((
                ClothCollider::sphere(0.05),
                Transform::from_xyz(0.0, 0.1, 0.0),
            ));
        }),
        ("the floor moving", |app, _, floor| {
            app.world_mut()
                .get_mut::<Transform>(floor)
                .unwrap()
                .translation
                .y += 0.01;
        }),
        ("the floor despawned", |app, _, floor| {
            app.world_mut().despawn(floor);
        }),
        ("wind starting", |app, _, _| {
            app.insert_resource(ClothWind(Wind {
                velocity: Vec3::X * 5.0,
                ..default()
            }));
        }),
        ("a grab", |app, cloth, _| {
            let at = particles(app, cloth).positions[40];
            app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap().grab(
                40,
                at + Vec3::Y * 0.05,
                GrabMode::Kinematic,
            );
        }),
        ("a pin", |app, cloth, _| {
            app.world_mut()
                .get_mut::<ClothParticles>(cloth)
                .unwrap()
                .pin(3);
        }),
        ("a material", |app, cloth, _| {
            app.world_mut()
                .entity_mut(cloth)
                .insert(ClothMaterial::DENIM);
        }),
        ("its settings", |app, cloth, _| {
            let mut settings = SimSettings::default();
            settings.gravity *= 2.0;
            app.world_mut()
                .entity_mut(cloth)
                .insert(ClothSettings(settings));
        }),
        ("the defaults", |app, _, _| {
            app.world_mut()
                .resource_mut::<ClothSettingsDefaults>()
                .0
                .damping = 1.0;
        }),
        ("a force", |app, cloth, _| {
            let mut forces = app.world_mut().get_mut::<ClothForces>(cloth).unwrap();
            forces.0.resize(81, Vec3::ZERO);
            forces.0[40] = Vec3::Y * 5.0;
        }),
        ("a teleport", |app, cloth, _| {
            let by = Isometry3d::from_translation(Vec3::Y * 0.5);
            app.world_mut()
                .commands()
                .entity(cloth)
                .queue(TeleportCloth(by));
        }),
        ("its connections", |app, cloth, _| {
            app.world_mut().entity_mut(cloth).insert(ClothCreases(vec![
                Crease::new(Vec2::new(0.0, 0.25), Vec2::new(0.5, 0.25)).with_side(FoldSide::Valley),
            ]));
        }),
        ("its collision settings", |app, cloth, _| {
            app.world_mut().entity_mut(cloth).insert(ClothCollision {
                thickness: 0.02,
                ..default()
            });
        }),
        ("its layers", |app, cloth, _| {
            app.world_mut()
                .entity_mut(cloth)
                .insert(ClothContactLayers::ALL);
        }),
    ];
    for (name, trigger) in triggers {
        let mut app = app();
        let (cloth, floor) = on_floor(&mut app);
        until_asleep(&mut app, cloth, 300);
        seen(&mut app);
        let count = steps(&app, cloth);
        for _ in 0..5 {
            app.update();
        }
        assert!(asleep(&app, cloth), "{name}: asleep before");
        trigger(&mut app, cloth, floor);
        wakes_in_the_next_step(&mut app, cloth, count, name);
    }
}

/// One update wakes the sleeping `cloth`, steps it once (its step count
/// was `count`) and fires one `ClothWoke`.
fn wakes_in_the_next_step(app: &mut App, cloth: Entity, count: u64, name: &str) {
    app.update();
    assert!(!asleep(app, cloth), "{name}: still asleep");
    assert_eq!(
        steps(app, cloth),
        count + 1,
        "{name}: stepped in the same fixed step"
    );
    assert_eq!(seen(app), ["woke"], "{name}");
}

#[test]
fn a_collider_moving_far_from_a_sleeping_cloth_leaves_it_asleep() {
    let mut app = app();
    let ball = app
        .world_mut()
        .spawn((
            ClothCollider::sphere(0.1),
            Transform::from_xyz(3.0, 0.5, 0.0),
        ))
        .id();
    let (cloth, _) = on_floor(&mut app);
    until_asleep(&mut app, cloth, 300);
    for k in 0..60 {
        app.world_mut()
            .get_mut::<Transform>(ball)
            .unwrap()
            .translation
            .z = (k as f32 * 0.1).sin();
        app.update();
        assert!(asleep(&app, cloth), "step {k}");
    }
}

#[test]
fn a_sleeping_cloth_whose_floor_is_despawned_falls() {
    let mut app = app();
    let (cloth, floor) = on_floor(&mut app);
    until_asleep(&mut app, cloth, 300);
    let y = particles(&app, cloth).positions[40].y;
    app.world_mut().despawn(floor);
    for _ in 0..30 {
        app.update();
    }
    let fell = y - particles(&app, cloth).positions[40].y;
    assert!(
        fell > 0.9 * 0.5 * 9.81 * 0.25 * 0.5,
        "fell {fell} m in 0.5 s"
    );
}

#[test]
fn a_moving_anchor_frame_or_wind_change_wakes_it() {
    // Anchored to a post, carried by a frame, in a light steady wind
    // pressing it down: each of them moving or changing wakes it.
    let triggers: [(&str, Trigger); 5] = [
        ("the anchor's post", |app, _, post| {
            app.world_mut()
                .get_mut::<Transform>(post)
                .unwrap()
                .translation
                .x += 0.02;
        }),
        ("the frame", |app, cloth, _| {
            let frame = app.world_mut().spawn(Transform::default()).id();
            app.world_mut()
                .entity_mut(cloth)
                .insert(ClothInertia::new(frame, 0.5, 0.5));
            app.update();
            app.world_mut()
                .get_mut::<Transform>(frame)
                .unwrap()
                .rotate_y(0.01);
        }),
        ("the wind changing", |app, _, _| {
            app.world_mut().resource_mut::<ClothWind>().velocity.y = -1.0;
        }),
        ("the wind gusting", |app, _, _| {
            let mut wind = app.world_mut().resource_mut::<ClothWind>();
            wind.gust_amplitude = 0.5;
            wind.gust_frequency = 1.0;
        }),
        ("the wind stopping", |app, _, _| {
            app.world_mut().remove_resource::<ClothWind>();
        }),
    ];
    for (name, trigger) in triggers {
        let mut app = app();
        app.insert_resource(ClothWind(Wind {
            velocity: Vec3::new(0.0, -0.5, 0.0),
            ..default()
        }));
        let post = app
            .world_mut()
            .spawn(Transform::from_xyz(-0.25, 0.01, -0.25))
            .id();
        let (cloth, _) = on_floor(&mut app);
        app.world_mut()
            .entity_mut(cloth)
            .insert(ClothAnchors::default().with(0, post));
        until_asleep(&mut app, cloth, 400);
        seen(&mut app);
        trigger(&mut app, cloth, post);
        // The frame's trigger spends a step adding the frame.
        assert!(asleep(&app, cloth), "{name}: asleep before");
        let count = steps(&app, cloth);
        wakes_in_the_next_step(&mut app, cloth, count, name);
    }
}

#[test]
fn with_sleep_off_a_resting_cloth_keeps_stepping() {
    let mut app = app();
    let (cloth, _) = on_floor(&mut app);
    let mut settings = SimSettings::default();
    settings.sleep.enabled = false;
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothSettings(settings));
    for _ in 0..300 {
        app.update();
        assert!(!asleep(&app, cloth));
    }
    let stats = app.world().get::<ClothStats>(cloth).unwrap();
    assert!(stats.resting, "at rest: {stats:?}");
    assert_eq!(stats.steps, 300);
    assert_eq!(seen(&mut app), ["rest"]);
}

#[test]
fn a_held_cloth_does_not_sleep() {
    let mut app = app();
    let (cloth, _) = on_floor(&mut app);
    let at = particles(&app, cloth).positions[40];
    app.world_mut()
        .get_mut::<ClothGrabs>(cloth)
        .unwrap()
        .grab(40, at, GrabMode::Kinematic);
    for _ in 0..300 {
        app.update();
        assert!(!asleep(&app, cloth));
    }
    // At rest (held still), once: no rest and wake every few steps.
    assert_eq!(seen(&mut app), ["rest"]);
}

#[test]
fn woken_every_other_step_it_neither_pops_nor_drifts() {
    let mut app = app();
    let (cloth, _) = on_floor(&mut app);
    until_asleep(&mut app, cloth, 300);
    seen(&mut app);
    let start = particles(&app, cloth).positions.clone();
    for k in 0..400 {
        if k % 2 == 0 {
            app.world_mut().commands().entity(cloth).queue(WakeCloth);
        }
        app.update();
        // The rest and wake events follow sleeping exactly.
        let events = seen(&mut app);
        let now = particles(&app, cloth);
        let moved = now
            .positions
            .iter()
            .zip(&start)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        assert!(now.is_finite() && moved < 1e-3, "step {k}: moved {moved} m");
        if asleep(&app, cloth) {
            assert!(events.is_empty() || events == ["rest"], "{k}: {events:?}");
        } else {
            assert!(!events.contains(&"rest"), "{k}: {events:?}");
        }
    }
    // Left alone, it sleeps again.
    until_asleep(&mut app, cloth, 60);
}

#[test]
fn rest_and_wake_events_match_sleeping() {
    let mut app = app();
    let (cloth, _) = on_floor(&mut app);
    let mut was = false;
    let mut flips = 0;
    for k in 0..900 {
        // Lift its middle now and then.
        if k % 300 == 299 {
            let at = particles(&app, cloth).positions[40];
            let mut grabs = app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap();
            grabs.grab(40, at + Vec3::Y * 0.1, GrabMode::Kinematic);
        }
        if k % 300 == 0 {
            app.world_mut()
                .get_mut::<ClothGrabs>(cloth)
                .unwrap()
                .release(40);
        }
        app.update();
        let now = asleep(&app, cloth);
        let events = seen(&mut app);
        match (was, now) {
            (false, true) => assert_eq!(events, ["rest"], "{k}"),
            (true, false) => assert_eq!(events, ["woke"], "{k}"),
            _ => assert!(events.is_empty(), "{k}: {events:?}"),
        }
        flips += usize::from(was != now);
        was = now;
    }
    assert!(flips >= 5, "slept and woke: {flips} changes");
}

#[test]
fn a_thousand_sleeping_cloths_spawned_and_despawned_leave_nothing_behind() {
    let mut app = app();
    app.world_mut()
        .spawn((ClothCollider::plane(), Transform::default()));
    for _ in 0..3 {
        app.update();
    }
    let baseline = app.world().entities().count_spawned();
    for round in 0..2 {
        let cloths: Vec<Entity> = (0..1000)
            .map(|i| {
                let cloth = ClothBuilder::new(3, 3)
                    .size(0.1, 0.1)
                    .position(Vec3::new(
                        (i % 40) as f32 * 0.2,
                        0.005,
                        (i / 40) as f32 * 0.2,
                    ))
                    .build()
                    .unwrap();
                app.world_mut().spawn(cloth).id()
            })
            .collect();
        for _ in 0..120 {
            app.update();
        }
        let sleeping = cloths.iter().filter(|&&c| asleep(&app, c)).count();
        assert_eq!(sleeping, 1000, "round {round}");
        // Despawned while asleep, half before a step, half after one.
        for &c in &cloths[..500] {
            app.world_mut().despawn(c);
        }
        app.update();
        for &c in &cloths[500..] {
            let mut commands = app.world_mut().commands();
            commands.entity(c).queue(WakeCloth);
            commands.entity(c).despawn();
        }
        for _ in 0..3 {
            app.update();
        }
        assert_eq!(
            app.world().entities().count_spawned(),
            baseline,
            "round {round}"
        );
    }
}

#[test]
fn bad_sleep_thresholds_are_an_error_and_the_cloth_is_left_alone() {
    let mut app = app();
    let (cloth, _) = on_floor(&mut app);
    let mut settings = SimSettings::default();
    settings.sleep.margin = f32::NAN;
    assert!(matches!(
        settings.validate(),
        Err(ClothError::InvalidSleep { .. })
    ));
    settings.sleep.margin = 0.05;
    settings.sleep.rest_speed = -1.0;
    assert!(settings.validate().is_err());
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothSettings(settings));
    let before = particles(&app, cloth).positions.clone();
    for _ in 0..10 {
        app.update();
    }
    assert_eq!(particles(&app, cloth).positions, before);
}
