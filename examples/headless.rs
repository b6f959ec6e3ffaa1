//! A cloth stepped without a window: a server, a test or a tool.
//!
//! `cargo run --release --example headless` (add `-- --seconds S` to run
//! longer than 3 simulated seconds).
//!
//! A 32 × 32 cotton cloth, 1 m square, hangs from two corners over a ball
//! and falls onto it in the wind. The app uses `MinimalPlugins` and steps
//! one 60 Hz fixed step per update, so it runs as
//! fast as the machine can; every half second it prints the cloth's
//! figures, and it listens to the cloth's events.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cloth::prelude::*;

fn main() {
    let seconds: f32 = std::env::args()
        .skip_while(|a| a != "--seconds")
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3.0);
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, ClothPlugin::default()))
        // One 60 Hz fixed step per update, whatever the wall clock says.
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(ClothWind(Wind {
            velocity: Vec3::new(3.0, 0.0, 1.0),
            ..default()
        }))
        .add_systems(Startup, setup);
    app.add_observer(|rest: On<ClothAtRest>| println!("the cloth {} is at rest", rest.entity))
        .add_observer(|woke: On<ClothWoke>| println!("the cloth {} moves again", woke.entity))
        .add_observer(|d: On<ClothDiverged>| println!("the cloth diverged: {:?}", d.reason));

    app.update(); // the first update runs no fixed step
    let steps = (seconds * 60.0).round() as u32;
    println!(
        "   t (s)   max strain (%)   kinetic (mJ)   fastest (m/s)   CG iterations   step (µs)"
    );
    for step in 1..=steps {
        app.update();
        if step % 30 == 0 {
            let mut cloths = app.world_mut().query::<&ClothStats>();
            for stats in cloths.iter(app.world()) {
                println!(
                    "{:8.2} {:16.2} {:14.3} {:15.3} {:15} {:11.0}",
                    step as f32 / 60.0,
                    100.0 * stats.max_strain,
                    1e3 * stats.kinetic_energy,
                    stats.max_speed,
                    stats.solver_iterations,
                    stats.step_micros,
                );
            }
        }
    }
}

fn setup(mut commands: Commands) {
    let cloth = ClothBuilder::new(32, 32)
        .size(1.0, 1.0)
        .material(ClothMaterial::COTTON)
        .position(Vec3::new(0.0, 1.2, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .expect("a valid cloth");
    commands.spawn((cloth, Name::new("cotton")));
    commands.spawn((
        ClothCollider::sphere(0.25).with_friction(0.5),
        Transform::from_xyz(0.0, 0.7, 0.3),
    ));
}
