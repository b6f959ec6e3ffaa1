//! Cloth of any shape from a Bevy `Mesh`: its particles and links
//! ([`MeshTopology`]), the [`MeshLayout`] a mesh cloth renders with, and the
//! pins an artist painted into its vertex colours or a named attribute.
//! The one place the mesh topology meets `bevy::mesh`.

use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

use bevy::math::{Vec2, Vec3};
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use bevy::reflect::Reflect;

use crate::error::ClothError;
use crate::sim::connections::Connections;
use crate::sim::grid::{Faces, Grid};
use crate::sim::topology::MeshTopology;

/// The shape of a cloth made from a mesh: its welded [`MeshTopology`]
/// (rest positions in the mesh's own space, m) and the source mesh's
/// vertices that the live mesh renders, so UV seams stay seams while the
/// particles on both sides are one. Cheap to clone (shared).
#[derive(Clone, Debug, PartialEq, Reflect)]
#[reflect(opaque, Clone, Debug, PartialEq)]
pub struct MeshLayout(Arc<ShapeData>);

#[derive(Debug)]
struct ShapeData {
    topology: MeshTopology,
    vertex_particles: Vec<u32>,
    uvs: Option<Vec<[f32; 2]>>,
    indices: Vec<u32>,
    spacing: f32,
    area: f32,
    cell_size: f32,
    /// The mesh rule's links of `topology`, once asked for.
    rule: OnceLock<Connections>,
}

/// Equal shapes, whether or not either has built its rule's links.
impl PartialEq for ShapeData {
    fn eq(&self, other: &Self) -> bool {
        self.topology == other.topology
            && self.vertex_particles == other.vertex_particles
            && self.uvs == other.uvs
            && self.indices == other.indices
            && self.spacing == other.spacing
            && self.area == other.area
            && self.cell_size == other.cell_size
    }
}

impl MeshLayout {
    /// The shape of `topology`, made from a mesh whose vertices have UVs
    /// `uvs` (if any) and triangles `indices` (three per triangle;
    /// consecutive vertices when `None`). Vertices no particle stands for
    /// are left out, and so are triangles that lost a corner to welding.
    pub fn new(topology: MeshTopology, uvs: Option<&[[f32; 2]]>, indices: Option<&[u32]>) -> Self {
        let mut render_of = vec![u32::MAX; topology.particle_of.len()];
        let mut vertex_particles = Vec::new();
        let mut kept_uvs = Vec::new();
        for (v, p) in topology.particle_of.iter().enumerate() {
            if let Some(p) = *p {
                render_of[v] = vertex_particles.len() as u32;
                vertex_particles.push(p);
                if let Some(uvs) = uvs {
                    kept_uvs.push(uvs.get(v).copied().unwrap_or_default());
                }
            }
        }
        let count = indices.map_or(topology.particle_of.len(), <[u32]>::len);
        let source = |k: usize| indices.map_or(k, |i| i[k] as usize);
        let mut kept = Vec::with_capacity(count);
        for t in 0..count / 3 {
            let v = [source(3 * t), source(3 * t + 1), source(3 * t + 2)];
            let r = v.map(|v| render_of.get(v).copied().unwrap_or(u32::MAX));
            if r.contains(&u32::MAX) {
                continue;
            }
            let p = r.map(|r| vertex_particles[r as usize]);
            if p[0] != p[1] && p[1] != p[2] && p[2] != p[0] {
                kept.extend(r);
            }
        }
        Self::from_parts(topology, vertex_particles, uvs.map(|_| kept_uvs), kept)
    }

