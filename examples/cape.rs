//! A cape on an animated character: a skinned body built in code walks a
//! circle, turns and jumps, wearing a cape skinned at the collar
//! (`ClothSkin`), kept off its back by a backstop and a capsule collider,
//! its long-range stretch bounded by tethers. The camera follows from
//! behind.
//!
//! `cargo run --release --example cape`
//!
//! Keys: `Space` jump, `Up`/`Down` walk faster or slower. Drag the cape to
//! pull it, scroll to zoom.

mod automation;

use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "Space: jump · Up/Down: walk faster/slower · drag the cape: pull · scroll: zoom";

/// Radius of the circle the character walks, m.
const CIRCLE: f32 = 1.4;
/// Height of the chest joint above the hips, m, and of the hips above the
/// ground.
const CHEST: f32 = 0.45;
const HIPS: f32 = 0.9;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: cape".into(),
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
        .add_systems(Update, (keys, follow))
        // The character moves in the fixed step, before the cloth reads it.
        .add_systems(FixedUpdate, walk.before(ClothSystems::Prepare))
        .run();
}

/// The character's gait: where it is on its circle and its jump.
#[derive(Component)]
struct Walker {
    /// Angle around the circle, rad.
    angle: f32,
    /// Walking speed, m/s.
    speed: f32,
    /// Seconds into the current jump, if jumping.
    jump: Option<f32>,
}

/// The chest joint, which leans with the gait.
#[derive(Component)]
struct Chest;

/// A body of `height` m from the feet and `radius` m as a skinned
/// cylinder: its lower half on joint 0 (hips), its upper half on joint 1
/// (chest), the middle blended; in bind space the hips sit at the origin.
fn body_mesh(radius: f32, height: f32) -> Mesh {
    let (sides, rings) = (12u32, 8u32);
    let mut positions = Vec::new();
    let (mut joints, mut weights) = (Vec::new(), Vec::new());
    for r in 0..=rings {
        let y = -HIPS + height * r as f32 / rings as f32;
        // Narrower at the top: shoulders, then the neck.
        let k = if y > CHEST + 0.1 { 0.6 } else { 1.0 };
        for s in 0..sides {
            let a = std::f32::consts::TAU * s as f32 / sides as f32;
            positions.push([k * radius * a.cos(), y, k * radius * a.sin()]);
            let t = ((y - 0.1) / 0.4).clamp(0.0, 1.0);
            joints.push([0u16, 1, 0, 0]);
            weights.push([1.0 - t, t, 0.0, 0.0]);
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..sides {
            let a = r * sides + s;
            let b = r * sides + (s + 1) % sides;
            let (c, d) = (b + sides, a + sides);
            indices.extend([a, d, c, a, c, b]);
        }
    }
    Mesh::new(PrimitiveTopology::TriangleList, default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            VertexAttributeValues::Uint16x4(joints),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights)
        .with_inserted_indices(Indices::U32(indices))
        .with_computed_smooth_normals()
}

/// The cape in bind space: 0.5 m wide and 0.85 m long behind the back (+Z),
/// its collar at the shoulders, skinned to the chest; the collar row
/// follows it (freedom 0), the next row may stray 9 cm, the rest is free.
fn cape_mesh() -> Mesh {
    let (cols, rows) = (9u32, 15u32);
    let mut positions = Vec::new();
    let (mut joints, mut weights, mut freedom) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..rows {
        for i in 0..cols {
            let u = i as f32 / (cols - 1) as f32;
            let y = CHEST + 0.08 - 0.85 * j as f32 / (rows - 1) as f32;
            // The collar wraps a little round the shoulders.
            let x = 0.25 * (2.0 * u - 1.0);
            // Behind: the character faces −Z.
            let z = 0.2 - 0.06 * (2.0 * u - 1.0).powi(2) * (1.0 - j as f32 / 3.0).max(0.0);
            positions.push([x, y, z]);
            joints.push([1u16, 0, 0, 0]);
            weights.push([1.0f32, 0.0, 0.0, 0.0]);
            freedom.push(match j {
                0 => 0.0f32,
                1 => 0.3,
                _ => 1.0,
            });
        }
    }
    let mut indices = Vec::new();
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            let a = j * cols + i;
            let (b, c, d) = (a + 1, a + 1 + cols, a + cols);
            indices.extend([a, d, c, a, c, b]);
        }
    }
    let uvs: Vec<[f32; 2]> = (0..rows)
        .flat_map(|j| {
            (0..cols).map(move |i| [i as f32 / (cols - 1) as f32, j as f32 / (rows - 1) as f32])
        })
        .collect();
    Mesh::new(PrimitiveTopology::TriangleList, default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            VertexAttributeValues::Uint16x4(joints),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights)
        .with_inserted_attribute(ATTRIBUTE_FREEDOM, freedom)
        .with_inserted_indices(Indices::U32(indices))
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut bindposes: ResMut<Assets<SkinnedMeshInverseBindposes>>,
) {
    stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(CIRCLE, 1.1, 0.0),
        3.0,
    );
    // The skeleton: hips (the walker) and chest, with a capsule collider
    // around the torso for the cape and anything else.
    let hips = commands
        .spawn((
            Transform::from_xyz(CIRCLE, HIPS, 0.0),
            Walker {
                angle: 0.0,
                speed: 1.4,
                jump: None,
            },
            ClothCollider::capsule(0.2, 0.35),
        ))
        .id();
    let chest = commands
        .spawn((Transform::from_xyz(0.0, CHEST, 0.0), Chest, ChildOf(hips)))
        .id();
    let binds = [
        Mat4::IDENTITY,
        Mat4::from_translation(Vec3::new(0.0, -CHEST, 0.0)),
    ];
    let skin = SkinnedMesh {
        inverse_bindposes: bindposes.add(binds.to_vec()),
        joints: vec![hips, chest],
    };
    commands.spawn((
        Mesh3d(meshes.add(body_mesh(0.19, HIPS + 0.7))),
        MeshMaterial3d(materials.add(Color::srgb(0.25, 0.3, 0.38))),
        skin.clone(),
        Transform::default(),
    ));
    // The head rides on the chest.
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(0.12))),
        MeshMaterial3d(materials.add(Color::srgb(0.85, 0.7, 0.58))),
        Transform::from_xyz(0.0, 0.5, 0.0),
        ChildOf(chest),
    ));
    // The cape: a mesh cloth, skinned at the collar to the chest.
    let mesh = cape_mesh();
    let cloth = ClothBuilder::from_mesh(&mesh)
        .material(ClothMaterial::DENIM)
        .build()
        .expect("a valid cape");
    let layout = cloth.cloth.mesh().expect("a mesh cloth").clone();
    // The cape wears the body's skeleton: its joints and bind poses.
    let worn = ClothSkin::from_skinned_mesh(
        &mesh,
        &layout,
        (&skin, &bindposes),
        ATTRIBUTE_FREEDOM.name,
        0.3,
    )
    .expect("the cape's skin")
    // Off the back: a capsule down the spine, in the hips' space.
    .with_backstop(
        0,
        (Vec3::new(0.0, -0.3, 0.0), Vec3::new(0.0, 0.4, 0.0)),
        0.19,
    );
    commands.spawn((
        cloth,
        worn,
        ClothTethers::default(),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.75, 0.08, 0.1),
            perceptual_roughness: 0.8,
            double_sided: true,
            cull_mode: None,
            ..default()
        })),
    ));
}

