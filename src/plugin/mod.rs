//! The ECS layer: [`ClothPlugin`], the components of a cloth entity (thin
//! newtypes over the [`sim`](crate::sim) types, in [`components`]), the
//! systems that step them in `FixedUpdate`, and everything a game sees of
//! a cloth: the live mesh, picking, grabs, anchors, colliders, wind,
//! creases, events, diagnostics, the panel and the debug view.
//!
//! What it may import: anything of Bevy, [`sim`](crate::sim),
//! [`error`](crate::error). Systems gather a cloth's components, call the
//! `sim` step and write back; they hold no physics of their own beyond
//! gathering poses and forces.

pub mod anchor;
#[cfg(feature = "avian")]
pub mod avian;
#[cfg(any(feature = "avian", feature = "rapier"))]
mod body_motion;
pub mod builder;
pub mod collision;
pub mod components;
pub mod crease;
#[cfg(feature = "debug")]
pub mod debug;
pub mod diagnostics;
pub mod events;
pub mod frame;
pub mod interaction;
pub mod lod;
pub mod material;
pub mod mesh;
pub mod mesh_builder;
pub mod mesh_cloth;
#[cfg(feature = "egui")]
pub mod panel;
#[cfg(any(feature = "avian", feature = "rapier"))]
mod parry_shapes;
#[cfg(feature = "picking")]
pub mod picking;
pub mod pose;
#[cfg(feature = "rapier")]
pub mod rapier;
pub mod schedule;
pub mod sew;
pub mod skin;
pub mod sleep;
pub mod systems;
pub mod tear;
pub mod tether;
pub mod wind;

use bevy::app::{App, FixedUpdate, Plugin};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::common_conditions::any_with_component;
use bevy::ecs::schedule::{IntoScheduleConfigs, ScheduleLabel};
use bevy::prelude::Resource;

use crate::plugin::anchor::ClothAnchors;
use crate::plugin::components::{
    Cloth, ClothConnections, ClothDefaults, ClothForces, ClothParticles, ClothSettings, ClothStats,
};
use crate::plugin::material::ClothMaterial;

/// Adds cloth simulation: the [`ClothDefaults`] resource, the
/// [`ClothSystems`](schedule::ClothSystems) sets in `FixedUpdate` (or the
/// schedule given to [`ClothPlugin::new`]) and the mesh sync in
/// `PostUpdate`.
///
/// **Order with a physics engine.** avian's `PhysicsPlugins::default()` steps
/// in `FixedPostUpdate`, after the cloth's `FixedUpdate`: each fixed step the
/// cloth meets the bodies where avian left them, moving at their
/// velocities, and the impulses it gives dynamic bodies enter avian's step
/// that follows. Both run before `PostUpdate`'s transform propagation, so
/// colliders read their pose from avian's `Position`/`Rotation` or, for the
/// crate's own [`ClothCollider`](collision::ClothCollider)s, from
/// `Transform`s as [`pose`] explains. Run the cloth in another fixed
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

