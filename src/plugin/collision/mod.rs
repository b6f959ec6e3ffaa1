//! Collision of cloth with objects and with itself (MODEL.md §8).
//!
//! - [`ClothCollider`] on any entity with a `Transform`: sphere, plane,
//!   cuboid, capsule, cylinder, or a triangle mesh built from a Bevy `Mesh`,
//!   each with friction and restitution. Its pose comes from the entity's
//!   rotation and translation (scale is ignored: size the shape itself), read
//!   from a root entity's own `Transform` (a child's `GlobalTransform`), so
//!   a collider moved in `FixedUpdate`
//!   is seen at once. Its motion over each fixed step enters the response.
//! - [`ClothCollision`] on a cloth sets its thickness (default 5 mm).
//! - [`ClothSelfCollision`] opts a cloth into self-collision.
//! - [`ClothToClothCollision`] opts a cloth into collision with other
//!   cloths that have it.
//!
//! The narrow phase and response are pure functions
//! ([`sim::collision`](crate::sim::collision)); the systems here only
//! gather poses:
//!
//! 1. In [`ClothSystems::Prepare`] every collider's pose at the start and
//!    end of the fixed step is gathered into the [`ClothColliderScene`].
//! 2. In [`ClothSystems::Integrate`] contacts with the scene's colliders
//!    (poses interpolated over the step), and self-contacts, are resolved
//!    **after every substep**: once per fixed step is too coarse for springs
//!    that oscillate eight times within it, and a draped cloth gains energy
//!    and flies off.
//! 3. In [`ClothSystems::Collide`] the paper's triangle–triangle pass runs
//!    once per step for mesh colliders.
//!
//! **Only when needed**: with no `ClothCollider` in the world none of this
//! runs, and self-collision runs only for cloths that ask for it.
//! [`ClothCollisionStats`] counts what was done.
//!
//! Imports: the simulation core and the rest of the plugin (the schedule,
//! poses, the components).

mod cloths;
mod from_mesh;
mod scene;

use std::sync::Arc;

use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::ecs::schedule::common_conditions::any_with_component;
use bevy::log::warn_once;
use bevy::math::{Isometry3d, Vec3};
use bevy::mesh::Mesh;
use bevy::prelude::*;
use bevy::time::Fixed;

use crate::error::ClothError;
use crate::plugin::step::components::Cloth;
use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::pose::WorldPose;
use crate::plugin::step::schedule::ClothSystems;
pub(crate) use crate::sim::collision::SelfCollisionBuffers;
use crate::sim::collision::contact::seed_triangle_pass;
use crate::sim::collision::scene::check_surface;
pub use crate::sim::collision::{Counts, Shape, TriMesh};
use crate::sim::particles::Particles;

pub use crate::sim::collision::bounds;
pub use crate::sim::collision::scene::{
    ClothContactLayers, ColliderKey, ColliderShape, ContactImpulse, MeshShape, SceneCollider,
};
pub(crate) use cloths::ClothToClothScratch;
pub use cloths::{ClothObstacles, ClothToClothCollision};
pub(crate) use cloths::{obstacles_in_use, take_obstacles};
pub use scene::{
    ClothColliderScene, ClothColliderSources, ClothContactImpulses, ClothReportImpulses,
};

/// An object the cloth collides with, on any entity with a `Transform`.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::plugin::collision::ClothCollider;
/// fn setup(mut commands: Commands) {
///     commands.spawn((ClothCollider::sphere(0.3).with_friction(0.5), Transform::from_xyz(0.0, 1.0, 0.0)));
/// }
/// ```
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component, Debug)]
#[require(ClothColliderMotion)]
pub struct ClothCollider {
    /// The surface, in the entity's local frame.
    pub shape: ColliderShape,
    /// Coulomb friction coefficient μ (≥ 0, dimensionless).
    pub friction: f32,
    /// Restitution e of the normal velocity (0 = no bounce … 1 = elastic).
    pub restitution: f32,
}

impl ClothCollider {
    fn analytic(shape: Shape) -> Self {
        Self {
            shape: ColliderShape::Analytic(shape),
            friction: 0.4,
            restitution: 0.0,
        }
    }

    /// A ball of `radius` m.
    pub fn sphere(radius: f32) -> Self {
        Self::analytic(Shape::Sphere { radius })
    }

    /// The half-space below the entity's local XZ plane (a floor facing +Y).
    pub fn plane() -> Self {
        Self::analytic(Shape::Plane)
    }

    /// A box with half extents in m.
    pub fn cuboid(half_extents: Vec3) -> Self {
        Self::analytic(Shape::Cuboid { half_extents })
    }

    /// A capsule along local Y: `radius` and half the inner length, m.
    pub fn capsule(radius: f32, half_length: f32) -> Self {
        Self::analytic(Shape::Capsule {
            radius,
            half_length,
        })
    }

