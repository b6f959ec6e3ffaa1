//! A physics engine's body moving over the coming fixed step, as the
//! bridges hand its colliders to the cloth.

use bevy::math::{Isometry3d, Quat, Vec3};

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
