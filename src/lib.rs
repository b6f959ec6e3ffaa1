//! # bevy_cloth
//!
//! Cloth for Bevy 0.19 with the particle model of Choi & Ko, *Stable but
//! Responsive Cloth* (SIGGRAPH 2002), as reproduced by Sato & Yoshida's
//! paper on interactive cloth, with Lander's spring cloth as the baseline
//! it is compared with. The equations, errata and test values are in the
//! repository's `MODEL.md` (see `README.md`).
//!
//! ## Getting started
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_cloth::prelude::*;
//!
//! fn main() {
//!     App::new()
//!         .add_plugins((DefaultPlugins, ClothPlugin::default()))
//!         .add_systems(Startup, spawn)
//!         .run();
//! }
//!
//! fn spawn(mut commands: Commands) {
//!     let cloth = ClothBuilder::new(15, 15)
//!         .size(1.0, 1.0)
//!         .position(Vec3::new(0.0, 1.5, 0.0))
//!         .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
//!         .pin_corner(GridCorner::TopLeft)
//!         .pin_corner(GridCorner::TopRight)
//!         .build()
//!         .expect("valid cloth");
//!     commands.spawn(cloth);
//! }
//! ```
//!
//! ## How it is organised
//!
//! - A cloth is **one entity**: [`Cloth`] (the grid), [`ClothParticles`]
//!   (positions, velocities, masses) and [`ClothConnections`] (Type 1 /
//!   Type 2 links) hold contiguous arrays.
//! - [`ClothSettings`] picks the model ([`ClothModel`]), the integrator
//!   ([`Integrator`]) and the constants: the global [`ClothDefaults`]
//!   resource, overridden per cloth by a `ClothSettings` component.
//! - The step runs in `FixedUpdate` in the chained [`ClothSystems`] sets and
//!   never reads the frame delta; the mesh follows in `PostUpdate`.
//! - The numerics ([`model`], [`integrate`], [`step::step_cloth`]) are plain
//!   functions over slices, usable without an `App`.
//!
//! ## Cargo features
//!
//! | feature | default | what it adds |
//! |---|---|---|
//! | `render` | yes | a default double-sided `StandardMaterial` for cloths that have none (pulls in `bevy_pbr`) |
//! | `picking` | yes | pick and pull cloths with the mouse ([`picking`]); `RayCastBackfaces` on cloth meshes so a double-sided cloth is picked from behind (pulls in `bevy_picking`) |
//! | `egui` | yes | `ClothPanelPlugin`, an egui panel to steer every cloth (pulls in `bevy_egui`) |
//!
//! Without default features the crate is headless: no renderer, no window,
//! no `wgpu`; meshes are still kept up to date when `Assets<Mesh>` exists.

#![warn(missing_docs)]

pub mod accuracy;
pub mod adaptive;
pub mod anchor;
pub mod cloth;
pub mod collision;
pub mod compare;
pub mod connections;
pub mod crease;
pub mod diagnostics;
pub mod guard;
pub mod integrate;
pub mod interaction;
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

/// The things most users need: `use bevy_cloth::prelude::*;`.
pub mod prelude {
    pub use crate::collision::{ClothCollider, ClothCollision, ClothSelfCollision};
    pub use crate::interaction::{ClothGrabs, GrabMode};
    pub use crate::mesh::ClothMeshSettings;
    pub use crate::wind::ClothWind;
    pub use crate::{
        ClothAnchors, ClothBuilder, ClothBundle, ClothConnections, ClothDefaults, ClothError,
        ClothForces, ClothMaterial, ClothModel, ClothParticles, ClothPlugin, ClothSettings,
        ClothStats, ClothSystems, Fabric, GridCorner, GridEdge, Integrator, cloth::Cloth,
    };
}

/// Adds cloth simulation: the [`ClothDefaults`] resource, the [`ClothSystems`]
/// sets in `FixedUpdate` and the mesh sync in `PostUpdate`.
///
/// Needs Bevy's time (`MinimalPlugins` or `DefaultPlugins`); anchors need
/// `TransformPlugin`; meshes need `Assets<Mesh>` (asset and mesh plugins).
#[derive(Clone, Debug)]
pub struct ClothPlugin {
    /// With the `render` feature: give cloths that have no
    /// `MeshMaterial3d<StandardMaterial>` a double-sided default material.
    /// Turn off when your cloths use another material type.
    pub default_material: bool,
}

impl Default for ClothPlugin {
    fn default() -> Self {
        Self {
            default_material: true,
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
            .register_type::<ClothParticles>()
            .register_type::<ClothConnections>()
            .register_type::<ClothMaterial>()
            .register_type::<ClothAnchors>()
            .register_type::<ClothForces>()
            .register_type::<ClothStats>()
            .register_type::<interaction::ClothGrabs>()
            .register_type::<wind::ClothWind>()
            .add_message::<guard::ClothDiverged>()
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
