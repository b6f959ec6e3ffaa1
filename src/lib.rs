//! # bevy_cloth
//!
//! Cloth for Bevy that a player can see, grab and fold: the particle cloth
//! of Sato & Yoshida's short paper on interactive cloth, after Choi & Ko,
//! *Stable but Responsive Cloth* (SIGGRAPH 2002), with Lander's spring
//! cloth as the baseline it is compared with. Its threads resist
//! stretching but not compression (*Type 1* links, between neighbours), and
//! links two particles apart buckle at once under compression (*Type 2*),
//! so the cloth wrinkles as fabric does. An implicit integrator keeps it
//! stable at one step per frame, at any size.
//!
//! ## Getting started
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_cloth::prelude::*;
//!
//! fn main() {
//!     App::new()
//!         // Also adds Bevy's mesh picking: the mouse pulls the cloth.
//!         .add_plugins((DefaultPlugins, ClothPlugin::default()))
//!         .add_systems(Startup, spawn)
//!         .run();
//! }
//!
//! fn spawn(mut commands: Commands) -> Result {
//!     commands.spawn((
//!         Camera3d::default(),
//!         Transform::from_xyz(0.0, 1.2, 2.5).looking_at(Vec3::Y, Vec3::Y),
//!     ));
//!     commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y)));
//!     let cloth = ClothBuilder::new(24, 24)
//!         .size(1.0, 1.0)
//!         .material(ClothMaterial::SILK)
//!         .position(Vec3::new(0.0, 1.5, 0.0))
//!         .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
//!         .pin_corner(GridCorner::TopLeft)
//!         .pin_corner(GridCorner::TopRight)
//!         .build()?;
//!     commands.spawn(cloth);
//!     Ok(())
//! }
//! ```
//!
//! ## How it is organised
//!
//! - A cloth is **one entity**: [`Cloth`] (the grid), [`ClothParticles`]
//!   (positions, velocities, masses) and [`ClothConnections`] (the links)
//!   hold contiguous arrays; [`ClothMaterial`] sets the fabric.
//! - [`ClothSettings`] picks the model ([`ClothModel`]), the integrator
//!   ([`Integrator`]) and the solver's constants: the global
//!   [`ClothDefaults`] resource, overridden per cloth by a `ClothSettings`
//!   component.
//! - The step runs in `FixedUpdate` in the chained [`ClothSystems`] sets and
//!   never reads the frame delta; the mesh follows in `PostUpdate`,
//!   interpolated between fixed steps.
//! - A game reacts to [`events`] (grab, release, rest, wake, divergence)
//!   and reads [`ClothStats`] and the [`diagnostics`].
//! - The numerics ([`model`], [`integrate`], [`step::step_cloth`],
//!   [`guard::step_guarded`]) are plain functions over slices, usable
//!   without an `App`. [`lab`] holds the research measurements.
//!
//! ## Cargo features
//!
//! | feature | default | what it adds |
//! |---|---|---|
//! | `render` | yes | a default double-sided `StandardMaterial` for cloths that have none (pulls in `bevy_pbr`) |
//! | `picking` | yes | pull and pin cloths with the mouse (`picking`); `ClothPlugin` adds `MeshPickingPlugin` when missing (pulls in `bevy_picking`) |
//! | `egui` | yes | `ClothPanelPlugin`, an egui panel to steer every cloth (pulls in `bevy_egui`) |
//! | `debug` | no | `ClothDebugPlugin`, a gizmo view of strain, pins, grabs, contacts and colliders |
//!
//! Without default features the crate is headless: no renderer, no window,
//! no `wgpu`; meshes are still kept up to date when `Assets<Mesh>` exists.

#![warn(missing_docs)]

pub mod adaptive;
pub mod anchor;
pub mod cloth;
pub mod collision;
pub mod connections;
pub mod crease;
#[cfg(feature = "debug")]
pub mod debug;
pub mod diagnostics;
pub mod error;
pub mod events;
pub mod grid;
pub mod guard;
pub mod integrate;
pub mod interaction;
pub mod lab;
pub mod material;
pub mod mesh;
pub mod model;
#[cfg(feature = "egui")]
pub mod panel;
pub mod particles;
#[cfg(feature = "picking")]
pub mod picking;
pub mod pose;
pub mod schedule;
pub mod settings;
pub mod simd;
mod soa;
pub mod step;
mod systems;
mod team;
pub mod wind;

use bevy::app::{App, FixedUpdate, Plugin};
use bevy::ecs::schedule::IntoScheduleConfigs;
use bevy::ecs::schedule::common_conditions::any_with_component;

pub use crate::anchor::{Anchor, ClothAnchors};
pub use crate::cloth::{Cloth, ClothBuilder, ClothBundle, ClothError, GridCorner, GridEdge};
pub use crate::connections::{ClothConnections, Link};
pub use crate::material::{ClothMaterial, Fabric};
pub use crate::particles::ClothParticles;
pub use crate::schedule::ClothSystems;
pub use crate::settings::{
    ChoiKoParams, ClothDefaults, ClothModel, ClothSettings, ImplicitParams, Integrator,
    LanderParams, Parallelism, SlackStiffness, SpringParams, Type2Jacobian,
};
pub use crate::step::{ClothForces, ClothStats};
pub use crate::systems::check_cloth;