    /// A solid cylinder along local Y: `radius` and half the height, m.
    pub fn cylinder(radius: f32, half_height: f32) -> Self {
        Self::analytic(Shape::Cylinder {
            radius,
            half_height,
        })
    }

    /// A solid cone along local Y, apex up: base `radius` and half the
    /// height, m.
    pub fn cone(radius: f32, half_height: f32) -> Self {
        Self::analytic(Shape::Cone {
            radius,
            half_height,
        })
    }

    /// A triangle mesh from a Bevy `Mesh` (triangle list, `Float32x3`
    /// positions) in the entity's local frame; the BVH is built here, once.
    pub fn mesh(mesh: &Mesh) -> Result<Self, ClothError> {
        Ok(Self {
            shape: ColliderShape::Mesh(MeshShape(Arc::new(TriMesh::from_mesh(mesh)?))),
            friction: 0.4,
            restitution: 0.0,
        })
    }

    /// The same collider with friction μ.
    pub fn with_friction(mut self, friction: f32) -> Self {
        self.friction = friction;
        self
    }

    /// The same collider with restitution e.
    pub fn with_restitution(mut self, restitution: f32) -> Self {
        self.restitution = restitution;
        self
    }

    /// Checks dimensions (finite, positive), friction (finite, ≥ 0) and
    /// restitution (in [0, 1]).
    pub fn validate(&self) -> Result<(), ClothError> {
        self.shape.validate()?;
        check_surface(self.friction, self.restitution)
    }
}

/// The collider's pose at the end of the previous fixed step, from which
/// its motion over the step is taken.
#[derive(Component, Clone, Debug, Default)]
pub struct ClothColliderMotion {
    previous: Option<Isometry3d>,
}

/// Per-cloth collision settings.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) -> Result<(), ClothError> {
///     // A thick felt kept 1 cm off every collider.
///     let felt = ClothCollision { thickness: 0.01, ..default() };
///     commands.spawn((ClothBuilder::new(24, 24).build()?, felt));
///     Ok(())
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct ClothCollision {
    /// How far particles are kept from collider surfaces, in m (≥ 0).
    pub thickness: f32,
    /// Whether the implicit integrators hold contacts inside their solve
    /// (`contacts`), as they do by
    /// default. Off, contacts are only pushed out after the step, as the
    /// explicit integrators' are after each substep: at one step per frame
    /// a drape then slides off a ball and strains in a ring at the edge of
    /// the contact, so this is for comparison, not for games.
    pub in_solve: bool,
}

impl Default for ClothCollision {
    fn default() -> Self {
        Self {
            thickness: 0.005,
            in_solve: true,
        }
    }
}

/// Opts a cloth into self-collision (vertex–triangle proximity).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) -> Result<(), ClothError> {
///     let towel = ClothBuilder::new(20, 20).build()?;
///     commands.spawn((towel, ClothSelfCollision { thickness: 0.01 }));
///     Ok(())
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
#[require(SelfCollisionScratch)]
pub struct ClothSelfCollision {
    /// Smallest distance kept between a particle and the cloth's own
    /// triangles, in m (> 0).
    pub thickness: f32,
}

impl Default for ClothSelfCollision {
    fn default() -> Self {
        Self { thickness: 0.01 }
    }
}

/// Buffers of the self-collision hash.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct SelfCollisionScratch(pub(crate) SelfCollisionBuffers);

/// Running totals of the collision work, to see (and test) that a scene
/// without colliders does none.
#[derive(Resource, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource, Default)]
pub struct ClothCollisionStats {
    /// Fixed steps in which the collider pass ran.
    pub collider_passes: u64,
    /// Particle–collider and triangle–collider tests.
    pub collider_tests: u64,
    /// Contacts resolved against colliders.
    pub collider_contacts: u64,
    /// Fixed steps in which the self-collision pass ran.
    pub self_passes: u64,
    /// Particle–triangle tests within cloths.
    pub self_tests: u64,
    /// Self-contacts resolved.
    pub self_contacts: u64,
    /// Fixed steps in which some cloth had another cloth near it.
    pub cloth_passes: u64,
    /// Contacts between cloths held by the solve, and particles put back
    /// after passing through another cloth.
    pub cloth_contacts: u64,
}

/// Adds the collision resources and systems (called by `ClothPlugin`).
pub(crate) fn configure(app: &mut App, schedule: Interned<dyn ScheduleLabel>) {
    app.init_resource::<ClothCollisionStats>()
        .init_resource::<ClothColliderScene>()
        .init_resource::<ClothContactImpulses>()
        .init_resource::<ClothObstacles>()
        .register_type::<ClothToClothCollision>()
        .register_type::<ClothCollider>()
        .register_type::<ClothCollision>()
        .register_type::<ClothSelfCollision>()
        .register_type::<ClothCollisionStats>()
        .register_type::<ClothContactLayers>()
        .register_type_data::<ClothContactLayers, ReflectComponent>()
        .register_type::<ClothReportImpulses>()
        .configure_sets(schedule, ClothColliderSources.in_set(ClothSystems::Prepare))
        .add_systems(
            schedule,
            (
                clear_scene
                    .run_if(scene_in_use)
                    .in_set(ClothSystems::Prepare)
                    .before(ClothColliderSources),
                gather_colliders
                    .run_if(any_with_component::<ClothCollider>)
                    .in_set(ClothColliderSources),
                seed_pass
                    .in_set(ClothSystems::Collide)
                    .run_if(mesh_in_scene),
            ),
        );
}

