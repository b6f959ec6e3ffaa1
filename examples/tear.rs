//! Tearing and cutting: two banners hang from a bar. Hold `Shift` and drag
//! the mouse across the left one to slash it (`ClothCut`); press `P` and a
//! hand pulls the right one's lower edge down until it tears under the
//! strain (`ClothTearing`, at silk's tear strain).
//!
//! `cargo run --release --example tear`
//!
//! Keys: `K` slashes the left banner across its middle, `P` pulls the
//! right one, `R` hangs both again. Shift + drag: cut; left drag: pull;
//! right click: pin.

mod automation;

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::picking::pointer::{PointerId, PointerLocation};
use bevy::prelude::*;
use bevy::shape::Ray3d;
use bevy_cloth::plugin::interaction::ClothPicking;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "Shift + drag across a banner: cut · K: slash the left one · P: pull the right one · R: hang them again";

/// The bar the banners hang from, m above the floor.
const BAR: f32 = 2.2;
/// Each banner: 1 m wide, 1.4 m long, 25 × 35 particles.
const WIDTH: f32 = 1.0;
const LENGTH: f32 = 1.4;
const COLS: u32 = 25;
const ROWS: u32 = 35;
/// Where the hand pulls the right banner's lower edge, m/s.
const PULL_SPEED: f32 = 0.6;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: tear".into(),
                resolution: (1024u32, 640u32).into(),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((EguiPlugin::default(), PanOrbitCameraPlugin))
        // Bevy's mesh picking (how the mouse reaches a cloth), the
        // simulation (the left button pulls a cloth, the right one pins),
        // its panel.
        .add_plugins((MeshPickingPlugin, ClothPlugin::default(), ClothPanelPlugin))
        .insert_resource(ClothPanel::with_help(HELP))
        // Scripted runs for the rendering check (`--frames`, `--screenshot`):
        // delete this line and the example runs the same.
        .add_plugins(automation::AutomationPlugin)
        .add_systems(Startup, setup)
        .add_systems(Update, (orbit_unless_on_cloth, slash, keys))
        .add_systems(FixedUpdate, pull.before(ClothSystems::Prepare))
        .add_observer(|torn: On<ClothTorn>| {
            info!(
                "cloth torn: {} links, {} particles split",
                torn.links.len(),
                torn.split.len()
            );
        })
        .run();
}

/// Which banner a cloth is.
#[derive(Component, Clone, Copy, PartialEq)]
enum Banner {
    /// The left one, for cutting.
    Cut,
    /// The right one, which tears when pulled.
    Torn,
}

/// The hand pulling the right banner's lower edge: how far it has moved
/// (m), while it pulls.
#[derive(Resource, Default)]
struct Hand(Option<f32>);

/// A banner hanging from the bar at `x` (m), its top edge pinned.
fn banner(x: f32, material: ClothMaterial) -> ClothBundle {
    ClothBuilder::new(COLS, ROWS)
        .size(WIDTH, LENGTH)
        .material(material)
        .position(Vec3::new(x, BAR - LENGTH / 2.0, 0.0))
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .pin_edge(GridEdge::Top)
        .build()
        .expect("a valid banner")
}

fn hang(commands: &mut Commands) {
    commands.spawn((banner(-0.65, ClothMaterial::COTTON), Banner::Cut));
    commands.spawn((
        banner(0.65, ClothMaterial::SILK),
        Banner::Torn,
        // Tears where silk does (25 % strain), a few links a step.
        ClothTearing::default(),
    ));
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let focus = Vec3::new(0.4, 1.3, 0.0);
    commands.spawn((
        Camera3d::default(),
        Transform::from_translation(focus + Vec3::new(0.0, 0.15, 1.0).normalize() * 3.6)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(3.6),
            yaw: Some(0.0),
            pitch: Some(0.15),
            ..default()
        },
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(2.0, 5.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(12.0, 12.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.55, 0.58, 0.52),
            perceptual_roughness: 1.0,
            ..default()
        })),
        ClothCollider::plane().with_friction(0.6),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.02, 2.8))),
        MeshMaterial3d(materials.add(Color::srgb(0.75, 0.75, 0.78))),
        Transform::from_xyz(0.0, BAR + 0.02, 0.0)
            .with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
    ));
    commands.init_resource::<Hand>();
    hang(&mut commands);
}

