//! The contacts an implicit step is to hold
//! (`integrate::implicit::contacts`):
//! every free particle that touches a collider at the start of the step,
//! or will within it if it keeps its velocity relative to the surface; next
//! to a free body, every particle within reach of the two motions.

use bevy::math::{Affine3A, Vec3};

use super::contact::{Geometry, MovingCollider};
use super::shapes::sweep;
use super::trimesh::{TriMesh, closest_point_on_triangle, segment_triangle};
use crate::sim::integrate::implicit::{Hold, NO_BODY, SolveContact};

/// How far outside the contact thickness (m) a particle still counts as
/// touching: a sheet at rest sits at the thickness, give or take rounding.
const TOUCH: f32 = 1e-4;

/// Adds to `out` the contacts with `collider` (its poses at the start and
/// end of a step of `dt` s) of the free particles at `x` (m) moving at `v`
/// (m/s), for a contact thickness of `thickness` m. Several colliders may
/// list the same particle; [`keep_nearest`] keeps the nearest.
///
/// With `free`, the collider is a free body that the solve moves with the
/// cloth, and a particle leaving its surface within reach is listed too: a
/// light body and the cloth part and meet again within a step, driven by
/// forces the particles' velocities do not show, and the solve decides
/// with those forces whether it holds the particle.
pub fn predict_contacts(
    collider: &MovingCollider,
    (x, v, inverse_masses): (&[Vec3], &[Vec3], &[f32]),
    (thickness, dt): (f32, f32),
    free: bool,
    out: &mut Vec<SolveContact>,
) {
    let to_local = Affine3A::from(collider.start.inverse());
    let to_end_local = Affine3A::from(collider.end.inverse());
    let (start, end) = (Affine3A::from(collider.start), Affine3A::from(collider.end));
    for (p, ((&xp, &vp), &w)) in x.iter().zip(v).zip(inverse_masses).enumerate() {
        if w == 0.0 {
            continue;
        }
        let local = to_local.transform_point3(xp);
        // The surface at the particle moves too: a collider striking a
        // resting cloth reaches it within the step.
        let velocity = (end.transform_point3(local) - xp) / dt;
        let reach = thickness + TOUCH + (vp.length() + velocity.length()) * dt;
        let Some((distance, normal)) = (match collider.geometry {
            Geometry::Shape(ref shape) => Some(shape.distance(local)),
            Geometry::Mesh(mesh) => mesh_distance(mesh, local, reach),
        }) else {
            continue;
        };
        let mut gap = distance - thickness;
        if gap > reach {
            continue;
        }
        // Near a free body's edge the nearest point's plane is tilted: a
        // particle passing under a plate's rim, level with its base, would
        // run into that plane and push the plate up and along. A particle
        // outside the thickness is held instead on the plane where its
        // path (relative to the body, over the step) first meets the
        // thickness, or, if it stays clear, on the plane nearest its end.
        let mut normal = normal;
        if free
            && gap > TOUCH
            && let Geometry::Shape(ref shape) = collider.geometry
        {
            let path_end = to_end_local.transform_point3(xp + vp * dt);
            let (q, clear) = match sweep(shape, local, path_end, thickness) {
                Some(t) => (local.lerp(path_end, t), false),
                None => (path_end, true),
            };
            let (dq, nq) = shape.distance(q);
            if dq > 0.0 {
                let shell = q - (dq - thickness) * nq;
                normal = nq;
                let along = (local - shell).dot(nq);
                // The plane nearest the end of a clear path may pass behind
                // the particle (one moving round the body): it is outside,
                // and no nearer to that plane than to the body.
                gap = if clear { along.max(gap) } else { along };
            }
        }
        let normal = start.transform_vector3(normal).normalize_or_zero();
        if normal == Vec3::ZERO {
            continue;
        }
        let approach = gap + dt * (vp - velocity).dot(normal);
        if gap <= TOUCH || approach < 0.0 || free {
            out.push(SolveContact {
                particle: p as u32,
                normal,
                gap,
                velocity,
                friction: collider.friction,
                source: 0,
                body: NO_BODY,
                edge: false,
            });
        }
    }
}

