//! What a cloth's step does to the colliders with
//! [`feedback`](SceneCollider::feedback): the impulses it gives them, and
//! how the implicit solve moves the bodies behind them within the step.

use bevy::math::{Isometry3d, Quat, Vec3};

use super::colliders::{ContactImpulse, SceneCollider};
use crate::sim::collision::contact::MovingCollider;
use crate::sim::step::Substep;

/// A free body's velocity change from a substep the implicit solve moved
/// it in, kept for the rest of the step.
#[derive(Clone, Copy, Debug)]
pub(super) struct Carried {
    /// Scene index of the collider.
    pub(super) collider: usize,
    /// Linear (m/s) and angular (rad/s) velocity change.
    pub(super) linear: Vec3,
    pub(super) angular: Vec3,
    /// The shift (m) out of the cloth's overlap made then.
    pub(super) shift: Vec3,
    /// From when (a fraction of the step) it moves so.
    pub(super) from: f32,
}

/// The impulses a cloth's step gave the colliders with feedback, by scene
/// index (a handful: a linear list), and how the implicit solve moved their
/// bodies within the step.
#[derive(Clone, Debug, Default)]
pub(crate) struct Feedback {
    /// Scene index and impulse on that collider.
    pub(crate) impulses: Vec<(usize, ContactImpulse)>,
    /// Scratch: the velocities before a collider's response, m/s.
    pub(super) before: Vec<Vec3>,
    /// The velocity changes the solve gave bodies in this step's substeps
    /// so far: a body the first substep stopped is not taken as still
    /// falling in the next.
    pub(super) carried: Vec<Carried>,
    /// The colliders of the last solve's bodies: scene index, and the
    /// body's index in the solve's bodies.
    pub(super) sources: Vec<(usize, u32)>,
    /// The substep of the last solve.
    pub(super) at: Substep,
}

impl Feedback {
    /// `collider` (scene index `c`) over `sub`, moved as the solve moved
    /// its body in the substeps before: by each velocity change since the
    /// substep it came from, turning about the body's centre of mass.
    pub(super) fn moving<'a>(
        &self,
        collider: &'a SceneCollider,
        c: usize,
        sub: Substep,
    ) -> MovingCollider<'a> {
        let mut moving = collider.between(sub.from, sub.to);
        if !self.carried.iter().any(|k| k.collider == c) {
            return moving;
        }
        let span = sub.to - sub.from;
        if span <= 0.0 {
            return moving;
        }
        let step = sub.dt / span;
        let origin = Vec3::from(collider.start.translation);
        let shift = |pose: &mut Isometry3d, t: f32| {
            let (mut linear, mut angular) = (Vec3::ZERO, Vec3::ZERO);
            for k in self.carried.iter().filter(|k| k.collider == c) {
                let time = (t - k.from).max(0.0) * step;
                linear += k.linear * time;
                angular += k.angular * time;
                if t >= k.from {
                    linear += k.shift;
                }
            }
            let turn = Quat::from_scaled_axis(angular);
            let at = Vec3::from(pose.translation);
            let centre = collider.centre + (at - origin);
            pose.rotation = turn * pose.rotation;
            pose.translation = (centre + turn * (at - centre) + linear).into();
        };
        shift(&mut moving.start, sub.from);
        shift(&mut moving.end, sub.to);
        moving
    }

    pub(super) fn entry(&mut self, c: usize) -> &mut ContactImpulse {
        match self.impulses.iter().position(|(i, _)| *i == c) {
            Some(k) => &mut self.impulses[k].1,
            None => {
                self.impulses.push((c, ContactImpulse::default()));
                &mut self.impulses.last_mut().expect("just pushed").1
            }
        }
    }

    /// Before a response that may change `v`: remembers it.
    pub(super) fn mark(&mut self, v: &[Vec3]) {
        self.before.clear();
        self.before.extend_from_slice(v);
    }

    /// After it: the momentum it gave the particles (masses from the
    /// inverse masses `w`, 1/kg), at their positions `x` (m), goes to
    /// collider `c` with the opposite sign.
    pub(super) fn measure(&mut self, c: usize, x: &[Vec3], v: &[Vec3], w: &[f32]) {
        let mut total = ContactImpulse::default();
        for (((&before, &after), &p), &w) in self.before.iter().zip(v).zip(x).zip(w) {
            if after != before && w > 0.0 {
                total.add_at(-(after - before) / w, p, after);
            }
        }
        if total != ContactImpulse::default() {
            *self.entry(c) += total;
        }
    }
}
