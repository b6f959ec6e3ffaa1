//! A physics engine's body moving over the coming fixed step, as the
//! bridges hand its colliders to the cloth.

use bevy::ecs::entity::Entity;
use bevy::math::{Isometry3d, Mat3, Quat, Vec3};

use crate::plugin::bridges::parry_shapes::Piece;
use crate::plugin::collision::{ClothContactLayers, SceneCollider};

/// A body's motion over the coming step: its centre of mass (world, m) and
/// linear (m/s) and angular (rad/s) velocity.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Motion {
    pub(crate) centre: Vec3,
    pub(crate) linear: Vec3,
    pub(crate) angular: Vec3,
}

impl Motion {
    /// Whether every part is finite.
    pub(crate) fn is_finite(&self) -> bool {
        self.centre.is_finite() && self.linear.is_finite() && self.angular.is_finite()
    }

    /// `pose` moved on by `dt` s.
    pub(crate) fn advance(&self, pose: Isometry3d, dt: f32) -> Isometry3d {
        let turn = Quat::from_scaled_axis(self.angular * dt);
        let at = Vec3::from(pose.translation);
        Isometry3d::new(
            self.centre + turn * (at - self.centre) + self.linear * dt,
            (turn * pose.rotation).normalize(),
        )
    }
}

/// How a collider's body moves over the step, and what the cloth's solve
/// knows of it: a static body or none stands still, infinitely heavy.
pub(crate) struct Carrier {
    /// Its motion (centre in m, velocities in m/s and rad/s).
    pub(crate) motion: Motion,
    /// Whether it is dynamic (the cloth's contacts push it).
    pub(crate) dynamic: bool,
    /// Mass, kg (infinite unless dynamic with two-way coupling).
    pub(crate) mass: f32,
    /// World inverse inertia, 1/(kg·m²).
    pub(crate) inverse_inertia: Mat3,
    /// Gravity on it, m/s².
    pub(crate) acceleration: Vec3,
}

impl Default for Carrier {
    fn default() -> Self {
        Self {
            motion: Motion::default(),
            dynamic: false,
            mass: f32::INFINITY,
            inverse_inertia: Mat3::ZERO,
            acceleration: Vec3::ZERO,
        }
    }
}

impl Carrier {
    /// The scene colliders of `entity`'s `pieces`, carried by this body from
    /// `pose` at the start of the step to `end`, with the combined friction
    /// and restitution (dimensionless) and its `layers`; with `two_way` a
    /// dynamic body feels the cloth's impulses.
    pub(crate) fn colliders<'a>(
        &'a self,
        entity: Entity,
        pieces: &'a [Piece],
        (pose, end): (Isometry3d, Isometry3d),
        (friction, restitution): (f32, f32),
        (layers, two_way): (ClothContactLayers, bool),
    ) -> impl Iterator<Item = SceneCollider> + 'a {
        pieces.iter().map(move |piece| {
            SceneCollider::new(
                entity,
                piece.shape.clone(),
                pose * piece.offset,
                end * piece.offset,
            )
            .with_friction(friction)
            .with_restitution(restitution)
            .with_margin(piece.margin)
            .with_layers(layers)
            .with_feedback(self.dynamic && two_way)
            .with_mass(self.mass)
            .with_inertia(self.motion.centre, self.inverse_inertia)
            .with_acceleration(self.acceleration)
        })
    }
}
