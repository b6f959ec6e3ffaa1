//! The colliders of a fixed step as a cloth's contacts see them: each
//! one's surface, its poses over the step, its material and layers and the
//! body behind it ([`SceneCollider`]), named by an opaque [`ColliderKey`]
//! its source chooses, in a [`ColliderScene`] any source fills; and what
//! the cloth gave each one ([`ContactImpulse`]).

use std::sync::Arc;

use bevy::math::{Isometry3d, Mat3, Vec3};
use bevy::reflect::Reflect;
use bevy::reflect::std_traits::ReflectDefault;

use crate::error::ClothError;
use crate::sim::collision::contact::{Geometry, MovingCollider};
use crate::sim::collision::{Shape, TriMesh};
use crate::sim::integrate::implicit::SolveBody;

/// Names a collider's source: what the [`ContactImpulse`]s on it are
/// reported to, and how the colliders around a sleeping cloth are told
/// apart. Opaque to the simulation; the plugin's sources use their
/// entity's bits (`From<Entity>`), and a game's own code may use any
/// number that is the same for one collider from step to step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Reflect)]
pub struct ColliderKey(pub u64);

/// A triangle mesh shared between colliders (opaque to reflection).
#[derive(Clone, Debug, Reflect)]
#[reflect(opaque, Debug, Clone)]
pub struct MeshShape(pub Arc<TriMesh>);

/// The surface of a collider, in its own frame.
#[derive(Clone, Debug, Reflect)]
pub enum ColliderShape {
    /// An analytic shape (exact distances, swept against fast motion).
    Analytic(Shape),
    /// A triangle mesh (vertex–triangle tests with a BVH, plus the paper's
    /// triangle–triangle test).
    Mesh(MeshShape),
}

impl ColliderShape {
    /// Checks an analytic shape's dimensions (finite, positive); a mesh is
    /// valid once built.
    pub fn validate(&self) -> Result<(), ClothError> {
        match self {
            ColliderShape::Analytic(shape) if !shape.is_valid() => Err(
                ClothError::InvalidCollider("shape dimensions must be finite and positive"),
            ),
            _ => Ok(()),
        }
    }

    /// Centre (local, m) and radius (m) of a ball holding the shape.
    pub fn bounding_ball(&self) -> (Vec3, f32) {
        match self {
            ColliderShape::Analytic(shape) => (Vec3::ZERO, shape.bounding_radius()),
            ColliderShape::Mesh(mesh) => {
                let (min, max) = mesh.0.bounds();
                ((min + max) / 2.0, (max - min).length() / 2.0)
            }
        }
    }
}

/// Which colliders a cloth meets, as 32 layer bits: a cloth and a collider
/// meet when each one's `memberships` share a bit with the other's
/// `filters` (avian's rule). On a cloth it sets the cloth's layers; on an
/// entity with a `ClothCollider`, the collider's.
/// Without it, an entity is in every layer and meets every layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Reflect)]
#[reflect(Default, Debug)]
pub struct ClothContactLayers {
    /// The layers it is in.
    pub memberships: u32,
    /// The layers it meets.
    pub filters: u32,
}

impl ClothContactLayers {
    /// In every layer, meeting every layer.
    pub const ALL: Self = Self {
        memberships: u32::MAX,
        filters: u32::MAX,
    };

    /// In `memberships`, meeting `filters`.
    pub const fn new(memberships: u32, filters: u32) -> Self {
        Self {
            memberships,
            filters,
        }
    }

    /// Whether the two meet.
    pub const fn interacts(self, other: Self) -> bool {
        self.memberships & other.filters != 0 && other.memberships & self.filters != 0
    }
}

impl Default for ClothContactLayers {
    fn default() -> Self {
        Self::ALL
    }
}

/// Checks a collider's surface: friction μ finite and ≥ 0, restitution e
/// in [0, 1].
pub(crate) fn check_surface(friction: f32, restitution: f32) -> Result<(), ClothError> {
    if !(friction.is_finite() && friction >= 0.0) {
        return Err(ClothError::InvalidCollider(
            "friction must be finite and non-negative",
        ));
    }
    if !(0.0..=1.0).contains(&restitution) {
        return Err(ClothError::InvalidCollider("restitution must be in [0, 1]"));
    }
    Ok(())
}