    /// The layout of `topology` rendered as `vertex_particles` (each
    /// rendered vertex's particle) with UVs `uvs` and triangles `indices`.
    fn from_parts(
        topology: MeshTopology,
        vertex_particles: Vec<u32>,
        uvs: Option<Vec<[f32; 2]>>,
        indices: Vec<u32>,
    ) -> Self {
        let x = &topology.positions;
        let edges: Vec<f32> = topology
            .triangles
            .iter()
            .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
            .map(|(a, b)| x[a as usize].distance(x[b as usize]))
            .collect();
        let spacing = edges.iter().sum::<f32>() / edges.len().max(1) as f32;
        let area = topology
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| x[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        let cell_size = topology.cell_size();
        Self(Arc::new(ShapeData {
            topology,
            vertex_particles,
            uvs,
            indices,
            spacing,
            area,
            cell_size,
            rule: OnceLock::new(),
        }))
    }

    /// The shape of a Bevy `Mesh` (see [`MeshTopology::from_mesh`]),
    /// keeping its `ATTRIBUTE_UV_0` for rendering.
    pub fn from_mesh(mesh: &Mesh) -> Result<Self, ClothError> {
        let topology = MeshTopology::from_mesh(mesh)?;
        let uvs = match mesh.try_attribute(Mesh::ATTRIBUTE_UV_0) {
            Ok(VertexAttributeValues::Float32x2(uvs)) => Some(uvs.as_slice()),
            _ => None,
        };
        Ok(Self::new(topology, uvs, mesh_indices(mesh).as_deref()))
    }

    /// The layout of a grid cloth: its particles and triangles
    /// ([`MeshTopology::from_grid`]), each particle rendered once, with the
    /// grid's UVs (over `[0, 1]²` along its columns and rows).
    pub fn from_grid(grid: &Grid) -> Self {
        let topology = MeshTopology::from_grid(grid);
        let (cu, rv) = ((grid.cols.max(2) - 1) as f32, (grid.rows.max(2) - 1) as f32);
        let uvs = (0..grid.len() as u32)
            .map(|p| [(p % grid.cols) as f32 / cu, (p / grid.cols) as f32 / rv])
            .collect();
        let indices = topology.triangles.iter().flatten().copied().collect();
        let vertex_particles = (0..grid.len() as u32).collect();
        Self::from_parts(topology, vertex_particles, Some(uvs), indices)
    }

    /// This layout after a tear that left `topology`: the same triangles
    /// (in the same order), some of whose corners are now copies of their
    /// particles (`tear`). A rendered vertex whose
    /// triangles now reach two particles is duplicated, its UV kept, so each
    /// side of the tear renders on its own.
    pub fn torn(&self, topology: MeshTopology) -> Self {
        let before = &self.topology().triangles;
        let key = |t: [u32; 3]| {
            let mut t = t;
            t.sort_unstable();
            t
        };
        let of_triangle: HashMap<[u32; 3], usize> = before
            .iter()
            .enumerate()
            .map(|(i, &t)| (key(t), i))
            .collect();
        let uvs = self.uvs_or_projected();
        let mut vertex_particles = self.vertex_particles().to_vec();
        let mut kept_uvs = uvs.clone();
        let mut copies: HashMap<(u32, u32), u32> = HashMap::new();
        let mut indices = self.indices().to_vec();
        for rendered in indices.chunks_exact_mut(3) {
            let old = [0, 1, 2].map(|k| self.vertex_particles()[rendered[k] as usize]);
            let Some(&t) = of_triangle.get(&key(old)) else {
                continue;
            };
            let (was, now) = (
                before[t],
                topology.triangles.get(t).copied().unwrap_or(before[t]),
            );
            for (r, p) in rendered.iter_mut().zip(old) {
                let Some(k) = was.iter().position(|&q| q == p) else {
                    continue;
                };
                let particle = now[k];
                if particle == p {
                    continue;
                }
                *r = *copies.entry((*r, particle)).or_insert_with(|| {
                    vertex_particles.push(particle);
                    kept_uvs.push(uvs[*r as usize]);
                    (vertex_particles.len() - 1) as u32
                });
            }
        }
        Self::from_parts(topology, vertex_particles, Some(kept_uvs), indices)
    }

    /// This layout after the seam `seam` (`sew`) that
    /// left `topology`: every rendered vertex shows the particle its own
    /// joined, UVs kept (a seam stays a UV seam), and a rendered triangle
    /// left with a repeated particle is dropped.
    pub(crate) fn sewn(&self, topology: MeshTopology, seam: &crate::sim::sew::Seam) -> Self {
        let at = |p: u32| seam.map.get(p as usize).copied().unwrap_or(p);
        let vertex_particles: Vec<u32> = self.vertex_particles().iter().map(|&p| at(p)).collect();
        let indices = self
            .indices()
            .chunks_exact(3)
            .filter(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|r| vertex_particles[r as usize]);
                a != b && b != c && c != a
            })
            .flatten()
            .copied()
            .collect();
        Self::from_parts(
            topology,
            vertex_particles,
            Some(self.uvs_or_projected()),
            indices,
        )
    }

    /// The welded particles and triangles.
    pub fn topology(&self) -> &MeshTopology {
        &self.0.topology
    }

    /// The links the mesh rule gives its topology
    /// ([`MeshTopology::connections`], rest lengths in m): built the first
    /// time they are asked for and kept (a tear maps a cloth's links from
    /// them).
    pub fn rule_links(&self) -> &Connections {
        self.0.rule.get_or_init(|| self.0.topology.connections())
    }

    /// Keeps `links` as [`rule_links`](Self::rule_links), which they must
    /// be (a tear that has just built them); no change if they were built
    /// already.
    pub(crate) fn keep_rule_links(&self, links: Connections) {
        let _ = self.0.rule.set(links);
    }

    /// For each vertex the live mesh renders, its particle.
    pub fn vertex_particles(&self) -> &[u32] {
        &self.0.vertex_particles
    }

    /// The source mesh's UVs of the rendered vertices, if it had any.
    pub fn uvs(&self) -> Option<&[[f32; 2]]> {
        self.0.uvs.as_deref()
    }

    /// The rendered triangles, three indices into
    /// [`vertex_particles`](Self::vertex_particles) each.
    pub fn indices(&self) -> &[u32] {
        &self.0.indices
    }

    /// The mean rest edge length, m.
    pub fn spacing(&self) -> f32 {
        self.0.spacing
    }

    /// The rest area, m².
    pub fn area(&self) -> f32 {
        self.0.area
    }

    /// The longest rest edge, m (see [`Faces::cell_size`]).
    pub fn cell_size(&self) -> f32 {
        self.0.cell_size
    }

    /// UVs for the rendered vertices: the source mesh's, or else the rest
    /// positions projected on their two widest axes, scaled to `[0, 1]`.
    pub fn uvs_or_projected(&self) -> Vec<[f32; 2]> {
        if let Some(uvs) = self.uvs() {
            return uvs.to_vec();
        }
        let x = &self.topology().positions;
        let (lo, hi) = x
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        let extent = (hi - lo).max(Vec3::splat(1e-9));
        let thin = extent.min_position();
        let (a, b) = match thin {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let scale = extent[a].max(extent[b]);
        self.vertex_particles()
            .iter()
            .map(|&p| {
                let q = (x[p as usize] - lo) / scale;
                Vec2::new(q[a], q[b]).to_array()
            })
            .collect()
    }
}

