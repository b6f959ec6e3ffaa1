//! A round tablecloth: a disc-shaped mesh cloth dropped on a round table,
//! where it drapes in folds all around the rim.
//!
//! `cargo run --release --example round_tablecloth`
//!
//! Keys: `N` drop the cloth again, `R` drop a smaller cloth that just
//! covers the top. Drag a cloth to pull it, drag elsewhere to orbit,
//! scroll to zoom.

mod automation;

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::plugin::spawn::disc_mesh;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "N: drop the cloth again · R: a smaller cloth · drag the cloth: pull · drag: orbit · scroll: zoom";

/// Height of the table top's upper face, m.
const TOP: f32 = 0.78;
/// Radius of the round table top, m.
const TABLE: f32 = 0.5;
/// Particles 5 cm apart across the disc.
const SPACING: f32 = 0.05;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: round tablecloth".into(),
                resolution: (1024u32, 640u32).into(),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((EguiPlugin::default(), PanOrbitCameraPlugin))
        // Bevy's mesh picking (how the mouse reaches a cloth), the
        // simulation (the left button pulls a cloth, the right one pins),
        // its panel and the debug view.
        .add_plugins((
            MeshPickingPlugin,
            ClothPlugin::default(),
            ClothPanelPlugin,
            debug_view,
        ))
        .insert_resource(ClothPanel::with_help(HELP))
        // Scripted runs for the rendering check (`--frames`, `--screenshot`):
        // delete this line and the example runs the same.
        .add_plugins(automation::AutomationPlugin)
        .add_systems(Update, orbit_unless_on_cloth)
        .add_systems(Startup, setup)
        .add_systems(Update, keys)
        .run();
}

/// The cloth's look, kept to give each new cloth.
#[derive(Resource)]
struct Linen(Handle<StandardMaterial>);

/// A round cloth of `radius` m, flat and level 25 cm above the table.
fn tablecloth(radius: f32) -> ClothBundle {
    let rings = (radius / SPACING).round() as u32;
    ClothBuilder::from_mesh(&disc_mesh(radius, rings))
        .material(ClothMaterial::COTTON)
        .position(Vec3::new(0.0, TOP + 0.25, 0.0))
        .build()
        .expect("a valid cloth")
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 0.55, 0.0),
        3.0,
    );
    commands.spawn((
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    let wood = materials.add(StandardMaterial {
        base_color: Color::srgb(0.42, 0.27, 0.15),
        perceptual_roughness: 0.6,
        ..default()
    });
    // The round top: a cylinder collider 1 cm wider than it looks, since
    // 5 cm cloth triangles cut the rim's corner.
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(TABLE, 0.04))),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, TOP - 0.02, 0.0),
        ClothCollider::cylinder(TABLE + 0.01, 0.02).with_friction(0.4),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.05, TOP - 0.04))),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, (TOP - 0.04) / 2.0, 0.0),
        ClothCollider::cylinder(0.05, (TOP - 0.04) / 2.0),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.28, 0.03))),
        MeshMaterial3d(wood),
        Transform::from_xyz(0.0, 0.015, 0.0),
    ));
    let linen = materials.add(StandardMaterial {
        base_color: Color::srgb(0.16, 0.32, 0.7),
        perceptual_roughness: 0.85,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    commands.insert_resource(Linen(linen.clone()));
    commands.spawn((tablecloth(0.85), MeshMaterial3d(linen)));
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    linen: Res<Linen>,
    cloths: Query<Entity, With<Cloth>>,
) {
    let radius = if input.just_pressed(KeyCode::KeyN) {
        0.85
    } else if input.just_pressed(KeyCode::KeyR) {
        0.6
    } else {
        return;
    };
    for cloth in &cloths {
        commands.entity(cloth).despawn();
    }
    commands.spawn((tablecloth(radius), MeshMaterial3d(linen.0.clone())));
}

/// A camera orbiting `focus` at `radius` metres, plus a sun with shadows and
/// a ground plane at y = 0.
fn stage(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
    focus: Vec3,
    radius: f32,
) {
    commands.spawn((
        Camera3d::default(),
        Transform::from_translation(focus + Vec3::new(0.6, 0.55, 1.0).normalize() * radius)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(radius),
            yaw: Some(0.5),
            pitch: Some(0.45),
            ..default()
        },
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(3.0, 6.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(12.0, 12.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.55, 0.58, 0.52),
            perceptual_roughness: 1.0,
            ..default()
        })),
    ));
}

/// The camera leaves the mouse alone while it is on a cloth (a press there
/// pulls the cloth) or on the panel.
fn orbit_unless_on_cloth(pointer: ClothPointer, mut cameras: Query<&mut PanOrbitCamera>) {
    let free = !pointer.busy();
    for mut camera in &mut cameras {
        if camera.enabled != free {
            camera.enabled = free;
        }
    }
}

/// The gizmo debug view, with the `debug` feature (F3 toggles it; this
/// repository's examples build with it).
#[cfg(feature = "debug")]
fn debug_view(app: &mut App) {
    app.add_plugins(ClothDebugPlugin);
}

/// The gizmo debug view needs the `debug` feature.
#[cfg(not(feature = "debug"))]
fn debug_view(_: &mut App) {}
