//! [`MeshClothBuilder`]: a validated cloth of any shape from a Bevy `Mesh`,
//! made by [`ClothBuilder::from_mesh`](crate::ClothBuilder::from_mesh).

use bevy::math::{Quat, Vec3};
use bevy::mesh::{Mesh, MeshVertexAttribute, VertexFormat};

use crate::error::ClothError;
use crate::plugin::spawn::builder::{ClothBuilder, ClothBundle, Common, common_methods};
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::spawn::mesh_cloth::{
    MeshLayout, float_attribute, marked_particles, painted_particles,
};
use crate::plugin::step::components::{Cloth, ClothConnections, ClothSettings};
use crate::sim::build::placed;

/// A pin request, resolved against the welded mesh.
enum Pin {
    Vertex(u32),
    Where(Box<dyn Fn(Vec3) -> bool + Send + Sync>),
    Painted(usize),
    Attribute(String),
}

impl ClothBuilder {
    /// A cloth of the shape of `mesh`: any triangle list with `Float32x3`
    /// positions (m, in the mesh's own space), indexed (`u16` or `u32`) or
    /// not. Vertices at the same position are welded into one particle;
    /// the mesh's UVs and triangles are kept for rendering, and its links
    /// follow [`MeshTopology::connections`](crate::sim::topology::MeshTopology::connections).
    ///
    /// A bad mesh is reported by [`build`](MeshClothBuilder::build): see
    /// [`MeshTopology::new`](crate::sim::topology::MeshTopology::new) and
    /// [`ClothError::UnsupportedMesh`].
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use bevy_cloth::prelude::*;
    /// // A round tablecloth of 0.8 m radius, 1 m up, pinned at its centre.
    /// let disc = Circle::new(0.8).mesh().resolution(48).build();
    /// let cloth = ClothBuilder::from_mesh(&disc)
    ///     .rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
    ///     .position(Vec3::Y)
    ///     .pin_where(|rest| rest.length() < 0.01)
    ///     .build()
    ///     .unwrap();
    /// assert!(cloth.cloth.mesh().is_some());
    /// ```
    pub fn from_mesh(mesh: &Mesh) -> MeshClothBuilder {
        MeshClothBuilder {
            mesh: mesh.clone(),
            common: Common::default(),
            pins: Vec::new(),
        }
    }
}

/// Builds a validated cloth from a triangle mesh; made by
/// [`ClothBuilder::from_mesh`].
///
/// The particles rest where the mesh's vertices are, in the mesh's own
/// space, before [`rotation`](Self::rotation) and
/// [`position`](Self::position) place them in the world. The material
/// defaults to [`ClothMaterial::COTTON`]; the mass to the material's
/// density, lumped by area (each triangle's mass split equally between its
/// corners).
pub struct MeshClothBuilder {
    mesh: Mesh,
    common: Common,
    pins: Vec<Pin>,
}

impl std::fmt::Debug for MeshClothBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("MeshClothBuilder");
        d.field("vertices", &self.mesh.count_vertices());
        self.common.debug_fields(&mut d);
        d.field("pins", &self.pins.len()).finish()
    }
}

impl MeshClothBuilder {
    common_methods!("the mesh's origin");

    /// Pins the particle of the mesh's vertex `vertex`.
    pub fn pin_vertex(mut self, vertex: u32) -> Self {
        self.pins.push(Pin::Vertex(vertex));
        self
    }

    /// Pins every particle whose rest position (m, in the mesh's own space)
    /// satisfies `predicate`.
    pub fn pin_where(mut self, predicate: impl Fn(Vec3) -> bool + Send + Sync + 'static) -> Self {
        self.pins.push(Pin::Where(Box::new(predicate)));
        self
    }

    /// Pins every particle with a vertex whose colour has `channel` (0 red,
    /// 1 green, 2 blue, 3 alpha) at 0.5 or more: pins painted in Blender's
    /// colour attribute.
    pub fn pin_painted(mut self, channel: usize) -> Self {
        self.pins.push(Pin::Painted(channel));
        self
    }

