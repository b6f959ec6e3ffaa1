//! Collision of cloth with objects and with itself (MODEL.md §8).
//!
//! - [`ClothCollider`] on any entity with a `Transform`: sphere, plane,
//!   cuboid, capsule, cylinder, or a triangle mesh built from a Bevy `Mesh`,
//!   each with friction and restitution. Its pose comes from the entity's
//!   rotation and translation (scale is ignored: size the shape itself), read
//!   as [`pose`](crate::plugin::pose) explains, so a collider moved in `FixedUpdate`
//!   is seen at once. Its motion over each fixed step enters the response.
//! - [`ClothCollision`] on a cloth sets its thickness (default 5 mm).
//! - [`ClothSelfCollision`] opts a cloth into self-collision.
//!
//! The narrow phase and response are pure functions
//! ([`sim::collision`](crate::sim::collision)); the systems here only
//! gather poses:
//!
//! 1. In [`ClothSystems::Prepare`] every collider's pose at the start and
//!    end of the fixed step is gathered into the [`ColliderScene`].
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

mod from_mesh;

use std::sync::Arc;

use bevy::ecs::schedule::common_conditions::{any_with_component, not};
use bevy::log::warn_once;
use bevy::math::{Isometry3d, Vec3};
use bevy::mesh::Mesh;
use bevy::prelude::*;
use bevy::time::Fixed;

use crate::error::ClothError;
use crate::plugin::components::Cloth;
use crate::plugin::components::ClothParticles;
use crate::plugin::pose::WorldPose;
use crate::plugin::schedule::ClothSystems;
use crate::sim::collision::contact::{
    Geometry, MovingCollider, collide_particles, seed_triangle_pass,
};
use crate::sim::collision::predict;
use crate::sim::collision::self_collision::self_collide;
pub use crate::sim::collision::{Counts, SelfCollisionBuffers, Shape, TriMesh};
use crate::sim::integrate::implicit::{Hold, SolveContact};
use crate::sim::particles::Particles;
use crate::sim::step::{ContactHook, Substep};
use crate::sim::team::both;
use crate::sim::tether::Tethers;

/// A triangle mesh shared between colliders (opaque to reflection).
#[derive(Clone, Debug, Reflect)]
#[reflect(opaque, Debug, Clone)]
pub struct MeshShape(pub Arc<TriMesh>);

/// The surface of a [`ClothCollider`].
#[derive(Clone, Debug, Reflect)]
pub enum ColliderShape {
    /// An analytic shape (exact distances, swept against fast motion).
    Analytic(Shape),
    /// A triangle mesh (vertex–triangle tests with a BVH, plus the paper's
    /// triangle–triangle test).
    Mesh(MeshShape),
}

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
#[require(ColliderMotion)]
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
        if let ColliderShape::Analytic(shape) = &self.shape
            && !shape.is_valid()
        {
            return Err(ClothError::InvalidCollider(
                "shape dimensions must be finite and positive",
            ));
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(ClothError::InvalidCollider(
                "friction must be finite and non-negative",
            ));
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(ClothError::InvalidCollider("restitution must be in [0, 1]"));
        }
        Ok(())
    }

    /// Centre (local, m) and radius (m) of a ball holding the shape.
    fn bounding_ball(&self) -> (Vec3, f32) {
        match &self.shape {
            ColliderShape::Analytic(shape) => (Vec3::ZERO, shape.bounding_radius()),
            ColliderShape::Mesh(mesh) => {
                let (min, max) = mesh.0.bounds();
                ((min + max) / 2.0, (max - min).length() / 2.0)
            }
        }
    }
}

/// The collider's pose at the end of the previous fixed step, from which
/// its motion over the step is taken.
#[derive(Component, Clone, Debug, Default)]
pub struct ColliderMotion {
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
    /// ([`contacts`](crate::sim::integrate::implicit::contacts)), as they do by
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
pub struct SelfCollisionScratch(pub SelfCollisionBuffers);

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
}

/// A collider over the current fixed step, owned so systems can share it.
#[derive(Clone, Debug)]
pub struct SceneCollider {
    /// The collider's surface.
    pub shape: ColliderShape,
    /// Pose at the start of the step.
    pub start: Isometry3d,
    /// Pose at the end of the step.
    pub end: Isometry3d,
    /// World box swept by the collider over the step, m.
    pub min: Vec3,
    /// World box swept by the collider over the step, m.
    pub max: Vec3,
    /// Friction coefficient μ.
    pub friction: f32,
    /// Restitution e.
    pub restitution: f32,
}

impl SceneCollider {
    fn geometry(&self) -> Geometry<'_> {
        match &self.shape {
            ColliderShape::Analytic(shape) => Geometry::Shape(*shape),
            ColliderShape::Mesh(mesh) => Geometry::Mesh(&mesh.0),
        }
    }

    /// The collider between fractions `from` and `to` of the step, poses
    /// interpolated (translation linearly, rotation by slerp).
    pub fn between(&self, from: f32, to: f32) -> MovingCollider<'_> {
        let at = |t: f32| {
            Isometry3d::new(
                Vec3::from(self.start.translation).lerp(Vec3::from(self.end.translation), t),
                self.start.rotation.slerp(self.end.rotation, t),
            )
        };
        MovingCollider {
            geometry: self.geometry(),
            start: at(from),
            end: at(to),
            friction: self.friction,
            restitution: self.restitution,
        }
    }
}