/// Shift + drag slashes every cloth under the pointer's path: the surface
/// the camera's ray sweeps between two frames is the blade. Picking is off
/// meanwhile, so the press grabs nothing.
fn slash(
    mouse: Res<ButtonInput<MouseButton>>,
    keys: Res<ButtonInput<KeyCode>>,
    pointers: Query<(&PointerId, &PointerLocation)>,
    camera: Single<(&Camera, &GlobalTransform)>,
    mut picking: ResMut<ClothPicking>,
    mut last: Local<Option<Ray3d>>,
    mut cuts: MessageWriter<ClothCut>,
) {
    let shift = keys.any_pressed([KeyCode::ShiftLeft, KeyCode::ShiftRight]);
    picking.enabled = !shift;
    let (camera, at) = *camera;
    let ray = pointers
        .iter()
        .find(|(id, _)| id.is_mouse())
        .and_then(|(_, location)| location.location())
        .and_then(|location| camera.viewport_to_world(at, location.position).ok());
    if !(shift && mouse.pressed(MouseButton::Left)) {
        *last = None;
        return;
    }
    if let (Some(from), Some(to)) = (*last, ray) {
        cuts.write(ClothCut::between_rays(None, from, to, 20.0));
    }
    *last = ray;
}

/// The hand holds the right banner's lower edge and moves it down at
/// [`PULL_SPEED`] for two seconds, then lets go.
fn pull(
    time: Res<Time>,
    mut hand: ResMut<Hand>,
    mut banners: Query<(&Banner, &ClothParticles, &mut ClothGrabs)>,
) {
    let Some(moved) = hand.0 else {
        return;
    };
    let dt = time.delta_secs();
    for (banner, particles, mut grabs) in &mut banners {
        if *banner != Banner::Torn {
            continue;
        }
        if moved == 0.0 {
            for col in 0..COLS {
                let p = (ROWS - 1) * COLS + col;
                grabs.grab(p, particles.positions[p as usize], GrabMode::Kinematic);
            }
        } else if moved >= 2.0 * PULL_SPEED {
            grabs.release_all();
        } else {
            let held: Vec<(u32, Vec3)> = grabs
                .grabs()
                .iter()
                .map(|g| (g.particle, g.target))
                .collect();
            for (p, target) in held {
                grabs.set_target(p, target - Vec3::Y * PULL_SPEED * dt);
            }
        }
    }
    hand.0 = (moved < 2.0 * PULL_SPEED).then_some(moved + PULL_SPEED * dt);
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    mut hand: ResMut<Hand>,
    banners: Query<(Entity, &Banner)>,
    mut cuts: MessageWriter<ClothCut>,
) {
    for (entity, banner) in &banners {
        if input.just_pressed(KeyCode::KeyK) && *banner == Banner::Cut {
            let y = BAR - 0.55 * LENGTH;
            cuts.write(ClothCut::along(
                Some(entity),
                Vec3::new(-1.5, y + 0.1, 0.0),
                Vec3::new(0.2, y - 0.1, 0.0),
                Vec3::Z * 0.5,
            ));
        }
        if input.just_pressed(KeyCode::KeyR) {
            commands.entity(entity).despawn();
        }
    }
    if input.just_pressed(KeyCode::KeyR) {
        hand.0 = None;
        hang(&mut commands);
    }
    if input.just_pressed(KeyCode::KeyP) && hand.0.is_none() {
        hand.0 = Some(0.0);
    }
}

/// The camera leaves the mouse alone while it is on a cloth (a press there
/// pulls the cloth), on the panel, or cutting.
fn orbit_unless_on_cloth(
    pointer: ClothPointer,
    keys: Res<ButtonInput<KeyCode>>,
    mut cameras: Query<&mut PanOrbitCamera>,
) {
    let cutting = keys.any_pressed([KeyCode::ShiftLeft, KeyCode::ShiftRight]);
    let free = !pointer.busy() && !cutting;
    for mut camera in &mut cameras {
        if camera.enabled != free {
            camera.enabled = free;
        }
    }
}
