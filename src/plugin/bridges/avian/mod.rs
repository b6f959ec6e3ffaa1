//! The avian bridge (cargo feature `avian`, avian3d 0.8): avian's colliders
//! are cloth colliders, and the cloth pushes avian's dynamic bodies back.
//!
//! [`ClothAvianPlugin`], added after [`ClothPlugin`](crate::ClothPlugin)
//! and avian's `PhysicsPlugins`:
//!
//! - **Colliders.** Every avian `Collider` collides with every cloth whose
//!   [`ClothContactLayers`] it shares (see [`From<CollisionLayers>`](ClothContactLayers)), with no
//!   [`ClothCollider`] beside it: balls, cuboids, capsules, cylinders and
//!   cones exactly; convex hulls, triangle meshes, height fields and
//!   triangles as triangle meshes; compounds part by part; the rounded
//!   shapes with their border radius; half-spaces as planes. Sensors,
//!   disabled colliders and colliders of disabled bodies are ignored, and
//!   an entity that also has a `ClothCollider` collides through that one
//!   only. A shape the cloth cannot use (a segment, a polyline, voxels) is
//!   skipped with one warning per collider.
//! - **Motion.** A collider is taken where avian left it (its body's
//!   `Position`/`Rotation` and the collider's offset on the body) and moved
//!   over the coming fixed step at its body's `LinearVelocity` and
//!   `AngularVelocity` about the centre of mass: the same swept and
//!   in-solve contacts as for a moving `ClothCollider`. A body whose
//!   velocity is not finite is taken as still (one warning).
//! - **Friction and restitution**: the collider's `Friction` (or its body's,
//!   or avian's default) combined with the cloth's
//!   [`ClothAvianPlugin::cloth_friction`] as avian combines two colliders'
//!   (the higher-priority rule of the two); restitution likewise.
//! - **Two-way coupling.** The impulses the cloth's contacts give a
//!   `RigidBody::Dynamic` body over a step ([`ClothContactImpulses`]) are
//!   applied to it in [`ClothSystems::Writeback`], linear and angular about
//!   its centre of mass, through avian's `Forces`; avian's step in
//!   `FixedPostUpdate` then moves it. Kinematic and static bodies are
//!   one-way. The shift out of the cloth that the cloth's overlap with a
//!   body calls for
//!   ([`ContactImpulse::shift`](crate::plugin::collision::ContactImpulse::shift))
//!   is made to its `Position`, not to its velocity.
//!
//! The bridge is a plugin of its own rather than part of `ClothPlugin`, so
//! that a game chooses it (and its settings) where it adds avian, and a
//! game with avian whose cloths meet only `ClothCollider`s pays nothing for
//! it.

use std::sync::Arc;

use avian3d::prelude::{
    AngularVelocity, Collider, ColliderDisabled, ColliderOf, ColliderTransform, CollisionLayers,
    ComputedAngularInertia, ComputedCenterOfMass, ComputedMass, Forces, Friction, Gravity,
    GravityScale, LinearVelocity, Position, ReadRigidBodyForces, Restitution, RigidBody,
    RigidBodyDisabled, Rotation, Sensor, WriteRigidBodyForces,
};
use bevy::app::{App, FixedUpdate, Plugin};
use bevy::ecs::query::QueryData;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::log::warn;
use bevy::math::{Isometry3d, Vec3};
use bevy::platform::collections::HashSet;
use bevy::prelude::*;
use bevy::time::Fixed;

use crate::plugin::ClothSchedule;
use crate::plugin::bridges::body_motion::{Carrier, Motion};
use crate::plugin::bridges::parry_shapes::{self as shapes, Piece};
use crate::plugin::collision::{
    ClothCollider, ClothColliderScene, ClothColliderSources, ClothContactImpulses,
    ClothContactLayers,
};
use crate::plugin::step::schedule::ClothSystems;

/// avian's colliders as cloth colliders, and the cloth's impulses on
/// avian's dynamic bodies (module docs). Add it after `ClothPlugin`.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// use avian3d::prelude::*;
/// use bevy_cloth::plugin::bridges::avian::ClothAvianPlugin;
///
/// App::new()
///     .add_plugins((DefaultPlugins, PhysicsPlugins::default()))
///     .add_plugins((ClothPlugin::default(), ClothAvianPlugin::default()))
///     .run();
/// ```
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ClothAvianPlugin {
    /// The cloth's side of every contact's friction, combined with the
    /// collider's as avian combines two colliders'.
    pub cloth_friction: Friction,
    /// The cloth's side of every contact's restitution, combined likewise.
    pub cloth_restitution: Restitution,
    /// Whether the cloth pushes dynamic bodies back (on by default).
    pub two_way: bool,
}

