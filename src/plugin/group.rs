//! [`ClothPlugin`]'s members: one plugin per thing a game does with cloth.
//!
//! [`ClothCorePlugin`] is the step itself and the one member the others
//! need; each other member registers its own types, messages, observers and
//! systems, and a game leaves one out with
//! `ClothPlugin::default().build().disable::<ClothWindPlugin>()`. The
//! members order their systems through the private [`Stage`] sets, which
//! the core chains inside the public [`ClothSystems`], so a member left out
//! leaves the others' order as it was.
//!
//! What it may import: anything of Bevy and of the rest of the plugin layer.

use bevy::app::{App, FixedUpdate, Plugin};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::common_conditions::{any_with_component, on_message};
use bevy::ecs::schedule::{IntoScheduleConfigs, ScheduleLabel, SystemSet};

use crate::plugin::ClothSchedule;
use crate::plugin::interaction::grab;
use crate::plugin::render::mesh;
use crate::plugin::spawn::material;
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::step::components::{
    Cloth, ClothConnections, ClothForces, ClothParticles, ClothSettings, ClothSettingsDefaults,
    ClothStats,
};
use crate::plugin::step::schedule::{self, ClothSystems};
use crate::plugin::step::{events, integrate, sleep, writeback};
use crate::plugin::tearing::{sew, tear};
use crate::plugin::worn::anchor::ClothAnchors;
use crate::plugin::worn::{anchor, frame, skin, tether};
use crate::plugin::{collision, crease, diagnostics, lod, wind};

/// The members' places inside the public [`ClothSystems`] sets: each
/// parent's stages are chained in this order.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Stage {
    /// In `Prepare`: the level of detail of this step.
    Detail,
    /// In `Prepare`: masses follow changed materials.
    Material,
    /// In `Prepare`: inertia frames, anchors and skins move their particles.
    Worn,
    /// In `Forces`: the game's and the pointer's grabs.
    Grabs,
    /// In `Forces`: the wind.
    Wind,
    /// In `Writeback`: anchored particles snap to their anchors.
    Anchors,
    /// In `Writeback`: kinematic grabs snap to their targets.
    SnapGrabs,
    /// In `Writeback`: skinned particles are held within their freedom.
    Skins,
    /// In `Writeback`: tears and seams edit the topology.
    Edit,
    /// In `Writeback`: statistics, events and sleep; a paused step is used up.
    Finish,
}

/// The schedule the step runs in, as [`ClothCorePlugin`] recorded it
/// (`FixedUpdate` when a member is added on its own).
fn fixed(app: &App) -> Interned<dyn ScheduleLabel> {
    app.world()
        .get_resource::<ClothSchedule>()
        .map_or(FixedUpdate.intern(), |s| s.0)
}

/// The step: [`ClothSettingsDefaults`], the components of a cloth entity, the
/// chained [`ClothSystems`] sets in the fixed schedule, the integration of
/// every cloth, the writeback (statistics, rest and sleep, divergence
/// reports), and [`ClothPause`](schedule::ClothPause).
#[derive(Clone, Debug)]
pub struct ClothCorePlugin {
    /// The schedule the step runs in: `FixedUpdate` by default.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl Default for ClothCorePlugin {
    fn default() -> Self {
        Self {
            schedule: FixedUpdate.intern(),
        }
    }
}

