//! The tablecloth trick: plates, a cup and a bottle, avian dynamic bodies,
//! stand on a cloth lying on a round table. Yanked out fast, the cloth
//! slides from under them and they stay where they stood, though where a
//! particle of the cloth catches at a dish's rim that dish is thrown (the
//! README's limitations say how often). Pulled slowly, friction carries
//! them along with the cloth.
//!
//! `cargo run --release --features avian --example tablecloth_trick`
//!
//! Keys: `Y` yanks the cloth out to the left (the hand reaches 7 m/s in
//! 0.1 s and travels 1.5 m, the cloth's length and more, then stops and
//! lets go), `S` pulls it slowly (0.5 m/s for 0.6 m), `R` lays the table
//! again. Drag the cloth to pull it, drag elsewhere to orbit, scroll to
//! zoom.

mod automation;

use avian3d::prelude::*;
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::plugin::bridges::avian::ClothAvianPlugin;
use bevy_cloth::prelude::*;
use bevy_egui::EguiPlugin;
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "Y: yank the cloth out · S: pull it slowly · R: lay the table again · drag the cloth: pull · drag: orbit · scroll: zoom";

/// Height of the table top's upper face, m.
const TOP: f32 = 0.78;
/// Radius of the round table top, m: the cloth lies wholly on it.
const RADIUS: f32 = 0.75;
/// The cloth: 1 m square, 41 × 41 particles (2.5 cm apart).
const SIZE: f32 = 1.0;
const N: u32 = 41;
/// The yank: top speed (m/s), the time the hand takes to reach it (s),
/// and how far it travels (m).
const YANK: (f32, f32, f32) = (7.0, 0.1, 1.5);
/// The slow pull: speed (m/s), no run-up, distance (m).
const SLOW: (f32, f32, f32) = (0.5, 0.0, 0.6);

/// How long the hand holds the cloth after it stops, s.
const HOLD: f32 = 0.3;

/// A dish: an upright cylinder.
struct Dish {
    /// Where it stands on the table (x, z), m.
    at: (f32, f32),
    /// Radius and height, m.
    radius: f32,
    height: f32,
    /// Mass, kg.
    mass: f32,
    colour: Color,
}

const CHINA: Color = Color::srgb(0.93, 0.93, 0.9);

/// Two plates, a cup and a squat bottle (a tall narrow one tips over at
/// the friction a cloth pulled from under it gives).
const DISHES: [Dish; 4] = [
    Dish {
        at: (0.1, -0.19),
        radius: 0.11,
        height: 0.02,
        mass: 0.5,
        colour: CHINA,
    },
    Dish {
        at: (0.1, 0.25),
        radius: 0.11,
        height: 0.02,
        mass: 0.5,
        colour: CHINA,
    },
    Dish {
        at: (-0.25, -0.17),
        radius: 0.04,
        height: 0.09,
        mass: 0.25,
        colour: Color::srgb(0.2, 0.35, 0.6),
    },
    Dish {
        at: (-0.25, 0.18),
        radius: 0.05,
        height: 0.25,
        mass: 0.9,
        colour: Color::srgb(0.15, 0.45, 0.25),
    },
];
/// Friction of the dishes' bases (avian combines it with the cloth's).
const DISH_FRICTION: f32 = 0.2;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: the tablecloth trick".into(),
                resolution: (1024u32, 640u32).into(),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((EguiPlugin::default(), PanOrbitCameraPlugin))
        // avian, and the bridge that makes its colliders cloth colliders
        // and lets the cloth and the dishes push each other.
        .add_plugins((PhysicsPlugins::default(), ClothAvianPlugin::default()))
        .add_plugins((MeshPickingPlugin, ClothPlugin::default(), ClothPanelPlugin))
        .insert_resource(ClothPanel::with_help(HELP))
        // Scripted runs for the rendering check (`--frames`, `--screenshot`,
        // `--press`): delete this line and the example runs the same.
        .add_plugins(automation::AutomationPlugin)
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, orbit_unless_on_cloth))
        // The hand moves in the fixed step, before the cloth reads it.
        .add_systems(FixedUpdate, pull.before(ClothSystems::Prepare))
        .run();
}

/// The looks of the cloth and the dishes, kept to lay the table again.
#[derive(Resource)]
struct Looks {
    cloth: Handle<StandardMaterial>,
    dishes: Vec<(Handle<Mesh>, Handle<StandardMaterial>)>,
}

/// Marks what `R` clears: the cloth and the dishes.
#[derive(Component)]
struct Laid;