impl Default for ClothAvianPlugin {
    fn default() -> Self {
        Self {
            cloth_friction: Friction::new(0.4),
            cloth_restitution: Restitution::ZERO,
            two_way: true,
        }
    }
}

impl ClothAvianPlugin {
    /// With the cloth's friction coefficient μ (avian's default rule).
    pub fn with_cloth_friction(mut self, friction: f32) -> Self {
        self.cloth_friction = Friction::new(friction);
        self
    }

    /// With or without the cloth's impulses on dynamic bodies.
    pub fn with_two_way(mut self, on: bool) -> Self {
        self.two_way = on;
        self
    }
}

/// The settings of [`ClothAvianPlugin`], as a resource.
#[derive(Resource, Clone, Debug)]
pub struct ClothAvianSettings {
    /// See [`ClothAvianPlugin::cloth_friction`].
    pub cloth_friction: Friction,
    /// See [`ClothAvianPlugin::cloth_restitution`].
    pub cloth_restitution: Restitution,
    /// See [`ClothAvianPlugin::two_way`].
    pub two_way: bool,
}

impl Plugin for ClothAvianPlugin {
    fn build(&self, app: &mut App) {
        let schedule = app
            .world()
            .get_resource::<ClothSchedule>()
            .map_or(FixedUpdate.intern(), |s| s.0);
        app.insert_resource(ClothAvianSettings {
            cloth_friction: self.cloth_friction,
            cloth_restitution: self.cloth_restitution,
            two_way: self.two_way,
        })
        .add_systems(
            schedule,
            (
                feed_colliders
                    .run_if(any_with_component::<Collider>)
                    .in_set(ClothColliderSources),
                (push_bodies, separate_bodies)
                    .chain()
                    .run_if(|i: Res<ClothContactImpulses>| !i.is_empty())
                    .in_set(ClothSystems::Writeback),
            ),
        );
    }
}

impl From<CollisionLayers> for ClothContactLayers {
    fn from(layers: CollisionLayers) -> Self {
        Self::new(layers.memberships.0, layers.filters.0)
    }
}

/// An avian collider's shape as the cloth's pieces (or the kind of shape
/// the cloth cannot use), converted when the collider first feeds the
/// scene and again when it changes.
#[derive(Component, Clone, Debug)]
pub struct ClothAvianShape {
    pieces: Result<Arc<[Piece]>, String>,
}

impl ClothAvianShape {
    fn of(collider: &Collider) -> Self {
        Self {
            pieces: shapes::pieces(collider.shape_scaled()).map(Arc::from),
        }
    }
}

/// What the bridge reads of an avian collider.
#[derive(QueryData)]
#[query_data(mutable)]
struct ColliderData {
    entity: Entity,
    collider: Ref<'static, Collider>,
    position: &'static Position,
    rotation: &'static Rotation,
    of: Option<&'static ColliderOf>,
    offset: Option<&'static ColliderTransform>,
    layers: Option<&'static CollisionLayers>,
    friction: Option<&'static Friction>,
    restitution: Option<&'static Restitution>,
    shape: Option<&'static mut ClothAvianShape>,
}

/// What the bridge reads of a collider's body.
#[derive(QueryData)]
struct BodyData {
    body: &'static RigidBody,
    position: &'static Position,
    rotation: &'static Rotation,
    velocity: Option<&'static LinearVelocity>,
    spin: Option<&'static AngularVelocity>,
    centre: Option<&'static ComputedCenterOfMass>,
    mass: Option<&'static ComputedMass>,
    inertia: Option<&'static ComputedAngularInertia>,
    gravity_scale: Option<&'static GravityScale>,
    friction: Option<&'static Friction>,
    restitution: Option<&'static Restitution>,
    disabled: Has<RigidBodyDisabled>,
}

/// The avian colliders the cloth meets: not sensors, not disabled, and not
/// already a [`ClothCollider`].
type Usable = (
    Without<Sensor>,
    Without<ColliderDisabled>,
    Without<ClothCollider>,
);

