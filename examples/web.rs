//! A red cloth hanging from two corners over a ball, small enough for a
//! browser: the example the web build ships (`.ci/web-check` builds it for
//! `wasm32-unknown-unknown` and runs it in Chromium). It also runs natively.
//!
//! `cargo run --release --example web`
//!
//! For the browser (WebGL2), see `docs/web.md`:
//! `cargo build --release --example web --target wasm32-unknown-unknown --features webgl2`,
//! then `wasm-bindgen` and any static file server.
//!
//! Press on the cloth and drag to pull it; right-click pins or unpins a
//! particle. `N` cycles the cloth's resolution (16², 32², 64², 128²),
//! `Space` drops it again. Every two seconds the log reports the cloth's
//! fixed-step time and the frame time (the browser's console on the web).

use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::prelude::*;

/// The resolutions `N` cycles through, particles per side.
const SIZES: [u32; 4] = [16, 32, 64, 128];

/// Height of the cloth's pinned edge, m.
const TOP: f32 = 1.5;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: web".into(),
                // On the web: draw into the page's `<canvas id="bevy">` and
                // follow its size; the page's keys and wheel stay with the app.
                canvas: Some("#bevy".into()),
                fit_canvas_to_parent: true,
                prevent_default_event_handling: true,
                ..default()
            }),
            ..default()
        }))
        // The mouse pulls the cloth through Bevy's mesh picking, which the
        // game adds (ClothPlugin leaves the choice of backend to it).
        .add_plugins((MeshPickingPlugin, ClothPlugin::default()))
        .init_resource::<Resolution>()
        .init_resource::<Timings>()
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, respawn, report).chain())
        .run();
}

/// The cloth's particles per side, an index into [`SIZES`].
#[derive(Resource, Default)]
struct Resolution(usize);

/// The last fixed steps' and frames' times, ms.
#[derive(Resource, Default)]
struct Timings {
    steps: Vec<f32>,
    frames: Vec<f32>,
    last_step: u64,
    since_report: f32,
}

/// Marks the cloth the keys respawn.
#[derive(Component)]
struct Sheet;

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 1.25, 2.6).looking_at(Vec3::new(0.0, 0.95, 0.0), Vec3::Y),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(2.0, 4.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(6.0, 6.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.25, 0.27, 0.3))),
    ));
    // A ball the cloth falls onto, and its collider (m).
    let ball = Sphere::new(0.25);
    commands.spawn((
        Mesh3d(meshes.add(ball.mesh().ico(4).expect("a valid icosphere"))),
        MeshMaterial3d(materials.add(Color::srgb(0.8, 0.8, 0.75))),
        Transform::from_xyz(0.0, 0.8, 0.1),
        ClothCollider::sphere(ball.radius),
    ));
    spawn_cloth(&mut commands, &mut materials, SIZES[0]);
}

/// A 1 m red cloth of `n × n` particles, level, pinned at its two back
/// corners, so it swings down over the ball.
fn spawn_cloth(commands: &mut Commands, materials: &mut Assets<StandardMaterial>, n: u32) {
    let cloth = ClothBuilder::new(n, n)
        .size(1.0, 1.0)
        .material(ClothMaterial::COTTON)
        .position(Vec3::new(0.0, TOP, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .expect("a valid cloth");
    let red = materials.add(StandardMaterial {
        base_color: Color::srgb(0.8, 0.08, 0.06),
        perceptual_roughness: 0.9,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    commands
        .spawn((cloth, MeshMaterial3d(red), Sheet))
        .observe(|grab: On<ClothGrabbed>| info!("web: pointer holds particle {}", grab.particle));
}

/// `N`: the next resolution; `Space`: the same cloth dropped again.
fn keys(keys: Res<ButtonInput<KeyCode>>, mut resolution: ResMut<Resolution>) {
    if keys.just_pressed(KeyCode::KeyN) {
        resolution.0 = (resolution.0 + 1) % SIZES.len();
    } else if keys.just_pressed(KeyCode::Space) {
        resolution.set_changed();
    }
}

/// Replaces the cloth when the resolution changes (or `Space` asks).
fn respawn(
    mut commands: Commands,
    resolution: Res<Resolution>,
    sheets: Query<Entity, With<Sheet>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut timings: ResMut<Timings>,
) {
    if !resolution.is_changed() || resolution.is_added() {
        return;
    }
    for sheet in &sheets {
        commands.entity(sheet).despawn();
    }
    let n = SIZES[resolution.0];
    info!("web: {n}x{n} cloth");
    spawn_cloth(&mut commands, &mut materials, n);
    *timings = Timings::default();
}

/// Every 2 s: the median fixed-step time of the cloth and the median frame
/// time since the last report, ms.
fn report(
    time: Res<Time<Real>>,
    mut timings: ResMut<Timings>,
    sheets: Query<(&Cloth, &ClothStats, &ClothSleep), With<Sheet>>,
) {
    let Ok((cloth, stats, sleep)) = sheets.single() else {
        return;
    };
    if stats.steps > timings.last_step {
        timings.last_step = stats.steps;
        timings.steps.push(stats.step_micros / 1000.0);
    }
    timings.frames.push(time.delta_secs() * 1000.0);
    timings.since_report += time.delta_secs();
    if timings.since_report < 2.0 || (timings.steps.is_empty() && !sleep.is_asleep()) {
        return;
    }
    let median = |v: &mut Vec<f32>| {
        v.sort_by(f32::total_cmp);
        let m = v.get(v.len() / 2).copied();
        v.clear();
        m
    };
    // A cloth that has come to rest sleeps: no step to time.
    let step = median(&mut timings.steps).map_or_else(|| "asleep".into(), |s| format!("{s:.2} ms"));
    let frame = median(&mut timings.frames).unwrap_or(f32::NAN);
    timings.since_report = 0.0;
    info!(
        "web: {} particles, step {step}, frame {frame:.1} ms, strain {:.2} %",
        cloth.len(),
        stats.max_strain * 100.0
    );
}
