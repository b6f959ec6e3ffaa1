//! Creases drawn with the mouse (paper §5, MODEL.md §9): a pale blue, paper-like napkin
//! on a table. Hold `Shift` and drag across it to draw a fold line; the
//! panel sets the next crease's ratio or angle and its side, lists the
//! creases and deletes them.
//!
//! `cargo run --release --example crease`
//!
//! Keys: `C` adds a fold down the middle, `X` removes every crease, `R`
//! resets the napkin. Shift + drag: draw a crease; left drag: pull; right
//! click: pin.

mod automation;

use bevy::picking::events::{PointerMove, PointerPress};
use bevy::picking::mesh_picking::MeshPickingPlugin;
use bevy::prelude::*;
use bevy_cloth::plugin::interaction::ClothPicking;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::crease::{Crease, FoldAmount, FoldSide};
use bevy_egui::EguiPlugin;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin};

const HELP: &str = "Shift + drag across the napkin: draw a crease · C: fold down the middle · X: remove creases · R: reset";

/// The napkin: 0.8 m square, 17 × 17, stiff like paper (k_b = 1e-4 N·m²).
const SIZE: f32 = 0.8;
const N: u32 = 17;
const TABLE: f32 = 0.75;

fn main() {
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cloth: creases".into(),
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
        .init_resource::<Drawing>()
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, finish_drawing))
        .add_systems(EguiPrimaryContextPass, crease_panel)
        .add_observer(start_drawing)
        .add_observer(track_drawing)
        .run();
}

/// The crease being drawn and the settings of the next one.
#[derive(Resource)]
struct Drawing {
    /// Rest `(u, v)` where the drag started and where it is now, m.
    line: Option<(Vec2, Vec2)>,
    /// Ratio (or, with `use_angle`, angle in degrees) of the next crease.
    ratio: f32,
    angle: f32,
    use_angle: bool,
    side: FoldSide,
}

impl Default for Drawing {
    fn default() -> Self {
        Self {
            line: None,
            ratio: 0.7,
            angle: 90.0,
            use_angle: false,
            side: FoldSide::Mountain,
        }
    }
}

impl Drawing {
    fn crease(&self, from: Vec2, to: Vec2) -> Crease {
        let crease = Crease::new(from, to).with_side(self.side);
        if self.use_angle {
            crease.with_angle(self.angle.to_radians())
        } else {
            crease.with_ratio(self.ratio)
        }
    }
}

