//! Cloth on a moving frame (a character, a cart): a teleport that moves the
//! whole cloth rigidly, and the inertia scales that set how much of the
//! frame's motion the cloth feels.
//!
//! **Inertia.** Before a step, every free particle is carried by `1 − s` of
//! the rigid motion its frame made since the last step (`s` the scale, per
//! translation and rotation), its velocity turned with it
//! ([`Carry`]). The rest of the motion reaches the cloth
//! through its pins, as it would without a frame. At `s = 1` the cloth is
//! simulated in the world as it is; at `s = 0` it moves with the frame as
//! if welded to it and only feels gravity, wind and its own dynamics in
//! the frame. In between, a particle's velocity settles at `s` times the
//! frame's, so the forces that accelerate or turn it (the frame's
//! acceleration, the centripetal pull of a spin) are `s` times what they
//! would be: the cloth feels `s` of the frame's inertia, as NvCloth's and
//! Chaos's inertia scales do.

use bevy::math::{Isometry3d, Quat, Vec3};

/// Moves every particle (pinned ones too) by the rigid motion `by` (a
/// world-space isometry, m and rad) and turns every velocity with it:
/// positions `x` in m, velocities `v` in m/s. The cloth's shape, strain
/// and motion relative to the moved frame are unchanged.
pub fn teleport(x: &mut [Vec3], v: &mut [Vec3], by: Isometry3d) {
    let rotation: Quat = by.rotation;
    for p in x.iter_mut() {
        *p = Vec3::from(by.transform_point(*p));
    }
    for u in v.iter_mut() {
        *u = rotation * *u;
    }
}

/// How much of its frame's motion a cloth feels (module docs): 1 is all
/// of it, 0 none (the cloth is carried with the frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertiaScale {
    /// Of the frame's translation, dimensionless in `[0, 1]`.
    pub linear: f32,
    /// Of the frame's rotation, dimensionless in `[0, 1]`.
    pub angular: f32,
}

/// `1 − s` of a frame's rigid motion over one step (module docs): the
/// motion that carries a cloth's free particles before the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Carry {
    /// The frame's origin before the step, m.
    from: Vec3,
    /// Where it is carried to, m.
    to: Vec3,
    /// The share of the frame's turn.
    turn: Quat,
}

impl Carry {
    /// The unfelt share of the frame's motion from pose `before` to pose
    /// `after` (m, rad) at scales `scale` (clamped to `[0, 1]`); `None`
    /// when it is nothing or a pose is not finite.
    pub fn new((before, after): (Isometry3d, Isometry3d), scale: InertiaScale) -> Option<Self> {
        let (c0, c1) = (
            Vec3::from(before.translation),
            Vec3::from(after.translation),
        );
        let finite = c0.is_finite()
            && c1.is_finite()
            && before.rotation.is_finite()
            && after.rotation.is_finite();
        let linear = 1.0 - scale.linear.clamp(0.0, 1.0);
        let angular = 1.0 - scale.angular.clamp(0.0, 1.0);
        if !finite || (linear == 0.0 && angular == 0.0) || before == after {
            return None;
        }
        let turn = (after.rotation * before.rotation.inverse()).normalize();
        Some(Self {
            from: c0,
            to: c0 + linear * (c1 - c0),
            turn: Quat::IDENTITY.slerp(turn, angular),
        })
    }

    /// The whole rigid motion `by` (m, rad), as a teleport moves a cloth.
    pub fn rigid(by: Isometry3d) -> Self {
        Self {
            from: Vec3::ZERO,
            to: Vec3::from(by.translation),
            turn: by.rotation,
        }
    }

    /// The rigid motion that turns by `turn` about `from` (m) and carries
    /// `from` to `to` (m).
    pub fn between(from: Vec3, to: Vec3, turn: Quat) -> Self {
        Self { from, to, turn }
    }

    /// Where the point `p` (m) is carried.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.to + self.turn * (p - self.from)
    }

    /// How the vector `v` (a velocity, m/s) turns.
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.turn * v
    }

    /// Carries the particles `i` for which `moves(i)`: positions `x` (m)
    /// move, velocities `v` (m/s) turn with them. The free particles move;
    /// so do pins that the frame itself carries (a cape's collar), or the
    /// links to them would stretch by the frame's motion at every step.
    pub fn apply(&self, x: &mut [Vec3], v: &mut [Vec3], moves: impl Fn(usize) -> bool) {
        for (i, (p, u)) in x.iter_mut().zip(v.iter_mut()).enumerate() {
            if moves(i) {
                *p = self.point(*p);
                *u = self.vector(*u);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_teleport_moves_and_turns_everything_rigidly() {
        let mut x = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
        let mut v = vec![Vec3::X, Vec3::Z];
        let by = Isometry3d::new(Vec3::new(10.0, 0.0, 0.0), Quat::from_rotation_y(1.0));
        let d = x[0].distance(x[1]);
        teleport(&mut x, &mut v, by);
        assert!((x[0].distance(x[1]) - d).abs() < 1e-5);
        assert!((x[1] - Vec3::new(10.0, 2.0, 0.0)).length() < 1e-5);
        assert!((v[0] - Quat::from_rotation_y(1.0) * Vec3::X).length() < 1e-6);
    }

    #[test]
    fn carrying_takes_the_unfelt_share_of_the_frames_motion() {
        let before = Isometry3d::new(Vec3::ZERO, Quat::IDENTITY);
        let after = Isometry3d::new(Vec3::new(1.0, 0.0, 0.0), Quat::from_rotation_y(0.5));
        let w = [1.0, 0.0];
        let start = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, 1.0)];
        let run = |linear, angular| {
            let (mut x, mut v) = (start, [Vec3::X; 2]);
            if let Some(c) = Carry::new((before, after), InertiaScale { linear, angular }) {
                c.apply(&mut x, &mut v, |i| w[i] > 0.0);
            }
            (x, v)
        };
        // Nothing felt: carried rigidly, velocity turned; the pinned
        // particle stays.
        let (x, v) = run(0.0, 0.0);
        let rigid = Vec3::from(after.transform_point(start[0]));
        assert!((x[0] - rigid).length() < 1e-6);
        assert!((v[0] - Quat::from_rotation_y(0.5) * Vec3::X).length() < 1e-6);
        assert_eq!((x[1], v[1]), (start[1], Vec3::X));
        // All felt: nothing moves.
        assert_eq!(run(1.0, 1.0), (start, [Vec3::X; 2]));
        // Half the translation felt: carried half way.
        let (x, _) = run(0.5, 1.0);
        assert!((x[0] - Vec3::new(0.5, 0.0, 1.0)).length() < 1e-6);
        // NaN poses do nothing.
        let bad = Isometry3d::new(Vec3::NAN, Quat::IDENTITY);
        let none = InertiaScale {
            linear: 0.0,
            angular: 0.0,
        };
        assert_eq!(Carry::new((before, bad), none), None);
    }
}
