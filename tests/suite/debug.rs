//! The gizmo debug view (`cargo test --test suite -- debug::`: the tests build with the `debug` feature).
#![cfg(feature = "debug")]

use crate::common;

use bevy::input::ButtonInput;
use bevy::prelude::*;
use bevy_cloth::plugin::tools::debug::ClothDebugDrawn;
use bevy_cloth::prelude::*;
use common::app;

/// A 5 × 5 cloth pinned at two corners, the middle of one edge grabbed,
/// lying on a ball; the app has the assets, the gizmos (as `DefaultPlugins`
/// gives a game) and the debug plugin.
fn scene() -> (App, Entity) {
    let mut app = app();
    app.add_plugins((
        AssetPlugin::default(),
        bevy::mesh::MeshPlugin,
        bevy::gizmos::GizmoPlugin,
        ClothDebugPlugin,
    ));
    let cloth = ClothBuilder::new(5, 5)
        .size(0.4, 0.4)
        .position(Vec3::new(0.0, 0.29, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    app.world_mut().get_mut::<ClothGrabs>(e).unwrap().grab(
        2,
        Vec3::new(0.0, 0.4, -0.2),
        GrabMode::Kinematic,
    );
    app.world_mut().spawn((
        ClothCollider::sphere(0.3),
        Transform::from_xyz(0.0, 0.0, 0.0),
    ));
    (app, e)
}

fn drawn(app: &App) -> usize {
    app.world().resource::<ClothDebugDrawn>().0
}

#[test]
fn off_by_default_it_draws_nothing() {
    let (mut app, _) = scene();
    for _ in 0..5 {
        app.update();
    }
    assert!(!app.world().resource::<ClothDebug>().enabled);
    assert_eq!(drawn(&app), 0);
}

#[test]
fn on_it_draws_links_pins_grabs_contacts_and_colliders() {
    let (mut app, e) = scene();
    app.world_mut().resource_mut::<ClothDebug>().enabled = true;
    app.update();
    let links = app
        .world()
        .get::<ClothConnections>(e)
        .unwrap()
        .type1_count();
    // Links, two pins plus the grabbed particle (pinned while held), the
    // grab's marker and line, at least one contact, and the ball.
    let least = links + 3 + 2 + 1 + 1;
    assert!(drawn(&app) >= least, "{} < {least}", drawn(&app));
    // Only the links.
    *app.world_mut().resource_mut::<ClothDebug>() = ClothDebug {
        enabled: true,
        pins: false,
        grabs: false,
        contacts: false,
        colliders: false,
        ..default()
    };
    app.update();
    assert_eq!(drawn(&app), links);
    // Off again: nothing.
    app.world_mut().resource_mut::<ClothDebug>().enabled = false;
    app.update();
    assert_eq!(drawn(&app), 0);
}

#[test]
fn its_key_toggles_it() {
    let (mut app, _) = scene();
    app.init_resource::<ButtonInput<KeyCode>>();
    let press = |app: &mut App| {
        let mut keys = app.world_mut().resource_mut::<ButtonInput<KeyCode>>();
        keys.press(KeyCode::F3);
        app.update();
        let mut keys = app.world_mut().resource_mut::<ButtonInput<KeyCode>>();
        keys.release(KeyCode::F3);
        keys.clear();
    };
    press(&mut app);
    assert!(app.world().resource::<ClothDebug>().enabled);
    assert!(drawn(&app) > 0);
    press(&mut app);
    assert!(!app.world().resource::<ClothDebug>().enabled);
    assert_eq!(drawn(&app), 0);
}

#[test]
fn it_draws_a_mesh_cloths_links_and_pins() {
    let mut app = app();
    app.add_plugins((
        AssetPlugin::default(),
        bevy::mesh::MeshPlugin,
        bevy::gizmos::GizmoPlugin,
        ClothDebugPlugin,
    ));
    let disc = bevy_cloth::plugin::spawn::disc_mesh(0.3, 4);
    let cloth = ClothBuilder::from_mesh(&disc)
        .position(Vec3::Y)
        .pin_vertex(0)
        .build()
        .unwrap();
    let links = cloth.connections.type1_count();
    app.world_mut().spawn(cloth);
    *app.world_mut().resource_mut::<ClothDebug>() = ClothDebug {
        enabled: true,
        grabs: false,
        contacts: false,
        colliders: false,
        ..default()
    };
    app.update();
    // Every Type 1 link and the one pin.
    assert_eq!(drawn(&app), links + 1);
}
