//! What the bench binaries share.

use bevy::asset::AssetPlugin;
use bevy::mesh::Mesh;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::prelude::*;

/// A headless app with meshes that steps at 60 Hz with `settings` as defaults.
pub fn headless(settings: ClothSettings) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        ClothPlugin::default(),
    ))
    .init_asset::<Mesh>()
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
    .insert_resource(ClothSettingsDefaults(settings.0));
    app
}
