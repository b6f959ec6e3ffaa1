//! The rapier bridge (cargo feature `rapier`, bevy_rapier3d 0.37): rapier's
//! colliders are cloth colliders, and the cloth pushes rapier's dynamic
//! bodies back.
//!
//! [`ClothRapierPlugin`], added after [`ClothPlugin`](crate::ClothPlugin)
//! and bevy_rapier's `RapierPhysicsPlugin`:
//!
//! - **Colliders.** Every collider in a rapier context collides with every
//!   cloth whose [`ClothContactLayers`] its `CollisionGroups` share (memberships
//!   and filters as bit masks), with no [`ClothCollider`] beside it; the
//!   shapes are those of the avian bridge (both engines use parry): balls,
//!   cuboids, capsules, cylinders and cones exactly; convex hulls, triangle
//!   meshes, height fields and triangles as triangle meshes; compounds part
//!   by part; rounded shapes with their border radius; half-spaces as
//!   planes. Sensors, disabled colliders, colliders of disabled bodies and
//!   rapier's own soft bodies are ignored, and an entity that also has a
//!   `ClothCollider` (or an avian collider, when both bridges run) collides
//!   through that one only. A shape the cloth cannot use is skipped with
//!   one warning per collider.
//! - **Where and how fast.** The bridge reads rapier's own sets: a collider
//!   is taken at the pose rapier holds for it and moved over the coming
//!   fixed step at its body's linear and angular velocity about the centre
//!   of mass (the body's `Velocity` component when it has one, so a
//!   velocity the game sets this frame moves the collider this step). A body whose velocity is not finite is taken as still (one
//!   warning).
//! - **Friction and restitution**: the collider's coefficients combined
//!   with [`ClothRapierPlugin::cloth_friction`] and
//!   [`ClothRapierPlugin::cloth_restitution`] as rapier combines two
//!   colliders' (the rule with the higher priority of the two).
//! - **Two-way coupling.** The impulses the cloth's contacts give a dynamic
//!   body over a step are added to its `ExternalImpulse` in
//!   [`ClothSystems::Writeback`], linear and angular about its centre of
//!   mass; rapier applies them at its next sync. The shift out of the
//!   cloth that its overlap calls for
//!   ([`ContactImpulse::shift`](crate::plugin::collision::ContactImpulse::shift))
//!   is made to its position in rapier's body set, not to its velocity.
//!   Kinematic and fixed bodies are one-way.
//!
//! bevy_rapier steps in `PostUpdate` unless told otherwise; with
//! `RapierPhysicsPlugin::in_fixed_schedule()` it steps in `FixedUpdate`,
//! and the plugin orders the cloth's sets before rapier's there, so the
//! cloth's impulses enter the step that follows.

use std::sync::Arc;

use bevy::app::{App, FixedUpdate, Plugin};
use bevy::ecs::schedule::ScheduleLabel;
use bevy::log::warn;
use bevy::math::{Isometry3d, Vec3};
use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::*;
use bevy::time::Fixed;
use bevy_rapier3d::plugin::PhysicsSet;
use bevy_rapier3d::prelude::{
    ExternalForce, ExternalImpulse, RapierConfiguration, RapierContextColliders,
    RapierRigidBodySet, Velocity,
};
use bevy_rapier3d::rapier::dynamics::{CoefficientCombineRule, RigidBody};
use bevy_rapier3d::rapier::geometry::Collider;

use crate::plugin::ClothSchedule;
use crate::plugin::bridges::body_motion::{Carrier, Motion};
use crate::plugin::bridges::parry_shapes::{self as shapes, Piece};
use crate::plugin::collision::{
    ClothCollider, ClothColliderScene, ClothColliderSources, ClothContactImpulses,
    ClothContactLayers,
};
use crate::plugin::step::schedule::{ClothSystems, MainThread};

/// rapier's colliders as cloth colliders, and the cloth's impulses on
/// rapier's dynamic bodies (module docs). Add it after `ClothPlugin`.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// use bevy_rapier3d::prelude::*;
/// use bevy_cloth::plugin::bridges::rapier::ClothRapierPlugin;
///
/// App::new()
///     .add_plugins((DefaultPlugins, RapierPhysicsPlugin::<NoUserData>::default()))
///     .add_plugins((ClothPlugin::default(), ClothRapierPlugin::default()))
///     .run();
/// ```
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ClothRapierPlugin {
    /// The cloth's side of every contact's friction coefficient μ
    /// (dimensionless).
    pub cloth_friction: f32,
    /// How [`Self::cloth_friction`] combines with a collider's.
    pub cloth_friction_rule: CoefficientCombineRule,
    /// The cloth's side of every contact's restitution (0 … 1).
    pub cloth_restitution: f32,
    /// How [`Self::cloth_restitution`] combines with a collider's.
    pub cloth_restitution_rule: CoefficientCombineRule,
    /// Whether the cloth pushes dynamic bodies back (on by default).
    pub two_way: bool,
}

