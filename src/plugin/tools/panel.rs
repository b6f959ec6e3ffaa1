//! An egui panel to steer every cloth (feature `egui`): [`ClothPanelPlugin`].
//!
//! It shows the settings of the first cloth that has its own
//! [`ClothSettings`], or [`ClothSettingsDefaults`] when none has, so that it shows
//! what runs. A change made in it is copied, field by field and only the
//! fields it shows, into [`ClothSettingsDefaults`] and every cloth's own settings;
//! the model can be switched only while no cloth has its own settings, so
//! two cloths that differ by model (or by anything the panel does not show)
//! keep differing. It shows the live
//! [`diagnostics`](crate::plugin::diagnostics), sets [`ClothWind`], and pauses,
//! single-steps and resets the simulation (reset restores every cloth to
//! how it was spawned). Add `EguiPlugin` yourself.

use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore};
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};

use crate::plugin::diagnostics::{
    KINETIC_ENERGY, MAX_STRAIN, SOLVER_ITERATIONS, STEP_TIME, SUBSTEPS,
};
use crate::plugin::interaction::grab::ClothGrabs;
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::step::components::Cloth;
use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::components::{ClothSettings, ClothSettingsDefaults};
use crate::plugin::step::schedule::ClothPause;
use crate::plugin::wind::ClothWind;
use crate::sim::material::Fabric;
use crate::sim::settings::{ClothModel, Integrator, SimSettings};

/// Adds the cloth panel (top right) to the primary egui context.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// App::new()
///     .add_plugins((DefaultPlugins, bevy_egui::EguiPlugin::default()))
///     .add_plugins((ClothPlugin::default(), ClothPanelPlugin))
///     .insert_resource(ClothPanel::with_help("R: reset"))
///     .run();
/// ```
pub struct ClothPanelPlugin;

/// What the panel shows: whether it is open, a help line at its top, and a
/// notice for the player (an asset that did not load, say).
#[derive(Resource, Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ClothPanel {
    /// Whether the panel is drawn.
    pub open: bool,
    /// A line of help shown at the top of the panel (none when empty).
    pub help: String,
    /// A notice shown in red under the help (none when empty).
    pub notice: String,
}

impl Default for ClothPanel {
    fn default() -> Self {
        Self {
            open: true,
            help: String::new(),
            notice: String::new(),
        }
    }
}

impl ClothPanel {
    /// An open panel with `help` at its top.
    pub fn with_help(help: impl Into<String>) -> Self {
        Self {
            help: help.into(),
            ..Self::default()
        }
    }
}

impl Plugin for ClothPanelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ClothWind>()
            .init_resource::<ClothPanel>()
            .add_observer(remember_spawn_state)
            .add_systems(EguiPrimaryContextPass, panel);
    }
}

/// How a cloth was when it was spawned, for the panel's reset.
#[derive(Component, Clone, Debug)]
pub(crate) struct SpawnState(pub(crate) ClothParticles);

