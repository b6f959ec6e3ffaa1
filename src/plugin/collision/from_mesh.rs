//! Collision shapes from Bevy meshes: the one place the narrow phase meets
//! `bevy::mesh`, so that [`TriMesh`] itself is plain triangles and a BVH.

use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};

use crate::error::ClothError;
use crate::sim::collision::TriMesh;

impl TriMesh {
    /// The triangles of a Bevy `Mesh` (triangle list, `Float32x3`
    /// positions, with or without indices), in the mesh's own space.
    pub fn from_mesh(mesh: &Mesh) -> Result<Self, ClothError> {
        let bad =
            ClothError::InvalidCollider("the mesh needs Float32x3 positions in a triangle list");
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            return Err(bad);
        }
        let Ok(VertexAttributeValues::Float32x3(positions)) =
            mesh.try_attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            return Err(bad);
        };
        let p = |i: usize| positions.get(i).map(|v| Vec3::from_array(*v));
        let indices: Vec<usize> = match mesh.try_indices() {
            Ok(Indices::U16(i)) => i.iter().map(|&i| i as usize).collect(),
            Ok(Indices::U32(i)) => i.iter().map(|&i| i as usize).collect(),
            Err(_) => (0..positions.len()).collect(),
        };
        let mut tris = Vec::with_capacity(indices.len() / 3);
        for c in indices.chunks_exact(3) {
            match (p(c[0]), p(c[1]), p(c[2])) {
                (Some(a), Some(b), Some(c)) => tris.push([a, b, c]),
                _ => return Err(ClothError::InvalidCollider("a mesh index is out of range")),
            }
        }
        Self::new(tris)
    }
}