/// The colliders of the current fixed step, gathered in `Prepare`.
#[derive(Resource, Clone, Debug, Default)]
pub struct ColliderScene {
    /// Every valid collider with its poses over the step.
    pub colliders: Vec<SceneCollider>,
}

impl ColliderScene {
    /// Indices of the colliders whose swept box overlaps `[min, max]` (m).
    pub fn overlapping(&self, min: Vec3, max: Vec3) -> impl Iterator<Item = usize> + '_ {
        self.colliders
            .iter()
            .enumerate()
            .filter(move |(_, c)| !(c.max.cmplt(min).any() || c.min.cmpgt(max).any()))
            .map(|(i, _)| i)
    }
}

/// Particles from which a cloth's contacts with each collider are resolved
/// in two halves, one on the implicit solver's helper thread, when
/// [`ImplicitParams::helper_thread`](crate::sim::settings::ImplicitParams::helper_thread)
/// allows (the result is the same either way).
pub const SPLIT_PARTICLES: usize = crate::sim::team::SPLIT_PARTICLES;

/// Resolves the contacts of one substep of one cloth: against the scene's
/// colliders listed in `near` (thickness `thickness` m), then with itself
/// when `self_collision` is given; with `helper`, a cloth of
/// [`SPLIT_PARTICLES`] or more shares the work with the helper thread. The
/// ECS step calls this from the integrator's contact hook; it is a plain
/// function so it can be tested and benched without an `App`.
#[expect(
    clippy::too_many_arguments,
    reason = "a plain function over the cloth's slices"
)]
pub fn resolve_substep(
    scene: &ColliderScene,
    near: &[usize],
    (thickness, helper): (f32, bool),
    self_collision: Option<(&Cloth, f32, &mut SelfCollisionBuffers)>,
    sub: Substep,
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
) -> (Counts, Counts) {
    let mut against = Counts::default();
    for &c in near {
        let collider = scene.colliders[c].between(sub.from, sub.to);
        let collide =
            |start, x, v, w| collide_particles(&collider, start, x, v, w, thickness, sub.dt);
        if !helper || x.len() < SPLIT_PARTICLES {
            against += collide(start, x, v, inverse_masses);
            continue;
        }
        // Each particle's contact is its own: half of them on the solver's
        // helper thread, to the same result.
        let mid = x.len() / 2;
        let (x0, x1) = x.split_at_mut(mid);
        let (v0, v1) = v.split_at_mut(mid);
        let (s0, s1) = start.split_at(mid);
        let (w0, w1) = inverse_masses.split_at(mid);
        let (a, b) = both(|| collide(s0, x0, v0, w0), || collide(s1, x1, v1, w1));
        against += a;
        against += b;
    }
    let mut itself = Counts::default();
    if let Some((cloth, self_thickness, buffers)) = self_collision {
        itself = self_collide(cloth, start, x, v, inverse_masses, self_thickness, buffers);
    }
    (against, itself)
}

/// The contacts of one cloth's step with the scene and with itself, as the
/// integrators' [`ContactHook`]: implicit steps hold the contacts
/// [`predict`](predict::predict_contacts) lists inside their solve;
/// [`resolve_substep`] resolves the rest after every substep, leaving the
/// particles the solve held alone.
pub(crate) struct SceneContacts<'a> {
    /// The scene.
    pub(crate) scene: &'a ColliderScene,
    /// The scene's colliders near the cloth.
    pub(crate) near: &'a [usize],
    /// Contact thickness, m.
    pub(crate) thickness: f32,
    /// Whether a large cloth may share the work with the helper thread.
    pub(crate) helper: bool,
    /// The cloth, its self-collision thickness (m) and buffers, when it
    /// collides with itself.
    pub(crate) self_collision: Option<(&'a Cloth, f32, &'a mut SelfCollisionBuffers)>,
    /// Whether the implicit solve holds contacts
    /// ([`ClothCollision::in_solve`]).
    pub(crate) in_solve: bool,
    /// The cloth's tethers and their slack, applied before the contacts
    /// ([`ClothTethers`](crate::plugin::tether::ClothTethers)).
    pub(crate) tethers: Option<(&'a Tethers, f32)>,
    /// Scratch: the inverse masses with the held particles' zeroed.
    pub(crate) masked: &'a mut Vec<f32>,
    /// Tests and contacts so far: against colliders, with itself.
    pub(crate) counts: (Counts, Counts),
}

