//! The paper's Fig. 5 tablecloth: a gingham cloth draped over a round table,
//! with the tablecloth trick.
//!
//! `cargo run --release --example tablecloth`
//!
//! Keys: `Y` yank the cloth off the table by one edge, `N` drop a new cloth
//! from above, `R` reset. Drag to orbit, scroll to zoom.

mod automation;

use bevy::asset::AssetLoadFailedEvent;
use bevy::image::{ImageAddressMode, ImageLoaderSettings, ImageSampler, ImageSamplerDescriptor};
use bevy::math::Affine2;
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "Y: yank the cloth off (the tablecloth trick) · N: drop a new cloth · R: reset · drag: orbit · scroll: zoom";

/// Height of the table top's upper face, m.
const TOP: f32 = 0.78;
/// Radius of the round table top, m.
const RADIUS: f32 = 0.55;
/// The cloth: 1.5 m square, 31 × 31 particles (5 cm apart).
const SIZE: f32 = 1.5;
const N: u32 = 31;
/// Speed of the yank, m/s, and how long the hand pulls, s: out and a
/// little down, as the trick is done, for the cloth's whole length and
/// some more (2 m), then it lets go.
const YANK_SPEED: f32 = 7.0;
const YANK_TIME: f32 = 2.0 / YANK_SPEED;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: tablecloth".into(),
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
        .add_systems(Update, (keys, plain_if_no_texture))
        // The hand moves in the fixed step, before the cloth reads it.
        .add_systems(FixedUpdate, pull.before(ClothSystems::Prepare))
        .run();
}

/// The cloth's material (gingham, repeated four times across).
#[derive(Resource)]
struct Fabric(Handle<StandardMaterial>);

