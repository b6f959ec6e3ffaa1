//! Opt-in self-collision: vertex–triangle proximity within one cloth, with a
//! spatial hash over its triangles, then continuous particle–triangle and
//! edge–edge collision ([`ccd`](super::ccd)). Off unless a cloth has
//! [`ClothSelfCollision`](crate::plugin::collision::ClothSelfCollision), as the paper leaves it
//! out for speed.

use bevy::math::Vec3;

#[cfg(test)]
use super::ccd::prevent_crossings;
use super::ccd::{CrossingBuffers, split};
use super::cells::{cell_of, key};
use super::contact::Counts;
use super::trimesh::closest_point_on_triangle;
use crate::sim::grid::Faces;

/// Reusable buffers of the spatial hash (no allocation once warm).
#[derive(Clone, Debug, Default)]
pub struct SelfCollisionBuffers {
    /// `(cell key, triangle)` pairs sorted by key.
    entries: Vec<(u64, u32)>,
    /// The continuous pass's buffers.
    crossings: CrossingBuffers,
}

/// Barycentric weights of point `c` on triangle `[a, b, d]`.
pub(super) fn barycentric(c: Vec3, [a, b, d]: [Vec3; 3]) -> [f32; 3] {
    let (v0, v1, v2) = (b - a, d - a, c - a);
    let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
    let (d20, d21) = (v2.dot(v0), v2.dot(v1));
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() < 1e-20 {
        return [1.0 / 3.0; 3];
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    [1.0 - v - w, v, w]
}

/// Keeps every particle of `cloth` at least `thickness` m from every
/// triangle it is not a corner of. Corrections are split by inverse mass
/// between the particle and the triangle's corners (momentum is conserved;
/// no particle moves farther than the correction),
/// and their approaching normal velocity is removed. `x` in m, `v` in m/s.
///
/// A particle within `thickness` of a triangle's inside is put back on the
/// side of the triangle's plane it was on at the step's start (`start`,
/// m): one that went through the triangle in this step, or lies on it,
/// does not stay on the wrong side. Then no particle passes through a
/// triangle and no edge through an edge over the step, however far they
/// moved ([`prevent_crossings`]).
#[cfg(test)]
pub fn self_collide(
    cloth: &impl Faces,
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
    thickness: f32,
    buffers: &mut SelfCollisionBuffers,
) -> Counts {
    let mut counts = keep_apart(cloth, start, x, v, inverse_masses, thickness, buffers);
    let crossings = &mut buffers.crossings;
    counts += prevent_crossings(cloth, start, x, v, inverse_masses, thickness, crossings).into();
    counts
}

/// The proximity pass of [`self_collide`] alone: keeps every particle at
/// least `thickness` m from the triangles it is not a corner of, on the
/// side it started on.
pub fn keep_apart(
    cloth: &impl Faces,
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
    thickness: f32,
    buffers: &mut SelfCollisionBuffers,
) -> Counts {
    let mut counts = Counts::default();
    let cell = cloth.cell_size().max(2.0 * thickness);
    let inv_cell = 1.0 / cell;
    let entries = &mut buffers.entries;
    entries.clear();
    for (t, tri) in cloth.faces().enumerate() {
        let [a, b, c] = tri.map(|p| x[p as usize]);
        let lo = cell_of(a.min(b).min(c) - thickness, inv_cell);
        let hi = cell_of(a.max(b).max(c) + thickness, inv_cell);
        // A triangle stretched over many cells (an exploding cloth) is
        // clamped to a 4×4×4 block rather than flooding the hash; one
        // thrown to the edge of `i32` cells saturates.
        for i in lo[0]..=hi[0].min(lo[0].saturating_add(3)) {
            for j in lo[1]..=hi[1].min(lo[1].saturating_add(3)) {
                for k in lo[2]..=hi[2].min(lo[2].saturating_add(3)) {
                    entries.push((key([i, j, k]), t as u32));
                }
            }
        }
    }
    entries.sort_unstable();
    for p in 0..x.len() {
        let k = key(cell_of(x[p], inv_cell));
        let from = entries.partition_point(|e| e.0 < k);
        let mut e = from;
        while e < entries.len() && entries[e].0 == k {
            let tri = cloth.face(entries[e].1);
            e += 1;
            if tri.contains(&(p as u32)) {
                continue;
            }
            counts.tests += 1;
            let corners = tri.map(|q| x[q as usize]);
            let c = closest_point_on_triangle(x[p], corners);
            let off = x[p] - c;
            let dist = off.length();
            if dist >= thickness {
                continue;
            }
            let bary = barycentric(c, corners);
            let face = (corners[1] - corners[0])
                .cross(corners[2] - corners[0])
                .normalize_or(Vec3::Y);
            let mut depth = thickness - dist;
            let n = if bary.iter().all(|&b| b > 1e-4) {
                // Over the triangle's inside: back to the side of its
                // plane the particle started on.
                let before = tri.map(|q| start[q as usize]);
                let normal = (before[1] - before[0]).cross(before[2] - before[0]);
                let was = (start[p] - before[0]).dot(normal) * normal.dot(face);
                let now = off.dot(face);
                let side = if was != 0.0 {
                    was.signum()
                } else {
                    now.signum()
                };
                if side * now < 0.0 {
                    depth = thickness + dist;
                }
                face * side
            } else if dist > 1e-9 {
                off / dist
            } else {
                face
            };
            let wp = inverse_masses[p];
            let lever = [1.0, -bary[0], -bary[1], -bary[2]];
            let masses = [p as u32, tri[0], tri[1], tri[2]].map(|q| inverse_masses[q as usize]);
            let share = split(lever, masses);
            if share == 0.0 {
                continue;
            }
            counts.contacts += 1;
            // Position: close the gap to the thickness.
            let s = depth / share;
            x[p] += wp * s * n;
            for i in 0..3 {
                let q = tri[i] as usize;
                x[q] -= bary[i] * inverse_masses[q] * s * n;
            }
            // Velocity: remove the approaching part of the relative motion.
            let vt: Vec3 = (0..3).map(|i| bary[i] * v[tri[i] as usize]).sum();
            let vn = (v[p] - vt).dot(n);
            if vn < 0.0 {
                let j = -vn / share;
                v[p] += wp * j * n;
                for i in 0..3 {
                    let q = tri[i] as usize;
                    v[q] -= bary[i] * inverse_masses[q] * j * n;
                }
            }
        }
    }
    counts
}

impl SelfCollisionBuffers {
    /// The continuous pass's buffers.
    pub(crate) fn crossings(&mut self) -> &mut CrossingBuffers {
        &mut self.crossings
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plugin::spawn::builder::ClothBuilder;

    #[test]
    fn a_particle_inside_the_thickness_is_pushed_out_with_momentum_conserved() {
        let cloth = ClothBuilder::new(3, 3).size(2.0, 2.0).build().unwrap();
        let mut x = cloth.particles.positions.clone();
        // Bring the corner particle 8 down onto triangle (0, 3, 4) from above.
        x[8] = Vec3::new(-0.6, 0.004, -0.4);
        let mut v = vec![Vec3::ZERO; 9];
        v[8] = Vec3::new(0.0, -1.0, 0.0);
        let w = vec![1.0; 9];
        let momentum = |v: &[Vec3]| v.iter().sum::<Vec3>();
        let centre = |x: &[Vec3]| x.iter().sum::<Vec3>();
        let (p0, c0) = (momentum(&v), centre(&x));
        let mut buffers = SelfCollisionBuffers::default();
        let start = x.clone();
        let counts = self_collide(&cloth.cloth, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
        assert!(counts.contacts >= 1, "{counts:?}");
        assert!(x[8].y >= 0.005, "{}", x[8]);
        assert!(v[8].y > -1.0);
        assert!((momentum(&v) - p0).length() < 1e-5);
        assert!((centre(&x) - c0).length() < 1e-5);
        // Far apart: nothing happens.
        let mut x = cloth.particles.positions.clone();
        let before = x.clone();
        let start = x.clone();
        let counts = self_collide(&cloth.cloth, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
        assert_eq!((counts.contacts, x), (0, before));
    }

    #[test]
    fn a_cloth_thrown_beyond_the_hash_s_range_is_hashed_without_overflow() {
        let cloth = ClothBuilder::new(3, 3).size(2.0, 2.0).build().unwrap();
        // Its cells lie past `i32::MAX`: the cell indices saturate.
        let mut x: Vec<Vec3> = cloth
            .particles
            .positions
            .iter()
            .map(|p| *p + Vec3::splat(1e12))
            .collect();
        let start = x.clone();
        let mut v = vec![Vec3::ZERO; 9];
        let w = vec![1.0; 9];
        let mut buffers = SelfCollisionBuffers::default();
        self_collide(&cloth.cloth, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
        assert!(x.iter().all(|p| p.is_finite()));
    }

    #[test]
    fn a_particle_that_went_through_a_triangle_is_put_back_on_its_side() {
        let cloth = ClothBuilder::new(3, 3).size(2.0, 2.0).build().unwrap();
        let start = {
            let mut x = cloth.particles.positions.clone();
            x[8] = Vec3::new(-0.6, 0.03, -0.4);
            x
        };
        let w = vec![1.0; 9];
        // It ends 4 mm below triangle (0, 3, 4), or exactly on it.
        for end in [-0.004, 0.0] {
            let mut x = start.clone();
            x[8].y = end;
            let mut v = vec![Vec3::ZERO; 9];
            v[8] = Vec3::new(0.0, -2.0, 0.0);
            let mut buffers = SelfCollisionBuffers::default();
            self_collide(&cloth.cloth, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
            // Above the sheet (which gave way by a share of the push).
            let sheet = (x[0].y + x[3].y + x[4].y) / 3.0;
            assert!(
                x[8].y > sheet,
                "ended at {end}: {} below the sheet at {sheet}",
                x[8].y
            );
            assert!(v[8].y > -2.0);
        }
    }
}