/// What the [`ClothCollider`] source reads of each collider.
type OwnColliders = (
    Entity,
    &'static ClothCollider,
    WorldPose,
    &'static mut ClothColliderMotion,
    Option<&'static ClothContactLayers>,
    Has<ClothReportImpulses>,
);

/// The [`ClothCollider`] source, in [`ClothColliderSources`]: every valid
/// collider's poses over the coming step; its end pose is its next start.
fn gather_colliders(
    _main: crate::plugin::step::schedule::MainThread,
    mut colliders: Query<OwnColliders>,
    mut scene: ResMut<ClothColliderScene>,
) {
    for (entity, collider, pose, mut motion, layers, feedback) in &mut colliders {
        if let Err(error) = collider.validate() {
            warn_once!("a cloth collider is ignored: {error}");
            continue;
        }
        let Some(end) = pose.isometry() else {
            continue;
        };
        let start = motion.previous.replace(end).unwrap_or(end);
        let pushed = scene.push(
            SceneCollider::new(entity, collider.shape.clone(), start, end)
                .with_friction(collider.friction)
                .with_restitution(collider.restitution)
                .with_layers(layers.copied().unwrap_or_default())
                .with_feedback(feedback),
        );
        if let Err(error) = pushed {
            warn_once!("a cloth collider is ignored: {error}");
        }
    }
}

/// Run condition of [`clear_scene`]: there is something to clear.
fn scene_in_use(scene: Res<ClothColliderScene>, impulses: Res<ClothContactImpulses>) -> bool {
    !scene.colliders.is_empty() || !impulses.is_empty()
}

/// Empties the scene, and the last step's impulses, before the sources
/// run.
fn clear_scene(
    _main: crate::plugin::step::schedule::MainThread,
    mut scene: ResMut<ClothColliderScene>,
    mut impulses: ResMut<ClothContactImpulses>,
) {
    scene.colliders.clear();
    impulses.map.clear();
}

/// Run condition of [`seed_pass`]: the scene has a mesh collider (only
/// those take part), so that a scene of analytic shapes costs it nothing.
fn mesh_in_scene(scene: Res<ClothColliderScene>) -> bool {
    scene
        .colliders
        .iter()
        .any(|c| matches!(c.shape, ColliderShape::Mesh(_)))
}

/// What the triangle–triangle pass reads and writes of one cloth.
type SeedQuery = (
    &'static Cloth,
    &'static mut ClothParticles,
    Option<&'static ClothCollision>,
    Option<&'static ClothContactLayers>,
    &'static crate::plugin::step::sleep::ClothSleep,
);

/// [`ClothSystems::Collide`]: the paper's
/// triangle–triangle pass against mesh colliders, once per fixed step.
fn seed_pass(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    scene: Res<ClothColliderScene>,
    mut cloths: Query<SeedQuery>,
    mut stats: ResMut<ClothCollisionStats>,
) {
    // Only mesh colliders take part: with none in the scene, no work.
    if !scene
        .colliders
        .iter()
        .any(|c| matches!(c.shape, ColliderShape::Mesh(_)))
    {
        return;
    }
    let dt = time.timestep().as_secs_f32();
    let mut counts = Counts::default();
    for (cloth, mut particles, settings, layers, sleep) in &mut cloths {
        if sleep.is_asleep() {
            continue;
        }
        let layers = layers.copied().unwrap_or_default();
        let thickness = settings.map_or(ClothCollision::default().thickness, |s| s.thickness);
        if particles.len() != cloth.len() || !(thickness.is_finite() && thickness >= 0.0) {
            continue;
        }
        let (lo, hi) = bounds(&particles.positions, thickness);
        let Particles {
            positions,
            velocities,
            inverse_masses,
            ..
        } = &mut particles.0;
        for c in scene.overlapping(lo, hi) {
            let collider = &scene.colliders[c];
            if !collider.layers.interacts(layers) {
                continue;
            }
            if let ColliderShape::Mesh(mesh) = &collider.shape {
                let moving = collider.between(0.0, 1.0);
                counts += seed_triangle_pass(
                    &moving,
                    &mesh.0,
                    crate::sim::grid::Faces::faces(cloth),
                    positions,
                    velocities,
                    inverse_masses,
                    thickness + collider.margin,
                    dt,
                );
            }
        }
    }
    stats.collider_tests += counts.tests as u64;
    stats.collider_contacts += counts.contacts as u64;
}