fn remember_spawn_state(
    event: On<Add<Cloth>>,
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

/// The panel's live figures, a line each, from the diagnostics' smoothed
/// values (`None` before the first measurement, shown as "–"); one line
/// saying so when the scene has no cloth.
fn figures(value: impl Fn(&DiagnosticPath) -> Option<f64>, any_cloth: bool) -> Vec<String> {
    if !any_cloth {
        return vec!["no cloth in the scene".to_string()];
    }
    let show = |path: &DiagnosticPath, scale: f64, decimals: usize| {
        value(path).filter(|v| v.is_finite()).map_or_else(
            || "–".to_string(),
            |v| format!("{:.*}", decimals, v * scale),
        )
    };
    vec![
        format!("{} µs per fixed step", show(&STEP_TIME, 1.0, 0)),
        format!(
            "{} substeps · {} solver iterations",
            show(&SUBSTEPS, 1.0, 0),
            show(&SOLVER_ITERATIONS, 1.0, 0)
        ),
        format!("max Type 1 strain {} %", show(&MAX_STRAIN, 100.0, 2)),
        format!("kinetic energy {} mJ", show(&KINETIC_ENERGY, 1e3, 2)),
    ]
}

#[expect(clippy::too_many_arguments, reason = "a Bevy system's parameters")]
fn panel(
    shown: Res<ClothPanel>,
    mut contexts: EguiContexts,
    mut defaults: ResMut<ClothSettingsDefaults>,
    mut wind: ResMut<ClothWind>,
    mut pause: ResMut<ClothPause>,
    store: Option<Res<DiagnosticsStore>>,
    mut overrides: Query<&mut ClothSettings>,
    mut materials: Query<&mut ClothMaterial>,
    mut cloths: Query<(&SpawnState, &mut ClothParticles, &mut ClothGrabs)>,
) -> Result {
    if !shown.open {
        return Ok(());
    }
    let ctx = contexts.ctx_mut()?;
    let material_before = materials.iter().next().copied().unwrap_or_default();
    let mut material = material_before;
    let own = overrides.iter().next().cloned();
    let per_cloth = own.is_some();
    let before = own.map_or_else(|| defaults.0.clone(), |own| own.0);
    let mut s = before.clone();
    egui::Window::new("Cloth")
        .anchor(egui::Align2::RIGHT_TOP, egui::vec2(-10.0, 10.0))
        .default_width(270.0)
        .show(ctx, |ui| {
            if !shown.help.is_empty() {
                ui.label(egui::RichText::new(&shown.help).strong());
            }
            if !shown.notice.is_empty() {
                ui.colored_label(egui::Color32::LIGHT_RED, &shown.notice);
            }
            if !(shown.help.is_empty() && shown.notice.is_empty()) {
                ui.separator();
            }
            ui.horizontal(|ui| {
                ui.label("model");
                if per_cloth {
                    ui.label("set per cloth");
                } else {
                    ui.radio_value(&mut s.model, ClothModel::ChoiKo, "Choi–Ko");
                    ui.radio_value(&mut s.model, ClothModel::Lander, "Lander");
                }
            });
            egui::ComboBox::from_label("integrator")
                .selected_text(s.integrator.name())
                .show_ui(ui, |ui| {
                    for i in Integrator::ALL {
                        ui.selectable_value(&mut s.integrator, i, i.name());
                    }
                });
            ui.add(egui::Slider::new(&mut s.substeps, 1..=400).text("substeps"));
            material_ui(ui, &mut material, &mut s);
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
            };
            for line in figures(value, !cloths.is_empty()) {
                ui.label(line);
            }
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
            copy_changes(&before, &s, &mut own);
        }
        copy_changes(&before, &s, &mut defaults.0);
    }
    if material != material_before {
        for mut m in &mut materials {
            copy_material(&material_before, &material, &mut m);
        }
    }
    Ok(())
}

/// The material: a preset or raw, then the fabric's properties, or the raw
/// per-link constants of the settings.
fn material_ui(ui: &mut egui::Ui, material: &mut ClothMaterial, s: &mut SimSettings) {
    let name = match material {
        ClothMaterial::Raw => "raw constants",
        ClothMaterial::Fabric(f) => Fabric::PRESETS
            .iter()
            .find(|(_, p)| p == f)
            .map_or("custom fabric", |(n, _)| n),
    };
    egui::ComboBox::from_label("material")
        .selected_text(name)
        .show_ui(ui, |ui| {
            for (name, fabric) in Fabric::PRESETS {
                ui.selectable_value(material, ClothMaterial::Fabric(fabric), name);
            }
            ui.selectable_value(material, ClothMaterial::Raw, "raw constants");
        });
    match material {
        ClothMaterial::Fabric(f) => {
            log_slider(ui, &mut f.stretch, 100.0..=1e6, "stretch (N/m)");
            log_slider(ui, &mut f.shear, 10.0..=1e6, "shear (N/m)");
            log_slider(ui, &mut f.bending, 1e-7..=1e-2, "bending (N·m)");
            log_slider(ui, &mut f.density, 0.01..=2.0, "density (kg/m²)");
            ui.add(egui::Slider::new(&mut f.damping, 0.0..=20.0).text("c (1/s)"));
        }
        ClothMaterial::Raw => {
            log_slider(ui, &mut s.choi_ko.stiffness, 1.0..=1e5, "k (N/m)");
            log_slider(
                ui,
                &mut s.choi_ko.shear_stiffness,
                1.0..=1e5,
                "k shear (N/m)",
            );
            log_slider(
                ui,
                &mut s.choi_ko.bending_rigidity,
                1e-9..=1e-3,
                "k_b (N·m²)",
            );
            log_slider(ui, &mut s.choi_ko.buckling_slope, 1.0..=1e5, "c_b (N/m)");
            ui.add(egui::Slider::new(&mut s.damping, 0.0..=20.0).text("c (1/s)"));
        }
    }
}