    /// Pins every particle with a vertex whose `Float32` attribute named
    /// `name` is 0.5 or more. [`ATTRIBUTE_PIN`] is such an attribute. A
    /// glTF's custom attribute `_PIN` (painted in Blender, exported as a
    /// float attribute) reaches it through
    /// `GltfPlugin::default().add_custom_vertex_attribute("PIN", ATTRIBUTE_PIN)`:
    /// Bevy's loader matches a custom attribute by its name without the
    /// leading underscore.
    pub fn pin_attribute(mut self, name: impl Into<String>) -> Self {
        self.pins.push(Pin::Attribute(name.into()));
        self
    }

    /// Checks the mesh and the description and makes the cloth.
    ///
    /// Errors: those of [`MeshLayout::from_mesh`], a pinned vertex out of
    /// range or unused ([`ClothError::ParticleOutOfRange`]), pins the mesh
    /// has no colours or attribute for ([`ClothError::UnsupportedMesh`]),
    /// and an invalid material, mass or placement.
    pub fn build(self) -> Result<ClothBundle, ClothError> {
        let (mass, m, rotation) = self.common.check()?;
        let shape = MeshLayout::from_mesh(&self.mesh)?;
        let topology = shape.topology();
        let masses = topology.masses(mass, self.common.uniform_mass);
        let positions = placed(
            topology.positions.iter().copied(),
            self.common.position,
            rotation,
        );
        let connections = ClothConnections(topology.connections());
        let cloth = Cloth::from(shape.clone());
        self.common.bundle(
            m,
            cloth,
            positions,
            masses,
            connections,
            &self.pins,
            |pin| self.resolve(&shape, pin),
        )
    }

    fn resolve(&self, shape: &MeshLayout, pin: &Pin) -> Result<Vec<u32>, ClothError> {
        let topology = shape.topology();
        let vertices = topology.particle_of.len();
        Ok(match pin {
            Pin::Vertex(v) => match topology.particle_of.get(*v as usize) {
                Some(Some(p)) => vec![*p],
                _ => {
                    return Err(ClothError::ParticleOutOfRange {
                        index: *v,
                        count: vertices as u32,
                    });
                }
            },
            Pin::Where(f) => topology.particles_where(f),
            Pin::Painted(channel) => painted_particles(&self.mesh, topology, *channel)?,
            Pin::Attribute(name) => {
                let values = float_attribute(&self.mesh, name).ok_or(
                    ClothError::UnsupportedMesh("no Float32 vertex attribute of that name"),
                )?;
                marked_particles(values, topology).ok_or(ClothError::UnsupportedMesh(
                    "the pin attribute and the mesh's vertices differ in number",
                ))?
            }
        })
    }
}

/// A `Float32` vertex attribute named `"Cloth_Pin"` for
/// [`MeshClothBuilder::pin_attribute`]: 1 pins a vertex's particle, 0
/// leaves it free.
pub const ATTRIBUTE_PIN: MeshVertexAttribute =
    MeshVertexAttribute::new("Cloth_Pin", 0x0c10_7b11_5f1a_2026, VertexFormat::Float32);

#[cfg(test)]
mod tests {
    use bevy::asset::RenderAssetUsages;
    use bevy::mesh::{Indices, MeshBuilder, Meshable, PrimitiveTopology, VertexAttributeValues};
    use bevy::shape::Plane3d;

    use super::*;

    /// A 1 m plane of 15 × 15 vertices in the xz plane.
    fn plane() -> Mesh {
        Plane3d::default()
            .mesh()
            .size(1.0, 1.0)
            .subdivisions(13)
            .build()
    }

    fn pinned(b: &ClothBundle) -> Vec<u32> {
        (0..b.particles.len() as u32)
            .filter(|&p| b.particles.is_pinned(p as usize))
            .collect()
    }

    #[test]
    fn a_plane_mesh_builds_the_grid_builders_cloth() {
        let mesh = ClothBuilder::from_mesh(&plane()).build().unwrap();
        let grid = ClothBuilder::new(15, 15).build().unwrap();
        assert_eq!(mesh.particles.len(), 225);
        assert_eq!(
            (
                mesh.connections.type1_count(),
                mesh.connections.type2_count()
            ),
            (812, 728)
        );
        let total = |b: &ClothBundle| b.particles.masses.iter().sum::<f32>();
        assert!((total(&mesh) - total(&grid)).abs() < 1e-5);
        assert!((mesh.cloth.area() - 1.0).abs() < 1e-5);
        assert!((mesh.cloth.spacing() - 1.0 / 14.0).abs() < 0.3 / 14.0);
        let heavy = ClothBuilder::from_mesh(&plane())
            .total_mass(2.0)
            .uniform_mass()
            .build()
            .unwrap();
        assert!((total(&heavy) - 2.0).abs() < 1e-4);
        assert!((heavy.particles.masses[0] - 2.0 / 225.0).abs() < 1e-6);
    }