impl Plugin for ClothPlugin {
    fn build(&self, app: &mut App) {
        use schedule::ClothSystems::*;
        let fixed = self.schedule;
        app.insert_resource(ClothSchedule(fixed))
            .init_resource::<ClothDefaults>()
            .register_type::<ClothDefaults>()
            .register_type::<ClothSettings>()
            .register_type::<Cloth>()
            .register_required_components::<Cloth, bevy::transform::components::Transform>()
            .register_required_components::<Cloth, ClothForces>()
            .register_required_components::<Cloth, systems::ClothScratch>()
            .register_required_components::<Cloth, ClothStats>()
            .register_required_components::<Cloth, sleep::ClothSleep>()
            .register_required_components::<Cloth, lod::ClothDetail>()
            .init_resource::<lod::ClothLodDefaults>()
            .register_type::<lod::ClothLodDefaults>()
            .register_type::<lod::ClothLod>()
            .register_type::<lod::ClothDetail>()
            .register_required_components::<Cloth, interaction::ClothGrabs>()
            .register_required_components::<Cloth, ClothMaterial>()
            .register_required_components::<Cloth, mesh::ClothPrevious>()
            .register_type::<ClothParticles>()
            .register_type::<ClothConnections>()
            .register_type::<ClothMaterial>()
            .register_type::<ClothAnchors>()
            .register_type::<ClothForces>()
            .register_type::<ClothStats>()
            .register_type::<interaction::ClothGrabs>()
            .register_type::<wind::ClothWind>()
            .add_message::<events::ClothDiverged>()
            .add_message::<tear::ClothCut>()
            .add_message::<sew::ClothSew>()
            .register_type::<sew::ClothSewn>()
            .register_type::<tear::ClothTearing>()
            .register_type::<tear::ClothTorn>()
            .register_type::<events::ClothGrabbed>()
            .register_type::<events::ClothReleased>()
            .register_type::<events::ClothAtRest>()
            .register_type::<events::ClothWoke>()
            .register_type::<sleep::ClothSleep>()
            .init_resource::<schedule::ClothPause>()
            .register_type::<schedule::ClothPause>()
            .configure_sets(
                fixed,
                (Prepare, Crease, Forces, Integrate, Collide, Writeback)
                    .chain()
                    .run_if(schedule::cloth_running),
            )
            .add_systems(
                fixed,
                (
                    // A system with nothing to do is skipped by its run
                    // condition, which costs no hand-off to a pool thread.
                    (
                        #[cfg(feature = "render")]
                        lod::choose_detail,
                        material::apply_density.run_if(material::materials_changed),
                        frame::carry_with_frames.run_if(any_with_component::<frame::ClothInertia>),
                        anchor::follow_anchors.run_if(any_with_component::<ClothAnchors>),
                        skin::follow_skins.run_if(any_with_component::<skin::ClothSkin>),
                    )
                        .chain()
                        .in_set(Prepare),
                    (
                        interaction::apply_grabs.run_if(interaction::grabs_active),
                        wind::apply_wind.run_if(wind::wind_blows),
                    )
                        .chain()
                        .in_set(Forces),
                    crease::update_creases
                        .run_if(any_with_component::<crease::ClothCreases>)
                        .in_set(Crease),
                    collision::take_obstacles
                        .run_if(collision::obstacles_in_use)
                        .in_set(Integrate)
                        .before(systems::step_cloths),
                    systems::step_cloths.in_set(Integrate),
                    (
                        anchor::snap_anchors.run_if(any_with_component::<ClothAnchors>),
                        interaction::snap_grabs.run_if(interaction::grabs_active),
                        skin::limit_skins.run_if(any_with_component::<skin::ClothSkin>),
                        tear::tear_cloths.run_if(tear::tearing_wanted),
                        sew::sew_cloths.run_if(
                            bevy::ecs::schedule::common_conditions::on_message::<sew::ClothSew>,
                        ),
                        systems::finish_step,
                        schedule::consume_step.run_if(schedule::paused),
                    )
                        .chain()
                        .in_set(Writeback),
                ),
            );
        app.add_observer(anchor::stop_on_remove)
            .add_observer(crease::remove_creases)
            .register_type::<crease::ClothCreases>()
            .register_type::<tether::ClothTethers>()
            .register_type::<frame::ClothInertia>();
        mesh::configure(app, fixed);
        collision::configure(app, fixed);
        diagnostics::configure(app, fixed);
        #[cfg(feature = "picking")]
        picking::configure(app);
        #[cfg(feature = "render")]
        if self.default_material {
            app.add_systems(
                bevy::app::PostUpdate,
                render::attach_default_material.in_set(mesh::ClothMeshSystems::Attach),
            );
        }
    }

    fn finish(&self, app: &mut App) {
        // Here rather than in `build`, so that the game's own
        // `MeshPickingPlugin`, added before or after this one, is seen.
        #[cfg(feature = "picking")]
        picking::warn_without_backend(app);
        #[cfg(not(feature = "picking"))]
        let _ = app;
    }
}

#[cfg(feature = "render")]
mod render {
    use bevy::asset::{Assets, Handle};
    use bevy::color::Color;
    use bevy::pbr::{MeshMaterial3d, StandardMaterial};
    use bevy::prelude::{Commands, Entity, Local, Query, ResMut, With, Without};

    use crate::plugin::builder::Cloth;

    /// Gives cloths without a material a double-sided, unculled one, so the
    /// back of the cloth is lit and visible.
    pub(crate) fn attach_default_material(
        mut commands: Commands,
        materials: Option<ResMut<Assets<StandardMaterial>>>,
        mut handle: Local<Option<Handle<StandardMaterial>>>,
        cloths: Query<Entity, (With<Cloth>, Without<MeshMaterial3d<StandardMaterial>>)>,
    ) {
        let Some(mut materials) = materials else {
            return;
        };
        for entity in &cloths {
            let material = handle.get_or_insert_with(|| {
                materials.add(StandardMaterial {
                    base_color: Color::srgb(0.75, 0.2, 0.2),
                    perceptual_roughness: 0.9,
                    double_sided: true,
                    cull_mode: None,
                    ..Default::default()
                })
            });
            commands
                .entity(entity)
                .try_insert(MeshMaterial3d(material.clone()));
        }
    }
}