/// Distance (m) from local point `p` to the nearest triangle of `mesh`
/// within `reach` m, and the outward normal there (towards `p`), or `None`.
pub(super) fn mesh_distance(mesh: &TriMesh, p: Vec3, reach: f32) -> Option<(f32, Vec3)> {
    let pad = Vec3::splat(reach);
    let mut nearest: Option<(f32, usize, Vec3)> = None;
    mesh.query(p - pad, p + pad, |t| {
        let c = closest_point_on_triangle(p, mesh.triangles[t]);
        let d = p.distance(c);
        if d <= reach && nearest.is_none_or(|(best, _, _)| d < best) {
            nearest = Some((d, t, c));
        }
    });
    let (d, t, c) = nearest?;
    let face = mesh.normals[t];
    let normal = if d > 1e-9 {
        (p - c) / d
    } else if (p - mesh.triangles[t][0]).dot(face) < 0.0 {
        -face
    } else {
        face
    };
    Some((d, normal))
}

/// Pushes the particles the solve held (`held[p]` not free) that crossed
/// into `collider` during the step back out to the contact thickness, and
/// takes out their velocity into it relative to the surface. The solve
/// holds a particle on the plane its contact had at the start of the step,
/// with a spring that yields to very large forces (a violent yank over an
/// edge), and a fast collider can carry its surface past that plane; this
/// catches both, along the particle's path (`start` → `x`, m), so it cannot
/// pass through a thin collider, and sends it on along the surface by the
/// rest of its path (round a corner, over a rim), so that its travel
/// matches the velocity it keeps. A particle that ends less than the
/// thickness inside a shape comes out the shortest way instead (it was
/// held on, or carried along, its surface). Their friction is the solve's:
/// nothing else changes. Returns how many were pushed.
pub fn push_out_held(
    collider: &MovingCollider,
    held: &[Hold],
    (start, x, v): (&[Vec3], &mut [Vec3], &mut [Vec3]),
    thickness: f32,
    dt: f32,
) -> u32 {
    let (to0, to1) = (
        Affine3A::from(collider.start.inverse()),
        Affine3A::from(collider.end.inverse()),
    );
    let (start_pose, end_pose) = (Affine3A::from(collider.start), Affine3A::from(collider.end));
    let mut pushed = 0;
    for (p, &h) in held.iter().enumerate() {
        if h == Hold::Free {
            continue;
        }
        let (p0, p1) = (to0.transform_point3(start[p]), to1.transform_point3(x[p]));
        let entry = match collider.geometry {
            Geometry::Shape(ref shape) => {
                let (d, n) = shape.distance(p1);
                if d < 0.0 && d > -thickness {
                    // Just inside at the end (a hair past the plane it was
                    // held on, or carried along the surface into a face it
                    // is held off): out by the shortest way. Back along its
                    // path, a particle carried along a surface would lose
                    // the step's motion there.
                    Some((p1 - d * n, n))
                } else {
                    // The first point of the path inside the collider.
                    sweep(shape, p0, p1, 0.0).map(|t| {
                        // On the surface (a path that starts inside starts
                        // there), and on along it by the rest of the path
                        // (round a corner, out again the shortest way):
                        // stopped where it met the surface, a particle
                        // drawn round an edge would keep the speed the
                        // step gave it and not its travel.
                        let q = p0.lerp(p1, t);
                        let (d, n) = shape.distance(q);
                        let q = q - d.min(0.0) * n;
                        let rest = p1 - q;
                        let q = q + rest - rest.dot(n) * n;
                        let (d, n) = shape.distance(q);
                        (q - d.min(thickness) * n, n)
                    })
                }
            }
            Geometry::Mesh(mesh) => mesh_crossing(mesh, p0, p1),
        };
        let Some((point, normal)) = entry else {
            continue;
        };
        let n = end_pose.transform_vector3(normal).normalize_or_zero();
        x[p] = end_pose.transform_point3(point) + thickness * n;
        let surface = (end_pose.transform_point3(point) - start_pose.transform_point3(point)) / dt;
        let into = (v[p] - surface).dot(n);
        if into < 0.0 {
            v[p] -= into * n;
        }
        pushed += 1;
    }
    pushed
}

/// Where the segment `p0 → p1` (local, m) first crosses a triangle of
/// `mesh`, and the normal there facing `p0`'s side.
fn mesh_crossing(mesh: &TriMesh, p0: Vec3, p1: Vec3) -> Option<(Vec3, Vec3)> {
    let mut first: Option<(f32, usize)> = None;
    mesh.query(p0.min(p1), p0.max(p1), |t| {
        if let Some(s) = segment_triangle(p0, p1, mesh.triangles[t])
            && first.is_none_or(|(best, _)| s < best)
        {
            first = Some((s, t));
        }
    });
    let (s, t) = first?;
    let face = mesh.normals[t];
    let normal = if (p0 - mesh.triangles[t][0]).dot(face) < 0.0 {
        -face
    } else {
        face
    };
    Some((p0.lerp(p1, s), normal))
}

