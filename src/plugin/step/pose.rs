//! Where the cloth systems see an entity (an anchor's target, a collider).
//!
//! `GlobalTransform` is propagated by Bevy once per frame, in `PostUpdate`,
//! so an entity moved in `FixedUpdate` (or several fixed steps run in one
//! frame) would reach the cloth late and in jumps. A **root** entity (no
//! parent) is therefore read from its own `Transform`, which is always
//! current; a child from its `GlobalTransform`, as of the last propagation.

use bevy::ecs::query::QueryData;
use bevy::math::{Affine3A, Isometry3d};
use bevy::prelude::{ChildOf, GlobalTransform, Has, Transform};

/// The parts of an entity that say where it is.
#[derive(QueryData)]
pub struct WorldPose {
    transform: Option<&'static Transform>,
    global: Option<&'static GlobalTransform>,
    child: Has<ChildOf>,
}

impl WorldPoseItem<'_, '_> {
    /// Local-to-world transform (m), or `None` without any transform.
    pub fn affine(&self) -> Option<Affine3A> {
        match (self.child, self.transform, self.global) {
            (false, Some(t), _) => Some(t.compute_affine()),
            (_, _, Some(g)) => Some(g.affine()),
            (true, Some(_), None) | (_, None, None) => None,
        }
    }

    /// Rotation and translation (m), scale dropped; `None` without any
    /// transform or when not finite.
    pub fn isometry(&self) -> Option<Isometry3d> {
        let (_, rotation, translation) = self.affine()?.to_scale_rotation_translation();
        (translation.is_finite() && rotation.is_finite())
            .then(|| Isometry3d::new(translation, rotation))
    }
}
