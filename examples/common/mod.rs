//! What every example shares: window, orbit camera, egui help overlay, and
//! the automated mode used by the rendering check:
//!
//! `--frames N` runs N frames and exits; `--screenshot PATH` saves the last
//! frame to PATH (through Bevy's `Screenshot`) before exiting.
#![allow(dead_code, reason = "each example uses a different subset")]

use std::path::PathBuf;

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured, save_to_disk};
use bevy_cloth::prelude::*;
use bevy_egui::input::EguiWantsInput;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};
use bevy_panorbit_camera::{PanOrbitCamera, PanOrbitCameraPlugin, PanOrbitCameraSystemSet};

/// Window, camera control, cloth, egui and automation for an example.
pub struct ExamplePlugin {
    /// Window title.
    pub title: &'static str,
    /// The help line shown on screen.
    pub help: &'static str,
}

/// The example's help line.
#[derive(Resource)]
pub struct Help(pub &'static str);

/// Command-line automation (`--frames`, `--screenshot`).
#[derive(Resource, Debug, Default)]
pub struct Automation {
    /// Frames to run before the screenshot and exit.
    pub frames: Option<u32>,
    /// Where to save the screenshot.
    pub screenshot: Option<PathBuf>,
    /// Frames rendered so far.
    pub frame: u32,
    requested: bool,
}

impl Automation {
    /// Reads `--frames N` and `--screenshot PATH` from the command line.
    pub fn from_args() -> Self {
        let mut out = Self::default();
        let mut args = std::env::args().skip(1);
        while let Some(arg) = args.next() {
            match arg.as_str() {
                "--frames" => out.frames = args.next().and_then(|n| n.parse().ok()),
                "--screenshot" => out.screenshot = args.next().map(PathBuf::from),
                _ => {}
            }
        }
        if out.screenshot.is_some() && out.frames.is_none() {
            out.frames = Some(60);
        }
        out
    }

    /// Whether the example runs unattended.
    pub fn active(&self) -> bool {
        self.frames.is_some()
    }
}

impl Plugin for ExamplePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: self.title.into(),
                resolution: (1024u32, 640u32).into(),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((
            EguiPlugin::default(),
            PanOrbitCameraPlugin,
            ClothPlugin::default(),
        ))
        .insert_resource(Help(self.help))
        .insert_resource(Automation::from_args())
        .add_systems(EguiPrimaryContextPass, help_overlay)
        .add_systems(Update, automate)
        .add_systems(
            PreUpdate,
            block_camera_under_egui.before(PanOrbitCameraSystemSet),
        );
    }
}

/// A camera orbiting `focus` at `radius` metres, plus a sun with shadows and
/// a ground plane at y = 0.
pub fn spawn_stage(
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

/// The help line and the first cloth's live figures, top left.
fn help_overlay(
    mut contexts: EguiContexts,
    help: Res<Help>,
    defaults: Res<ClothDefaults>,
    cloths: Query<(&ClothStats, Option<&ClothSettings>)>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    egui::Area::new(egui::Id::new("help"))
        .anchor(egui::Align2::LEFT_TOP, egui::vec2(10.0, 10.0))
        .show(ctx, |ui| {
            egui::Frame::popup(ui.style()).show(ui, |ui| {
                ui.label(egui::RichText::new(help.0).strong());
                for (stats, own) in &cloths {
                    let s = own.unwrap_or(&defaults);
                    ui.label(format!(
                        "{:?} · {:?} × {} substeps · step {} · max strain {:.2}% · kinetic {:.2} mJ",
                        s.model,
                        s.integrator,
                        s.substeps,
                        stats.steps,
                        100.0 * stats.max_strain,
                        1e3 * stats.kinetic_energy
                    ));
                }
            });
        });
    Ok(())
}

/// The orbit camera ignores the mouse while egui uses it.
fn block_camera_under_egui(wants: Res<EguiWantsInput>, mut cameras: Query<&mut PanOrbitCamera>) {
    let free = !(wants.wants_pointer_input() || wants.is_pointer_over_area());
    for mut camera in &mut cameras {
        if camera.enabled != free {
            camera.enabled = free;
        }
    }
}

/// Counts frames; at `--frames` takes the screenshot (if asked) and exits
/// once it is on disk.
fn automate(
    mut commands: Commands,
    mut auto: ResMut<Automation>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(frames) = auto.frames else {
        return;
    };
    auto.frame += 1;
    if auto.frame < frames || auto.requested {
        return;
    }
    auto.requested = true;
    match auto.screenshot.clone() {
        Some(path) => {
            commands
                .spawn(Screenshot::primary_window())
                .observe(save_to_disk(path))
                .observe(
                    |_: On<ScreenshotCaptured>, mut exit: MessageWriter<AppExit>| {
                        exit.write(AppExit::Success);
                    },
                );
        }
        None => {
            exit.write(AppExit::Success);
        }
    }
}
