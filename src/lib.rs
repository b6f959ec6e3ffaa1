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
//! use bevy::picking::mesh_picking::MeshPickingPlugin;
//! use bevy::prelude::*;
//! use bevy_cloth::prelude::*;
//!
//! fn main() {
//!     App::new()
//!         // Bevy's mesh picking lets the mouse pull the cloth.
//!         .add_plugins((DefaultPlugins, MeshPickingPlugin, ClothPlugin::default()))
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
//!   [`ClothSettingsDefaults`] resource, overridden per cloth by a `ClothSettings`
//!   component.
//! - [`ClothPlugin`] is a plugin group with a member per concern (the step,
//!   the mesh, grabs, collision, wind, creases, tearing, worn cloth, level
//!   of detail, diagnostics); a game disables the ones it does without.
//! - The step runs in `FixedUpdate` in the chained [`ClothSystems`] sets and
//!   never reads the frame delta; the mesh follows in `PostUpdate`,
//!   interpolated between fixed steps.
//! - A game reacts to [`events`](plugin::step) (grab, release, rest, wake,
//!   divergence, and [`tear`](plugin::tearing)s) and reads [`ClothStats`] and
//!   the [`diagnostics`](plugin::diagnostics).
//! - Two layers: [`sim`] is the simulation, plain data and plain functions
//!   over slices usable without an `App` ([`sim::step::step_cloth`],
//!   [`sim::guard::step_guarded`]); [`plugin`] is everything ECS, its
//!   components thin newtypes over the `sim` types. `lab` (feature `lab`)
//!   holds the research measurements.
//!
//! ## Cargo features
//!
//! | feature | default | what it adds |
//! |---|---|---|
//! | `render` | yes | a default double-sided `StandardMaterial` for cloths that have none (pulls in `bevy_pbr`) |
//! | `picking` | yes | pull and pin cloths with the mouse (`picking`) through the game's mesh picking backend, such as `MeshPickingPlugin`, which the game adds (pulls in `bevy_picking`) |
//! | `egui` | no | `ClothPanelPlugin`, an egui panel to steer every cloth (pulls in `bevy_egui`) |
//! | `debug` | no | `ClothDebugPlugin`, a gizmo view of strain, pins, grabs, contacts and colliders |
//! | `lab` | no | `bevy_cloth::lab`: the accuracy and comparison measurements behind the docs' tables |
//!
//! Without default features the crate is headless: no renderer, no window,
//! no `wgpu`; meshes are still kept up to date when `Assets<Mesh>` exists.

#![warn(missing_docs)]

pub mod error;
#[cfg(feature = "lab")]
pub mod lab;
pub mod plugin;
pub mod sim;
mod simd;

pub use crate::error::ClothError;
pub use crate::plugin::ClothPlugin;
pub use crate::plugin::spawn::ClothMaterial;
pub use crate::plugin::spawn::{ClothBuilder, ClothBundle};
pub use crate::plugin::step::ClothSystems;
pub use crate::plugin::step::check_cloth;
pub use crate::plugin::step::{
    Cloth, ClothConnections, ClothForces, ClothParticles, ClothSettings, ClothSettingsDefaults,
    ClothStats,
};
pub use crate::plugin::worn::{Anchor, ClothAnchors};
pub use crate::sim::connections::Link;
pub use crate::sim::grid::{GridCorner, GridEdge};
pub use crate::sim::material::Fabric;
pub use crate::sim::particles::PinOwner;
pub use crate::sim::settings::{
    ChoiKoSettings, ClothModel, ImplicitSettings, Integrator, LanderSettings, Parallelism,
    SimSettings, SlackStiffness, SleepSettings, SpringSettings, Type2Jacobian,
};

/// Every type a game names: `use bevy_cloth::prelude::*;`.
pub mod prelude {
    pub use crate::plugin::collision::{
        ClothCollider, ClothCollision, ClothContactLayers, ClothSelfCollision,
        ClothToClothCollision, ColliderShape, MeshShape,
    };
    pub use crate::plugin::crease::ClothCreases;
    pub use crate::plugin::interaction::{ClothGrabs, GrabMode};
    #[cfg(feature = "picking")]
    pub use crate::plugin::interaction::{ClothPicking, ClothPointer};
    pub use crate::plugin::lod::{ClothDetail, ClothLod, ClothLodDefaults};
    pub use crate::plugin::render::ClothMeshSettings;
    pub use crate::plugin::spawn::MeshLayout;
    pub use crate::plugin::spawn::{ATTRIBUTE_PIN, MeshClothBuilder};
    pub use crate::plugin::step::ClothPause;
    pub use crate::plugin::step::{
        ClothAtRest, ClothDiverged, ClothGrabbed, ClothReleased, ClothWoke,
    };
    pub use crate::plugin::step::{ClothSleep, WakeCloth};
    pub use crate::plugin::tearing::{ClothCut, ClothTearing, ClothTorn};
    pub use crate::plugin::tearing::{ClothSew, ClothSewn};
    #[cfg(feature = "debug")]
    pub use crate::plugin::tools::debug::{ClothDebug, ClothDebugPlugin};
    #[cfg(feature = "egui")]
    pub use crate::plugin::tools::panel::{ClothPanel, ClothPanelPlugin};
    pub use crate::plugin::wind::ClothWind;
    pub use crate::plugin::worn::ClothTethers;
    pub use crate::plugin::worn::{ATTRIBUTE_FREEDOM, ClothSkin};
    pub use crate::plugin::worn::{ClothInertia, TeleportCloth};
    pub use crate::sim::collision::TriMesh;
    pub use crate::sim::crease::{Crease, FoldSide};
    pub use crate::sim::guard::Divergence;
    pub use crate::sim::lod::{Detail, LodSettings};
    pub use crate::sim::particles::PinOwner;
    pub use crate::sim::settings::{AdaptiveSubsteps, Fallback, GuardSettings};
    pub use crate::sim::wind::Wind;
    pub use crate::{
        Anchor, Cloth, ClothAnchors, ClothBuilder, ClothBundle, ClothConnections, ClothError,
        ClothForces, ClothMaterial, ClothModel, ClothParticles, ClothPlugin, ClothSettings,
        ClothSettingsDefaults, ClothStats, ClothSystems, Fabric, GridCorner, GridEdge,
        ImplicitSettings, Integrator, SimSettings, SleepSettings,
    };
}

/// Compiles the README's snippet as a doctest so it stays true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