/// A collider over the current fixed step, as a source hands it to the
/// [`ColliderScene`].
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct SceneCollider {
    /// The source it came from, to which its [`ContactImpulse`]s are
    /// reported.
    pub key: ColliderKey,
    /// The collider's surface, in its own frame.
    pub shape: ColliderShape,
    /// Pose at the start of the step (world).
    pub start: Isometry3d,
    /// Pose at the end of the step (world).
    pub end: Isometry3d,
    /// World box swept by the collider over the step, m.
    pub min: Vec3,
    /// World box swept by the collider over the step, m.
    pub max: Vec3,
    /// Friction coefficient μ (≥ 0, dimensionless).
    pub friction: f32,
    /// Restitution e (0 … 1).
    pub restitution: f32,
    /// A rounding radius around the shape (m, ≥ 0), added to the cloth's
    /// contact thickness: a rounded box, a sphere-swept mesh.
    pub margin: f32,
    /// The collider's layers.
    pub layers: ClothContactLayers,
    /// Whether the step measures the impulses the cloth gives it
    /// ([`ContactImpulse`]): on for bodies that feel the cloth.
    pub feedback: bool,
    /// The mass (kg) of the body that gives way when the cloth pushes it,
    /// taken into the implicit solve
    /// (`contacts`); infinite
    /// (the default) for a collider that moves as it was going to
    /// whatever the cloth does.
    pub mass: f32,
    /// The body's centre of mass at the start of the step (world, m), about
    /// which it turns when the cloth rubs on it.
    pub centre: Vec3,
    /// The body's inverse inertia tensor at the start of the step (world,
    /// 1/(kg·m²)); zero (the default) for a body that does not turn. With
    /// [`mass`](Self::mass) it sets how the body turns when the cloth
    /// pushes or rubs it off its centre.
    pub inverse_inertia: Mat3,
    /// The acceleration (m/s²) the body's own engine gives it over the
    /// step besides the cloth (its gravity): the implicit solve counts it,
    /// so a body resting on the cloth stays at rest. Zero by default.
    pub acceleration: Vec3,
}

impl SceneCollider {
    /// A collider of `shape` from the source `key` (an entity, in the
    /// plugin), at pose `start` at the start of
    /// the step and `end` at its end; friction 0.4, no restitution, no
    /// margin, every layer, no feedback.
    pub fn new(
        key: impl Into<ColliderKey>,
        shape: ColliderShape,
        start: Isometry3d,
        end: Isometry3d,
    ) -> Self {
        let mut collider = Self {
            key: key.into(),
            shape,
            start,
            end,
            min: Vec3::ZERO,
            max: Vec3::ZERO,
            friction: 0.4,
            restitution: 0.0,
            margin: 0.0,
            layers: ClothContactLayers::ALL,
            feedback: false,
            mass: f32::INFINITY,
            centre: Vec3::ZERO,
            inverse_inertia: Mat3::ZERO,
            acceleration: Vec3::ZERO,
        };
        collider.update_bounds();
        collider
    }

    /// With friction μ.
    pub fn with_friction(mut self, friction: f32) -> Self {
        self.friction = friction;
        self
    }

    /// With restitution e.
    pub fn with_restitution(mut self, restitution: f32) -> Self {
        self.restitution = restitution;
        self
    }

    /// With a rounding radius of `margin` m.
    pub fn with_margin(mut self, margin: f32) -> Self {
        self.margin = margin;
        self.update_bounds();
        self
    }

    /// In `layers`.
    pub fn with_layers(mut self, layers: ClothContactLayers) -> Self {
        self.layers = layers;
        self
    }

    /// With the cloth's impulses on it measured and reported.
    pub fn with_feedback(mut self, feedback: bool) -> Self {
        self.feedback = feedback;
        self
    }

    /// With a body of `mass` kg behind it that gives way (see
    /// [`mass`](Self::mass)).
    pub fn with_mass(mut self, mass: f32) -> Self {
        self.mass = mass;
        self
    }

    /// With the body turning about `centre` (world, m) under the inverse
    /// inertia tensor `inverse_inertia` (world, 1/(kg·m²)) as the cloth rubs
    /// on it (see [`inverse_inertia`](Self::inverse_inertia)).
    pub fn with_inertia(mut self, centre: Vec3, inverse_inertia: Mat3) -> Self {
        self.centre = centre;
        self.inverse_inertia = inverse_inertia;
        self
    }

    /// With the body's engine accelerating it at `acceleration` m/s² over
    /// the step (see [`acceleration`](Self::acceleration)).
    pub fn with_acceleration(mut self, acceleration: Vec3) -> Self {
        self.acceleration = acceleration;
        self
    }

    /// The free body behind the collider, as the implicit solve moves it
    /// within the step; `None` for a collider that does not give way.
    pub fn body(&self) -> Option<SolveBody> {
        let body = SolveBody {
            mass: self.mass,
            centre: self.centre,
            inverse_inertia: self.inverse_inertia,
            acceleration: self.acceleration,
        };
        body.is_usable().then_some(body)
    }

    /// Recomputes [`min`](Self::min)/[`max`](Self::max) from the shape,
    /// margin and poses.
    pub fn update_bounds(&mut self) {
        let (centre, radius) = self.shape.bounding_ball();
        let radius = radius + self.margin.max(0.0);
        let (c0, c1) = (
            Vec3::from(self.start.transform_point(centre)),
            Vec3::from(self.end.transform_point(centre)),
        );
        self.min = c0.min(c1) - radius;
        self.max = c0.max(c1) + radius;
    }

