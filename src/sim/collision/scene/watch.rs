//! What a sleeping cloth watches of the colliders around it, to wake when
//! one appears, leaves or moves ([`sleep`](crate::sim::sleep) module docs).

use bevy::math::{Isometry3d, Vec3};

use super::colliders::{ClothContactLayers, ColliderKey, ColliderScene};

/// The colliders around a cloth at the moment it fell asleep, to see what
/// has changed since.
#[derive(Clone, Debug, Default)]
pub(crate) struct ColliderWatch {
    /// Its box grown by thickness and margin, m.
    bounds: (Vec3, Vec3),
    /// The colliders in that box then, sorted by key, with their poses.
    near: Vec<(ColliderKey, Isometry3d)>,
    /// Scratch for the same list now.
    now: Vec<(ColliderKey, Isometry3d)>,
}

impl ColliderWatch {
    /// The colliders of `scene` (sorted by key, with their end poses)
    /// within `bounds` that meet `layers`, into `out`; whether one of them
    /// feels the cloth (a body that must not lose its support), and whether
    /// one moves over this step by more than `tolerance` ([`moved`]).
    fn gather(
        scene: &ColliderScene,
        (bounds, layers, tolerance): ((Vec3, Vec3), ClothContactLayers, f32),
        out: &mut Vec<(ColliderKey, Isometry3d)>,
    ) -> (bool, bool) {
        out.clear();
        let (mut feedback, mut moving) = (false, false);
        for c in scene.overlapping(bounds.0, bounds.1) {
            let collider = &scene.colliders[c];
            if collider.layers.interacts(layers) {
                feedback |= collider.feedback;
                moving |= moved(collider.start, collider.end, tolerance);
                out.push((collider.key, collider.end));
            }
        }
        out.sort_by_key(|(key, _)| key.0);
        (feedback, moving)
    }

    /// Remembers the scene around a cloth falling asleep within `bounds`
    /// (its box grown by thickness and margin, m). `false` if it must stay
    /// awake: a body that feels the cloth is there.
    pub(crate) fn fall_asleep(
        &mut self,
        scene: &ColliderScene,
        bounds: (Vec3, Vec3),
        layers: ClothContactLayers,
    ) -> bool {
        self.bounds = bounds;
        let mut near = std::mem::take(&mut self.near);
        let (feedback, _) = Self::gather(scene, (bounds, layers, f32::INFINITY), &mut near);
        self.near = near;
        !feedback
    }

    /// Whether the colliders around the sleeping cloth have changed: one
    /// appeared or disappeared, or one moved (start to end of this step, or
    /// since it fell asleep) as [`moved`] has it.
    pub(crate) fn scene_changed(
        &mut self,
        scene: &ColliderScene,
        layers: ClothContactLayers,
        tolerance: f32,
    ) -> bool {
        let mut now = std::mem::take(&mut self.now);
        let (_, moving) = Self::gather(scene, (self.bounds, layers, tolerance), &mut now);
        let changed = moving
            || now.len() != self.near.len()
            || now
                .iter()
                .zip(&self.near)
                .any(|(a, b)| a.0 != b.0 || moved(a.1, b.1, tolerance));
        self.now = now;
        changed
    }
}

/// Whether a collider moved from `a` to `b`: its origin by more than
/// `tolerance` m, or a point 1 m from its origin by turning (by more than
/// `tolerance` rad).
fn moved(a: Isometry3d, b: Isometry3d, tolerance: f32) -> bool {
    let shift = Vec3::from(b.translation - a.translation).length();
    let turn = (b.rotation * a.rotation.inverse())
        .normalize()
        .to_axis_angle()
        .1;
    let turn = turn.min(std::f32::consts::TAU - turn);
    !(shift <= tolerance && turn <= tolerance)
}

#[cfg(test)]
mod tests {
    use bevy::math::Quat;

    use super::*;
    use crate::sim::collision::Shape;
    use crate::sim::collision::scene::{ColliderShape, SceneCollider};

    fn scene(poses: &[(u64, Isometry3d, Isometry3d)]) -> ColliderScene {
        let mut scene = ColliderScene::default();
        for &(e, start, end) in poses {
            let shape = ColliderShape::Analytic(Shape::Sphere { radius: 0.1 });
            scene
                .push(SceneCollider::new(ColliderKey(e), shape, start, end))
                .unwrap();
        }
        scene
    }

    #[test]
    fn the_scene_around_a_sleeping_cloth_is_watched() {
        let still = Isometry3d::from_translation(Vec3::ZERO);
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut watch = ColliderWatch::default();
        let all = ClothContactLayers::ALL;
        assert!(watch.fall_asleep(&scene(&[(1, still, still)]), bounds, all));
        assert!(!watch.scene_changed(&scene(&[(1, still, still)]), all, 1e-4));
        // Gone, doubled, replaced, moving, moved since, turned.
        assert!(watch.scene_changed(&scene(&[]), all, 1e-4));
        assert!(watch.scene_changed(&scene(&[(1, still, still), (2, still, still)]), all, 1e-4));
        assert!(watch.scene_changed(&scene(&[(2, still, still)]), all, 1e-4));
        let there = Isometry3d::from_translation(Vec3::X * 0.01);
        assert!(watch.scene_changed(&scene(&[(1, still, there)]), all, 1e-4));
        assert!(watch.scene_changed(&scene(&[(1, there, there)]), all, 1e-4));
        let turned = Isometry3d::from_rotation(Quat::from_rotation_y(0.01));
        assert!(watch.scene_changed(&scene(&[(1, turned, turned)]), all, 1e-4));
        // Far away: not watched.
        let far = Isometry3d::from_translation(Vec3::X * 5.0);
        let far_on = Isometry3d::from_translation(Vec3::X * 6.0);
        assert!(!watch.scene_changed(&scene(&[(1, still, still), (3, far, far_on)]), all, 1e-4));
        // A moving one that enters the box.
        assert!(watch.scene_changed(&scene(&[(1, still, still), (3, far, still)]), all, 1e-4));
    }

    #[test]
    fn a_body_that_feels_the_cloth_keeps_it_awake() {
        let still = Isometry3d::from_translation(Vec3::ZERO);
        let shape = ColliderShape::Analytic(Shape::Sphere { radius: 0.1 });
        let mut scene = ColliderScene::default();
        scene
            .push(SceneCollider::new(ColliderKey(1), shape, still, still).with_feedback(true))
            .unwrap();
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut watch = ColliderWatch::default();
        assert!(!watch.fall_asleep(&scene, bounds, ClothContactLayers::ALL));
    }

    #[test]
    fn a_half_turn_counts_as_moved_and_no_turn_does_not() {
        let a = Isometry3d::from_rotation(Quat::from_rotation_z(3.0));
        let b = Isometry3d::from_rotation(Quat::from_rotation_z(-3.0));
        assert!(moved(a, b, 1e-3));
        assert!(!moved(a, a, 0.0));
    }
}