/// Keeps, for each particle listed more than once, its contact with the
/// smallest gap, and its edge contact ([`SolveContact::edge`]) with the
/// smallest gap, and sorts the list by particle. A particle squeezed
/// between surfaces of different kinds (`kind(source)`, below 32: a fixed
/// surface, a free body, another cloth), with normals facing the nearest
/// one's, keeps the nearest contact of each kind: a plate on a tablecloth
/// on a table rests on the cloth, which rests on the table, rather than
/// sinking through the cloth, and a particle caught between a collider
/// and another cloth is held off both.
pub fn keep_nearest(contacts: &mut Vec<SolveContact>, kind: impl Fn(u32) -> u8) {
    contacts.sort_unstable_by(|a, b| {
        (a.particle.cmp(&b.particle))
            .then(a.edge.cmp(&b.edge))
            .then(a.gap.total_cmp(&b.gap))
    });
    let (mut kept, mut i) = (0, 0);
    while i < contacts.len() {
        let nearest = contacts[i];
        contacts[kept] = nearest;
        kept += 1;
        let bit = |source| 1u32 << kind(source).min(31);
        let mut kinds = bit(nearest.source);
        i += 1;
        while i < contacts.len()
            && contacts[i].particle == nearest.particle
            && contacts[i].edge == nearest.edge
        {
            let c = contacts[i];
            if kinds & bit(c.source) == 0 && !c.edge && c.normal.dot(nearest.normal) < 0.0 {
                contacts[kept] = c;
                kept += 1;
                kinds |= bit(c.source);
            }
            i += 1;
        }
    }
    contacts.truncate(kept);
    // A particle at a corner that a link of it wraps: its own contact's
    // normal force is the straight link's pull into the face, which the
    // corner carries on a cloth that wraps it. As friction it would hold
    // the particle against the pull (a skirt pulled back over a table's
    // rim); the face holds it without friction.
    for group in contacts.chunk_by_mut(|a, b| a.particle == b.particle) {
        let Some(edge) = group.iter().find(|c| c.edge).map(|c| c.normal) else {
            continue;
        };
        for c in group.iter_mut() {
            if !c.edge && c.normal.dot(edge) < CORNER_COS {
                c.friction = 0.0;
            }
        }
    }
}

