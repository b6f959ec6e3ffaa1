//! Cloth particles against one moving collider over one step (pure
//! functions over slices).
//!
//! For every free particle the motion `start → x` is brought into the
//! collider's frame, the start taken at the collider's start pose and the
//! end at its end pose. In that frame the collider stands still, so a swept
//! test of the segment is exact for translation and close for rotation:
//!
//! 1. **Detect** the first point `p_c` where the segment comes within the
//!    cloth thickness `δ` of the surface (analytic: conservative advancement
//!    on the exact distance; mesh: segment–triangle crossing, else
//!    vertex–triangle proximity). A particle that started within `δ` and
//!    ends clear is leaving and left alone.
//! 2. **Respond** with `respond`: relative velocity, normal part reversed
//!    with restitution, Coulomb friction on the tangential part.
//! 3. **Place** the particle at `p_c` plus the tangential part of the rest of
//!    its motion scaled by the same friction factor (so static friction
//!    holds positions, not only velocities), pushed out to `δ`, then back
//!    into the world at the end pose.

use bevy::math::{Affine3A, Isometry3d, Vec3};

use super::narrow::{edges_pierce, respond, triangles_intersect};
use super::shapes::{Shape, sweep};
use super::trimesh::{TriMesh, closest_point_on_triangle, segment_triangle};

/// The surface a collider presents.
#[derive(Clone, Copy, Debug)]
pub enum Geometry<'a> {
    /// An analytic shape.
    Shape(Shape),
    /// A triangle mesh with its BVH.
    Mesh(&'a TriMesh),
}

/// A collider over one step: its surface, its pose at the start and at the
/// end of the step (rotation + translation, m), and its surface material.
#[derive(Clone, Copy, Debug)]
pub struct MovingCollider<'a> {
    /// Surface in the collider's local frame.
    pub geometry: Geometry<'a>,
    /// Pose at the start of the step.
    pub start: Isometry3d,
    /// Pose at the end of the step.
    pub end: Isometry3d,
    /// Coulomb friction coefficient μ ≥ 0.
    pub friction: f32,
    /// Restitution e ∈ [0, 1].
    pub restitution: f32,
}

/// What one call did, for the collision counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Particles (or cloth triangles) tested.
    pub tests: u32,
    /// Contacts resolved.
    pub contacts: u32,
}

impl std::ops::AddAssign for Counts {
    fn add_assign(&mut self, rhs: Self) {
        self.tests += rhs.tests;
        self.contacts += rhs.contacts;
    }
}

/// A contact in the collider's frame: where the particle touched, the
/// outward normal there, and (meshes) which triangle.
#[derive(Clone, Copy, Debug)]
struct Local {
    point: Vec3,
    normal: Vec3,
    triangle: usize,
}

fn shape_contact(shape: &Shape, p0: Vec3, p1: Vec3, thickness: f32) -> Option<Local> {
    let t = sweep(shape, p0, p1, thickness)?;
    let (d0, n0) = shape.distance(p0);
    if t == 0.0 && shape.distance(p1).0 >= thickness && (p1 - p0).dot(n0) >= 0.0 {
        return None; // started in contact and leaves
    }
    let point = p0.lerp(p1, t);
    // A particle that starts touching (within the thickness) is pushed back
    // out on the side it touched, even when the collider's motion carries
    // its end past the middle or out the far side (a fast ball, one step per
    // frame); one that started deep inside goes out where its end is nearest
    // the surface.
    let normal = if t == 0.0 && d0 < 0.0 {
        shape.distance(p1).1
    } else if t == 0.0 {
        n0
    } else {
        shape.distance(point).1
    };
    Some(Local {
        point,
        normal,
        triangle: 0,
    })
}

fn shape_push(shape: &Shape, q: Vec3, thickness: f32) -> Vec3 {
    let (d, n) = shape.distance(q);
    if d < thickness {
        q + (thickness - d) * n
    } else {
        q
    }
}

