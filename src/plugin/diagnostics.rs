//! Live figures as Bevy diagnostics, recorded every fixed step in
//! [`ClothSystems::Writeback`] (read them from `DiagnosticsStore`, or let
//! an egui panel show them):
//!
//! | path | value |
//! |---|---|
//! | [`STEP_TIME`] | µs of integration (with contacts) per fixed step, all cloths |
//! | [`step_time_path`]`(integrator)` | the same, only cloths using that integrator |
//! | [`SUBSTEPS`] | largest substep count of any cloth |
//! | [`MAX_STRAIN`] | largest Type 1 strain of any cloth (dimensionless) |
//! | [`KINETIC_ENERGY`] | kinetic energy of all cloths, J |
//! | [`SOLVER_ITERATIONS`] | most conjugate-gradient iterations of any implicit cloth |
//!
//! A cloth with a [`Name`] also gets its own figures, under
//! `cloth/<name>/`: [`PER_CLOTH`] lists the leaves (`step_us`, `substeps`,
//! `max_strain`, `kinetic_energy`, `solver_iterations`); [`cloth_path`]
//! builds the path. Every cloth's [`ClothStats`] component holds the same
//! figures for the last fixed step.
//!
//! Timing uses the wall clock: for display, never for assertions.
//!
//! ```
//! # use bevy::prelude::*;
//! # use bevy::diagnostic::DiagnosticsStore;
//! # use bevy_cloth::plugin::diagnostics::cloth_path;
//! fn show(store: Res<DiagnosticsStore>) {
//!     if let Some(strain) = store.get(&cloth_path("flag", "max_strain")).and_then(|d| d.value()) {
//!         info!("the flag is stretched by {:.1} %", 100.0 * strain);
//!     }
//! }
//! ```

use bevy::app::App;
use bevy::diagnostic::{
    Diagnostic, DiagnosticMeasurement, DiagnosticPath, Diagnostics, DiagnosticsStore,
    RegisterDiagnostic,
};
use bevy::ecs::schedule::IntoScheduleConfigs;
use bevy::platform::collections::HashMap;
use bevy::platform::time::Instant;
use bevy::prelude::{Entity, Local, Name, Query, Res, ResMut};

use crate::plugin::step::components::ClothStats;
use crate::plugin::step::components::{ClothSettings, ClothSettingsDefaults};
use crate::plugin::step::schedule::ClothSystems;
use crate::sim::settings::Integrator;

/// µs of integration per fixed step, summed over cloths.
pub const STEP_TIME: DiagnosticPath = DiagnosticPath::const_new("cloth/step_us");
/// Largest substep count.
pub const SUBSTEPS: DiagnosticPath = DiagnosticPath::const_new("cloth/substeps");
/// Largest Type 1 strain.
pub const MAX_STRAIN: DiagnosticPath = DiagnosticPath::const_new("cloth/max_strain");
/// Total kinetic energy, J.
pub const KINETIC_ENERGY: DiagnosticPath = DiagnosticPath::const_new("cloth/kinetic_energy");
/// Most conjugate-gradient iterations.
pub const SOLVER_ITERATIONS: DiagnosticPath = DiagnosticPath::const_new("cloth/solver_iterations");

static PER_INTEGRATOR: [DiagnosticPath; 5] = [
    DiagnosticPath::const_new("cloth/step_us/explicit_euler"),
    DiagnosticPath::const_new("cloth/step_us/symplectic_euler"),
    DiagnosticPath::const_new("cloth/step_us/rk4"),
    DiagnosticPath::const_new("cloth/step_us/backward_euler"),
    DiagnosticPath::const_new("cloth/step_us/bdf2"),
];

/// The step-time path of one integrator (`cloth/step_us/<name>`).
pub fn step_time_path(integrator: Integrator) -> &'static DiagnosticPath {
    let index = Integrator::ALL
        .iter()
        .position(|i| *i == integrator)
        .unwrap_or(0);
    &PER_INTEGRATOR[index]
}

