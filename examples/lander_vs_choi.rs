//! The paper's §6.2 comparison to play with: two identical cloths side by
//! side, Choi–Ko's on the left and Lander's on the right, same stiffness,
//! damping and masses. Pull either with the mouse, or press `P` to run the
//! same scripted pull and release on both (the script of
//! `bevy_cloth::lab::compare`, whose figures the README quotes).
//!
//! `cargo run --release --example lander_vs_choi`
//!
//! Keys: `P` scripted pull on both, `R` reset. Left mouse: grab and pull;
//! right mouse: pin/unpin; drag elsewhere to orbit.

mod automation;

use std::f32::consts::FRAC_PI_2;

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "left: Choi–Ko · right: Lander · P: same scripted pull on both · R: reset · mouse: grab (left), pin (right) · drag: orbit";

/// Bar height (m) and the two cloths' centres along X (m).
const BAR: f32 = 1.8;
const SIDES: [(f32, ClothModel); 2] = [(-0.65, ClothModel::ChoiKo), (0.65, ClothModel::Lander)];

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: Lander vs Choi–Ko".into(),
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
        .add_systems(FixedUpdate, script.before(ClothSystems::Prepare))
        .run();
}

/// A running scripted pull: seconds since it began.
#[derive(Resource)]
struct Script(f32);

/// Which cloth is which.
#[derive(Component)]
struct Side(usize);

fn cloth(x: f32) -> ClothBundle {
    ClothBuilder::new(15, 15)
        .size(1.0, 1.0)
        .position(Vec3::new(x, BAR - 0.5, 0.0))
        .rotation(Quat::from_rotation_x(FRAC_PI_2))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
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
        Vec3::new(0.0, 1.2, 0.0),
        3.6,
    );
    let wood = materials.add(Color::srgb(0.45, 0.3, 0.18));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.02, 2.6))),
        MeshMaterial3d(wood),
        Transform::from_xyz(0.0, BAR + 0.02, 0.0).with_rotation(Quat::from_rotation_z(FRAC_PI_2)),
    ));
    for (i, (x, model)) in SIDES.into_iter().enumerate() {
        let colour = [Color::srgb(0.8, 0.2, 0.2), Color::srgb(0.2, 0.45, 0.8)][i];
        let material = materials.add(StandardMaterial {
            base_color: colour,
            perceptual_roughness: 0.9,
            double_sided: true,
            cull_mode: None,
            ..default()
        });
        commands.spawn((
            cloth(x),
            ClothSettings::default().with_model(model),
            MeshMaterial3d(material),
            Side(i),
        ));
    }
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    mut cloths: Query<(&Side, &mut ClothParticles, &mut ClothGrabs)>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        commands.insert_resource(Script(0.0));
    }
    if input.just_pressed(KeyCode::KeyR) {
        commands.remove_resource::<Script>();
        for (side, mut particles, mut grabs) in &mut cloths {
            grabs.release_all();
            *particles = cloth(SIDES[side.0].0).particles;
        }
    }
}

/// The script of `bevy_cloth::lab::compare`: the bottom-left corner is carried
/// 0.4 m towards the camera over 0.5 s, held 0.5 s and let go.
fn script(
    mut commands: Commands,
    time: Res<Time>,
    script: Option<ResMut<Script>>,
    mut cloths: Query<(&Side, &ClothParticles, &mut ClothGrabs)>,
) {
    let Some(mut script) = script else {
        return;
    };
    script.0 += time.delta_secs();
    let t = script.0;
    for (side, particles, mut grabs) in &mut cloths {
        let corner = 14 * 15;
        let rest = cloth(SIDES[side.0].0).particles.positions[corner];
        let goal = rest + Vec3::new(0.0, 0.0, 0.4);
        if t <= 1.0 {
            if grabs.is_empty() {
                grabs.grab(
                    corner as u32,
                    particles.positions[corner],
                    GrabMode::Kinematic,
                );
            }
            grabs.set_targets(rest.lerp(goal, (t / 0.5).min(1.0)));
        } else {
            grabs.release_all();
        }
    }
    if t > 1.0 {
        commands.remove_resource::<Script>();
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