impl Default for ClothRapierPlugin {
    fn default() -> Self {
        Self {
            cloth_friction: 0.4,
            cloth_friction_rule: CoefficientCombineRule::Average,
            cloth_restitution: 0.0,
            cloth_restitution_rule: CoefficientCombineRule::Average,
            two_way: true,
        }
    }
}

impl ClothRapierPlugin {
    /// With the cloth's friction coefficient μ (rapier's default rule, the
    /// average).
    pub fn with_cloth_friction(mut self, friction: f32) -> Self {
        self.cloth_friction = friction;
        self
    }

    /// With or without the cloth's impulses on dynamic bodies.
    pub fn with_two_way(mut self, on: bool) -> Self {
        self.two_way = on;
        self
    }
}

/// The settings of [`ClothRapierPlugin`], as a resource.
#[derive(Resource, Clone, Debug)]
pub struct ClothRapierSettings(pub ClothRapierPlugin);

impl Plugin for ClothRapierPlugin {
    fn build(&self, app: &mut App) {
        let schedule = app
            .world()
            .get_resource::<ClothSchedule>()
            .map_or(FixedUpdate.intern(), |s| s.0);
        app.insert_resource(ClothRapierSettings(self.clone()))
            .init_resource::<HeldUp>()
            .configure_sets(
                schedule,
                ClothSystems::Writeback.before(PhysicsSet::SyncBackend),
            )
            .add_systems(
                schedule,
                (
                    feed_colliders
                        .run_if(any_with_component::<RapierContextColliders>)
                        .in_set(ClothColliderSources),
                    (push_bodies, separate_bodies)
                        .chain()
                        .run_if(|i: Res<ClothContactImpulses>, lifted: Res<HeldUp>| {
                            !(i.is_empty() && lifted.0.is_empty())
                        })
                        .in_set(ClothSystems::Writeback),
                ),
            );
    }
}

/// A rapier collider's pieces, keyed by the shape they came from.
struct Cached {
    /// The address of the collider's shape when converted.
    shape: usize,
    pieces: Result<Arc<[Piece]>, String>,
    /// Whether the collider was seen in the latest pass.
    seen: bool,
}

/// The address of a collider's shape: a new shape is a new allocation.
fn shape_key(collider: &Collider) -> usize {
    Arc::as_ptr(&collider.shared_shape().0) as *const () as usize
}

/// A rapier body's motion: its `Velocity` component when it has one (the
/// velocity rapier takes into its coming step, written by the game this
/// frame), else rapier's own.
fn motion_of(body: &RigidBody, velocity: Option<&Velocity>) -> Motion {
    let (linear, angular) =
        velocity.map_or((body.linvel(), body.angvel()), |v| (v.linear, v.angular));
    Motion {
        centre: body.center_of_mass(),
        linear,
        angular,
    }
}

/// The entities whose colliders the cloth already meets another way.
#[cfg(feature = "avian")]
type Elsewhere = Or<(With<ClothCollider>, With<avian3d::prelude::Collider>)>;
#[cfg(not(feature = "avian"))]
type Elsewhere = With<ClothCollider>;

