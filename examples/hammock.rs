//! A canvas hammock between two posts, and avian balls of different masses
//! dropped into it: the cloth holds them, they roll together to its lowest
//! point, and the cloth and the balls push each other both ways.
//!
//! `cargo run --release --features avian --example hammock`
//!
//! Keys: `Space` drops a ball (a 5 kg ball, a 2 kg ball, a 0.5 kg ball and
//! a 0.1 kg beach ball in turn), `R` clears them. Drag the hammock to
//! pull it, drag elsewhere to orbit, scroll to zoom.

mod automation;

use avian3d::prelude::*;
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::plugin::bridges::avian::ClothAvianPlugin;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str =
    "Space: drop a ball · R: clear the balls · drag the hammock: pull · drag: orbit · scroll: zoom";

/// Height of the posts' hooks, m.
const HOOKS: f32 = 1.2;
/// Length along the hammock and width across it, m.
const LENGTH: f32 = 1.8;
const WIDTH: f32 = 0.8;
/// Distance between the hooks, m: the canvas sags between them.
const SPAN: f32 = 1.5;

/// The balls `Space` drops, in turn: mass (kg), radius (m), colour, and
/// where along the hammock it is dropped (m): the later ones to the side of
/// the first, to land on the canvas and roll down to them.
const BALLS: [(f32, f32, Color, f32); 4] = [
    (5.0, 0.14, Color::srgb(0.25, 0.25, 0.28), 0.3),
    (2.0, 0.12, Color::srgb(0.3, 0.75, 0.35), -0.35),
    (0.5, 0.1, Color::srgb(0.2, 0.6, 0.9), 0.5),
    (0.1, 0.16, Color::srgb(0.95, 0.8, 0.2), -0.5),
];

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: hammock".into(),
                resolution: (1024u32, 640u32).into(),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((EguiPlugin::default(), PanOrbitCameraPlugin))
        // avian, and the bridge that makes its colliders cloth colliders
        // and lets its dynamic bodies and the cloth push each other.
        .add_plugins((PhysicsPlugins::default(), ClothAvianPlugin::default()))
        .add_plugins((MeshPickingPlugin, ClothPlugin::default(), ClothPanelPlugin))
        .insert_resource(ClothPanel::with_help(HELP))
        // Scripted runs for the rendering check (`--frames`, `--screenshot`,
        // `--press`): delete this line and the example runs the same.
        .add_plugins(automation::AutomationPlugin)
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, orbit_unless_on_cloth))
        .run();
}

/// The balls' meshes and looks, and which one drops next.
#[derive(Resource)]
struct Balls {
    looks: Vec<(Handle<Mesh>, Handle<StandardMaterial>)>,
    next: usize,
}

/// Marks a dropped ball.
#[derive(Component)]
struct Ball;

/// The canvas: 37 × 17 particles 5 cm apart, its short edges gathered on
/// the hooks, hanging in the arc its length makes between them.
fn hammock() -> ClothBundle {
    let mut cloth = ClothBuilder::new(37, 17)
        .size(LENGTH, WIDTH)
        .material(ClothMaterial::DENIM)
        .total_mass(0.6)
        .position(Vec3::new(0.0, HOOKS, 0.0))
        .pin_edge(GridEdge::Left)
        .pin_edge(GridEdge::Right)
        .build()
        .expect("a valid cloth");
    // An arc of length LENGTH over the chord SPAN: half-angle φ with
    // sin φ / φ = SPAN / LENGTH, found by a few Newton steps.
    let ratio = SPAN / LENGTH;
    let mut phi = 1.0f32;
    for _ in 0..20 {
        let f = phi.sin() / phi - ratio;
        let df = (phi * phi.cos() - phi.sin()) / (phi * phi);
        phi -= f / df;
    }
    let radius = 0.5 * LENGTH / phi;
    for p in &mut cloth.particles.positions {
        let a = p.x / radius;
        // Gathered towards the ends, to 40 % of the width at the hooks, so
        // the canvas cradles what lies in it.
        let gather = 1.0 - 0.6 * (p.x / (0.5 * LENGTH)).powi(4);
        *p = Vec3::new(
            radius * a.sin(),
            HOOKS - radius * (a.cos() - phi.cos()),
            p.z * gather,
        );
    }
    cloth
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let focus = Vec3::new(0.0, 0.8, 0.0);
    commands.spawn((
        Camera3d::default(),
        Transform::from_translation(focus + Vec3::new(0.5, 0.6, 1.0).normalize() * 3.2)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(3.2),
            yaw: Some(0.45),
            pitch: Some(0.5),
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
    // The ground: avian's, and so the cloth's too.
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(12.0, 12.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.45, 0.55, 0.4),
            perceptual_roughness: 1.0,
            ..default()
        })),
        RigidBody::Static,
        Collider::half_space(Vec3::Y),
    ));
    // Two posts, a little outside the hooks.
    let wood = materials.add(StandardMaterial {
        base_color: Color::srgb(0.42, 0.27, 0.15),
        perceptual_roughness: 0.7,
        ..default()
    });
    let post = meshes.add(Cylinder::new(0.05, HOOKS + 0.2));
    for x in [-0.5 * SPAN - 0.08, 0.5 * SPAN + 0.08] {
        for z in [-0.5 * WIDTH, 0.5 * WIDTH] {
            commands.spawn((
                Mesh3d(post.clone()),
                MeshMaterial3d(wood.clone()),
                Transform::from_xyz(x, 0.5 * (HOOKS + 0.2), z),
                RigidBody::Static,
                Collider::cylinder(0.05, HOOKS + 0.2),
            ));
        }
    }
    let canvas = materials.add(StandardMaterial {
        base_color: Color::srgb(0.75, 0.2, 0.15),
        perceptual_roughness: 0.9,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    commands.spawn((hammock(), MeshMaterial3d(canvas)));
    let looks = BALLS
        .iter()
        .map(|&(_, radius, colour, _)| {
            (
                meshes.add(Sphere::new(radius)),
                materials.add(StandardMaterial {
                    base_color: colour,
                    perceptual_roughness: 0.5,
                    ..default()
                }),
            )
        })
        .collect();
    commands.insert_resource(Balls { looks, next: 0 });
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    mut balls: ResMut<Balls>,
    dropped: Query<Entity, With<Ball>>,
) {
    if input.just_pressed(KeyCode::KeyR) {
        for ball in &dropped {
            commands.entity(ball).despawn();
        }
        balls.next = 0;
    }
    if input.just_pressed(KeyCode::Space) {
        let k = balls.next % BALLS.len();
        let (mass, radius, _, x) = BALLS[k];
        let (mesh, look) = balls.looks[k].clone();
        commands.spawn((
            Ball,
            Mesh3d(mesh),
            MeshMaterial3d(look),
            Transform::from_xyz(x, HOOKS + 0.4, 0.05),
            RigidBody::Dynamic,
            Collider::sphere(radius),
            Mass(mass),
        ));
        balls.next += 1;
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
