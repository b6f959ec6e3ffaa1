//! Cloth of any shape from a Bevy `Mesh`: its particles and links
//! ([`MeshTopology`]), and the pins an artist painted into its vertex
//! colours. The one place the mesh topology meets `bevy::mesh`.

use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};

use crate::error::ClothError;
use crate::sim::topology::MeshTopology;

impl MeshTopology {
    /// The particles and triangles of a Bevy `Mesh`: a triangle list with
    /// `Float32x3` positions (m, in the mesh's own space), with `u16` or
    /// `u32` indices or none. Errors as [`MeshTopology::new`], and
    /// [`ClothError::UnsupportedMesh`] for another topology or no
    /// positions.
    pub fn from_mesh(mesh: &Mesh) -> Result<Self, ClothError> {
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            return Err(ClothError::UnsupportedMesh("not a triangle list"));
        }
        let Ok(VertexAttributeValues::Float32x3(positions)) =
            mesh.try_attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            return Err(ClothError::UnsupportedMesh("no Float32x3 positions"));
        };
        let positions: Vec<Vec3> = positions.iter().map(|&p| Vec3::from_array(p)).collect();
        let indices: Option<Vec<u32>> = match mesh.try_indices() {
            Ok(Indices::U16(i)) => Some(i.iter().map(|&i| i as u32).collect()),
            Ok(Indices::U32(i)) => Some(i.clone()),
            Err(_) => None,
        };
        Self::new(&positions, indices.as_deref())
    }
}

/// The particles of `topology` (made from `mesh`) that an artist painted
/// for pinning: those with a vertex whose colour has `channel` (0 red,
/// 1 green, 2 blue, 3 alpha) at 0.5 or more. In increasing order.
///
/// Errors: [`ClothError::UnsupportedMesh`] when the mesh has no `Float32x4`
/// or `Float32x3` vertex colours, one per vertex of `topology`, or the
/// channel does not exist.
pub fn painted_particles(
    mesh: &Mesh,
    topology: &MeshTopology,
    channel: usize,
) -> Result<Vec<u32>, ClothError> {
    let values: Vec<f32> = match mesh.try_attribute(Mesh::ATTRIBUTE_COLOR) {
        Ok(VertexAttributeValues::Float32x4(c)) if channel < 4 => {
            c.iter().map(|c| c[channel]).collect()
        }
        Ok(VertexAttributeValues::Float32x3(c)) if channel < 3 => {
            c.iter().map(|c| c[channel]).collect()
        }
        _ => {
            return Err(ClothError::UnsupportedMesh(
                "no vertex colours with that channel",
            ));
        }
    };
    if values.len() != topology.particle_of.len() {
        return Err(ClothError::UnsupportedMesh(
            "vertex colours and the cloth's vertices differ in number",
        ));
    }
    let mut pins: Vec<u32> = values
        .iter()
        .zip(&topology.particle_of)
        .filter(|&(&v, _)| v >= 0.5)
        .filter_map(|(_, &p)| p)
        .collect();
    pins.sort_unstable();
    pins.dedup();
    Ok(pins)
}

#[cfg(test)]
mod tests {
    use bevy::asset::RenderAssetUsages;
    use bevy::math::primitives::{Annulus, Circle, Plane3d, Sphere};
    use bevy::mesh::{MeshBuilder, Meshable};

    use super::*;

    #[test]
    fn bevy_primitives_make_cloths() {
        let plane = Plane3d::default()
            .mesh()
            .size(1.0, 1.0)
            .subdivisions(13)
            .build();
        let t = MeshTopology::from_mesh(&plane).unwrap();
        let links = t.connections();
        assert_eq!(
            (t.len(), links.type1_count(), links.type2_count()),
            (225, 812, 728)
        );
        // A circle is a fan of slivers around its rim; an annulus a strip.
        for (mesh, particles) in [
            (Circle::new(0.5).mesh().resolution(32).build(), 32),
            (Annulus::new(0.3, 0.5).mesh().resolution(32).build(), 64),
        ] {
            let t = MeshTopology::from_mesh(&mesh).unwrap();
            assert_eq!(t.len(), particles);
            assert!(t.connections().type1_count() > particles);
        }
        // A UV sphere's seam and poles weld: fewer particles than vertices,
        // the poles' zero-area triangles dropped.
        let sphere = Sphere::new(0.5).mesh().uv(16, 8);
        let vertices = sphere.count_vertices();
        let t = MeshTopology::from_mesh(&sphere).unwrap();
        assert_eq!(t.len(), 16 * 7 + 2, "{vertices} vertices");
        assert!(t.len() < vertices);
        assert_eq!(t.non_manifold_edges, 0);
    }

    #[test]
    fn other_meshes_get_an_error() {
        let lines = Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::default())
            .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 2]);
        assert_eq!(
            MeshTopology::from_mesh(&lines),
            Err(ClothError::UnsupportedMesh("not a triangle list"))
        );
        let empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        assert_eq!(
            MeshTopology::from_mesh(&empty),
            Err(ClothError::UnsupportedMesh("no Float32x3 positions"))
        );
        let nan = empty.clone().with_inserted_attribute(
            Mesh::ATTRIBUTE_POSITION,
            vec![[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 0.0, 1.0]],
        );
        assert!(matches!(
            MeshTopology::from_mesh(&nan),
            Err(ClothError::NonFiniteVertex { vertex: 1, .. })
        ));
    }

    #[test]
    fn pins_painted_in_vertex_colours_are_found() {
        // A plane whose top row (z = −0.5) is painted red.
        let mut plane = Plane3d::default()
            .mesh()
            .size(1.0, 1.0)
            .subdivisions(13)
            .build();
        let Some(VertexAttributeValues::Float32x3(positions)) =
            plane.attribute(Mesh::ATTRIBUTE_POSITION).cloned()
        else {
            panic!("a plane has positions");
        };
        let colours: Vec<[f32; 4]> = positions
            .iter()
            .map(|p| {
                if p[2] < -0.49 {
                    [1.0, 0.0, 0.0, 1.0]
                } else {
                    [0.0, 0.0, 0.0, 1.0]
                }
            })
            .collect();
        plane.insert_attribute(Mesh::ATTRIBUTE_COLOR, colours);
        let t = MeshTopology::from_mesh(&plane).unwrap();
        let pins = painted_particles(&plane, &t, 0).unwrap();
        assert_eq!(pins.len(), 15);
        assert!(pins.iter().all(|&p| t.positions[p as usize].z < -0.49));
        // Green is painted nowhere, alpha everywhere; no fifth channel.
        assert!(painted_particles(&plane, &t, 1).unwrap().is_empty());
        assert_eq!(painted_particles(&plane, &t, 3).unwrap().len(), 225);
        assert!(painted_particles(&plane, &t, 4).is_err());
        // Without colours: an error, not an empty list.
        let bare = Plane3d::default().mesh().build();
        let t = MeshTopology::from_mesh(&bare).unwrap();
        assert!(painted_particles(&bare, &t, 0).is_err());
    }
}