    #[test]
    fn pins_come_by_vertex_place_colour_and_attribute() {
        let mut mesh = plane();
        let Some(VertexAttributeValues::Float32x3(x)) =
            mesh.attribute(Mesh::ATTRIBUTE_POSITION).cloned()
        else {
            panic!("positions")
        };
        // The top row (z = −0.5) painted red, the left column (x = −0.5)
        // flagged in the pin attribute.
        let red: Vec<[f32; 4]> = x
            .iter()
            .map(|p| [if p[2] < -0.49 { 1.0 } else { 0.0 }, 0.0, 0.0, 1.0])
            .collect();
        let flag: Vec<f32> = x
            .iter()
            .map(|p| if p[0] < -0.49 { 1.0 } else { 0.0 })
            .collect();
        mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, red);
        mesh.insert_attribute(ATTRIBUTE_PIN, flag);
        let top = ClothBuilder::from_mesh(&mesh)
            .pin_painted(0)
            .build()
            .unwrap();
        assert_eq!(pinned(&top).len(), 15);
        let left = ClothBuilder::from_mesh(&mesh)
            .pin_attribute("Cloth_Pin")
            .build()
            .unwrap();
        let p = pinned(&left);
        assert_eq!(p.len(), 15);
        assert!(
            p.iter()
                .all(|&p| left.particles.positions[p as usize].x < -0.49)
        );
        let both = ClothBuilder::from_mesh(&mesh)
            .pin_painted(0)
            .pin_attribute(ATTRIBUTE_PIN.name)
            .pin_vertex(224)
            .pin_where(|rest| rest.length() < 1e-3)
            .build()
            .unwrap();
        // 15 + 15 − 1 shared corner + the far corner + the centre.
        assert_eq!(pinned(&both).len(), 31);
        // Placement moves the particles, not which are pinned.
        let placed = ClothBuilder::from_mesh(&mesh)
            .position(Vec3::Y)
            .rotation(Quat::from_rotation_z(1.0))
            .pin_where(|rest| rest.x < -0.49)
            .build()
            .unwrap();
        assert_eq!(pinned(&placed), p);
    }

    #[test]
    fn bad_meshes_and_pins_are_errors() {
        let empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 3]);
        assert!(matches!(
            ClothBuilder::from_mesh(&empty).build(),
            Err(ClothError::DegenerateMesh { .. })
        ));
        let no_triangles = empty.clone().with_inserted_indices(Indices::U32(vec![]));
        assert!(matches!(
            ClothBuilder::from_mesh(&no_triangles).build(),
            Err(ClothError::NoTriangles { indices: 0 })
        ));
        assert!(matches!(
            ClothBuilder::from_mesh(&plane()).pin_vertex(225).build(),
            Err(ClothError::ParticleOutOfRange { index: 225, .. })
        ));
        assert!(matches!(
            ClothBuilder::from_mesh(&plane()).pin_painted(0).build(),
            Err(ClothError::UnsupportedMesh(_))
        ));
        assert!(matches!(
            ClothBuilder::from_mesh(&plane())
                .pin_attribute("nope")
                .build(),
            Err(ClothError::UnsupportedMesh(_))
        ));
        assert!(matches!(
            ClothBuilder::from_mesh(&plane()).total_mass(-1.0).build(),
            Err(ClothError::InvalidMass(_))
        ));
        assert!(matches!(
            ClothBuilder::from_mesh(&plane())
                .position(Vec3::NAN)
                .build(),
            Err(ClothError::InvalidPlacement)
        ));
        // A vertex no triangle uses cannot be pinned.
        let mut loose = plane();
        if let Some(VertexAttributeValues::Float32x3(x)) =
            loose.attribute_mut(Mesh::ATTRIBUTE_POSITION)
        {
            x.push([5.0, 0.0, 0.0]);
        }
        assert!(matches!(
            ClothBuilder::from_mesh(&loose).pin_vertex(225).build(),
            Err(ClothError::ParticleOutOfRange { index: 225, .. })
        ));
    }
}
