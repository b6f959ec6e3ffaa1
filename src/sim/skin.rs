//! Cloth worn on a skinned mesh: where the animation puts each particle
//! (linear blend skinning, as Bevy's renderer skins a mesh), and the limit
//! that keeps a simulated particle within a maximum distance of it.

use bevy::math::{Affine3A, Vec3};

/// Up to four joints and their weights acting on one particle, as a
/// skinned mesh's `ATTRIBUTE_JOINT_INDEX` and `ATTRIBUTE_JOINT_WEIGHT`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Influence {
    /// Indices into the skin's joints.
    pub joints: [u16; 4],
    /// Their weights (dimensionless, summing to 1).
    pub weights: [f32; 4],
}

/// Linear blend skinning as Bevy's renderer does it: the point `rest` (m,
/// in the mesh's bind space) goes to `(Σₖ wₖ Mₖ) rest`, with
/// `Mₖ = Jₖ Bₖ` the joint's world transform times its inverse bind pose
/// (`joint_matrices`, indexed by [`Influence::joints`]). A joint index out
/// of range counts as the identity.
pub fn skinned_point(rest: Vec3, influence: &Influence, joint_matrices: &[Affine3A]) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (&j, &w) in influence.joints.iter().zip(&influence.weights) {
        if w != 0.0 {
            let m = joint_matrices
                .get(j as usize)
                .copied()
                .unwrap_or(Affine3A::IDENTITY);
            sum += w * m.transform_point3(rest);
        }
    }
    sum
}

/// Every particle's animated position: [`skinned_point`] of `rest[i]` with
/// `influences[i]`, into `out` (m, world).
pub fn skin(
    rest: &[Vec3],
    influences: &[Influence],
    joint_matrices: &[Affine3A],
    out: &mut Vec<Vec3>,
) {
    out.clear();
    out.extend(
        rest.iter()
            .zip(influences)
            .map(|(&p, i)| skinned_point(p, i, joint_matrices)),
    );
}

/// Keeps each particle `i` with `limit[i] > 0` within `limit[i]` m of its
/// animated position `target[i]`: one farther is moved onto that sphere
/// and loses its velocity away from the target (relative to the target's
/// velocity `target_v`, m/s). `x` in m, `v` in m/s. Returns how many
/// particles were moved.
pub fn limit_distance(
    x: &mut [Vec3],
    v: &mut [Vec3],
    (target, target_v): (&[Vec3], &[Vec3]),
    limit: &[f32],
) -> u32 {
    let mut moved = 0;
    for i in 0..x.len().min(target.len()).min(limit.len()) {
        let r = limit[i];
        if !(r > 0.0 && r.is_finite()) {
            continue;
        }
        let d = x[i] - target[i];
        let far = d.length_squared();
        if far <= r * r || !far.is_finite() {
            continue;
        }
        let n = d / far.sqrt();
        x[i] = target[i] + n * r;
        let tv = target_v.get(i).copied().unwrap_or(Vec3::ZERO);
        let away = (v[i] - tv).dot(n);
        if away > 0.0 {
            v[i] -= away * n;
        }
        moved += 1;
    }
    moved
}

/// A capsule (a sphere when `from == to`) in a joint's space that a worn
/// cloth stays outside of, as Unity's and Jolt's backstops keep a cape off
/// the body it hangs from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Backstop {
    /// The joint it moves with (an index into the skin's joints).
    pub joint: usize,
    /// One end of its axis in the joint's space, m.
    pub from: Vec3,
    /// The other end, m.
    pub to: Vec3,
    /// Its radius, m.
    pub radius: f32,
}

