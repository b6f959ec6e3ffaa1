//! The paper's §6.1 scene: a 15×15, 1 m cotton cloth pinned at two corners of
//! a bar, released flat so it swings down under gravity and settles.
//!
//! `cargo run --release --example hanging`
//!
//! Keys: `R` release it flat again, `M` switch Choi–Ko / Lander, `I` next
//! integrator (backward Euler, BDF2, explicit Euler, symplectic Euler, RK4).
//! Drag to orbit, scroll to zoom.

mod automation;

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str =
    "R: release again · M: Choi–Ko / Lander · I: next integrator · drag: orbit · scroll: zoom";

/// Height of the bar the cloth hangs from, m.
const BAR: f32 = 1.6;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: hanging".into(),
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

/// The cloth, flat and level behind the bar, its two pinned corners moved
/// 10 cm inwards so it hangs with slack and folds (pinned exactly one width
/// apart it could only hang flat).
fn cloth() -> ClothBundle {
    let mut cloth = ClothBuilder::new(15, 15)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, BAR, 0.5))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .expect("a valid cloth");
    cloth.particles.positions[0].x += 0.1;
    cloth.particles.positions[14].x -= 0.1;
    cloth
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
        Vec3::new(0.0, 1.1, 0.0),
        3.2,
    );
    // The bar and its two posts.
    let wood = materials.add(Color::srgb(0.45, 0.3, 0.18));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.02, 1.1))),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, BAR + 0.02, 0.0)
            .with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
    ));
    for x in [-0.55, 0.55] {
        commands.spawn((
            Mesh3d(meshes.add(Cylinder::new(0.025, BAR + 0.04))),
            MeshMaterial3d(wood.clone()),
            Transform::from_xyz(x, (BAR + 0.04) / 2.0, 0.0),
        ));
    }
    commands.spawn(cloth());
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut defaults: ResMut<ClothSettingsDefaults>,
    mut cloths: Query<(&mut ClothParticles, &mut ClothConnections), With<Cloth>>,
) {
    if input.just_pressed(KeyCode::KeyR) {
        let fresh = cloth();
        for (mut particles, mut connections) in &mut cloths {
            *particles = fresh.particles.clone();
            *connections = fresh.connections.clone();
        }
    }
    if input.just_pressed(KeyCode::KeyM) {
        defaults.model = match defaults.model {
            ClothModel::ChoiKo => ClothModel::Lander,
            ClothModel::Lander => ClothModel::ChoiKo,
        };
    }
    if input.just_pressed(KeyCode::KeyI) {
        // The next integrator; the explicit ones take as many substeps as
        // the cloth needs (adaptive substeps, on by default).
        let all = Integrator::ALL;
        let next = all
            .iter()
            .position(|&i| i == defaults.integrator)
            .map_or(0, |k| k + 1);
        defaults.integrator = all[next % all.len()];
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