/// Walks the character round its circle, facing where it goes, leaning
/// its chest with each step, and jumping when asked.
fn walk(
    time: Res<Time>,
    mut walkers: Query<(&mut Walker, &mut Transform), Without<Chest>>,
    mut chests: Query<&mut Transform, With<Chest>>,
) {
    let dt = time.delta_secs();
    for (mut walker, mut transform) in &mut walkers {
        walker.angle += walker.speed / CIRCLE * dt;
        let a = walker.angle;
        let lift = match walker.jump {
            Some(t) if t < 0.6 => {
                walker.jump = Some(t + dt);
                let s = t / 0.6;
                4.0 * 0.45 * s * (1.0 - s)
            }
            Some(_) => {
                walker.jump = None;
                0.0
            }
            None => 0.0,
        };
        // A little bob with each step.
        let bob = 0.03 * (2.0 * a * CIRCLE / 0.7).sin().abs();
        transform.translation = Vec3::new(CIRCLE * a.cos(), HIPS + bob + lift, -CIRCLE * a.sin());
        // Facing along the circle (its tangent, anticlockwise seen from above).
        transform.rotation = Quat::from_rotation_y(a);
        for mut chest in &mut chests {
            chest.rotation = Quat::from_rotation_z(0.08 * (2.0 * a * CIRCLE / 0.7).sin());
        }
    }
}

/// Keeps the camera behind the character, a little to its side.
fn follow(walkers: Query<(&Walker, &Transform)>, mut cameras: Query<&mut PanOrbitCamera>) {
    let Ok((walker, at)) = walkers.single() else {
        return;
    };
    for mut camera in &mut cameras {
        camera.target_focus = at.translation + Vec3::new(0.0, 0.2, 0.0);
        camera.target_yaw = walker.angle + 0.6;
    }
}

fn keys(input: Res<ButtonInput<KeyCode>>, mut walkers: Query<&mut Walker>) {
    for mut walker in &mut walkers {
        if input.just_pressed(KeyCode::Space) && walker.jump.is_none() {
            walker.jump = Some(0.0);
        }
        if input.just_pressed(KeyCode::ArrowUp) {
            walker.speed = (walker.speed + 0.5).min(6.0);
        }
        if input.just_pressed(KeyCode::ArrowDown) {
            walker.speed = (walker.speed - 0.5).max(0.0);
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
        Transform::from_translation(focus + Vec3::new(0.2, 0.45, 1.0).normalize() * radius)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(radius),
            yaw: Some(0.2),
            pitch: Some(0.4),
            ..default()
        },
        // A headlight, so the side of the cape the camera sees is lit
        // whichever way the character faces the sun.
        children![(
            DirectionalLight {
                illuminance: 4_000.0,
                ..default()
            },
            Transform::default(),
        )],
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
