//! A pennant on a pole in gusty wind: a triangle mesh cloth loaded from
//! glTF (`assets/pennant.gltf`), pinned along its hoist by a vertex
//! attribute painted into the file.
//!
//! `cargo run --release --example flag`
//!
//! Keys: `W` next wind (calm, breeze, gusty, storm), `R` hoist it again.
//! Drag the pennant to pull it, drag elsewhere to orbit, scroll to zoom.

mod automation;

use bevy::gltf::{GltfAssetLabel, GltfPlugin};
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str =
    "W: next wind · R: hoist it again · drag the pennant: pull · drag: orbit · scroll: zoom";

/// Height of the pennant's hoist centre on the pole, m.
const HOIST: f32 = 1.9;
/// The winds `W` steps through: name and mean speed (m/s), blowing along
/// +X with a little along +Z, gusting by ±50 %.
const WINDS: [(&str, f32); 4] = [
    ("calm", 0.0),
    ("breeze", 4.0),
    ("gusty", 8.0),
    ("storm", 16.0),
];

fn main() {
    App::new()
        .add_plugins(
            DefaultPlugins
                .set(WindowPlugin {
                    primary_window: Some(Window {
                        title: "bevy_cloth: flag".into(),
                        resolution: (1024u32, 640u32).into(),
                        ..default()
                    }),
                    ..default()
                })
                // The file's `_PIN` attribute (1 on the hoist) becomes
                // `ATTRIBUTE_PIN`; Bevy's loader names it without the `_`.
                .set(GltfPlugin::default().add_custom_vertex_attribute("PIN", ATTRIBUTE_PIN)),
        )
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
        .insert_resource(wind(2))
        .add_systems(Update, orbit_unless_on_cloth)
        .add_systems(Startup, setup)
        .add_systems(Update, (hoist_when_loaded, keys))
        .run();
}

/// The pennant's mesh as loaded, and its look.
#[derive(Resource)]
struct Pennant {
    mesh: Handle<Mesh>,
    look: Handle<StandardMaterial>,
}

/// Wind number `k` of [`WINDS`].
fn wind(k: usize) -> ClothWind {
    let speed = WINDS[k % WINDS.len()].1;
    ClothWind(Wind {
        velocity: Vec3::new(1.0, 0.0, 0.3).normalize() * speed,
        gust_amplitude: 0.5,
        gust_frequency: 0.7,
        ..default()
    })
}

/// The pennant's cloth, its hoist against the pole.
fn pennant(mesh: &Mesh) -> Result<ClothBundle, ClothError> {
    ClothBuilder::from_mesh(mesh)
        .material(ClothMaterial::SILK)
        .pin_attribute(ATTRIBUTE_PIN.name)
        .position(Vec3::new(0.03, HOIST, 0.0))
        .build()
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
        Vec3::new(0.6, 1.5, 0.0),
        3.2,
    );
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.025, HOIST + 0.4))),
        MeshMaterial3d(materials.add(Color::srgb(0.75, 0.75, 0.78))),
        Transform::from_xyz(0.0, (HOIST + 0.4) / 2.0, 0.0),
    ));
    commands.insert_resource(Pennant {
        mesh: assets.load(
            GltfAssetLabel::Primitive {
                mesh: 0,
                primitive: 0,
            }
            .from_asset("pennant.gltf"),
        ),
        look: materials.add(StandardMaterial {
            base_color: Color::srgb(0.8, 0.1, 0.12),
            perceptual_roughness: 0.7,
            double_sided: true,
            cull_mode: None,
            ..default()
        }),
    });
}

/// Spawns the pennant once its mesh has loaded (and again after `R`, which
/// despawns it).
fn hoist_when_loaded(
    mut commands: Commands,
    pennant_mesh: Res<Pennant>,
    meshes: Res<Assets<Mesh>>,
    assets: Res<AssetServer>,
    cloths: Query<(), With<Cloth>>,
    mut panel: ResMut<ClothPanel>,
    mut failed: Local<bool>,
) {
    if !cloths.is_empty() || *failed {
        return;
    }
    if let Some(bevy::asset::LoadState::Failed(error)) = assets.get_load_state(&pennant_mesh.mesh) {
        error!("the pennant did not load: {error}");
        // On screen too: the player may not see the log.
        panel.notice = format!("The pennant did not load, so there is no cloth: {error}");
        *failed = true;
        return;
    }
    let Some(mesh) = meshes.get(&pennant_mesh.mesh) else {
        return;
    };
    match pennant(mesh) {
        Ok(cloth) => {
            commands.spawn((cloth, MeshMaterial3d(pennant_mesh.look.clone())));
        }
        Err(error) => {
            error!("the pennant is not a cloth: {error}");
            panel.notice = format!("The pennant is not a cloth: {error}");
            *failed = true;
        }
    }
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    mut which: Local<Option<usize>>,
    cloths: Query<Entity, With<Cloth>>,
) {
    if input.just_pressed(KeyCode::KeyW) {
        let next = (which.unwrap_or(2) + 1) % WINDS.len();
        *which = Some(next);
        info!("wind: {} ({} m/s)", WINDS[next].0, WINDS[next].1);
        commands.insert_resource(wind(next));
    }
    if input.just_pressed(KeyCode::KeyR) {
        for cloth in &cloths {
            commands.entity(cloth).despawn();
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
        Transform::from_translation(focus + Vec3::new(0.3, 0.2, 1.0).normalize() * radius)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(radius),
            yaw: Some(0.3),
            pitch: Some(0.2),
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