/// The avian source, in [`ClothColliderSources`]: every usable avian
/// collider's pieces over the coming step.
#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: each parameter is one resource or query"
)]
fn feed_colliders(
    _main: crate::plugin::step::schedule::MainThread,
    mut commands: Commands,
    time: Res<Time<Fixed>>,
    settings: Res<ClothAvianSettings>,
    gravity: Option<Res<Gravity>>,
    mut colliders: Query<ColliderData, Usable>,
    bodies: Query<BodyData>,
    mut scene: ResMut<ClothColliderScene>,
    mut warned: Local<HashSet<Entity>>,
) {
    let dt = time.timestep().as_secs_f32();
    for mut item in &mut colliders {
        let entity = item.entity;
        let Some(pieces) = pieces_of(&mut item, &mut commands, &mut warned) else {
            continue;
        };
        // Where the collider is and how it moves: through its body.
        let own = Isometry3d::new(item.position.0, item.rotation.0);
        let body_entity = item.of.map_or(item.entity, |of| of.body);
        let body = bodies.get(body_entity).ok();
        if body.as_ref().is_some_and(|b| b.disabled) {
            continue;
        }
        let pose = match (&body, item.offset) {
            (Some(b), Some(offset)) if body_entity != item.entity => {
                Isometry3d::new(b.position.0, b.rotation.0)
                    * Isometry3d::new(offset.translation, offset.rotation)
            }
            _ => own,
        };
        let carried = match &body {
            Some(b) if !b.body.is_static() => {
                let gravity = gravity.as_deref();
                carrier(b, body_entity, &settings, gravity, &mut warned)
            }
            _ => Carrier::default(),
        };
        let end = carried.motion.advance(pose, dt);
        let body_friction = body.as_ref().and_then(|b| b.friction);
        let body_restitution = body.as_ref().and_then(|b| b.restitution);
        let friction = item
            .friction
            .or(body_friction)
            .copied()
            .unwrap_or_default()
            .combine(settings.cloth_friction)
            .dynamic_coefficient;
        let restitution = item
            .restitution
            .or(body_restitution)
            .copied()
            .unwrap_or_default()
            .combine(settings.cloth_restitution)
            .coefficient
            .clamp(0.0, 1.0);
        let layers = item
            .layers
            .copied()
            .map_or(ClothContactLayers::ALL, ClothContactLayers::from);
        let surface = (friction, restitution);
        let how = (layers, settings.two_way);
        for collider in carried.colliders(entity, &pieces, (pose, end), surface, how) {
            if let Err(error) = scene.push(collider)
                && warned.insert(entity)
            {
                warn!("avian collider {entity} is ignored by cloth: {error}");
            }
        }
    }
}

/// A collider's pieces, converted once and again when the collider
/// changes (kept in its [`ClothAvianShape`]), or `None`, with a warning
/// once, for a shape the cloth cannot use.
fn pieces_of(
    item: &mut ColliderDataItem<'_, '_>,
    commands: &mut Commands,
    warned: &mut HashSet<Entity>,
) -> Option<Arc<[Piece]>> {
    let entity = item.entity;
    let mut fresh = None;
    let pieces = match item.shape.as_deref_mut() {
        Some(shape) => {
            if item.collider.is_changed() {
                *shape = ClothAvianShape::of(&item.collider);
            }
            shape.pieces.clone()
        }
        None => fresh
            .insert(ClothAvianShape::of(&item.collider))
            .pieces
            .clone(),
    };
    if let Some(fresh) = fresh {
        commands.entity(entity).try_insert(fresh);
    }
    match pieces {
        Ok(pieces) => Some(pieces),
        Err(kind) => {
            if warned.insert(entity) {
                warn!(
                    "avian collider {entity} is ignored by cloth: its shape ({kind}) is not supported"
                );
            }
            None
        }
    }
}