/// The cosine of the smallest angle between a particle's own contact and a
/// link's edge contact on it at which the particle counts as at a corner
/// ([`keep_nearest`]): 30°.
const CORNER_COS: f32 = 0.866;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::collision::shapes::Shape;
    use bevy::math::Isometry3d;

    fn floor(speed: f32) -> MovingCollider<'static> {
        MovingCollider {
            geometry: Geometry::Shape(Shape::Plane),
            start: Isometry3d::IDENTITY,
            end: Isometry3d::from_translation(Vec3::new(speed * 0.1, 0.0, 0.0)),
            friction: 0.5,
            restitution: 0.0,
        }
    }

    #[test]
    fn touching_and_arriving_particles_are_listed_and_others_not() {
        let x = [
            Vec3::new(0.0, 0.01, 0.0),  // resting at the thickness
            Vec3::new(0.0, 0.05, 0.0),  // falling, reaches it within the step
            Vec3::new(0.0, 0.05, 0.0),  // rising
            Vec3::new(0.0, 0.5, 0.0),   // far
            Vec3::new(0.0, 0.005, 0.0), // inside the thickness, pinned
        ];
        let v = [Vec3::ZERO, -Vec3::Y, Vec3::Y, -Vec3::Y, Vec3::ZERO];
        let w = [1.0, 1.0, 1.0, 1.0, 0.0];
        let mut out = Vec::new();
        predict_contacts(&floor(2.0), (&x, &v, &w), (0.01, 0.1), false, &mut out);
        let listed: Vec<u32> = out.iter().map(|c| c.particle).collect();
        assert_eq!(listed, [0, 1]);
        assert!(out[0].gap.abs() < 1e-6 && (out[1].gap - 0.04).abs() < 1e-6);
        assert_eq!(out[0].normal, Vec3::Y);
        // The floor slides along x at 2 m/s: so does its surface.
        assert!((out[0].velocity - Vec3::X * 2.0).length() < 1e-4);
        assert_eq!(out[0].friction, 0.5);
    }

    #[test]
    fn the_nearest_of_two_contacts_is_kept() {
        let c = |particle, gap| SolveContact {
            particle,
            normal: Vec3::Y,
            gap,
            velocity: Vec3::ZERO,
            friction: 0.0,
            source: 0,
            body: NO_BODY,
            edge: false,
        };
        let mut list = vec![c(3, 0.0), c(1, 0.2), c(3, -0.1), c(1, 0.1)];
        keep_nearest(&mut list, |_| 0);
        let kept: Vec<(u32, f32)> = list.iter().map(|c| (c.particle, c.gap)).collect();
        assert_eq!(kept, [(1, 0.1), (3, -0.1)]);
    }

    /// A plate, r 0.11 m and 2 cm tall, centred on the origin.
    const PLATE: Shape = Shape::Cylinder {
        radius: 0.11,
        half_height: 0.01,
    };

    /// `shape` at the origin, staying there (friction 0.5).
    fn still(shape: Shape) -> MovingCollider<'static> {
        MovingCollider {
            geometry: Geometry::Shape(shape),
            start: Isometry3d::IDENTITY,
            end: Isometry3d::IDENTITY,
            friction: 0.5,
            restitution: 0.0,
        }
    }

    /// The contacts with [`PLATE`], still, as a free body or fixed (contact
    /// thickness 5 mm, a 1/60 s step), of one particle at `x` (m) moving at
    /// `v` (m/s).
    fn near_plate(x: Vec3, v: Vec3, free: bool) -> Vec<SolveContact> {
        let plate = still(PLATE);
        let mut out = Vec::new();
        predict_contacts(
            &plate,
            (&[x], &[v], &[1.0]),
            (0.005, 1.0 / 60.0),
            free,
            &mut out,
        );
        out
    }

    #[test]
    fn a_particle_passing_under_a_bodys_rim_is_held_on_its_base() {
        // A plate (r 0.11 m, 2 cm tall) as a free body; a particle 1 cm
        // outside its rim, level with its base at the contact thickness
        // (5 mm below it), moving towards it at 1 m/s. The nearest point
        // is the rim's edge, whose plane faces it half sideways; its path
        // runs under the base, so it is held on the base's plane.
        let (x, v) = (Vec3::new(0.0, -0.015, -0.12), Vec3::Z);
        let out = near_plate(x, v, true);
        assert_eq!(out.len(), 1);
        assert!(out[0].normal.y < -0.99, "{}", out[0].normal);
        assert!(out[0].gap.abs() < 1e-3, "{}", out[0].gap);
        // Fixed, it keeps the edge's plane (the sweep and push-out handle
        // fixed surfaces).
        let out = near_plate(x, v, false);
        assert!(out.iter().all(|c| c.normal.z < -0.1), "{out:?}");
    }

    #[test]
    fn a_particle_moving_round_a_bodys_rim_is_not_held_as_inside_it() {
        // The plate as above; a particle 6 mm outside its rim, 4.7 mm below
        // its base, moving at 4 m/s along the rim's tangent and a little
        // away. Its path stays clear, and the plane nearest the path's end
        // faces a quarter turn on: the particle lies behind that plane, but
        // it is outside the thickness, and its contact says so. Held as
        // 5 mm inside, it would be pushed off and the plate the other way.
        let (x, v) = (Vec3::new(0.116, -0.0147, 0.0), Vec3::new(0.3, 0.0, 4.0));
        let (distance, _) = PLATE.distance(x);
        let out = near_plate(x, v, true);
        assert_eq!(out.len(), 1);
        assert!(
            out[0].gap >= distance - 0.005 - 1e-6,
            "gap {} for a particle {} m outside the thickness",
            out[0].gap,
            distance - 0.005
        );
    }

    #[test]
    fn a_particle_between_a_surface_and_a_body_keeps_both() {
        // Source 1 is a free body; source 0 a fixed surface.
        let c = |particle, gap, normal, source| SolveContact {
            particle,
            normal,
            gap,
            velocity: Vec3::ZERO,
            friction: 0.0,
            source,
            body: NO_BODY,
            edge: false,
        };
        let mut list = vec![
            // Squeezed: the table below, the plate above, and a second
            // fixed surface below, farther.
            c(2, 0.001, Vec3::NEG_Y, 1),
            c(2, 0.0, Vec3::Y, 0),
            c(2, 0.002, Vec3::Y, 0),
            // Beside a body whose surface faces the same way: the nearest.
            c(5, 0.0, Vec3::Y, 0),
            c(5, 0.001, Vec3::Y, 1),
        ];
        keep_nearest(&mut list, |source| u8::from(source == 1));
        let kept: Vec<(u32, f32, u32)> =
            list.iter().map(|c| (c.particle, c.gap, c.source)).collect();
        assert_eq!(kept, [(2, 0.0, 0), (2, 0.001, 1), (5, 0.0, 0)]);
    }

    #[test]
    fn a_particle_at_a_corner_a_link_wraps_keeps_its_nearest_edge_contact_and_a_frictionless_face()
    {
        let c = |particle, gap, normal: Vec3, edge| SolveContact {
            particle,
            normal: normal.normalize(),
            gap,
            velocity: Vec3::ZERO,
            friction: 0.5,
            source: 0,
            body: NO_BODY,
            edge,
        };
        let mut list = vec![
            // On a table's side, two links over its rim.
            c(1, 0.0, Vec3::X, false),
            c(1, -0.01, Vec3::new(1.0, 1.0, 0.0), true),
            c(1, -0.02, Vec3::new(1.0, 2.0, 0.0), true),
            // On its top, a link over a gentle bump in it.
            c(4, 0.0, Vec3::Y, false),
            c(4, -0.001, Vec3::new(0.1, 1.0, 0.0), true),
        ];
        keep_nearest(&mut list, |_| 0);
        let kept: Vec<(u32, f32, bool, f32)> = list
            .iter()
            .map(|c| (c.particle, c.gap, c.edge, c.friction))
            .collect();
        assert_eq!(
            kept,
            [
                (1, 0.0, false, 0.0),
                (1, -0.02, true, 0.5),
                (4, 0.0, false, 0.5),
                (4, -0.001, true, 0.5)
            ]
        );
    }

    #[test]
    fn a_held_particle_just_inside_comes_out_the_shortest_way_and_a_deep_one_along_its_path() {
        // A table top 4 cm thick, its top at y = 0. One particle carried
        // 10 cm along under it ends 1 mm inside its bottom; one that went
        // 3 cm into its top comes back out, 1 cm on from where it entered
        // as it was going along.
        let table = MovingCollider {
            geometry: Geometry::Shape(Shape::Cuboid {
                half_extents: Vec3::new(0.6, 0.02, 0.6),
            }),
            start: Isometry3d::from_translation(Vec3::new(0.0, -0.02, 0.0)),
            end: Isometry3d::from_translation(Vec3::new(0.0, -0.02, 0.0)),
            friction: 0.5,
            restitution: 0.0,
        };
        let start = [Vec3::new(0.0, -0.045, 0.0), Vec3::new(0.2, 0.005, 0.0)];
        let mut x = [Vec3::new(0.1, -0.039, 0.0), Vec3::new(0.21, -0.025, 0.0)];
        let mut v = [Vec3::new(6.0, 0.36, 0.0), Vec3::new(0.6, -1.8, 0.0)];
        let held = [Hold::Stick; 2];
        let pushed = push_out_held(&table, &held, (&start, &mut x, &mut v), 0.005, 1.0 / 60.0);
        assert_eq!(pushed, 2);
        assert!(
            x[0].distance(Vec3::new(0.1, -0.045, 0.0)) < 1e-5,
            "{}",
            x[0]
        );
        assert_eq!(v[0], Vec3::new(6.0, 0.0, 0.0));
        assert!(
            x[1].distance(Vec3::new(0.21, 0.005, 0.0)) < 1e-5,
            "{}",
            x[1]
        );
        assert_eq!(v[1], Vec3::new(0.6, 0.0, 0.0));
    }

    #[test]
    fn a_held_particle_drawn_round_a_corner_keeps_its_travel() {
        // A particle on a table's side face, 5 cm under its top, drawn up
        // and in at (-3, 6) m/s: its path cuts the corner. It comes out
        // on the face and goes on up it by the rest of its path, over the
        // rim, rather than stopping where it met the face.
        let table = still(Shape::Cuboid {
            half_extents: Vec3::splat(0.5),
        });
        let (h, thickness) = (1.0 / 60.0, 0.005);
        let start = [Vec3::new(0.5 + thickness, 0.45, 0.0)];
        let mut v = [Vec3::new(-3.0, 6.0, 0.0)];
        let mut x = [start[0] + h * v[0]];
        let pushed = push_out_held(
            &table,
            &[Hold::Slide],
            (&start, &mut x, &mut v),
            thickness,
            h,
        );
        assert_eq!(pushed, 1);
        assert!(
            x[0].distance(Vec3::new(0.5, 0.55, 0.0)) < 1e-5,
            "it ends at {}, over the rim at [0.5, 0.55, 0]",
            x[0]
        );
        assert_eq!(v[0], Vec3::new(-3.0, 6.0, 0.0));
    }
}