/// The hand pulling the cloth's left edge along −X.
#[derive(Component)]
struct Hand {
    /// The cloth it holds.
    cloth: Entity,
    /// Top speed (m/s), run-up time (s), distance (m).
    pull: (f32, f32, f32),
    /// Time since it began (s), distance travelled (m), and time since it
    /// stopped (s).
    age: f32,
    travelled: f32,
    stopped: f32,
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let focus = Vec3::new(-0.3, 0.5, 0.0);
    commands.spawn((
        Camera3d::default(),
        Transform::from_translation(focus + Vec3::new(0.3, 0.45, 1.0).normalize() * 3.4)
            .looking_at(focus, Vec3::Y),
        PanOrbitCamera {
            focus,
            radius: Some(3.4),
            yaw: Some(0.3),
            pitch: Some(0.42),
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
    // The floor, the round top and its pedestal: avian's colliders, and so
    // the cloth's too.
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(12.0, 12.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.55, 0.58, 0.52),
            perceptual_roughness: 1.0,
            ..default()
        })),
        RigidBody::Static,
        Collider::half_space(Vec3::Y),
    ));
    let wood = materials.add(StandardMaterial {
        base_color: Color::srgb(0.42, 0.27, 0.15),
        perceptual_roughness: 0.6,
        ..default()
    });
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(RADIUS, 0.04))),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, TOP - 0.02, 0.0),
        RigidBody::Static,
        Collider::cylinder(RADIUS, 0.04),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.06, TOP - 0.04))),
        MeshMaterial3d(wood),
        Transform::from_xyz(0.0, (TOP - 0.04) / 2.0, 0.0),
        RigidBody::Static,
        Collider::cylinder(0.06, TOP - 0.04),
    ));
    let looks = Looks {
        cloth: materials.add(StandardMaterial {
            base_color: Color::srgb(0.75, 0.15, 0.15),
            perceptual_roughness: 0.95,
            double_sided: true,
            cull_mode: None,
            ..default()
        }),
        dishes: DISHES
            .iter()
            .map(|dish| {
                (
                    meshes.add(Cylinder::new(dish.radius, dish.height)),
                    materials.add(StandardMaterial {
                        base_color: dish.colour,
                        perceptual_roughness: 0.3,
                        ..default()
                    }),
                )
            })
            .collect(),
    };
    lay_the_table(&mut commands, &looks);
    commands.insert_resource(looks);
}

/// The cloth lying on the table top, and the dishes standing on it.
fn lay_the_table(commands: &mut Commands, looks: &Looks) {
    let cloth = ClothBuilder::new(N, N)
        .size(SIZE, SIZE)
        .position(Vec3::new(0.0, TOP + 0.005, 0.0))
        .build()
        .expect("a valid cloth");
    commands.spawn((Laid, cloth, MeshMaterial3d(looks.cloth.clone())));
    for (dish, (mesh, look)) in DISHES.iter().zip(&looks.dishes) {
        let (x, z) = dish.at;
        commands.spawn((
            Laid,
            Mesh3d(mesh.clone()),
            MeshMaterial3d(look.clone()),
            // On the cloth: its particles lie 5 mm above the top, and the
            // dish 5 mm above them.
            Transform::from_xyz(x, TOP + 0.0105 + dish.height / 2.0, z),
            RigidBody::Dynamic,
            Collider::cylinder(dish.radius, dish.height),
            Mass(dish.mass),
            Friction::new(DISH_FRICTION),
        ));
    }
}

fn keys(
    mut commands: Commands,
    input: Res<ButtonInput<KeyCode>>,
    looks: Res<Looks>,
    laid: Query<Entity, With<Laid>>,
    hands: Query<Entity, With<Hand>>,
    mut cloths: Query<(Entity, &ClothParticles, &mut ClothGrabs)>,
) {
    if input.just_pressed(KeyCode::KeyR) {
        for entity in laid.iter().chain(&hands) {
            commands.entity(entity).despawn();
        }
        lay_the_table(&mut commands, &looks);
        return;
    }
    let pull = if input.just_pressed(KeyCode::KeyY) {
        YANK
    } else if input.just_pressed(KeyCode::KeyS) {
        SLOW
    } else {
        return;
    };
    if !hands.is_empty() {
        return;
    }
    for (cloth, particles, mut grabs) in &mut cloths {
        // The hand takes the whole left edge where it lies.
        for p in edge() {
            grabs.grab(p, particles.positions[p as usize], GrabMode::Kinematic);
        }
        commands.spawn(Hand {
            cloth,
            pull,
            age: 0.0,
            travelled: 0.0,
            stopped: 0.0,
        });
    }
}

/// The particles the hand holds: the cloth's left edge (its first column).
fn edge() -> impl Iterator<Item = u32> {
    (0..N).map(|row| row * N)
}

/// Moves the hand: up to its speed over its run-up, for its distance; then
/// it stops, holds the cloth a moment and lets it fall.
fn pull(
    mut commands: Commands,
    time: Res<Time>,
    mut hands: Query<(Entity, &mut Hand)>,
    mut cloths: Query<&mut ClothGrabs>,
) {
    let dt = time.delta_secs();
    for (entity, mut hand) in &mut hands {
        let Ok(mut grabs) = cloths.get_mut(hand.cloth) else {
            commands.entity(entity).despawn();
            continue;
        };
        let (speed, run_up, distance) = hand.pull;
        hand.age += dt;
        if hand.travelled >= distance {
            hand.stopped += dt;
            if hand.stopped >= HOLD {
                // It lets go of its own grabs only: a player's stay.
                for p in edge() {
                    grabs.release(p);
                }
                commands.entity(entity).despawn();
            }
            continue;
        }
        let step = speed * (hand.age / run_up.max(dt)).min(1.0) * dt;
        hand.travelled += step;
        let moves: Vec<(u32, Vec3)> = grabs
            .grabs()
            .iter()
            // The hand's own grabs: the left edge's particles.
            .filter(|g| g.particle % N == 0)
            .map(|g| (g.particle, g.target - Vec3::X * step))
            .collect();
        for (particle, target) in moves {
            grabs.set_target(particle, target);
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