fn mesh_contact(mesh: &TriMesh, p0: Vec3, p1: Vec3, thickness: f32) -> Option<Local> {
    let pad = Vec3::splat(thickness);
    let (min, max) = (p0.min(p1) - pad, p0.max(p1) + pad);
    let mut crossing: Option<(f32, usize)> = None;
    let mut nearest: Option<(f32, usize, Vec3)> = None;
    mesh.query(min, max, |t| {
        let tri = mesh.triangles[t];
        if let Some(s) = segment_triangle(p0, p1, tri)
            && crossing.is_none_or(|(best, _)| s < best)
        {
            crossing = Some((s, t));
        }
        let c = closest_point_on_triangle(p1, tri);
        let d = p1.distance(c);
        if d < thickness && nearest.is_none_or(|(best, _, _)| d < best) {
            nearest = Some((d, t, c));
        }
    });
    // The side a particle came from decides which way is out.
    let side = |t: usize| {
        let n = mesh.normals[t];
        if (p0 - mesh.triangles[t][0]).dot(n) < 0.0 {
            -n
        } else {
            n
        }
    };
    if let Some((s, t)) = crossing {
        return Some(Local {
            point: p0.lerp(p1, s),
            normal: side(t),
            triangle: t,
        });
    }
    let (d, t, c) = nearest?;
    let normal = if d > 1e-9 { (p1 - c) / d } else { side(t) };
    // Within δ at the start too and moving away: leaving.
    let c0 = closest_point_on_triangle(p0, mesh.triangles[t]);
    if p0.distance(c0) < thickness && (p1 - p0).dot(normal) >= 0.0 {
        return None;
    }
    Some(Local {
        point: p0,
        normal,
        triangle: t,
    })
}

fn mesh_push(mesh: &TriMesh, contact: &Local, q: Vec3, thickness: f32) -> Vec3 {
    let c = closest_point_on_triangle(q, mesh.triangles[contact.triangle]);
    let off = q - c;
    let along = off.dot(contact.normal);
    if along < thickness {
        q + (thickness - along) * contact.normal
    } else {
        q
    }
}

/// Collides the free particles of a cloth (`inverse_masses ≠ 0`) moving
/// from `start` to `x` (world, m) during `dt` seconds with `collider`,
/// keeping them `thickness` m off its surface. Rewrites `x` and `v` (m/s)
/// of the particles in contact.
pub fn collide_particles(
    collider: &MovingCollider,
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
    thickness: f32,
    dt: f32,
) -> Counts {
    // The poses as matrices: a rotation by a 3×3 matrix takes 15 operations
    // where one by a quaternion took 27, and every particle is rotated at
    // least twice (a third of a 64×64 cloth's contact pass).
    let (to0, to1) = (
        Affine3A::from(collider.start.inverse()),
        Affine3A::from(collider.end.inverse()),
    );
    let (start_pose, end_pose) = (Affine3A::from(collider.start), Affine3A::from(collider.end));
    let mut counts = Counts::default();
    for i in 0..x.len() {
        if inverse_masses[i] == 0.0 {
            continue;
        }
        counts.tests += 1;
        let p0 = to0.transform_point3(start[i]);
        let p1 = to1.transform_point3(x[i]);
        let contact = match collider.geometry {
            Geometry::Shape(ref shape) => shape_contact(shape, p0, p1, thickness),
            Geometry::Mesh(mesh) => mesh_contact(mesh, p0, p1, thickness),
        };
        let Some(contact) = contact else {
            continue;
        };
        counts.contacts += 1;
        let normal = end_pose.transform_vector3(contact.normal);
        let world_point = end_pose.transform_point3(contact.point);
        let before = start_pose.transform_point3(contact.point);
        let v_obj = (world_point - before) / dt;
        let (v_new, factor) = respond(v[i], v_obj, normal, collider.friction, collider.restitution);
        let rest = p1 - contact.point;
        let slide = rest - rest.dot(contact.normal) * contact.normal;
        let q = contact.point + factor * slide;
        let q = match collider.geometry {
            Geometry::Shape(ref shape) => shape_push(shape, q, thickness),
            Geometry::Mesh(mesh) => mesh_push(mesh, &contact, q, thickness),
        };
        x[i] = end_pose.transform_point3(q);
        v[i] = v_new;
    }
    counts
}