    /// Checks the shape (finite, positive dimensions; a mesh with
    /// triangles), the poses (finite), friction (finite, ≥ 0), restitution
    /// (in [0, 1]), mass (> 0, may be infinite), margin (finite, ≥ 0), centre
    /// of mass and inertia (finite).
    pub fn validate(&self) -> Result<(), ClothError> {
        self.shape.validate()?;
        let finite = |p: &Isometry3d| {
            Vec3::from(p.translation).is_finite()
                && p.rotation.is_finite()
                && p.rotation.length() > 0.5
        };
        if !(finite(&self.start) && finite(&self.end)) {
            return Err(ClothError::InvalidCollider("pose must be finite"));
        }
        check_surface(self.friction, self.restitution)?;
        if self.mass.is_nan() || self.mass <= 0.0 {
            return Err(ClothError::InvalidCollider("mass must be positive"));
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(ClothError::InvalidCollider(
                "margin must be finite and non-negative",
            ));
        }
        if !(self.centre.is_finite() && self.inverse_inertia.is_finite()) {
            return Err(ClothError::InvalidCollider(
                "centre of mass and inertia must be finite",
            ));
        }
        Ok(())
    }

    pub(crate) fn geometry(&self) -> Geometry<'_> {
        match &self.shape {
            ColliderShape::Analytic(shape) => Geometry::Shape(*shape),
            ColliderShape::Mesh(MeshShape(mesh)) => Geometry::Mesh(mesh),
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

/// The colliders of the current fixed step, as every source hands them in
/// (in the plugin, the `ClothColliderScene` resource).
#[derive(Clone, Debug, Default)]
pub struct ColliderScene {
    /// Every valid collider with its poses over the step.
    pub colliders: Vec<SceneCollider>,
}

impl ColliderScene {
    /// Adds `collider` when it is valid ([`SceneCollider::validate`]);
    /// otherwise leaves the scene as it was and says why.
    pub fn push(&mut self, collider: SceneCollider) -> Result<(), ClothError> {
        collider.validate()?;
        self.colliders.push(collider);
        Ok(())
    }

    /// Indices of the colliders whose swept box overlaps `[min, max]` (m).
    pub fn overlapping(&self, min: Vec3, max: Vec3) -> impl Iterator<Item = usize> + '_ {
        self.colliders
            .iter()
            .enumerate()
            .filter(move |(_, c)| !(c.max.cmplt(min).any() || c.min.cmpgt(max).any()))
            .map(|(i, _)| i)
    }
}

/// What the cloths gave one collider over a fixed step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Reflect)]
pub struct ContactImpulse {
    /// Linear impulse on the collider, N·s.
    pub linear: Vec3,
    /// Angular impulse on the collider about the world origin, N·m·s (the
    /// sum of `point × impulse` over the contacts).
    pub angular: Vec3,
    /// The velocity (m/s) of the cloth where it touched the collider,
    /// averaged with each contact's impulse as weight.
    pub cloth_velocity: Vec3,
    /// The shift (m) out of the cloth that the cloth's overlap with the
    /// collider's body calls for, to be made to the body's position with
    /// no change to its velocity (a split impulse: the cloth's contact
    /// springs take only as much of an overlap as their load explains).
    /// Reported with one collider of the body; of several cloths, the
    /// larger shift.
    pub shift: Vec3,
    /// The weight of that average: the sum of the contacts' impulse
    /// magnitudes, N·s.
    weight: f32,
}

impl ContactImpulse {
    /// The angular impulse (N·m·s) about `point` (world, m), such as the
    /// body's centre of mass.
    pub fn angular_about(&self, point: Vec3) -> Vec3 {
        self.angular - point.cross(self.linear)
    }

    /// Adds an impulse `impulse` (N·s) applied at `point` (world, m) by
    /// cloth moving at `velocity` (m/s).
    pub fn add_at(&mut self, impulse: Vec3, point: Vec3, velocity: Vec3) {
        *self += Self {
            linear: impulse,
            angular: point.cross(impulse),
            cloth_velocity: velocity,
            weight: impulse.length(),
            ..Self::default()
        };
    }
}

impl std::ops::AddAssign for ContactImpulse {
    fn add_assign(&mut self, other: Self) {
        self.linear += other.linear;
        self.angular += other.angular;
        let weight = self.weight + other.weight;
        if weight > 0.0 {
            self.cloth_velocity =
                (self.cloth_velocity * self.weight + other.cloth_velocity * other.weight) / weight;
        }
        self.weight = weight;
        // Two cloths under one body each see its overlap: the larger shift
        // takes both out.
        if other.shift.length() > self.shift.length() {
            self.shift = other.shift;
        }
    }
}
