//! The paper's Fig. 5 sphere: a cloth dropped onto a ball, which the player
//! can then drive through it.
//!
//! `cargo run --release --example sphere`
//!
//! Keys: arrows or `W`/`A`/`S`/`D` move the ball, `Q`/`E` lower and raise
//! it, `Space` throws it up through the cloth at 4 m/s, `R` resets. Drag to
//! orbit, scroll to zoom.

mod automation;

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "arrows/WASD: move the ball · Q/E: lower/raise · Space: throw it up · R: reset · drag: orbit · scroll: zoom";

/// Ball radius and rest position, m.
const RADIUS: f32 = 0.3;
const HOME: Vec3 = Vec3::new(0.0, 0.6, 0.0);
/// How fast the keys move the ball, m/s.
const SPEED: f32 = 1.2;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: sphere".into(),
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
        // The ball moves in the fixed step, before the cloth reads it.
        .add_systems(
            FixedUpdate,
            (drive, fly).chain().before(ClothSystems::Prepare),
        )
        .run();
}

/// The ball, with its vertical velocity when thrown (m/s).
#[derive(Component)]
struct Ball {
    rise: f32,
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
        Vec3::new(0.0, 0.6, 0.0),
        3.0,
    );
    commands.spawn((
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    commands.spawn((
        Ball { rise: 0.0 },
        Mesh3d(meshes.add(Sphere::new(RADIUS).mesh().uv(48, 24))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.85, 0.75, 0.3),
            metallic: 0.2,
            perceptual_roughness: 0.4,
            ..default()
        })),
        Transform::from_translation(HOME),
        ClothCollider::sphere(RADIUS).with_friction(0.5),
    ));
    spawn_cloth(&mut commands, &mut materials);
}

/// A 1.2 m, 21 × 21 cloth held flat 0.5 m above the ball's top.
fn spawn_cloth(commands: &mut Commands, materials: &mut Assets<StandardMaterial>) {
    let cloth = ClothBuilder::new(21, 21)
        .size(1.2, 1.2)
        .position(HOME + Vec3::Y * (RADIUS + 0.5))
        .build()
        .expect("a valid cloth");
    let material = materials.add(StandardMaterial {
        base_color: Color::srgb(0.2, 0.45, 0.75),
        perceptual_roughness: 0.9,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    commands.spawn((
        cloth,
        MeshMaterial3d(material),
        ClothCollision {
            thickness: 0.008,
            ..default()
        },
    ));
}

/// Moves the ball while movement keys are held.
fn drive(
    input: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    mut ball: Single<&mut Transform, With<Ball>>,
) {
    let held = |keys: [KeyCode; 2]| keys.iter().any(|k| input.pressed(*k));
    let mut dir = Vec3::ZERO;
    for (keys, d) in [
        ([KeyCode::ArrowLeft, KeyCode::KeyA], Vec3::NEG_X),
        ([KeyCode::ArrowRight, KeyCode::KeyD], Vec3::X),
        ([KeyCode::ArrowUp, KeyCode::KeyW], Vec3::NEG_Z),
        ([KeyCode::ArrowDown, KeyCode::KeyS], Vec3::Z),
        ([KeyCode::KeyQ, KeyCode::KeyQ], Vec3::NEG_Y),
        ([KeyCode::KeyE, KeyCode::KeyE], Vec3::Y),
    ] {
        if held(keys) {
            dir += d;
        }
    }
    ball.translation += dir.normalize_or_zero() * SPEED * time.delta_secs();
    ball.translation.y = ball.translation.y.max(RADIUS);
}

/// Throws the ball and resets the scene.
fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut ball: Single<(&mut Transform, &mut Ball)>,
    cloths: Query<Entity, With<Cloth>>,
) {
    let (transform, ball) = &mut *ball;
    if input.just_pressed(KeyCode::Space) {
        ball.rise = 4.0;
    }
    if input.just_pressed(KeyCode::KeyR) {
        transform.translation = HOME;
        ball.rise = 0.0;
        for cloth in &cloths {
            commands.entity(cloth).despawn();
        }
        spawn_cloth(&mut commands, &mut materials);
    }
}

/// A thrown ball rises, slows under gravity and settles back home.
fn fly(time: Res<Time>, mut ball: Single<(&mut Transform, &mut Ball)>) {
    let (transform, ball) = &mut *ball;
    if ball.rise == 0.0 && transform.translation.y <= HOME.y {
        return;
    }
    let dt = time.delta_secs();
    ball.rise -= 9.81 * dt;
    transform.translation.y += ball.rise * dt;
    if transform.translation.y <= HOME.y && ball.rise < 0.0 {
        transform.translation.y = HOME.y;
        ball.rise = 0.0;
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