/// The rapier source, in [`ClothColliderSources`]: every usable collider of
/// every rapier context, over the coming step.
#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: each parameter is one resource or query"
)]
fn feed_colliders(
    _main: MainThread,
    time: Res<Time<Fixed>>,
    settings: Res<ClothRapierSettings>,
    contexts: Query<(
        &RapierContextColliders,
        &RapierRigidBodySet,
        Option<&RapierConfiguration>,
    )>,
    elsewhere: Query<(), Elsewhere>,
    velocities: Query<&Velocity>,
    mut scene: ResMut<ClothColliderScene>,
    mut cache: Local<HashMap<Entity, Cached>>,
    mut warned: Local<HashSet<Entity>>,
) {
    let dt = time.timestep().as_secs_f32();
    let settings = &settings.0;
    for cached in cache.values_mut() {
        cached.seen = false;
    }
    for (colliders, bodies, config) in &contexts {
        let gravity = config.map_or(Vec3::ZERO, |c| c.gravity);
        for (_, collider) in colliders.colliders.iter() {
            if !collider.is_enabled() || collider.is_sensor() {
                continue;
            }
            let entity = RapierContextColliders::entity_from_collider(collider);
            if elsewhere.contains(entity) {
                continue;
            }
            let body = collider.parent().and_then(|h| bodies.bodies.get(h));
            if body.is_some_and(|b| !b.is_enabled() || b.soft_body().is_some()) {
                continue;
            }
            let Some(pieces) = pieces_of(&mut cache, entity, collider, &mut warned) else {
                continue;
            };
            let at = collider.position();
            let pose = Isometry3d::new(at.translation, at.rotation);
            let carried = match body {
                Some(body) if !body.is_fixed() => {
                    let velocity = Entity::try_from_bits(body.user_data as u64)
                        .and_then(|e| velocities.get(e).ok());
                    carrier(body, velocity, entity, (settings, gravity), &mut warned)
                }
                _ => Carrier::default(),
            };
            let end = carried.motion.advance(pose, dt);
            let friction = CoefficientCombineRule::combine(
                collider.friction(),
                settings.cloth_friction,
                collider.friction_combine_rule(),
                settings.cloth_friction_rule,
            );
            let restitution = CoefficientCombineRule::combine(
                collider.restitution(),
                settings.cloth_restitution,
                collider.restitution_combine_rule(),
                settings.cloth_restitution_rule,
            )
            .clamp(0.0, 1.0);
            let groups = collider.collision_groups();
            let layers = ClothContactLayers::new(groups.memberships.bits(), groups.filter.bits());
            let surface = (friction, restitution);
            let how = (layers, settings.two_way);
            for collider in carried.colliders(entity, &pieces, (pose, end), surface, how) {
                if let Err(error) = scene.push(collider)
                    && warned.insert(entity)
                {
                    warn!("rapier collider {entity} is ignored by cloth: {error}");
                }
            }
        }
    }
    cache.retain(|_, cached| cached.seen);
}

/// A collider's pieces, converted once and again when its shape is
/// replaced (kept in `cache`, marked seen), or `None`, with a warning once,
/// for a shape the cloth cannot use.
fn pieces_of(
    cache: &mut HashMap<Entity, Cached>,
    entity: Entity,
    collider: &Collider,
    warned: &mut HashSet<Entity>,
) -> Option<Arc<[Piece]>> {
    let key = shape_key(collider);
    let cached = cache.entry(entity).or_insert_with(|| Cached {
        shape: usize::MAX,
        pieces: Err(String::new()),
        seen: false,
    });
    if cached.shape != key {
        cached.shape = key;
        cached.pieces = shapes::pieces(collider.shared_shape()).map(Arc::from);
    }
    cached.seen = true;
    match &cached.pieces {
        Ok(pieces) => Some(pieces.clone()),
        Err(kind) => {
            if warned.insert(entity) {
                warn!(
                    "rapier collider {entity} is ignored by cloth: its shape ({kind}) is not supported"
                );
            }
            None
        }
    }
}

/// A kinematic or dynamic rapier `body` as a [`Carrier`], moving at its
/// `velocity` component if it has one: with two-way coupling a dynamic one
/// of positive mass brings its mass, inertia and `gravity` (m/s²); a
/// non-finite velocity is taken as still, with a warning once.
fn carrier(
    body: &RigidBody,
    velocity: Option<&Velocity>,
    entity: Entity,
    (settings, gravity): (&ClothRapierPlugin, Vec3),
    warned: &mut HashSet<Entity>,
) -> Carrier {
    let mut carrier = Carrier {
        dynamic: body.is_dynamic(),
        ..default()
    };
    if carrier.dynamic && settings.two_way && body.mass() > 0.0 {
        carrier.mass = body.mass();
        carrier.acceleration = gravity * body.gravity_scale();
        let i = body.mass_properties().effective_world_inv_inertia;
        carrier.inverse_inertia = Mat3::from_cols(
            Vec3::new(i.m11, i.m12, i.m13),
            Vec3::new(i.m12, i.m22, i.m23),
            Vec3::new(i.m13, i.m23, i.m33),
        );
    }
    carrier.motion = motion_of(body, velocity);
    if !carrier.motion.is_finite() {
        if warned.insert(entity) {
            warn!(
                "rapier collider {entity} moves with a non-finite velocity: cloth takes it as still"
            );
        }
        carrier.motion = Motion::default();
    }
    carrier
}

/// The bodies whose gravity [`push_bodies`] cancelled over the last step:
/// the weight (N) it held up and the `ExternalForce` it left.
#[derive(Resource, Default)]
struct HeldUp(HashMap<Entity, (Vec3, Vec3)>);

