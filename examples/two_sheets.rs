//! Sheets falling on each other: two cloths dropped over a ball collide
//! with it, with the floor and with each other (`ClothToClothCollision`),
//! and come to rest one over the other without passing through. Each sheet
//! dropped lies in a higher layer than the ones before, so it is kept off
//! them.
//!
//! `cargo run --release --example two_sheets --features egui`
//!
//! Keys: `Space` drops another sheet (the oldest goes once there are six),
//! `R` starts again. Drag a sheet with the left button; drag elsewhere to
//! orbit, scroll to zoom.

mod automation;

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str =
    "Space: drop another sheet · R: start again · drag a sheet: pull it · drag elsewhere: orbit";

/// Sheets dropped at the start.
const FIRST: usize = 2;
/// Most sheets at once.
const MOST: usize = 6;
/// The sheets' colours, in the order they fall.
const COLOURS: [Color; 3] = [
    Color::srgb(0.2, 0.4, 0.8),
    Color::srgb(0.8, 0.12, 0.1),
    Color::srgb(0.9, 0.75, 0.2),
];

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: two sheets".into(),
                resolution: (1024u32, 640u32).into(),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((EguiPlugin::default(), PanOrbitCameraPlugin))
        // Bevy's mesh picking (how the mouse reaches a cloth), the
        // simulation and its panel.
        .add_plugins((MeshPickingPlugin, ClothPlugin::default(), ClothPanelPlugin))
        .insert_resource(ClothPanel::with_help(HELP))
        // Scripted runs for the rendering check (`--frames`, `--screenshot`):
        // delete this line and the example runs the same.
        .add_plugins(automation::AutomationPlugin)
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, orbit_unless_on_cloth))
        .run();
}

/// Sheets in the order they fell, and the layer of the next one.
#[derive(Resource, Default)]
struct Dropped(Vec<Entity>, i32);

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let focus = Vec3::new(0.0, 0.1, 0.0);
    commands.spawn((
        Camera3d::default(),
        Transform::from_translation(focus + Vec3::new(0.6, 0.9, 1.0).normalize() * 2.5)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(2.5),
            yaw: Some(0.5),
            pitch: Some(0.7),
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
        // The floor: cloth stays above it.
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(0.29).mesh().uv(48, 24))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.85, 0.85, 0.8),
            ..default()
        })),
        ClothCollider::sphere(0.3),
        Transform::from_xyz(0.0, 0.3, 0.0),
    ));
    let mut dropped = Dropped::default();
    for _ in 0..FIRST {
        drop_sheet(&mut commands, &mut materials, &mut dropped);
    }
    commands.insert_resource(dropped);
}

/// A 1.2 m, 21 × 21 sheet held flat over the ball, each one higher, turned
/// a little more and in a higher layer than the one before, in the next
/// colour.
fn drop_sheet(
    commands: &mut Commands,
    materials: &mut Assets<StandardMaterial>,
    dropped: &mut Dropped,
) {
    if dropped.0.len() >= MOST {
        commands.entity(dropped.0.remove(0)).despawn();
    }
    let k = dropped.0.len();
    let sheet = ClothBuilder::new(21, 21)
        .size(1.2, 1.2)
        .position(Vec3::new(0.05 * k as f32, 0.7 + 0.3 * k as f32, 0.0))
        .rotation(Quat::from_rotation_y(0.5 * k as f32))
        .build()
        .expect("a valid cloth");
    let material = materials.add(StandardMaterial {
        base_color: COLOURS[k % COLOURS.len()],
        perceptual_roughness: 0.9,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    let entity = commands
        .spawn((
            sheet,
            MeshMaterial3d(material),
            // Kept 1 cm off every sheet dropped before it.
            ClothToClothCollision {
                layer: dropped.1,
                ..default()
            },
        ))
        .id();
    dropped.0.push(entity);
    dropped.1 += 1;
}

/// `Space` drops another sheet; `R` starts again.
fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut dropped: ResMut<Dropped>,
) {
    if input.just_pressed(KeyCode::Space) {
        drop_sheet(&mut commands, &mut materials, &mut dropped);
    }
    if input.just_pressed(KeyCode::KeyR) {
        for sheet in dropped.0.drain(..) {
            commands.entity(sheet).despawn();
        }
        for _ in 0..FIRST {
            drop_sheet(&mut commands, &mut materials, &mut dropped);
        }
    }
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