impl Plugin for ClothCorePlugin {
    fn build(&self, app: &mut App) {
        use ClothSystems::*;
        let fixed = self.schedule;
        app.insert_resource(ClothSchedule(fixed))
            .init_resource::<ClothSettingsDefaults>()
            .register_type::<ClothSettingsDefaults>()
            .register_type::<ClothSettings>()
            .register_type::<Cloth>()
            .register_required_components::<Cloth, bevy::transform::components::Transform>()
            .register_required_components::<Cloth, ClothForces>()
            .register_required_components::<Cloth, writeback::ClothScratch>()
            .register_required_components::<Cloth, ClothStats>()
            .register_required_components::<Cloth, sleep::ClothSleep>()
            .register_required_components::<Cloth, ClothMaterial>()
            .register_type::<ClothParticles>()
            .register_type::<ClothConnections>()
            .register_type::<ClothMaterial>()
            .register_type::<ClothForces>()
            .register_type::<ClothStats>()
            .add_message::<events::ClothDiverged>()
            .register_type::<events::ClothAtRest>()
            .register_type::<events::ClothWoke>()
            .register_type::<sleep::ClothSleep>()
            .init_resource::<schedule::ClothPause>()
            .register_type::<schedule::ClothPause>()
            .configure_sets(
                fixed,
                // With no cloth (since the step after the last one went),
                // none of the members' systems runs.
                (Prepare, Crease, Forces, Integrate, Collide, Writeback)
                    .chain()
                    .run_if(schedule::cloth_running)
                    .run_if(schedule::cloths_present),
            )
            .configure_sets(
                fixed,
                (
                    (Stage::Detail, Stage::Material, Stage::Worn)
                        .chain()
                        .in_set(Prepare),
                    (Stage::Grabs, Stage::Wind).chain().in_set(Forces),
                    (
                        Stage::Anchors,
                        Stage::SnapGrabs,
                        Stage::Skins,
                        Stage::Edit,
                        Stage::Finish,
                    )
                        .chain()
                        .in_set(Writeback),
                ),
            )
            .add_systems(
                fixed,
                (
                    // A system with nothing to do is skipped by its run
                    // condition, which costs no hand-off to a pool thread.
                    material::apply_density
                        .run_if(material::materials_changed)
                        .in_set(Stage::Material),
                    integrate::step_cloths.in_set(Integrate),
                    (
                        writeback::finish_step,
                        schedule::consume_step.run_if(schedule::paused),
                    )
                        .chain()
                        .in_set(Stage::Finish),
                ),
            );
    }
}

/// The live mesh: each cloth's `Mesh3d` made and kept in step with its
/// particles (interpolated between fixed steps) in `PostUpdate`, and, with
/// the `render` feature, a double-sided default material for cloths that
/// have none.
#[derive(Clone, Debug)]
pub struct ClothRenderPlugin {
    /// With the `render` feature: give cloths that have no
    /// `MeshMaterial3d<StandardMaterial>` a double-sided default material.
    pub default_material: bool,
}

impl Default for ClothRenderPlugin {
    fn default() -> Self {
        Self {
            default_material: true,
        }
    }
}

impl Plugin for ClothRenderPlugin {
    fn build(&self, app: &mut App) {
        app.register_required_components::<Cloth, mesh::ClothPrevious>();
        mesh::configure(app, fixed(app));
        #[cfg(feature = "render")]
        if self.default_material {
            app.add_systems(
                bevy::app::PostUpdate,
                crate::plugin::render::attach_default_material
                    .in_set(mesh::ClothMeshSystems::Attach),
            );
        }
        #[cfg(not(feature = "render"))]
        let _ = self.default_material;
    }
}

/// Grabs: [`ClothGrabs`](grab::ClothGrabs) on every cloth, pulled by
/// game code, and with the `picking` feature by the pointer through the
/// game's picking backend.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothInteractionPlugin;

impl Plugin for ClothInteractionPlugin {
    fn build(&self, app: &mut App) {
        let fixed = fixed(app);
        app.register_required_components::<Cloth, grab::ClothGrabs>()
            .register_type::<grab::ClothGrabs>()
            .register_type::<events::ClothGrabbed>()
            .register_type::<events::ClothReleased>()
            .add_systems(
                fixed,
                (
                    grab::apply_grabs
                        .run_if(grab::grabs_active)
                        .in_set(Stage::Grabs),
                    grab::snap_grabs
                        .run_if(grab::grabs_active)
                        .in_set(Stage::SnapGrabs),
                ),
            );
        #[cfg(feature = "picking")]
        crate::plugin::interaction::picking::configure(app);
    }

    fn finish(&self, app: &mut App) {
        // Here rather than in `build`, so that the game's own
        // `MeshPickingPlugin`, added before or after this one, is seen.
        #[cfg(feature = "picking")]
        crate::plugin::interaction::picking::warn_without_backend(app);
        #[cfg(not(feature = "picking"))]
        let _ = app;
    }
}

/// Collision with objects, with other cloths and with itself
/// ([`collision`]): the collider scene, its sources, the contact passes and
/// [`ClothCollisionStats`](collision::ClothCollisionStats). Without it the
/// step meets an empty scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothCollisionPlugin;

impl Plugin for ClothCollisionPlugin {
    fn build(&self, app: &mut App) {
        let fixed = fixed(app);
        collision::configure(app, fixed);
        app.add_systems(
            fixed,
            collision::take_obstacles
                .run_if(collision::obstacles_in_use)
                .in_set(ClothSystems::Integrate)
                .before(integrate::step_cloths),
        );
    }
}