impl ContactHook for SceneContacts<'_> {
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        held: &[Hold],
    ) {
        let w = if held.len() == w.len() {
            self.masked.clear();
            self.masked.extend(
                w.iter()
                    .zip(held)
                    .map(|(&w, &h)| if h == Hold::Free { w } else { 0.0 }),
            );
            &self.masked[..]
        } else {
            w
        };
        if let Some((tethers, slack)) = self.tethers {
            tethers.apply(x, v, w, slack);
        }
        let own = self
            .self_collision
            .as_mut()
            .map(|(c, t, b)| (*c, *t, &mut **b));
        let (mut against, itself) = resolve_substep(
            self.scene,
            self.near,
            (self.thickness, self.helper),
            own,
            sub,
            start,
            x,
            v,
            w,
        );
        if held.len() == x.len() {
            for &c in self.near {
                let collider = self.scene.colliders[c].between(sub.from, sub.to);
                against.contacts +=
                    predict::push_out_held(&collider, held, (start, x, v), self.thickness, sub.dt);
            }
        }
        self.counts.0 += against;
        self.counts.1 += itself;
    }

    fn predict(
        &mut self,
        sub: Substep,
        x: &[Vec3],
        v: &[Vec3],
        w: &[f32],
        out: &mut Vec<SolveContact>,
    ) {
        if !self.in_solve {
            return;
        }
        for &c in self.near {
            let collider = self.scene.colliders[c].between(sub.from, sub.to);
            predict::predict_contacts(&collider, (x, v, w), self.thickness, sub.dt, out);
        }
        predict::keep_nearest(out);
    }
}

/// Adds the collision resources and systems (called by `ClothPlugin`).
pub(crate) fn configure(app: &mut App) {
    app.init_resource::<ClothCollisionStats>()
        .init_resource::<ColliderScene>()
        .register_type::<ClothCollider>()
        .register_type::<ClothCollision>()
        .register_type::<ClothSelfCollision>()
        .register_type::<ClothCollisionStats>()
        .add_systems(
            FixedUpdate,
            (
                (
                    gather_colliders.run_if(any_with_component::<ClothCollider>),
                    clear_colliders.run_if(not(any_with_component::<ClothCollider>)),
                )
                    .in_set(ClothSystems::Prepare),
                seed_pass
                    .in_set(ClothSystems::Collide)
                    .run_if(mesh_in_scene),
            ),
        );
}

/// [`ClothSystems::Prepare`]: every valid
/// collider's poses over the coming step; its end pose is its next start.
fn gather_colliders(
    _main: crate::plugin::schedule::MainThread,
    mut colliders: Query<(&ClothCollider, WorldPose, &mut ColliderMotion)>,
    mut scene: ResMut<ColliderScene>,
    mut stats: ResMut<ClothCollisionStats>,
) {
    stats.collider_passes += 1;
    scene.colliders.clear();
    for (collider, pose, mut motion) in &mut colliders {
        if let Err(error) = collider.validate() {
            warn_once!("a cloth collider is ignored: {error}");
            continue;
        }
        let Some(end) = pose.isometry() else {
            continue;
        };
        let start = motion.previous.replace(end).unwrap_or(end);
        let (centre, radius) = collider.bounding_ball();
        let (c0, c1) = (
            Vec3::from(start.transform_point(centre)),
            Vec3::from(end.transform_point(centre)),
        );
        scene.colliders.push(SceneCollider {
            shape: collider.shape.clone(),
            start,
            end,
            min: c0.min(c1) - radius,
            max: c0.max(c1) + radius,
            friction: collider.friction,
            restitution: collider.restitution,
        });
    }
}

/// Empties the scene once the last collider is gone.
fn clear_colliders(_main: crate::plugin::schedule::MainThread, mut scene: ResMut<ColliderScene>) {
    if !scene.colliders.is_empty() {
        scene.colliders.clear();
    }
}

/// Run condition of [`seed_pass`]: the scene has a mesh collider (only
/// those take part), so that a scene of analytic shapes costs it nothing.
fn mesh_in_scene(scene: Res<ColliderScene>) -> bool {
    scene
        .colliders
        .iter()
        .any(|c| matches!(c.shape, ColliderShape::Mesh(_)))
}

/// [`ClothSystems::Collide`]: the paper's
/// triangle–triangle pass against mesh colliders, once per fixed step.
fn seed_pass(
    _main: crate::plugin::schedule::MainThread,
    time: Res<Time<Fixed>>,
    scene: Res<ColliderScene>,
    mut cloths: Query<(&Cloth, &mut ClothParticles, Option<&ClothCollision>)>,
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
    for (cloth, mut particles, settings) in &mut cloths {
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
            if let ColliderShape::Mesh(mesh) = &collider.shape {
                let moving = collider.between(0.0, 1.0);
                counts += seed_triangle_pass(
                    &moving,
                    &mesh.0,
                    crate::sim::grid::Faces::faces(cloth),
                    positions,
                    velocities,
                    inverse_masses,
                    thickness,
                    dt,
                );
            }
        }
    }
    stats.collider_tests += counts.tests as u64;
    stats.collider_contacts += counts.contacts as u64;
}

/// The box around `x` (m) grown by `pad` m.
pub fn bounds(x: &[Vec3], pad: f32) -> (Vec3, Vec3) {
    let (lo, hi) = x.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &p| {
        (lo.min(p), hi.max(p))
    });
    (lo - pad, hi + pad)
}