/// A round cloth's mesh: a disc of `radius` m in the xz plane, centred on
/// the origin and facing +y, of a centre and `rings` rings of 6, 12, 18, …
/// vertices joined by near-equilateral triangles (see
/// [`disc`](crate::sim::topology::disc)), with UVs mapping the disc's
/// bounding square onto `[0, 1]²`. Bevy's `Circle` mesh is a fan of
/// slivers around one centre vertex; this is the mesh for
/// [`ClothBuilder::from_mesh`](crate::ClothBuilder::from_mesh).
///
/// ```
/// use bevy_cloth::plugin::spawn::disc_mesh;
/// use bevy_cloth::prelude::*;
/// // A 1.7 m tablecloth with 5 cm between particles: 919 of them.
/// let cloth = ClothBuilder::from_mesh(&disc_mesh(0.85, 17)).build().unwrap();
/// assert_eq!(cloth.particles.len(), 1 + 3 * 17 * 18);
/// ```
pub fn disc_mesh(radius: f32, rings: u32) -> Mesh {
    let (positions, indices) = crate::sim::topology::disc(radius, rings);
    let uvs: Vec<[f32; 2]> = positions
        .iter()
        .map(|p| [0.5 + 0.5 * p.x / radius, 0.5 + 0.5 * p.z / radius])
        .collect();
    let normals = vec![[0.0, 1.0, 0.0]; positions.len()];
    Mesh::new(
        PrimitiveTopology::TriangleList,
        bevy::asset::RenderAssetUsages::default(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_POSITION,
        positions.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
    .with_inserted_indices(Indices::U32(indices))
}

/// A mesh's indices as `u32`, `None` for a mesh without indices.
pub(crate) fn mesh_indices(mesh: &Mesh) -> Option<Vec<u32>> {
    match mesh.try_indices() {
        Ok(Indices::U16(i)) => Some(i.iter().map(|&i| i as u32).collect()),
        Ok(Indices::U32(i)) => Some(i.clone()),
        Err(_) => None,
    }
}

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
        Self::new(&positions, mesh_indices(mesh).as_deref())
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
    marked_particles(&values, topology).ok_or(ClothError::UnsupportedMesh(
        "vertex colours and the cloth's vertices differ in number",
    ))
}

/// The particles of `topology` with a vertex whose value in `values` (one
/// per vertex) is 0.5 or more, in increasing order; `None` when the
/// values and the vertices differ in number.
pub(crate) fn marked_particles(values: &[f32], topology: &MeshTopology) -> Option<Vec<u32>> {
    if values.len() != topology.particle_of.len() {
        return None;
    }
    let mut marked: Vec<u32> = values
        .iter()
        .zip(&topology.particle_of)
        .filter(|&(&v, _)| v >= 0.5)
        .filter_map(|(_, &p)| p)
        .collect();
    marked.sort_unstable();
    marked.dedup();
    Some(marked)
}

/// The values of `mesh`'s `Float32` vertex attribute named `name`.
pub(crate) fn float_attribute<'a>(mesh: &'a Mesh, name: &str) -> Option<&'a [f32]> {
    match mesh.attributes().find(|(a, _)| a.name == name) {
        Some((_, VertexAttributeValues::Float32(values))) => Some(values),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use bevy::asset::RenderAssetUsages;
    use bevy::mesh::{MeshBuilder, Meshable};
    use bevy::shape::{Annulus, Circle, Plane3d, Sphere};

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