/// [`ClothSystems::Writeback`]: the cloth's impulses on each dynamic body,
/// added to its `ExternalImpulse`, linear and angular about its centre of
/// mass.
///
/// The solve moved the body as backward Euler does, its position changing
/// by the step times its velocity at the end, gravity included; rapier
/// integrates gravity over its substeps, which would leave a body the cloth
/// holds up a little higher and with a few cm/s downwards. So for each step
/// in which the cloth touches it, the body's gravity comes as part of the
/// impulse, and an `ExternalForce` against its weight cancels rapier's. It
/// is taken off again the step after, unless the game has written that
/// `ExternalForce` since (which replaced it).
#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: each parameter is one resource or query"
)]
fn push_bodies(
    _main: MainThread,
    mut commands: Commands,
    time: Res<Time<Fixed>>,
    impulses: Res<ClothContactImpulses>,
    contexts: Query<(
        &RapierContextColliders,
        &RapierRigidBodySet,
        Option<&RapierConfiguration>,
    )>,
    mut pending: Query<(Option<&mut ExternalImpulse>, Option<&mut ExternalForce>)>,
    mut fresh: Local<HashMap<Entity, (ExternalImpulse, ExternalForce)>>,
    mut lifted: ResMut<HeldUp>,
    mut now: Local<HashMap<Entity, Vec3>>,
) {
    let dt = time.timestep().as_secs_f32();
    // The weight each body touched now is held up by (N).
    now.clear();
    for (entity, impulse) in impulses.iter() {
        if !(impulse.linear.is_finite() && impulse.angular.is_finite()) {
            continue;
        }
        let Some((body_entity, body, gravity)) = contexts.iter().find_map(|(c, b, config)| {
            let body_entity = c.collider_parent(b, entity)?;
            let body = b.bodies.get(*b.entity2body().get(&body_entity)?)?;
            Some((body_entity, body, config.map_or(Vec3::ZERO, |c| c.gravity)))
        }) else {
            continue;
        };
        let mass = body.mass();
        if !body.is_dynamic() || mass.is_nan() || mass <= 0.0 {
            continue;
        }
        let mut add = ExternalImpulse {
            impulse: impulse.linear,
            torque_impulse: impulse.angular_about(body.center_of_mass()),
        };
        let weight = mass * body.gravity_scale() * gravity;
        if weight.is_finite() && !now.contains_key(&body_entity) {
            now.insert(body_entity, weight);
            add.impulse += weight * dt;
        }
        match pending.get_mut(body_entity) {
            Ok((Some(mut queued), _)) => *queued += add,
            _ => fresh.entry(body_entity).or_default().0 += add,
        }
    }
    // The force cancelling gravity: last step's taken off (unless the game
    // replaced it since: `lifted` holds the weight and the force left),
    // this step's put on.
    for (body, (weight, force_left)) in lifted.0.drain() {
        if let Ok((_, Some(mut force))) = pending.get_mut(body)
            && force.force == force_left
        {
            force.force += weight;
        }
    }
    for (&body, &weight) in now.iter() {
        let force = match pending.get_mut(body) {
            Ok((_, Some(mut force))) => {
                force.force -= weight;
                force.force
            }
            _ => {
                let force = &mut fresh.entry(body).or_default().1.force;
                *force -= weight;
                *force
            }
        };
        lifted.0.insert(body, (weight, force));
    }
    for (body, (impulse, force)) in fresh.drain() {
        let mut body = commands.entity(body);
        if impulse != ExternalImpulse::default() {
            body.try_insert(impulse);
        }
        if force != ExternalForce::default() {
            body.try_insert(force);
        }
    }
}

/// [`ClothSystems::Writeback`], after [`push_bodies`]: each dynamic body's
/// shift out of the cloth it overlaps ([`ContactImpulse::shift`]), made to
/// its position in rapier's body set and not to its velocity (a split
/// impulse).
///
/// [`ContactImpulse::shift`]: crate::plugin::collision::ContactImpulse::shift
fn separate_bodies(
    _main: MainThread,
    impulses: Res<ClothContactImpulses>,
    mut contexts: Query<(&RapierContextColliders, &mut RapierRigidBodySet)>,
    mut moved: Local<HashSet<Entity>>,
) {
    moved.clear();
    for (entity, impulse) in impulses.iter() {
        if impulse.shift == Vec3::ZERO || !impulse.shift.is_finite() {
            continue;
        }
        for (colliders, mut set) in contexts.iter_mut() {
            let Some(body_entity) = colliders.collider_parent(&set, entity) else {
                continue;
            };
            let Some(&handle) = set.entity2body().get(&body_entity) else {
                continue;
            };
            if let Some(body) = set.bodies.get_mut(handle)
                && body.is_dynamic()
                && moved.insert(body_entity)
            {
                let translation = body.translation() + impulse.shift;
                body.set_translation(translation, true);
            }
        }
    }
}