pub(crate) fn configure(
    app: &mut App,
    schedule: bevy::ecs::intern::Interned<dyn bevy::ecs::schedule::ScheduleLabel>,
) {
    for path in [
        STEP_TIME,
        SUBSTEPS,
        MAX_STRAIN,
        KINETIC_ENERGY,
        SOLVER_ITERATIONS,
    ]
    .into_iter()
    .chain(PER_INTEGRATOR.iter().cloned())
    {
        app.register_diagnostic(Diagnostic::new(path).with_max_history_length(60));
    }
    app.add_systems(
        schedule,
        (record, record_named)
            .in_set(ClothSystems::Writeback)
            .after(crate::plugin::step::writeback::finish_step),
    );
}

/// The leaves of a named cloth's own diagnostics (see [`cloth_path`]).
pub const PER_CLOTH: [&str; 5] = [
    "step_us",
    "substeps",
    "max_strain",
    "kinetic_energy",
    "solver_iterations",
];

/// The path of one of a named cloth's own figures: `cloth/<name>/<leaf>`,
/// with `leaf` one of [`PER_CLOTH`]. A `/` in the name becomes `_`.
pub fn cloth_path(name: &str, leaf: &str) -> DiagnosticPath {
    let name = if name.is_empty() {
        "_".to_owned()
    } else {
        name.replace('/', "_")
    };
    DiagnosticPath::from_components(["cloth", &name, leaf])
}

/// Records the figures of every cloth with a [`Name`] under its own paths,
/// registering them the first time.
fn record_named(
    _main: crate::plugin::step::schedule::MainThread,
    store: Option<ResMut<DiagnosticsStore>>,
    cloths: Query<(Entity, &ClothStats, &Name)>,
    mut paths: Local<HashMap<Entity, (Name, Vec<DiagnosticPath>)>>,
) {
    let Some(mut store) = store else {
        return;
    };
    let time = Instant::now();
    paths.retain(|entity, _| cloths.contains(*entity));
    for (entity, stats, name) in &cloths {
        let values = [
            stats.step_micros as f64,
            stats.substeps.max(1) as f64,
            stats.max_strain as f64,
            stats.kinetic_energy as f64,
            stats.solver_iterations as f64,
        ];
        let (named, own) = paths
            .entry(entity)
            .or_insert_with(|| (name.clone(), Vec::new()));
        if own.is_empty() || named != name {
            *named = name.clone();
            *own = PER_CLOTH
                .iter()
                .map(|leaf| cloth_path(name.as_str(), leaf))
                .collect();
        }
        for (path, value) in own.iter().zip(values) {
            if store.get(path).is_none() {
                store.add(Diagnostic::new(path.clone()).with_max_history_length(60));
            }
            if let Some(diagnostic) = store.get_mut(path) {
                diagnostic.add_measurement(DiagnosticMeasurement { time, value });
            }
        }
    }
}

fn record(
    _main: crate::plugin::step::schedule::MainThread,
    mut diagnostics: Diagnostics,
    defaults: Res<ClothSettingsDefaults>,
    cloths: Query<(&ClothStats, Option<&ClothSettings>)>,
) {
    if cloths.is_empty() {
        return;
    }
    let mut per = [None::<f64>; 5];
    let (mut time, mut substeps, mut strain, mut energy, mut iterations) =
        (0.0, 0u32, 0.0f32, 0.0, 0u32);
    for (stats, own) in &cloths {
        let settings = own.map_or(&defaults.0, |own| &own.0);
        time += stats.step_micros as f64;
        substeps = substeps.max(stats.substeps.max(1));
        strain = strain.max(stats.max_strain);
        energy += stats.kinetic_energy as f64;
        iterations = iterations.max(stats.solver_iterations);
        let index = Integrator::ALL
            .iter()
            .position(|i| *i == settings.integrator)
            .unwrap_or(0);
        *per[index].get_or_insert(0.0) += stats.step_micros as f64;
    }
    diagnostics.add_measurement(&STEP_TIME, || time);
    diagnostics.add_measurement(&SUBSTEPS, || substeps as f64);
    diagnostics.add_measurement(&MAX_STRAIN, || strain as f64);
    diagnostics.add_measurement(&KINETIC_ENERGY, || energy);
    diagnostics.add_measurement(&SOLVER_ITERATIONS, || iterations as f64);
    for (path, value) in PER_INTEGRATOR.iter().zip(per) {
        if let Some(value) = value {
            diagnostics.add_measurement(path, || value);
        }
    }
}
