//! The seed's §6.1 scene: a 15×15, 1 m cotton cloth pinned at two corners of
//! a bar, released flat so it swings down under gravity and settles.
//!
//! `cargo run --release --example hanging`
//!
//! Keys: `R` release it flat again, `M` switch Choi–Ko / Lander, `I` next
//! integrator (backward Euler, BDF2, explicit Euler, symplectic Euler, RK4).
//! Drag to orbit, scroll to zoom.

mod common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::{ExamplePlugin, spawn_stage};

const HELP: &str =
    "R: release again · M: Choi–Ko / Lander · I: next integrator · drag: orbit · scroll: zoom";

/// Height of the bar the cloth hangs from, m.
const BAR: f32 = 1.6;

fn main() {
    App::new()
        .add_plugins(ExamplePlugin {
            title: "bevy_cloth: hanging",
            help: HELP,
        })
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
    spawn_stage(
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
    mut defaults: ResMut<ClothDefaults>,
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
