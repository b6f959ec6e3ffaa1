//! `ClothPlugin` leaves the game's picking as it is: it adds no picking
//! backend, and marks its own meshes so any mesh backend, with or without
//! required markers, picks them from both sides.

use crate::common;

use bevy::asset::AssetPlugin;
use bevy::mesh::{Mesh, Mesh3d};
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::picking::mesh_picking::ray_cast::RayCastBackfaces;
use bevy::picking::{Pickable, PickingPlugin};
use bevy::prelude::*;
use bevy::transform::TransformPlugin;
use bevy_cloth::prelude::*;
use common::sheet;

fn app_with_picking() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        PickingPlugin,
        ClothPlugin::default(),
    ))
    .init_asset::<Mesh>();
    app.finish();
    app.cleanup();
    app
}

#[test]
fn the_plugin_adds_no_picking_backend() {
    let app = app_with_picking();
    assert!(
        !app.is_plugin_added::<MeshPickingPlugin>(),
        "ClothPlugin made every mesh of the game pickable"
    );
}

#[test]
fn cloth_meshes_are_marked_pickable_from_both_sides() {
    let mut app = app_with_picking();
    let cloth = app.world_mut().spawn(sheet(6)).id();
    for _ in 0..3 {
        app.update();
    }
    let e = app.world().entity(cloth);
    assert!(e.contains::<Mesh3d>(), "no mesh was attached");
    assert!(
        e.contains::<Pickable>(),
        "the cloth mesh is not marked Pickable"
    );
    assert!(e.contains::<RayCastBackfaces>());
}

/// With the game's own `MeshPickingPlugin` the plugin has nothing to add,
/// whichever of the two is added first.
#[test]
fn a_game_adds_mesh_picking_before_or_after_the_plugin() {
    for before in [true, false] {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default(), PickingPlugin));
        if before {
            app.add_plugins((MeshPickingPlugin, ClothPlugin::default()));
        } else {
            app.add_plugins((ClothPlugin::default(), MeshPickingPlugin));
        }
        app.init_asset::<Mesh>();
        app.finish();
        assert!(app.is_plugin_added::<MeshPickingPlugin>());
    }
}
