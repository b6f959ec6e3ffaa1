//! An egui panel to steer every cloth (feature `egui`): [`ClothPanelPlugin`].
//!
//! It edits [`ClothDefaults`]; a change is also copied into every cloth's
//! own [`ClothSettings`] (field by field, never the model, so two cloths that
//! differ only by model keep differing only by model). It shows the live
//! [`diagnostics`](crate::diagnostics), sets [`ClothWind`], and pauses,
//! single-steps and resets the simulation (reset restores every cloth to
//! how it was spawned). Add `EguiPlugin` yourself.

use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore};
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};

use crate::cloth::Cloth;
use crate::diagnostics::{KINETIC_ENERGY, MAX_STRAIN, SOLVER_ITERATIONS, STEP_TIME, SUBSTEPS};
use crate::interaction::ClothGrabs;
use crate::particles::ClothParticles;
use crate::schedule::ClothPause;
use crate::settings::{ClothDefaults, ClothModel, ClothSettings, Integrator};
use crate::wind::ClothWind;

/// Adds the cloth panel (top right) to the primary egui context.
pub struct ClothPanelPlugin;

impl Plugin for ClothPanelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ClothWind>()
            .add_observer(remember_spawn_state)
            .add_systems(EguiPrimaryContextPass, panel);
    }
}

/// How a cloth was when it was spawned, for the panel's reset.
#[derive(Component, Clone, Debug)]
pub struct SpawnState(pub ClothParticles);

fn remember_spawn_state(
    event: On<Add, Cloth>,
    mut commands: Commands,
    particles: Query<&ClothParticles>,
) {
    if let Ok(p) = particles.get(event.entity) {
        commands
            .entity(event.entity)
            .try_insert(SpawnState(p.clone()));
    }
}

/// A logarithmic slider for a positive constant.
fn log_slider(
    ui: &mut egui::Ui,
    value: &mut f32,
    range: std::ops::RangeInclusive<f32>,
    label: &str,
) {
    ui.add(
        egui::Slider::new(value, range)
            .logarithmic(true)
            .text(label),
    );
}

fn panel(
    mut contexts: EguiContexts,
    mut defaults: ResMut<ClothDefaults>,
    mut wind: ResMut<ClothWind>,
    mut pause: ResMut<ClothPause>,
    store: Option<Res<DiagnosticsStore>>,
    mut overrides: Query<&mut ClothSettings>,
    mut cloths: Query<(&SpawnState, &mut ClothParticles, &mut ClothGrabs)>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let before = defaults.0.clone();
    let mut s = before.clone();
    egui::Window::new("Cloth")
        .anchor(egui::Align2::RIGHT_TOP, egui::vec2(-10.0, 10.0))
        .default_width(270.0)
        .show(ctx, |ui| {
            ui.horizontal(|ui| {
                ui.label("model");
                ui.radio_value(&mut s.model, ClothModel::ChoiKo, "Choi–Ko");
                ui.radio_value(&mut s.model, ClothModel::Lander, "Lander");
            });
            egui::ComboBox::from_label("integrator")
                .selected_text(s.integrator.name())
                .show_ui(ui, |ui| {
                    for i in Integrator::ALL {
                        ui.selectable_value(&mut s.integrator, i, i.name());
                    }
                });
            ui.add(egui::Slider::new(&mut s.substeps, 1..=400).text("substeps"));
            log_slider(ui, &mut s.choi_ko.stiffness, 1.0..=1e5, "k (N/m)");
            log_slider(
                ui,
                &mut s.choi_ko.bending_rigidity,
                1e-9..=1e-3,
                "k_b (N·m²)",
            );
            log_slider(ui, &mut s.choi_ko.buckling_slope, 1.0..=1e5, "c_b (N/m)");
            ui.add(egui::Slider::new(&mut s.damping, 0.0..=20.0).text("c (1/s)"));
            ui.add(egui::Slider::new(&mut s.gravity.y, -20.0..=0.0).text("gravity (m/s²)"));
            ui.separator();
            ui.add(egui::Slider::new(&mut wind.velocity.x, -20.0..=20.0).text("wind x (m/s)"));
            ui.add(egui::Slider::new(&mut wind.velocity.z, -20.0..=20.0).text("wind z (m/s)"));
            ui.add(egui::Slider::new(&mut wind.gust_amplitude, 0.0..=1.0).text("gusts"));
            ui.separator();
            let value = |path: &DiagnosticPath| {
                store
                    .as_ref()
                    .and_then(|s| s.get(path))
                    .and_then(|d| d.smoothed())
                    .unwrap_or(f64::NAN)
            };
            ui.label(format!("{:.0} µs per fixed step", value(&STEP_TIME)));
            ui.label(format!(
                "{:.0} substeps · {:.0} solver iterations",
                value(&SUBSTEPS),
                value(&SOLVER_ITERATIONS)
            ));
            ui.label(format!(
                "max Type 1 strain {:.2} %",
                100.0 * value(&MAX_STRAIN)
            ));
            ui.label(format!(
                "kinetic energy {:.2} mJ",
                1e3 * value(&KINETIC_ENERGY)
            ));
            ui.horizontal(|ui| {
                if ui
                    .button(if pause.paused { "resume" } else { "pause" })
                    .clicked()
                {
                    pause.paused = !pause.paused;
                }
                if ui
                    .add_enabled(pause.paused, egui::Button::new("step"))
                    .clicked()
                {
                    pause.steps += 1;
                }
                if ui.button("reset").clicked() {
                    for (spawn, mut particles, mut grabs) in &mut cloths {
                        grabs.release_all();
                        *particles = spawn.0.clone();
                    }
                }
            });
        });
    if s != before {
        for mut own in &mut overrides {
            if s.integrator != before.integrator {
                own.integrator = s.integrator;
            }
            if s.substeps != before.substeps {
                own.substeps = s.substeps;
            }
            if s.gravity != before.gravity {
                own.gravity = s.gravity;
            }
            if s.damping != before.damping {
                own.damping = s.damping;
            }
            if s.choi_ko != before.choi_ko {
                own.choi_ko = s.choi_ko;
            }
        }
        defaults.0 = s;
    }
    Ok(())
}
