//! parry's shapes (avian's and rapier's colliders) as the cloth's collider
//! shapes.

use std::borrow::Cow;
use std::sync::Arc;

#[cfg(feature = "avian")]
use avian3d::parry;
use bevy::math::{Isometry3d, Quat, Vec3};
#[cfg(all(feature = "rapier", not(feature = "avian")))]
use bevy_rapier3d::rapier::parry;
use parry::shape::{SharedShape, TypedShape};

use crate::plugin::collision::{ColliderShape, MeshShape, Shape, TriMesh};

/// One convex or mesh piece of a physics engine's collider, in the collider's frame.
#[derive(Clone, Debug)]
pub(crate) struct Piece {
    /// The piece's pose in the collider's frame.
    pub(crate) offset: Isometry3d,
    /// Its surface.
    pub(crate) shape: ColliderShape,
    /// Its rounding radius, m.
    pub(crate) margin: f32,
}

/// The pieces of `shape` (already scaled), or what kind of shape the cloth
/// cannot use.
pub(crate) fn pieces(shape: &SharedShape) -> Result<Vec<Piece>, String> {
    let mut out = Vec::new();
    add(shape, Isometry3d::IDENTITY, 0.0, &mut out)?;
    Ok(out)
}

fn analytic(offset: Isometry3d, shape: Shape, margin: f32) -> Piece {
    Piece {
        offset,
        shape: ColliderShape::Analytic(shape),
        margin,
    }
}

/// A triangle-mesh piece from vertices and index triples.
fn mesh(
    offset: Isometry3d,
    vertices: &[Vec3],
    indices: &[[u32; 3]],
    margin: f32,
) -> Result<Piece, String> {
    let corner = |i: u32| vertices.get(i as usize).copied();
    let triangles = indices
        .iter()
        .filter_map(|t| Some([corner(t[0])?, corner(t[1])?, corner(t[2])?]));
    let mesh = TriMesh::new(triangles).map_err(|error| error.to_string())?;
    Ok(Piece {
        offset,
        shape: ColliderShape::Mesh(MeshShape(Arc::new(mesh))),
        margin,
    })
}

fn add(
    shape: &SharedShape,
    offset: Isometry3d,
    margin: f32,
    out: &mut Vec<Piece>,
) -> Result<(), String> {
    let typed = shape.as_typed_shape();
    if let TypedShape::Compound(compound) = typed {
        for (pose, part) in compound.shapes() {
            let local = Isometry3d::new(pose.translation, pose.rotation);
            add(part, offset * local, margin, out)?;
        }
        return Ok(());
    }
    let grown = |border: Option<f32>| border.map_or(margin, |border| margin + border);
    if let Some((analytic_shape, local, border)) = as_analytic(&typed) {
        let pose = local.map_or(offset, |local| offset * local);
        out.push(analytic(pose, analytic_shape, grown(border)));
        return Ok(());
    }
    let Some((vertices, indices, border)) = as_triangles(&typed) else {
        return Err(format!("{:?}", shape.shape_type()));
    };
    out.push(mesh(offset, &vertices, &indices, grown(border))?);
    Ok(())
}

/// A parry shape the cloth takes as one of its analytic shapes: the shape,
/// its pose in the parry shape's frame (`None`: the same frame) and the
/// rounding radius (m) of a rounded one.
fn as_analytic(shape: &TypedShape<'_>) -> Option<(Shape, Option<Isometry3d>, Option<f32>)> {
    Some(match shape {
        TypedShape::Ball(ball) => (
            Shape::Sphere {
                radius: ball.radius,
            },
            None,
            None,
        ),
        TypedShape::Cuboid(cuboid) => (
            Shape::Cuboid {
                half_extents: cuboid.half_extents,
            },
            None,
            None,
        ),
        TypedShape::Capsule(capsule) => {
            let (a, b) = (capsule.segment.a, capsule.segment.b);
            let axis = b - a;
            let turn = if axis.length() > 1e-9 {
                Quat::from_rotation_arc(Vec3::Y, axis.normalize())
            } else {
                Quat::IDENTITY
            };
            let shape = Shape::Capsule {
                radius: capsule.radius,
                half_length: axis.length() / 2.0,
            };
            (shape, Some(Isometry3d::new((a + b) / 2.0, turn)), None)
        }
        TypedShape::Cylinder(cylinder) => (
            Shape::Cylinder {
                radius: cylinder.radius,
                half_height: cylinder.half_height,
            },
            None,
            None,
        ),
        TypedShape::Cone(cone) => (
            Shape::Cone {
                radius: cone.radius,
                half_height: cone.half_height,
            },
            None,
            None,
        ),
        TypedShape::HalfSpace(half) => {
            let turn = Quat::from_rotation_arc(Vec3::Y, half.normal.normalize());
            (Shape::Plane, Some(Isometry3d::from_rotation(turn)), None)
        }
        TypedShape::RoundCuboid(round) => (
            Shape::Cuboid {
                half_extents: round.inner_shape.half_extents,
            },
            None,
            Some(round.border_radius),
        ),
        TypedShape::RoundCylinder(round) => (
            Shape::Cylinder {
                radius: round.inner_shape.radius,
                half_height: round.inner_shape.half_height,
            },
            None,
            Some(round.border_radius),
        ),
        TypedShape::RoundCone(round) => (
            Shape::Cone {
                radius: round.inner_shape.radius,
                half_height: round.inner_shape.half_height,
            },
            None,
            Some(round.border_radius),
        ),
        _ => return None,
    })
}