fn napkin() -> ClothBundle {
    ClothBuilder::new(N, N)
        .size(SIZE, SIZE)
        .material(ClothMaterial::PAPER)
        .position(Vec3::new(0.0, TABLE + 0.02, 0.0))
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
        Vec3::new(0.0, TABLE, 0.0),
        2.2,
    );
    commands.spawn((
        Mesh3d(meshes.add(Cuboid::new(1.6, 0.04, 1.2))),
        MeshMaterial3d(materials.add(Color::srgb(0.42, 0.27, 0.15))),
        Transform::from_xyz(0.0, TABLE - 0.02, 0.0),
        ClothCollider::cuboid(Vec3::new(0.8, 0.02, 0.6)).with_friction(0.6),
    ));
    // Paper keeps the flaps flat, so folds take their angle (see
    // `bevy_cloth::sim::crease`).
    let material = materials.add(StandardMaterial {
        base_color: Color::srgb(0.55, 0.7, 0.95),
        perceptual_roughness: 0.8,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    commands.spawn((napkin(), MeshMaterial3d(material), ClothCreases::default()));
}

/// The rest coordinates (m) of the particle nearest a world point.
fn rest_uv(cloth: &Cloth, particles: &ClothParticles, point: Vec3) -> Option<Vec2> {
    let grid = cloth.grid()?;
    bevy_cloth::plugin::interaction::nearest(particles, point).map(|p| grid.rest_uv(p))
}

fn shift(keys: &ButtonInput<KeyCode>) -> bool {
    keys.any_pressed([KeyCode::ShiftLeft, KeyCode::ShiftRight])
}

/// Shift + press on the napkin starts a crease there.
fn start_drawing(
    event: On<PointerPress>,
    keys: Res<ButtonInput<KeyCode>>,
    cloths: Query<(&Cloth, &ClothParticles)>,
    mut drawing: ResMut<Drawing>,
) {
    if !shift(&keys) {
        return;
    }
    if let (Ok((cloth, particles)), Some(hit)) = (cloths.get(event.entity), event.hit.position) {
        drawing.line = rest_uv(cloth, particles, hit).map(|uv| (uv, uv));
    }
}

/// While drawing, the crease's end follows the pointer over the napkin.
fn track_drawing(
    event: On<PointerMove>,
    cloths: Query<(&Cloth, &ClothParticles)>,
    mut drawing: ResMut<Drawing>,
) {
    let Some((from, _)) = drawing.line else {
        return;
    };
    if let (Ok((cloth, particles)), Some(hit)) = (cloths.get(event.entity), event.hit.position)
        && let Some(uv) = rest_uv(cloth, particles, hit)
    {
        drawing.line = Some((from, uv));
    }
}

/// On release the drawn line (stretched a little past both ends, so it
/// crosses the connections at its ends too) becomes a crease.
fn finish_drawing(
    mouse: Res<ButtonInput<MouseButton>>,
    keys: Res<ButtonInput<KeyCode>>,
    mut drawing: ResMut<Drawing>,
    mut picking: ResMut<ClothPicking>,
    mut creases: Query<&mut ClothCreases>,
) {
    // Shift turns the pointer into a pen: no grabbing meanwhile.
    picking.enabled = !shift(&keys) && drawing.line.is_none();
    if !mouse.just_released(MouseButton::Left) {
        return;
    }
    let Some((from, to)) = drawing.line.take() else {
        return;
    };
    if from.distance(to) < 0.05 {
        return;
    }
    let along = (to - from).normalize() * 0.03;
    let crease = drawing.crease(from - along, to + along);
    info!(
        "crease drawn from {} to {} (rest m)",
        crease.from, crease.to
    );
    for mut c in &mut creases {
        c.0.push(crease);
    }
}

fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    drawing: Res<Drawing>,
    mut cloths: Query<(&mut ClothCreases, &mut ClothParticles, &mut ClothGrabs)>,
) {
    for (mut creases, mut particles, mut grabs) in &mut cloths {
        if keys.just_pressed(KeyCode::KeyC) {
            let middle = drawing.crease(
                Vec2::new(SIZE / 2.0, -0.05),
                Vec2::new(SIZE / 2.0, SIZE + 0.05),
            );
            creases.0.push(middle);
        }
        if keys.just_pressed(KeyCode::KeyX) {
            creases.0.clear();
        }
        if keys.just_pressed(KeyCode::KeyR) {
            creases.0.clear();
            grabs.release_all();
            *particles = napkin().particles;
        }
    }
}

fn crease_panel(
    mut contexts: EguiContexts,
    mut drawing: ResMut<Drawing>,
    mut creases: Query<&mut ClothCreases>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    egui::Window::new("Creases")
        .anchor(egui::Align2::LEFT_BOTTOM, egui::vec2(10.0, -10.0))
        .show(ctx, |ui| {
            ui.checkbox(&mut drawing.use_angle, "set the angle instead of the ratio");
            if drawing.use_angle {
                ui.add(egui::Slider::new(&mut drawing.angle, 5.0..=175.0).text("fold angle (°)"));
            } else {
                ui.add(egui::Slider::new(&mut drawing.ratio, 0.2..=1.0).text("ratio r"));
            }
            ui.horizontal(|ui| {
                ui.radio_value(&mut drawing.side, FoldSide::Mountain, "mountain");
                ui.radio_value(&mut drawing.side, FoldSide::Valley, "valley");
                ui.radio_value(&mut drawing.side, FoldSide::Free, "free");
            });
            ui.separator();
            for mut c in &mut creases {
                let mut remove = None;
                for (k, crease) in c.0.iter().enumerate() {
                    ui.horizontal(|ui| {
                        let amount = match crease.amount {
                            FoldAmount::Ratio(r) => format!("r {r:.2}"),
                            FoldAmount::Angle(b) => format!("{:.0}°", b.to_degrees()),
                        };
                        ui.label(format!(
                            "({:.2}, {:.2}) to ({:.2}, {:.2}) m · {amount} · {:?}",
                            crease.from.x, crease.from.z, crease.to.x, crease.to.z, crease.side
                        ));
                        if ui.small_button("delete").clicked() {
                            remove = Some(k);
                        }
                    });
                }
                if let Some(k) = remove {
                    c.0.remove(k);
                }
            }
        });
    Ok(())
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