/// Pushes every particle `i` with `w[i] > 0` (1/kg) out of the capsule
/// from `a` to `b` (m, world) of radius `radius` m, and removes its velocity
/// into it (m/s, relative to `surface_v`, the capsule's velocity). Returns
/// how many particles were moved.
pub fn push_out_of_capsule(
    x: &mut [Vec3],
    v: &mut [Vec3],
    w: &[f32],
    (a, b, radius): (Vec3, Vec3, f32),
    surface_v: Vec3,
) -> u32 {
    if !(a.is_finite() && b.is_finite() && radius > 0.0 && radius.is_finite()) {
        return 0;
    }
    let axis = b - a;
    let len2 = axis.length_squared();
    let mut moved = 0;
    for i in 0..x.len().min(w.len()) {
        if w[i] == 0.0 {
            continue;
        }
        let t = if len2 > 0.0 {
            ((x[i] - a).dot(axis) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let c = a + t * axis;
        let d = x[i] - c;
        let dist = d.length();
        if dist >= radius || !dist.is_finite() {
            continue;
        }
        let n = if dist > 1e-9 {
            d / dist
        } else {
            axis.any_orthonormal_vector()
        };
        x[i] = c + n * radius;
        let into = (v[i] - surface_v).dot(n);
        if into < 0.0 {
            v[i] -= into * n;
        }
        moved += 1;
    }
    moved
}

#[cfg(test)]
mod tests {
    use bevy::math::{Mat4, Quat, Vec4};

    use super::*;

    #[test]
    fn blending_matches_the_renderers_sum_of_matrices() {
        // Two bones: the root at the origin, the second 1 m up, bent 60°
        // about z and moved; bind poses at their rest places.
        let j0 = Affine3A::from_rotation_translation(Quat::from_rotation_y(0.3), Vec3::X);
        let j1 = Affine3A::from_rotation_translation(
            Quat::from_rotation_z(1.05),
            Vec3::new(1.0, 1.2, 0.0),
        );
        let b0 = Affine3A::IDENTITY;
        let b1 = Affine3A::from_translation(Vec3::new(0.0, -1.0, 0.0));
        let joints = [j0 * b0, j1 * b1];
        for (rest, weights) in [
            (Vec3::new(0.1, 0.2, 0.0), [1.0, 0.0, 0.0, 0.0]),
            (Vec3::new(0.0, 1.0, 0.1), [0.5, 0.5, 0.0, 0.0]),
            (Vec3::new(-0.1, 1.7, 0.0), [0.1, 0.9, 0.0, 0.0]),
        ] {
            let influence = Influence {
                joints: [0, 1, 0, 0],
                weights,
            };
            let got = skinned_point(rest, &influence, &joints);
            // The shader: Σ w·M as 4×4 matrices, times (p, 1).
            let m: Mat4 = joints
                .iter()
                .zip(weights)
                .map(|(j, w)| Mat4::from(*j) * w)
                .fold(Mat4::ZERO, |a, b| a + b);
            let want = (m * Vec4::new(rest.x, rest.y, rest.z, 1.0)).truncate();
            assert!((got - want).length() < 1e-5, "{got} vs {want}");
        }
    }

    #[test]
    fn a_backstop_pushes_particles_out_of_its_capsule() {
        let mut x = vec![
            Vec3::new(0.05, 0.5, 0.0),
            Vec3::new(0.3, 0.5, 0.0),
            Vec3::ZERO,
        ];
        let mut v = vec![Vec3::new(-1.0, 0.0, 0.0); 3];
        let w = [1.0, 1.0, 0.0];
        let capsule = (Vec3::ZERO, Vec3::Y, 0.1);
        assert_eq!(
            push_out_of_capsule(&mut x, &mut v, &w, capsule, Vec3::ZERO),
            1
        );
        assert!((x[0] - Vec3::new(0.1, 0.5, 0.0)).length() < 1e-6);
        assert!(v[0].x.abs() < 1e-6);
        assert_eq!(x[1], Vec3::new(0.3, 0.5, 0.0));
        assert_eq!(x[2], Vec3::ZERO, "pinned particles stay");
    }

    #[test]
    fn a_particle_past_its_max_distance_is_brought_back() {
        let mut x = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.05, 0.0, 0.0)];
        let mut v = vec![Vec3::new(3.0, 0.0, 0.0), Vec3::X];
        let target = [Vec3::ZERO; 2];
        let moved = limit_distance(&mut x, &mut v, (&target, &[]), &[0.1, 0.1]);
        assert_eq!(moved, 1);
        assert!((x[0].length() - 0.1).abs() < 1e-6 && v[0].x.abs() < 1e-6);
        assert_eq!(x[1], Vec3::new(0.05, 0.0, 0.0));
        // No limit (0, NaN): nothing happens.
        let mut far = vec![Vec3::splat(9.0); 2];
        let limits = [0.0, f32::NAN];
        assert_eq!(limit_distance(&mut far, &mut v, (&target, &[]), &limits), 0);
    }
}