/// A kinematic or dynamic `body` as a [`Carrier`]: with two-way coupling a
/// dynamic one brings its mass, inertia and gravity; a non-finite velocity
/// is taken as still, with a warning once.
fn carrier(
    b: &BodyDataItem<'_, '_>,
    body_entity: Entity,
    settings: &ClothAvianSettings,
    gravity: Option<&Gravity>,
    warned: &mut HashSet<Entity>,
) -> Carrier {
    let mut carrier = Carrier {
        dynamic: b.body.is_dynamic(),
        ..default()
    };
    if carrier.dynamic && settings.two_way {
        let scale = b.gravity_scale.map_or(1.0, |g| g.0);
        carrier.acceleration = gravity.map_or(Vec3::ZERO, |g| g.0) * scale;
        // Zero inverse mass (infinitely heavy) stays infinite.
        carrier.mass = b.mass.map_or(f32::INFINITY, |m| 1.0 / m.inverse());
        carrier.inverse_inertia = b
            .inertia
            .map_or(Mat3::ZERO, |i| i.rotated(b.rotation.0).inverse().to_mat3());
    }
    let centre = b.centre.map_or(Vec3::ZERO, |c| c.0);
    carrier.motion = Motion {
        centre: b.position.0 + b.rotation.0 * centre,
        linear: b.velocity.map_or(Vec3::ZERO, |v| v.0),
        angular: b.spin.map_or(Vec3::ZERO, |w| w.0),
    };
    if !carrier.motion.is_finite() {
        if warned.insert(body_entity) {
            warn!("avian body {body_entity} has a non-finite velocity: cloth takes it as still");
        }
        carrier.motion = Motion::default();
    }
    carrier
}

/// What [`push_bodies`] reads and writes of a body.
type PushedBody = (
    &'static RigidBody,
    &'static ComputedCenterOfMass,
    &'static ComputedMass,
    Option<&'static GravityScale>,
    Forces,
);

/// [`ClothSystems::Writeback`]: the cloth's impulses on each dynamic body,
/// linear and angular about its centre of mass.
fn push_bodies(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    gravity: Option<Res<Gravity>>,
    impulses: Res<ClothContactImpulses>,
    colliders: Query<&ColliderOf>,
    mut bodies: Query<PushedBody, Without<RigidBodyDisabled>>,
    mut lifted: Local<HashSet<Entity>>,
) {
    // The bodies whose gravity this step has swapped already (a body of
    // several colliders is touched through each).
    lifted.clear();
    for (entity, impulse) in impulses.iter() {
        let body = colliders.get(entity).map_or(entity, |of| of.body);
        let Ok((kind, centre, mass, gravity_scale, mut forces)) = bodies.get_mut(body) else {
            continue;
        };
        if !kind.is_dynamic() || !(impulse.linear.is_finite() && impulse.angular.is_finite()) {
            continue;
        }
        let dt = time.timestep().as_secs_f32();
        if dt <= 0.0 {
            continue;
        }
        let body_gravity =
            gravity.as_ref().map_or(Vec3::ZERO, |g| g.0) * gravity_scale.map_or(1.0, |s| s.0);
        let centre = forces.position() + forces.rotation() * centre.0;
        let angular = impulse.angular_about(centre);
        // The solve moved the body as backward Euler does: its position
        // changes by the step times its velocity at the end, gravity
        // included. Avian spreads gravity over its substeps, which leaves
        // the body higher by a part of `g h²` and with a velocity that an
        // impulse at the start of the next step has to take back again:
        // a ball resting on the cloth would read a few cm/s downwards. So
        // for this step the body's gravity comes as an impulse at the
        // start with the cloth's, and a force cancels it over the
        // substeps.
        let weight = Some(mass.value() * body_gravity)
            .filter(|w| w.is_finite() && lifted.insert(body))
            .unwrap_or_default();
        forces.apply_linear_impulse(impulse.linear + weight * dt);
        forces.apply_force(-weight);
        forces.apply_angular_impulse(angular);
    }
}

/// [`ClothSystems::Writeback`], after [`push_bodies`]: each dynamic body's
/// shift out of the cloth it overlaps ([`ContactImpulse::shift`]), made to
/// its `Position` and not to its velocity (a split impulse).
fn separate_bodies(
    _main: crate::plugin::step::schedule::MainThread,
    impulses: Res<ClothContactImpulses>,
    colliders: Query<&ColliderOf>,
    mut bodies: Query<(&RigidBody, &mut Position), Without<RigidBodyDisabled>>,
    mut moved: Local<HashSet<Entity>>,
) {
    moved.clear();
    for (entity, impulse) in impulses.iter() {
        if impulse.shift == Vec3::ZERO || !impulse.shift.is_finite() {
            continue;
        }
        let body = colliders.get(entity).map_or(entity, |of| of.body);
        if let Ok((kind, mut position)) = bodies.get_mut(body)
            && kind.is_dynamic()
            && moved.insert(body)
        {
            position.0 += impulse.shift;
        }
    }
}
