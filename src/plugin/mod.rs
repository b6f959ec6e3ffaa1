//! The ECS layer: [`ClothPlugin`], the components of a cloth entity (thin
//! newtypes over the [`sim`](crate::sim) types, in [`step`]), the
//! systems that step them in `FixedUpdate`, and everything a game sees of
//! a cloth: the live mesh, picking, grabs, anchors, colliders, wind,
//! creases, events, diagnostics, the panel and the debug view.
//!
//! What it may import: anything of Bevy, [`sim`](crate::sim),
//! [`error`](crate::error). Systems gather a cloth's components, call the
//! `sim` step and write back; they hold no physics of their own beyond
//! gathering poses and forces.

#[cfg(any(feature = "avian", feature = "rapier"))]
pub mod bridges;
pub mod collision;
pub mod crease;
pub mod diagnostics;
mod group;
pub mod interaction;
pub mod lod;
pub mod render;
pub mod spawn;
pub mod step;
pub mod tearing;
#[cfg(any(feature = "egui", feature = "debug"))]
pub mod tools;
pub mod wind;
pub mod worn;

use bevy::app::{FixedUpdate, PluginGroup, PluginGroupBuilder};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::Resource;

pub use group::{
    ClothCollisionPlugin, ClothCorePlugin, ClothCreasePlugin, ClothDiagnosticsPlugin,
    ClothInteractionPlugin, ClothLodPlugin, ClothRenderPlugin, ClothTearingPlugin, ClothWindPlugin,
    ClothWornPlugin,
};
pub use step::ComputePool;

/// Adds cloth simulation: the [`ClothSettingsDefaults`](step::ClothSettingsDefaults)
/// resource, the [`ClothSystems`](step::ClothSystems) sets in
/// `FixedUpdate` (or the schedule given to [`ClothPlugin::new`]) and the mesh
/// sync in `PostUpdate`.
///
/// It is a [`PluginGroup`] of one plugin per concern, in this order:
///
/// | member | what it adds |
/// |---|---|
/// | [`ClothCorePlugin`] | the step, its sets, the cloth components, statistics, rest and sleep, [`ClothPause`](step::ClothPause); the others need it |
/// | [`ClothRenderPlugin`] | the live mesh in `PostUpdate`, the default material |
/// | [`ClothInteractionPlugin`] | grabs by game code and by the pointer |
/// | [`ClothCollisionPlugin`] | colliders, the collider scene, cloth–cloth and self-collision |
/// | [`ClothWindPlugin`] | [`ClothWind`](wind::ClothWind) |
/// | [`ClothCreasePlugin`] | [`ClothCreases`](crease::ClothCreases) |
/// | [`ClothTearingPlugin`] | tearing, cuts and seams |
/// | [`ClothWornPlugin`] | anchors, skins, tethers, inertia frames |
/// | [`ClothLodPlugin`] | level of detail |
/// | [`ClothDiagnosticsPlugin`] | Bevy diagnostics of the step |
///
/// A game that does without a concern leaves its member out, and the rest
/// build and run as before:
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// use bevy_cloth::plugin::{ClothTearingPlugin, ClothWindPlugin};
///
/// App::new().add_plugins((
///     MinimalPlugins,
///     ClothPlugin::default()
///         .build()
///         .disable::<ClothWindPlugin>()
///         .disable::<ClothTearingPlugin>(),
/// ));
/// ```
///
/// The bridges (`ClothAvianPlugin`, `ClothRapierPlugin`), the panel and the
/// debug view are plugins of their own, added after this group.
///
/// **Order with a physics engine.** avian's `PhysicsPlugins::default()` steps
/// in `FixedPostUpdate`, after the cloth's `FixedUpdate`: each fixed step the
/// cloth meets the bodies where avian left them, moving at their
/// velocities, and the impulses it gives dynamic bodies enter avian's step
/// that follows. Both run before `PostUpdate`'s transform propagation, so
/// colliders read their pose from avian's `Position`/`Rotation` or, for the
/// crate's own [`ClothCollider`](collision::ClothCollider)s, from
/// `Transform`s (a root entity's own, current even when moved in
/// `FixedUpdate`). Run the cloth in another fixed
/// schedule (`ClothPlugin::new(FixedPostUpdate)`, ordered against
/// `PhysicsSystems` there) only when avian itself runs elsewhere; the
/// schedule must run inside the fixed main loop, as the step reads
/// `Time<Fixed>`. bevy_rapier steps in `PostUpdate` by default, or in
/// `FixedUpdate` with `in_fixed_schedule()`, where
/// `ClothRapierPlugin` (feature `rapier`) orders the cloth
/// before it.
///
/// Needs Bevy's time (`MinimalPlugins` or `DefaultPlugins`); anchors need
/// `TransformPlugin`; meshes need `Assets<Mesh>` (asset and mesh plugins).
///
/// With the `picking` feature the pointer pulls cloths, through whichever
/// picking backend the game adds: `ClothPlugin` adds none, because Bevy's
/// `MeshPickingPlugin` with its default settings makes every mesh of the
/// game pickable. Add it yourself (cloth meshes carry `Pickable` and
/// `RayCastBackfaces`, so they are picked from both sides, also under
/// `MeshPickingSettings::require_markers`). Without a mesh backend the
/// plugin warns once at start-up, unless `ClothPicking::enabled` is off.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// use bevy::picking::mesh_picking::MeshPickingPlugin;
///
/// App::new()
///     .add_plugins((DefaultPlugins, MeshPickingPlugin))
///     // Cloths drawn with a custom material.
///     .add_plugins(ClothPlugin::default().with_default_material(false))
///     .run();
/// ```
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ClothPlugin {
    /// With the `render` feature: give cloths that have no
    /// `MeshMaterial3d<StandardMaterial>` a double-sided default material.
    /// Turn off when your cloths use another material type.
    pub default_material: bool,
    /// The schedule the step runs in: `FixedUpdate` by default.
    pub schedule: Interned<dyn ScheduleLabel>,
}

/// The schedule [`ClothPlugin`] runs the step in, for bridges and games
/// that add systems to its sets.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClothSchedule(pub Interned<dyn ScheduleLabel>);

impl ClothPlugin {
    /// The plugin with the step in `schedule` (one of the fixed main
    /// loop's: `FixedPreUpdate`, `FixedUpdate`, `FixedPostUpdate`).
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        Self {
            schedule: schedule.intern(),
            ..Self::default()
        }
    }

    /// Sets [`default_material`](Self::default_material).
    pub fn with_default_material(mut self, on: bool) -> Self {
        self.default_material = on;
        self
    }
}

impl Default for ClothPlugin {
    fn default() -> Self {
        Self {
            default_material: true,
            schedule: FixedUpdate.intern(),
        }
    }
}

impl PluginGroup for ClothPlugin {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(group::ClothCorePlugin {
                schedule: self.schedule,
            })
            .add(group::ClothRenderPlugin {
                default_material: self.default_material,
            })
            .add(group::ClothInteractionPlugin)
            .add(group::ClothCollisionPlugin)
            .add(group::ClothWindPlugin)
            .add(group::ClothCreasePlugin)
            .add(group::ClothTearingPlugin)
            .add(group::ClothWornPlugin)
            .add(group::ClothLodPlugin)
            .add(group::ClothDiagnosticsPlugin)
    }
}
