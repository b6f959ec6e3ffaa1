//! The overlap of a free body with a cloth that cannot give way (lying on
//! a fixed surface under the body), taken out by moving the body (a split
//! impulse): such a contact's spring takes only as much of an overlap as
//! its load explains, and the rest is removed from the body's position
//! without giving it any velocity.
//!
//! Taken out as velocity, as the springs of fixed surfaces take it, an
//! overlap becomes motion that outlasts it: a plate tipped by a tablecloth
//! sliding out under it sinks its leading rim into the cloth, is pushed
//! back out over the step, and overshoots to the other rim, faster each
//! step, until it is thrown.
//!
//! The body is shifted, not turned: a turn made to its position would tip
//! a body standing on an uneven, moving cloth (a wrinkle passing under one
//! rim of a plate), which its contacts' springs then hold tipped.

use bevy::math::Vec3;

/// Gauss–Seidel sweeps over a body's overlapping contacts.
const SWEEPS: usize = 8;

/// One contact of a body that overlaps the cloth more than its load
/// explains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Overlap {
    /// The body's outward surface normal at the contact (unit).
    pub(super) normal: Vec3,
    /// How far (m) the body is to move out along the normal (> 0).
    pub(super) depth: f32,
}

/// The smallest shift (m) of a body that takes it out of each of
/// `overlaps`, each contact pushing only (projected Gauss–Seidel over the
/// contacts, [`SWEEPS`] sweeps). `pushes` is scratch: the push (m) each
/// contact has given so far.
pub(super) fn push_out(overlaps: &[Overlap], pushes: &mut Vec<f32>) -> Vec3 {
    pushes.clear();
    pushes.resize(overlaps.len(), 0.0);
    let mut shift = Vec3::ZERO;
    for _ in 0..SWEEPS {
        for (o, pushed) in overlaps.iter().zip(pushes.iter_mut()) {
            // The body moving against the normal opens the gap.
            let opened = -shift.dot(o.normal);
            let total = (*pushed + o.depth - opened).max(0.0);
            shift -= (total - *pushed) * o.normal;
            *pushed = total;
        }
    }
    if shift.is_finite() { shift } else { Vec3::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn under(depth: f32) -> Overlap {
        Overlap {
            normal: Vec3::NEG_Y,
            depth,
        }
    }

    #[test]
    fn a_body_sunk_evenly_rises_by_its_depth() {
        let overlaps = vec![under(1e-3); 25];
        let shift = push_out(&overlaps, &mut Vec::new());
        assert!((shift - Vec3::Y * 1e-3).length() < 1e-9, "{shift}");
    }

    #[test]
    fn a_body_sunk_unevenly_rises_by_its_deepest_contact() {
        let overlaps = [under(2e-3), under(5e-4), under(1e-3)];
        let shift = push_out(&overlaps, &mut Vec::new());
        assert!((shift - Vec3::Y * 2e-3).length() < 1e-9, "{shift}");
    }

    #[test]
    fn a_body_in_a_pocket_moves_out_of_every_side() {
        // A ball pressed into the cloth from below and from the side: each
        // contact ends open by at least its depth.
        let side = Vec3::new(1.0, -1.0, 0.0).normalize();
        let overlaps = [
            under(1e-3),
            Overlap {
                normal: side,
                depth: 2e-3,
            },
        ];
        let shift = push_out(&overlaps, &mut Vec::new());
        for o in &overlaps {
            let opened = -shift.dot(o.normal);
            assert!(opened >= o.depth * 0.999, "{opened} < {}", o.depth);
        }
    }

    #[test]
    fn nothing_overlapping_or_a_non_finite_depth_does_not_move_it() {
        assert_eq!(push_out(&[], &mut Vec::new()), Vec3::ZERO);
        assert_eq!(push_out(&[under(f32::NAN)], &mut Vec::new()), Vec3::ZERO);
    }
}