/// Every type a game names: `use bevy_cloth::prelude::*;`.
pub mod prelude {
    pub use crate::adaptive::AdaptiveSubsteps;
    pub use crate::collision::{
        ClothCollider, ClothCollision, ClothSelfCollision, ColliderShape, MeshShape, TriMesh,
    };
    pub use crate::crease::{ClothCreases, Crease, FoldSide};
    #[cfg(feature = "debug")]
    pub use crate::debug::{ClothDebug, ClothDebugPlugin};
    pub use crate::events::{ClothAtRest, ClothGrabbed, ClothReleased, ClothWoke};
    pub use crate::guard::{ClothDiverged, Divergence, Fallback, GuardSettings};
    pub use crate::interaction::{ClothGrabs, GrabMode};
    pub use crate::mesh::ClothMeshSettings;
    #[cfg(feature = "egui")]
    pub use crate::panel::{ClothPanel, ClothPanelPlugin};
    #[cfg(feature = "picking")]
    pub use crate::picking::{ClothPicking, ClothPointer};
    pub use crate::schedule::ClothPause;
    pub use crate::wind::ClothWind;
    pub use crate::{
        Anchor, ClothAnchors, ClothBuilder, ClothBundle, ClothConnections, ClothDefaults,
        ClothError, ClothForces, ClothMaterial, ClothModel, ClothParticles, ClothPlugin,
        ClothSettings, ClothStats, ClothSystems, Fabric, GridCorner, GridEdge, ImplicitParams,
        Integrator, cloth::Cloth,
    };
}

/// Adds cloth simulation: the [`ClothDefaults`] resource, the [`ClothSystems`]
/// sets in `FixedUpdate` and the mesh sync in `PostUpdate`.
///
/// Needs Bevy's time (`MinimalPlugins` or `DefaultPlugins`); anchors need
/// `TransformPlugin`; meshes need `Assets<Mesh>` (asset and mesh plugins).
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// App::new()
///     .add_plugins(DefaultPlugins)
///     // Cloths drawn with a custom material, picked by another backend.
///     .add_plugins(ClothPlugin {
///         default_material: false,
///         mesh_picking: false,
///     })
///     .run();
/// ```
#[derive(Clone, Debug)]
pub struct ClothPlugin {
    /// With the `render` feature: give cloths that have no
    /// `MeshMaterial3d<StandardMaterial>` a double-sided default material.
    /// Turn off when your cloths use another material type.
    pub default_material: bool,
    /// With the `picking` feature: add Bevy's `MeshPickingPlugin` when the
    /// app has picking (`DefaultPlugins` do) but no mesh picking backend, so
    /// the mouse can pull a cloth. Turn off when you pick with another
    /// backend.
    pub mesh_picking: bool,
}

impl Default for ClothPlugin {
    fn default() -> Self {
        Self {
            default_material: true,
            mesh_picking: true,
        }
    }
}

impl Plugin for ClothPlugin {
    fn build(&self, app: &mut App) {
        use schedule::ClothSystems::*;
        app.init_resource::<ClothDefaults>()
            .register_type::<ClothDefaults>()
            .register_type::<ClothSettings>()
            .register_type::<Cloth>()
            .register_required_components::<Cloth, bevy::transform::components::Transform>()
            .register_required_components::<Cloth, ClothForces>()
            .register_required_components::<Cloth, systems::ClothScratch>()
            .register_required_components::<Cloth, ClothStats>()
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
            .add_message::<guard::ClothDiverged>()
            .register_type::<events::ClothGrabbed>()
            .register_type::<events::ClothReleased>()
            .register_type::<events::ClothAtRest>()
            .register_type::<events::ClothWoke>()
            .init_resource::<schedule::ClothPause>()
            .register_type::<schedule::ClothPause>()
            .configure_sets(
                FixedUpdate,
                (Prepare, Crease, Forces, Integrate, Collide, Writeback)
                    .chain()
                    .run_if(schedule::cloth_running),
            )
            .add_systems(
                FixedUpdate,
                (
                    // A system with nothing to do is skipped by its run
                    // condition, which costs no hand-off to a pool thread.
                    (
                        material::apply_density.run_if(material::materials_changed),
                        anchor::follow_anchors.run_if(any_with_component::<ClothAnchors>),
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
                    systems::step_cloths.in_set(Integrate),
                    (
                        anchor::snap_anchors.run_if(any_with_component::<ClothAnchors>),
                        interaction::snap_grabs.run_if(interaction::grabs_active),
                        systems::finish_step,
                        schedule::consume_step.run_if(schedule::paused),
                    )
                        .chain()
                        .in_set(Writeback),
                ),
            );
        app.add_observer(anchor::stop_on_remove)
            .add_observer(crease::remove_creases)
            .register_type::<crease::ClothCreases>();
        mesh::configure(app);
        collision::configure(app);
        diagnostics::configure(app);
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
        // Here rather than in `build`, so that the user's own
        // `MeshPickingPlugin`, added before or after this one, is seen.
        #[cfg(feature = "picking")]
        if self.mesh_picking
            && app.is_plugin_added::<bevy::picking::PickingPlugin>()
            && !app.is_plugin_added::<bevy::picking::mesh_picking::MeshPickingPlugin>()
        {
            app.add_plugins(bevy::picking::mesh_picking::MeshPickingPlugin);
        }
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

    use crate::cloth::Cloth;

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

/// Compiles the README's snippet as a doctest so it stays true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