/// The hand that yanks the cloth: moves along +Z (towards the camera), then lets go.
#[derive(Component)]
struct Hand {
    /// Seconds since the yank began.
    age: f32,
    /// The cloth it holds.
    cloth: Entity,
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
) {
    stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 0.5, 0.4),
        3.8,
    );
    commands.spawn((
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    // The round top (a cylinder collider) on a pedestal.
    let wood = materials.add(StandardMaterial {
        base_color: Color::srgb(0.42, 0.27, 0.15),
        perceptual_roughness: 0.6,
        ..default()
    });
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(RADIUS, 0.04))),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, TOP - 0.02, 0.0),
        // 1 cm wider than it looks: 5 cm cloth triangles cut the rim's corner.
        ClothCollider::cylinder(RADIUS + 0.01, 0.02).with_friction(0.35),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.05, TOP - 0.04))),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, (TOP - 0.04) / 2.0, 0.0),
        ClothCollider::cylinder(0.05, (TOP - 0.04) / 2.0),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.3, 0.03))),
        MeshMaterial3d(wood),
        Transform::from_xyz(0.0, 0.015, 0.0),
    ));
    // Plates and a vase that stay put when the cloth is pulled (they are
    // scenery: the trick always works here).
    let china = materials.add(Color::srgb(0.93, 0.93, 0.9));
    for (x, z) in [(-0.25, 0.1), (0.22, -0.18), (0.05, 0.3)] {
        commands.spawn((
            Mesh3d(meshes.add(Cylinder::new(0.11, 0.015))),
            MeshMaterial3d(china.clone()),
            Transform::from_xyz(x, TOP + 0.02, z),
        ));
    }
    commands.spawn((
        Mesh3d(meshes.add(Capsule3d::new(0.05, 0.12))),
        MeshMaterial3d(materials.add(Color::srgb(0.2, 0.35, 0.6))),
        Transform::from_xyz(0.0, TOP + 0.1, -0.05),
    ));
    let texture = assets
        .load_builder()
        .with_settings(|s: &mut ImageLoaderSettings| {
            s.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
                address_mode_u: ImageAddressMode::Repeat,
                address_mode_v: ImageAddressMode::Repeat,
                ..ImageSamplerDescriptor::linear()
            });
        })
        .load("gingham.png");
    let fabric = materials.add(StandardMaterial {
        base_color_texture: Some(texture),
        uv_transform: Affine2::from_scale(Vec2::splat(4.0)),
        perceptual_roughness: 0.95,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    spawn_cloth(&mut commands, &fabric, TOP + 0.03);
    commands.insert_resource(Fabric(fabric));
}

/// A flat cloth centred over the table at `height` m.
fn spawn_cloth(commands: &mut Commands, fabric: &Handle<StandardMaterial>, height: f32) {
    let cloth = ClothBuilder::new(N, N)
        .size(SIZE, SIZE)
        .material(ClothMaterial::COTTON)
        .position(Vec3::new(0.0, height, 0.0))
        .build()
        .expect("a valid cloth");
    commands.spawn((
        cloth,
        MeshMaterial3d(fabric.clone()),
        ClothCollision {
            thickness: 0.01,
            ..default()
        },
    ));
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    fabric: Res<Fabric>,
    cloths: Query<(Entity, &ClothParticles), With<Cloth>>,
    hands: Query<Entity, With<Hand>>,
) {
    let respawn = |commands: &mut Commands, height: f32| {
        for (cloth, _) in &cloths {
            commands.entity(cloth).despawn();
        }
        for hand in &hands {
            commands.entity(hand).despawn();
        }
        spawn_cloth(commands, &fabric.0, height);
    };
    if input.just_pressed(KeyCode::KeyR) {
        respawn(&mut commands, TOP + 0.03);
    }
    if input.just_pressed(KeyCode::KeyN) {
        respawn(&mut commands, TOP + 0.6);
    }
    if input.just_pressed(KeyCode::KeyY) && hands.is_empty() {
        for (cloth, particles) in &cloths {
            // Grab the whole +Z edge (the last row, nearest the camera) by a
            // hand at its middle.
            let edge: Vec<u32> = (0..N).map(|i| (N - 1) * N + i).collect();
            let middle = edge
                .iter()
                .map(|&p| particles.positions[p as usize])
                .sum::<Vec3>()
                / N as f32;
            let hand = commands
                .spawn((
                    Hand { age: 0.0, cloth },
                    Transform::from_translation(middle),
                ))
                .id();
            let anchors = edge
                .iter()
                .fold(ClothAnchors::default(), |a, &p| a.with(p, hand));
            commands.entity(cloth).insert(anchors);
        }
    }
}

/// Moves the hand at the yank speed, then lets go of the cloth.
fn pull(
    mut commands: Commands,
    time: Res<Time>,
    mut hands: Query<(Entity, &mut Hand, &mut Transform)>,
) {
    for (entity, mut hand, mut transform) in &mut hands {
        let dt = time.delta_secs().min(YANK_TIME - hand.age).max(0.0);
        transform.translation += Vec3::new(0.0, -0.3 * YANK_SPEED, YANK_SPEED) * dt;
        hand.age += time.delta_secs();
        if hand.age >= YANK_TIME {
            // The anchors let go: the cloth flies on with the hand's speed.
            commands.entity(hand.cloth).remove::<ClothAnchors>();
            commands.entity(entity).despawn();
        }
    }
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
        Transform::from_translation(focus + Vec3::new(0.6, 0.35, 1.0).normalize() * radius)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(radius),
            yaw: Some(0.5),
            pitch: Some(0.3),
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

/// A gingham.png that fails to load (say, the example run outside its
/// repository) leaves a plain red cloth rather than an invisible one.
fn plain_if_no_texture(
    mut failed: MessageReader<AssetLoadFailedEvent<Image>>,
    fabric: Res<Fabric>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut panel: ResMut<ClothPanel>,
) {
    for event in failed.read() {
        warn!("{}: the cloth is drawn plain red", event.error);
        panel.notice = format!("{}: the cloth is drawn plain red", event.error);
        if let Some(mut material) = materials.get_mut(&fabric.0) {
            material.base_color_texture = None;
            material.base_color = Color::srgb(0.75, 0.15, 0.15);
        }
    }
}