/// The paper's pass for mesh colliders (MODEL.md §8.1): every cloth triangle
/// that intersects a collider triangle (`triangles_intersect`, both
/// directions) has the velocities of its three free vertices answered with
/// the corrected response of §8.2. Positions are left to the vertex pass.
///
/// The normal depends on which triangle pierces which: a cloth edge through
/// a collider face is answered along that face's outward normal; a collider
/// edge poking through the cloth triangle (which no vertex test can see)
/// along the cloth triangle's normal, turned against the cloth's motion
/// relative to the collider.
#[expect(
    clippy::too_many_arguments,
    reason = "a plain function over the cloth's slices"
)]
pub fn seed_triangle_pass(
    collider: &MovingCollider,
    mesh: &TriMesh,
    cloth_triangles: impl Iterator<Item = [u32; 3]>,
    x: &[Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
    thickness: f32,
    dt: f32,
) -> Counts {
    let to1 = collider.end.inverse();
    let mut counts = Counts::default();
    for tri in cloth_triangles {
        counts.tests += 1;
        let local = tri.map(|p| Vec3::from(to1.transform_point(x[p as usize])));
        let pad = Vec3::splat(thickness);
        let (min, max) = (
            local[0].min(local[1]).min(local[2]) - pad,
            local[0].max(local[1]).max(local[2]) + pad,
        );
        let mut hit = None;
        mesh.query(min, max, |t| {
            if hit.is_none() && triangles_intersect(mesh.triangles[t], local) {
                hit = Some(t);
            }
        });
        let Some(t) = hit else {
            continue;
        };
        counts.contacts += 1;
        let v_obj = tri.map(|p| {
            let p = p as usize;
            let local_p: Vec3 = to1.transform_point(x[p]).into();
            (x[p] - Vec3::from(collider.start.transform_point(local_p))) / dt
        });
        let normal: Vec3 = if edges_pierce(mesh.triangles[t], local) {
            collider.end.rotation * mesh.normals[t]
        } else {
            let [a, b, c] = tri.map(|p| x[p as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            let approach: Vec3 = (0..3).map(|k| v[tri[k] as usize] - v_obj[k]).sum();
            if approach.dot(n) > 0.0 { -n } else { n }
        };
        for (k, &p) in tri.iter().enumerate() {
            let p = p as usize;
            if inverse_masses[p] != 0.0 {
                v[p] = respond(
                    v[p],
                    v_obj[k],
                    normal,
                    collider.friction,
                    collider.restitution,
                )
                .0;
            }
        }
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Quat;

    fn still(geometry: Geometry, at: Vec3) -> MovingCollider {
        let pose = Isometry3d::from_translation(at);
        MovingCollider {
            geometry,
            start: pose,
            end: pose,
            friction: 0.0,
            restitution: 0.0,
        }
    }

    #[test]
    fn a_falling_particle_lands_on_a_sphere_at_the_thickness() {
        let c = still(Geometry::Shape(Shape::Sphere { radius: 0.5 }), Vec3::Y);
        let start = [Vec3::new(0.0, 1.6, 0.0)];
        let mut x = [Vec3::new(0.0, 1.2, 0.0)]; // ends inside
        let mut v = [Vec3::new(0.0, -3.0, 0.0)];
        let n = collide_particles(&c, &start, &mut x, &mut v, &[1.0], 0.01, 1.0 / 60.0);
        assert_eq!(n.contacts, 1);
        assert!(
            (x[0] - Vec3::new(0.0, 1.51, 0.0)).length() < 1e-4,
            "{}",
            x[0]
        );
        assert!(v[0].length() < 1e-6);
        // Pinned particles are never touched.
        let mut x = [Vec3::new(0.0, 1.2, 0.0)];
        let n = collide_particles(&c, &start, &mut x, &mut v, &[0.0], 0.01, 1.0 / 60.0);
        assert_eq!((n.contacts, x[0]), (0, Vec3::new(0.0, 1.2, 0.0)));
    }

    #[test]
    fn a_fast_sphere_pushes_a_particle_instead_of_passing_it() {
        // The sphere moves 0.6 m in one step through a particle at rest.
        let shape = Geometry::Shape(Shape::Sphere { radius: 0.1 });
        let c = MovingCollider {
            geometry: shape,
            start: Isometry3d::from_translation(Vec3::new(0.0, 0.0, -0.3)),
            end: Isometry3d::from_translation(Vec3::new(0.0, 0.0, 0.3)),
            friction: 0.0,
            restitution: 0.0,
        };
        let start = [Vec3::new(0.01, 0.0, 0.0)];
        let mut x = start;
        let mut v = [Vec3::ZERO];
        let n = collide_particles(&c, &start, &mut x, &mut v, &[1.0], 0.005, 1.0 / 60.0);
        assert_eq!(n.contacts, 1);
        // It ends in front of the sphere (z > 0.3), not left behind it.
        assert!(x[0].z > 0.3 + 0.09, "{}", x[0]);
        assert!(v[0].z > 30.0, "{}", v[0]);
    }

    #[test]
    fn static_friction_holds_position_and_zero_friction_slides() {
        let floor = Geometry::Shape(Shape::Plane);
        let start = [Vec3::new(0.0, 0.01, 0.0)];
        let end = [Vec3::new(0.05, 0.005, 0.0)];
        let v0 = [Vec3::new(3.0, -1.0, 0.0)];
        let mut sticky = still(floor, Vec3::ZERO);
        sticky.friction = 5.0;
        let (mut x, mut v) = (end, v0);
        collide_particles(&sticky, &start, &mut x, &mut v, &[1.0], 0.01, 0.01);
        assert!((x[0] - start[0]).length() < 1e-6, "{}", x[0]);
        assert_eq!(v[0], Vec3::ZERO);
        let slippery = still(floor, Vec3::ZERO);
        let (mut x, mut v) = (end, v0);
        collide_particles(&slippery, &start, &mut x, &mut v, &[1.0], 0.01, 0.01);
        assert!(
            (x[0] - Vec3::new(0.05, 0.01, 0.0)).length() < 1e-6,
            "{}",
            x[0]
        );
        assert_eq!(v[0], Vec3::new(3.0, 0.0, 0.0));
    }

    #[test]
    fn rotated_colliders_use_their_frame() {
        // A floor tilted 90° about Z becomes a wall at x = 1 facing −X... its
        // local +Y maps to world −X.
        let pose = Isometry3d::new(Vec3::X, Quat::from_rotation_z(std::f32::consts::FRAC_PI_2));
        let c = MovingCollider {
            geometry: Geometry::Shape(Shape::Plane),
            start: pose,
            end: pose,
            friction: 0.0,
            restitution: 0.0,
        };
        let start = [Vec3::new(0.5, 0.0, 0.0)];
        let mut x = [Vec3::new(1.5, 0.0, 0.0)];
        let mut v = [Vec3::X * 2.0];
        collide_particles(&c, &start, &mut x, &mut v, &[1.0], 0.01, 0.5);
        assert!((x[0].x - 0.99).abs() < 1e-5, "{}", x[0]);
        assert!(v[0].x.abs() < 1e-6);
    }

    #[test]
    fn mesh_contacts_cross_and_rest() {
        use bevy::mesh::{MeshBuilder, Meshable};
        use bevy::shape::Cuboid;
        let mesh = TriMesh::from_mesh(&Cuboid::new(2.0, 0.02, 2.0).mesh().build()).unwrap();
        let c = still(Geometry::Mesh(&mesh), Vec3::ZERO);
        // Through the 2 cm slab in one step: caught at the top face.
        let start = [Vec3::new(0.3, 0.5, 0.2)];
        let mut x = [Vec3::new(0.3, -0.5, 0.2)];
        let mut v = [Vec3::new(0.0, -60.0, 0.0)];
        let n = collide_particles(&c, &start, &mut x, &mut v, &[1.0], 0.005, 1.0 / 60.0);
        assert_eq!(n.contacts, 1);
        assert!(
            (x[0] - Vec3::new(0.3, 0.015, 0.2)).length() < 1e-5,
            "{}",
            x[0]
        );
        // Resting within δ and pressed down: held at δ.
        let start = x;
        let mut x2 = [x[0] - Vec3::Y * 0.002];
        let mut v = [Vec3::new(0.0, -0.1, 0.0)];
        collide_particles(&c, &start, &mut x2, &mut v, &[1.0], 0.005, 1.0 / 60.0);
        assert!((x2[0].y - 0.015).abs() < 1e-5, "{}", x2[0]);
        // Beside the slab, just below its top, it is pushed sideways, not up.
        let start = [Vec3::new(1.003, 0.0, 0.0)];
        let mut x3 = [Vec3::new(1.002, -0.001, 0.0)];
        collide_particles(
            &c,
            &start,
            &mut x3,
            &mut [Vec3::ZERO],
            &[1.0],
            0.005,
            1.0 / 60.0,
        );
        assert!(x3[0].x >= 1.0049 && x3[0].y < 0.0, "{}", x3[0]);
    }

    #[test]
    fn seed_pass_answers_an_edge_poking_through_a_cloth_triangle() {
        use bevy::mesh::{MeshBuilder, Meshable};
        use bevy::shape::Cuboid;
        // A thin tall box whose top edge pokes up through a large cloth
        // triangle whose vertices are all far from the box.
        let mesh = TriMesh::from_mesh(&Cuboid::new(0.02, 1.0, 0.02).mesh().build()).unwrap();
        let c = still(Geometry::Mesh(&mesh), Vec3::ZERO);
        let x = [
            Vec3::new(-1.0, 0.45, -1.0),
            Vec3::new(1.0, 0.45, -1.0),
            Vec3::new(0.0, 0.45, 1.0),
        ];
        let mut v = [Vec3::new(0.0, -1.0, 0.0); 3];
        let n = seed_triangle_pass(
            &c,
            &mesh,
            std::iter::once([0, 1, 2]),
            &x,
            &mut v,
            &[1.0; 3],
            0.005,
            0.01,
        );
        assert_eq!(n.contacts, 1);
        assert!(v.iter().all(|v| v.y >= 0.0), "{v:?}");
    }
}
