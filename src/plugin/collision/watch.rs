//! What a sleeping cloth watches of the collider scene
//! ([`sleep`](crate::plugin::step::sleep) module docs).

use bevy::ecs::change_detection::Tick;
use bevy::math::{Isometry3d, Vec3};
use bevy::prelude::Entity;

use super::{ClothColliderScene, ClothContactLayers};
use crate::plugin::step::sleep::Change;
use crate::sim::sleep::SleepSettings;

/// What a sleeping cloth remembers of the moment it fell asleep, to see
/// what has changed since (not reflected).
#[derive(Clone, Debug, Default)]
pub(crate) struct SleepWatch {
    /// The particles' change tick when it fell asleep.
    pub(crate) tick: Option<Tick>,
    /// Its box grown by thickness and margin, m.
    pub(crate) bounds: (Vec3, Vec3),
    /// The colliders in that box then, sorted by entity, with their poses.
    pub(crate) near: Vec<(Entity, Isometry3d)>,
    /// Scratch for the same list now.
    now: Vec<(Entity, Isometry3d)>,
    /// The thresholds of its last step.
    pub(crate) settings: SleepSettings,
    /// An event to trigger at the end of the step.
    pub(crate) event: Option<Change>,
}

impl SleepWatch {
    /// The colliders of `scene` (sorted by entity, with their end poses)
    /// within `bounds` that meet `layers`, into `out`; whether one of them
    /// feels the cloth (a body that must not lose its support), and whether
    /// one moves over this step by more than `tolerance` ([`moved`]).
    fn gather(
        scene: &ClothColliderScene,
        (bounds, layers, tolerance): ((Vec3, Vec3), ClothContactLayers, f32),
        out: &mut Vec<(Entity, Isometry3d)>,
    ) -> (bool, bool) {
        out.clear();
        let (mut feedback, mut moving) = (false, false);
        for c in scene.overlapping(bounds.0, bounds.1) {
            let collider = &scene.colliders[c];
            if collider.layers.interacts(layers) {
                feedback |= collider.feedback;
                moving |= moved(collider.start, collider.end, tolerance);
                out.push((collider.entity, collider.end));
            }
        }
        out.sort_by_key(|(e, _)| e.to_bits());
        (feedback, moving)
    }

    /// Remembers the scene around a cloth falling asleep within `bounds`
    /// (its box grown by thickness and margin, m). `false` if it must stay
    /// awake: a body that feels the cloth is there.
    pub(crate) fn fall_asleep(
        &mut self,
        scene: &ClothColliderScene,
        bounds: (Vec3, Vec3),
        layers: ClothContactLayers,
        tick: Tick,
    ) -> bool {
        self.bounds = bounds;
        let mut near = std::mem::take(&mut self.near);
        let (feedback, _) = Self::gather(scene, (bounds, layers, f32::INFINITY), &mut near);
        self.near = near;
        self.tick = (!feedback).then_some(tick);
        !feedback
    }

    /// Whether the colliders around the sleeping cloth have changed: one
    /// appeared or disappeared, or one moved (start to end of this step, or
    /// since it fell asleep) as [`moved`] has it.
    pub(crate) fn scene_changed(
        &mut self,
        scene: &ClothColliderScene,
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
    use super::*;
    use crate::plugin::collision::{ColliderShape, SceneCollider, Shape};
    use bevy::math::Quat;

    fn scene(poses: &[(u32, Isometry3d, Isometry3d)]) -> ClothColliderScene {
        let mut scene = ClothColliderScene::default();
        for &(e, start, end) in poses {
            let shape = ColliderShape::Analytic(Shape::Sphere { radius: 0.1 });
            scene
                .push(SceneCollider::new(
                    Entity::from_raw_u32(e).unwrap(),
                    shape,
                    start,
                    end,
                ))
                .unwrap();
        }
        scene
    }

    #[test]
    fn the_scene_around_a_sleeping_cloth_is_watched() {
        let still = Isometry3d::from_translation(Vec3::ZERO);
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut watch = SleepWatch::default();
        let tick = Tick::new(1);
        let all = ClothContactLayers::ALL;
        assert!(watch.fall_asleep(&scene(&[(1, still, still)]), bounds, all, tick));
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
        let mut scene = ClothColliderScene::default();
        scene
            .push(
                SceneCollider::new(Entity::from_raw_u32(1).unwrap(), shape, still, still)
                    .with_feedback(true),
            )
            .unwrap();
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut watch = SleepWatch::default();
        assert!(!watch.fall_asleep(&scene, bounds, ClothContactLayers::ALL, Tick::new(1)));
    }

    #[test]
    fn a_half_turn_counts_as_moved_and_no_turn_does_not() {
        let a = Isometry3d::from_rotation(Quat::from_rotation_z(3.0));
        let b = Isometry3d::from_rotation(Quat::from_rotation_z(-3.0));
        assert!(moved(a, b, 1e-3));
        assert!(!moved(a, a, 0.0));
    }
}