/// Wind: the [`ClothWind`](wind::ClothWind) resource's force on every cloth.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothWindPlugin;

impl Plugin for ClothWindPlugin {
    fn build(&self, app: &mut App) {
        let fixed = fixed(app);
        app.register_type::<wind::ClothWind>().add_systems(
            fixed,
            wind::apply_wind
                .run_if(wind::wind_blows)
                .in_set(Stage::Wind),
        );
    }
}

/// Creases: [`ClothCreases`](crease::ClothCreases) edit a cloth's rest
/// shape.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothCreasePlugin;

impl Plugin for ClothCreasePlugin {
    fn build(&self, app: &mut App) {
        let fixed = fixed(app);
        app.register_type::<crease::ClothCreases>()
            .add_observer(crease::remove_creases)
            .add_systems(
                fixed,
                crease::update_creases
                    .run_if(any_with_component::<crease::ClothCreases>)
                    .in_set(ClothSystems::Crease),
            );
    }
}

/// Tearing and sewing: [`ClothTearing`](tear::ClothTearing) and
/// [`ClothCut`](tear::ClothCut) split a cloth, [`ClothSew`](sew::ClothSew)
/// joins particles into one.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothTearingPlugin;

impl Plugin for ClothTearingPlugin {
    fn build(&self, app: &mut App) {
        let fixed = fixed(app);
        app.add_message::<tear::ClothCut>()
            .add_message::<sew::ClothSew>()
            .register_type::<sew::ClothSewn>()
            .register_type::<tear::ClothTearing>()
            .register_type::<tear::ClothTorn>()
            .add_systems(
                fixed,
                (
                    tear::tear_cloths.run_if(tear::tearing_wanted),
                    sew::sew_cloths.run_if(on_message::<sew::ClothSew>),
                )
                    .chain()
                    .in_set(Stage::Edit),
            );
    }
}

/// Worn cloth: [`ClothAnchors`] tie particles to entities,
/// [`ClothSkin`](skin::ClothSkin) to a skinned mesh,
/// [`ClothTethers`](tether::ClothTethers) limit how far particles stray from
/// their pins, and [`ClothInertia`](frame::ClothInertia) carries a cloth
/// with a moving frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothWornPlugin;

impl Plugin for ClothWornPlugin {
    fn build(&self, app: &mut App) {
        let fixed = fixed(app);
        app.register_type::<ClothAnchors>()
            .register_type::<tether::ClothTethers>()
            .register_type::<frame::ClothInertia>()
            .add_observer(anchor::stop_on_remove)
            .add_systems(
                fixed,
                (
                    (
                        frame::carry_with_frames.run_if(any_with_component::<frame::ClothInertia>),
                        anchor::follow_anchors.run_if(any_with_component::<ClothAnchors>),
                        skin::follow_skins.run_if(any_with_component::<skin::ClothSkin>),
                    )
                        .chain()
                        .in_set(Stage::Worn),
                    anchor::snap_anchors
                        .run_if(any_with_component::<ClothAnchors>)
                        .in_set(Stage::Anchors),
                    skin::limit_skins
                        .run_if(any_with_component::<skin::ClothSkin>)
                        .in_set(Stage::Skins),
                ),
            );
    }
}

/// Level of detail: [`ClothDetail`](lod::ClothDetail) on every cloth, chosen
/// each fixed step from the active cameras (with the `render` feature) as
/// [`ClothLodDefaults`](lod::ClothLodDefaults) and
/// [`ClothLod`](lod::ClothLod) say. Without it every cloth steps at full
/// detail. (Sleep is the step's own: [`SleepSettings`](crate::SleepSettings)
/// turn it off.)
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothLodPlugin;

impl Plugin for ClothLodPlugin {
    fn build(&self, app: &mut App) {
        app.register_required_components::<Cloth, lod::ClothDetail>()
            .init_resource::<lod::ClothLodDefaults>()
            .register_type::<lod::ClothLodDefaults>()
            .register_type::<lod::ClothLod>()
            .register_type::<lod::ClothDetail>();
        #[cfg(feature = "render")]
        app.add_systems(fixed(app), lod::choose_detail.in_set(Stage::Detail));
    }
}

/// Diagnostics: step time, substeps, strain, energy and solver iterations
/// in Bevy's `DiagnosticsStore` ([`diagnostics`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct ClothDiagnosticsPlugin;

impl Plugin for ClothDiagnosticsPlugin {
    fn build(&self, app: &mut App) {
        diagnostics::configure(app, fixed(app));
    }
}