/// The vertices, triangles and rounding radius (m) of a parry shape the
/// cloth takes as a triangle mesh.
type Triangles<'a> = (Cow<'a, [Vec3]>, Cow<'a, [[u32; 3]]>, Option<f32>);

/// A parry shape the cloth takes as a triangle mesh ([`Triangles`]).
fn as_triangles<'a>(shape: &TypedShape<'a>) -> Option<Triangles<'a>> {
    Some(match shape {
        TypedShape::ConvexPolyhedron(hull) => {
            let (vertices, indices) = hull.to_trimesh();
            (vertices.into(), indices.into(), None)
        }
        TypedShape::TriMesh(trimesh) => (trimesh.vertices().into(), trimesh.indices().into(), None),
        TypedShape::HeightField(field) => {
            let (vertices, indices) = field.to_trimesh();
            (vertices.into(), indices.into(), None)
        }
        TypedShape::Triangle(t) => (vec![t.a, t.b, t.c].into(), vec![[0, 1, 2]].into(), None),
        TypedShape::RoundConvexPolyhedron(round) => {
            let (vertices, indices) = round.inner_shape.to_trimesh();
            (vertices.into(), indices.into(), Some(round.border_radius))
        }
        TypedShape::RoundTriangle(round) => {
            let t = &round.inner_shape;
            let vertices = vec![t.a, t.b, t.c].into();
            (vertices, vec![[0, 1, 2]].into(), Some(round.border_radius))
        }
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shape_the_bridge_lists_becomes_pieces() {
        let shapes = [
            SharedShape::ball(0.3),
            SharedShape::cuboid(0.1, 0.2, 0.3),
            SharedShape::capsule_y(0.2, 0.1),
            SharedShape::cylinder(0.2, 0.1),
            SharedShape::cone(0.2, 0.1),
            SharedShape::round_cuboid(0.1, 0.1, 0.1, 0.02),
        ];
        for shape in shapes {
            let pieces = pieces(&shape).expect("supported");
            assert_eq!(pieces.len(), 1);
            assert!(pieces[0].shape.validate().is_ok());
        }
    }

    #[test]
    fn a_capsule_along_x_is_turned_onto_local_y() {
        let shape = SharedShape::capsule_x(0.5, 0.1);
        let piece = &pieces(&shape).expect("supported")[0];
        let axis = piece.offset.rotation * Vec3::Y;
        assert!(axis.cross(Vec3::X).length() < 1e-6, "{axis}");
        assert!(matches!(
            piece.shape,
            ColliderShape::Analytic(Shape::Capsule { half_length, .. }) if (half_length - 0.5).abs() < 1e-6
        ));
    }

    #[test]
    fn a_compound_gives_one_piece_per_part_at_its_offset() {
        let shape = SharedShape::compound(vec![
            (
                parry::math::Pose::from_translation(Vec3::X),
                SharedShape::ball(0.1),
            ),
            (
                parry::math::Pose::from_translation(Vec3::NEG_X),
                SharedShape::cuboid(0.1, 0.1, 0.1),
            ),
        ]);
        let pieces = pieces(&shape).expect("supported");
        assert_eq!(pieces.len(), 2);
        assert_eq!(Vec3::from(pieces[0].offset.translation), Vec3::X);
        assert_eq!(Vec3::from(pieces[1].offset.translation), Vec3::NEG_X);
    }

    #[test]
    fn a_segment_is_refused_by_name() {
        let shape = SharedShape::segment(Vec3::ZERO, Vec3::X);
        let error = pieces(&shape).expect_err("a segment has no inside");
        assert!(error.contains("Segment"), "{error}");
    }
}