/// Copies into `target` the material change from `before` to `after`: a
/// preset or raw whole, a moved slider field by field onto a fabric (so
/// cloths of different fabrics keep what the slider did not touch).
fn copy_material(before: &ClothMaterial, after: &ClothMaterial, target: &mut ClothMaterial) {
    match (before, after, &mut *target) {
        (ClothMaterial::Fabric(b), ClothMaterial::Fabric(a), ClothMaterial::Fabric(t))
            if Fabric::PRESETS.iter().all(|(_, p)| p != a) =>
        {
            let copy = |b: f32, a: f32, t: &mut f32| {
                if a != b {
                    *t = a;
                }
            };
            copy(b.stretch, a.stretch, &mut t.stretch);
            copy(b.shear, a.shear, &mut t.shear);
            copy(b.bending, a.bending, &mut t.bending);
            copy(b.density, a.density, &mut t.density);
            copy(b.damping, a.damping, &mut t.damping);
        }
        _ => *target = *after,
    }
}

/// Copies into `target` every setting the panel shows that differs between
/// `before` and `after`, and nothing else.
fn copy_changes(before: &SimSettings, after: &SimSettings, target: &mut SimSettings) {
    fn copy<T: PartialEq + Copy>(before: T, after: T, target: &mut T) {
        if after != before {
            *target = after;
        }
    }
    let (b, a, t) = (before, after, target);
    copy(b.model, a.model, &mut t.model);
    copy(b.integrator, a.integrator, &mut t.integrator);
    copy(b.substeps, a.substeps, &mut t.substeps);
    copy(b.gravity, a.gravity, &mut t.gravity);
    copy(b.damping, a.damping, &mut t.damping);
    let (b, a, t) = (&b.choi_ko, &a.choi_ko, &mut t.choi_ko);
    copy(b.stiffness, a.stiffness, &mut t.stiffness);
    copy(b.shear_stiffness, a.shear_stiffness, &mut t.shear_stiffness);
    copy(
        b.bending_rigidity,
        a.bending_rigidity,
        &mut t.bending_rigidity,
    );
    copy(b.buckling_slope, a.buckling_slope, &mut t.buckling_slope);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A slider moved on the tablecloth's own settings reaches that cloth
    /// and the defaults, and leaves alone what the panel does not show
    /// (its pair damping, the defaults' substeps it did not touch).
    #[test]
    fn only_the_changed_fields_are_copied() {
        let mut own = SimSettings {
            substeps: 80,
            ..default()
        };
        own.choi_ko.pair_damping = 0.3;
        let mut defaults = SimSettings::default();
        let before = own.clone();
        let mut after = before.clone();
        after.choi_ko.stiffness = 2500.0;
        copy_changes(&before, &after, &mut own);
        copy_changes(&before, &after, &mut defaults);
        assert_eq!(own.choi_ko.stiffness, 2500.0);
        assert_eq!(own.choi_ko.pair_damping, 0.3);
        assert_eq!(own.substeps, 80);
        assert_eq!(defaults.choi_ko.stiffness, 2500.0);
        assert_eq!(defaults.substeps, SimSettings::default().substeps);
        assert_eq!(
            defaults.choi_ko.pair_damping,
            SimSettings::default().choi_ko.pair_damping
        );
        let mut lander = before.clone().with_model(ClothModel::Lander);
        after.model = ClothModel::ChoiKo;
        after.substeps = 12;
        copy_changes(&before, &after, &mut lander);
        assert_eq!((lander.model, lander.substeps), (ClothModel::Lander, 12));
    }

    #[test]
    fn a_moved_fabric_slider_keeps_each_cloths_other_properties() {
        let before = ClothMaterial::COTTON;
        let after = ClothMaterial::Fabric(Fabric {
            bending: 1e-4,
            ..Fabric::COTTON
        });
        let mut silk = ClothMaterial::SILK;
        copy_material(&before, &after, &mut silk);
        let f = silk.fabric().unwrap();
        assert_eq!((f.bending, f.density), (1e-4, Fabric::SILK.density));
        // A preset or raw replaces the whole material.
        copy_material(&before, &ClothMaterial::DENIM, &mut silk);
        assert_eq!(silk, ClothMaterial::DENIM);
        copy_material(&before, &ClothMaterial::Raw, &mut silk);
        assert_eq!(silk, ClothMaterial::Raw);
    }

    #[test]
    fn the_figures_say_when_there_is_no_cloth_and_never_show_nan() {
        let none = |_: &DiagnosticPath| None;
        assert_eq!(figures(none, false), ["no cloth in the scene"]);
        let nan = |_: &DiagnosticPath| Some(f64::NAN);
        for lines in [figures(none, true), figures(nan, true)] {
            assert_eq!(lines.len(), 4);
            assert!(
                lines.iter().all(|l| !l.contains("NaN") && l.contains('–')),
                "{lines:?}"
            );
        }
        let strain = |p: &DiagnosticPath| (*p == MAX_STRAIN).then_some(0.0123);
        assert!(figures(strain, true)[2].contains("1.23 %"));
    }
}
