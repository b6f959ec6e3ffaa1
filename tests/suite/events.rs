//! The events a game observes on a cloth entity (grab, release, rest, wake,
//! divergence) and the per-cloth diagnostics.

use crate::common;

use bevy::diagnostic::{DiagnosticsPlugin, DiagnosticsStore};
use bevy::prelude::*;
use bevy_cloth::plugin::diagnostics::cloth_path;
use bevy_cloth::prelude::*;
use common::{app, particles};

/// Every event of type `E` observed on `cloth`, as its debug text, in order.
#[derive(Resource, Default)]
struct Seen(Vec<String>);

fn record<E: EntityEvent + std::fmt::Debug>(event: On<E>, mut seen: ResMut<Seen>) {
    seen.0.push(format!("{:?}", event.event()));
}

fn observed(app: &mut App, cloth: Entity) {
    app.init_resource::<Seen>();
    app.world_mut()
        .entity_mut(cloth)
        .observe(record::<ClothGrabbed>)
        .observe(record::<ClothReleased>)
        .observe(record::<ClothAtRest>)
        .observe(record::<ClothWoke>)
        .observe(record::<ClothDiverged>);
}

fn seen(app: &mut App) -> Vec<String> {
    std::mem::take(&mut app.world_mut().resource_mut::<Seen>().0)
}

/// A small sheet lying on a floor, so it comes to rest quickly.
fn on_floor(app: &mut App) -> Entity {
    app.world_mut().spawn((
        ClothCollider::plane().with_friction(0.8),
        Transform::default(),
    ));
    let cloth = ClothBuilder::new(9, 9)
        .size(0.5, 0.5)
        .position(Vec3::new(0.0, 0.01, 0.0))
        .build()
        .unwrap();
    app.world_mut().spawn(cloth).id()
}

#[test]
fn a_grab_and_its_release_are_observed_once_each() {
    let mut app = app();
    let cloth = on_floor(&mut app);
    observed(&mut app, cloth);
    for _ in 0..5 {
        app.update();
    }
    seen(&mut app);
    let at = particles(&app, cloth).positions[40];
    app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap().grab(
        40,
        at + Vec3::Y * 0.2,
        GrabMode::Kinematic,
    );
    for _ in 0..10 {
        app.update();
    }
    let events = seen(&mut app);
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(events[0].starts_with("ClothGrabbed") && events[0].contains("particle: 40"));
    app.world_mut()
        .get_mut::<ClothGrabs>(cloth)
        .unwrap()
        .release(40);
    app.update();
    let events = seen(&mut app);
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(events[0].starts_with("ClothReleased") && events[0].contains("particle: 40"));
    // A grab released before it ever acted is neither grabbed nor released.
    let mut grabs = app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap();
    grabs.grab(3, at, GrabMode::Kinematic);
    grabs.release(3);
    app.update();
    assert!(seen(&mut app).is_empty());
}

#[test]
fn a_cloth_on_the_floor_comes_to_rest_and_wakes_when_pulled() {
    let mut app = app();
    let cloth = on_floor(&mut app);
    observed(&mut app, cloth);
    let mut rested_at = None;
    for step in 0..180 {
        app.update();
        if seen(&mut app).iter().any(|e| e.starts_with("ClothAtRest")) {
            rested_at = Some(step);
            break;
        }
    }
    let rested_at = rested_at.expect("at rest within 3 s");
    assert!(rested_at >= 30, "rest needs half a second of calm");
    assert!(app.world().get::<ClothStats>(cloth).unwrap().resting);
    // Nothing more while it lies there.
    for _ in 0..60 {
        app.update();
    }
    assert!(seen(&mut app).is_empty());
    // Lifting its middle 10 cm in one step wakes it.
    let at = particles(&app, cloth).positions[40];
    app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap().grab(
        40,
        at + 0.1 * Vec3::Y,
        GrabMode::Kinematic,
    );
    app.update();
    let events = seen(&mut app);
    let stats = app.world().get::<ClothStats>(cloth).unwrap();
    assert!(
        events.iter().any(|e| e.starts_with("ClothWoke")),
        "{events:?} {stats:?}"
    );
    assert!(events.iter().any(|e| e.starts_with("ClothGrabbed")));
    assert!(!app.world().get::<ClothStats>(cloth).unwrap().resting);
}

#[test]
fn a_divergence_is_an_entity_event_and_a_message() {
    let mut app = app();
    let cloth = on_floor(&mut app);
    observed(&mut app, cloth);
    app.update();
    seen(&mut app);
    app.world_mut()
        .get_mut::<ClothParticles>(cloth)
        .unwrap()
        .velocities[7] = Vec3::NAN;
    app.update();
    let events = seen(&mut app);
    assert!(
        events.iter().any(|e| e.starts_with("ClothDiverged")),
        "{events:?}"
    );
    let messages = app
        .world()
        .resource::<bevy::ecs::message::Messages<ClothDiverged>>();
    assert_eq!(messages.iter_current_update_messages().count(), 1);
    assert!(particles(&app, cloth).is_finite());
}

#[test]
fn a_named_cloth_has_its_own_diagnostics() {
    let mut app = app();
    app.add_plugins(DiagnosticsPlugin);
    let hanging = common::hanging(9);
    let flag = app.world_mut().spawn((hanging, Name::new("flag"))).id();
    app.world_mut().spawn(common::hanging(5));
    for _ in 0..20 {
        app.update();
    }
    let store = app.world().resource::<DiagnosticsStore>();
    let strain = store
        .get(&cloth_path("flag", "max_strain"))
        .and_then(|d| d.value())
        .expect("the flag's strain");
    let stats = app.world().get::<ClothStats>(flag).unwrap();
    assert_eq!(strain, stats.max_strain as f64);
    let energy = store
        .get(&cloth_path("flag", "kinetic_energy"))
        .and_then(|d| d.value())
        .unwrap();
    assert_eq!(energy, stats.kinetic_energy as f64);
    // The unnamed cloth has none; the flag has exactly its five.
    let own = store
        .iter()
        .filter(|d| d.path().as_str().starts_with("cloth/flag/"))
        .count();
    assert_eq!(own, 5);
}
