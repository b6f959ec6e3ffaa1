//! [`RestSurface`]: a cloth's particles at rest, as creases see them.
//!
//! A crease is a segment in the cloth's rest space (m). A grid's rest
//! space is the xz plane, `(u, 0, v)` of [`Grid::rest_uv`], the same as
//! [`MeshTopology::from_grid`]'s; a mesh cloth's is its mesh's own
//! coordinates. Each particle has a unit rest normal: `+y` on a grid (its
//! `+v × +u`), the area-weighted normal of its triangles (their winding)
//! on a mesh.

use bevy::math::{Vec2, Vec3};

use crate::sim::connections::Connections;
use crate::sim::grid::Grid;
use crate::sim::topology::MeshTopology;

/// A cloth's rest positions (m) and normals, and how to find the hinge of
/// a Type 2 link (the particle midway between its ends).
#[derive(Clone, Debug)]
pub struct RestSurface {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    kind: Kind,
}

#[derive(Clone, Debug)]
enum Kind {
    /// A grid: the hinge is the particle at the middle (column, row).
    Grid { cols: u32, rows: u32, size: Vec2 },
    /// A mesh: each particle's Type 1 neighbours, sorted.
    Mesh { neighbours: Vec<Vec<u32>> },
}

impl RestSurface {
    /// The rest surface of `grid`: the xz plane, normal `+y`.
    pub fn grid(grid: &Grid) -> Self {
        let positions = (0..grid.len() as u32)
            .map(|p| {
                let uv = grid.rest_uv(p);
                Vec3::new(uv.x, 0.0, uv.y)
            })
            .collect::<Vec<_>>();
        Self {
            normals: vec![Vec3::Y; positions.len()],
            positions,
            kind: Kind::Grid {
                cols: grid.cols,
                rows: grid.rows,
                size: grid.size,
            },
        }
    }

    /// The rest surface of a mesh cloth: `topology`'s rest positions, its
    /// triangles' normals, and the Type 1 links of `connections` (the
    /// links Type 2 links continue, [`MeshTopology::connections`]).
    pub fn mesh(topology: &MeshTopology, connections: &Connections) -> Self {
        let positions = topology.positions.clone();
        let n = positions.len();
        let mut normals = vec![Vec3::ZERO; n];
        for t in &topology.triangles {
            let [a, b, c] = t.map(|p| positions[p as usize]);
            // Twice the area times the unit normal: area-weighted.
            let face = (b - a).cross(c - a);
            for &p in t {
                normals[p as usize] += face;
            }
        }
        for normal in &mut normals {
            *normal = normal.normalize_or_zero();
        }
        let mut neighbours = vec![Vec::new(); n];
        for l in connections.type1() {
            let (a, b) = (l.a as usize, l.b as usize);
            if a < n && b < n && a != b {
                neighbours[a].push(l.b);
                neighbours[b].push(l.a);
            }
        }
        for list in &mut neighbours {
            list.sort_unstable();
            list.dedup();
        }
        Self {
            positions,
            normals,
            kind: Kind::Mesh { neighbours },
        }
    }

    /// A grid's rest size (m) along `u` and `v`; `None` on a mesh.
    pub fn grid_size(&self) -> Option<Vec2> {
        match self.kind {
            Kind::Grid { size, .. } => Some(size),
            Kind::Mesh { .. } => None,
        }
    }

    /// Rest position of particle `p` (m).
    pub fn position(&self, p: u32) -> Vec3 {
        self.positions[p as usize]
    }

    /// Unit rest normal of particle `p` (zero where it has none).
    pub fn normal(&self, p: u32) -> Vec3 {
        self.normals[p as usize]
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The hinge of the Type 2 link `a–c` and the four particles whose
    /// positions give the hinge's normal `(d − u) × (r − l)` as
    /// `[l, r, u, d]`, that normal pointing along the rest normal. `None`
    /// where the link has no particle between its ends.
    pub fn hinge(&self, a: u32, c: u32) -> Option<(u32, [u32; 4])> {
        match &self.kind {
            Kind::Grid { cols, rows, .. } => {
                let (cols, rows) = (*cols, *rows);
                let index = |i: u32, j: u32| j * cols + i;
                let (ia, ja) = (a % cols, a / cols);
                let (ic, jc) = (c % cols, c / cols);
                let (ih, jh) = ((ia + ic) / 2, (ja + jc) / 2);
                Some((
                    index(ih, jh),
                    [
                        index(ih.saturating_sub(1), jh),
                        index((ih + 1).min(cols - 1), jh),
                        index(ih, jh.saturating_sub(1)),
                        index(ih, (jh + 1).min(rows - 1)),
                    ],
                ))
            }
            Kind::Mesh { neighbours } => self.mesh_hinge(neighbours, a, c),
        }
    }

    /// On a mesh: the common Type 1 neighbour of `a` and `c` nearest their
    /// midpoint is the hinge; `l`, `r` are the ends, and `u`, `d` the
    /// hinge's neighbours farthest to either side of the line `a → c` (the
    /// hinge itself on a side with none).
    fn mesh_hinge(&self, neighbours: &[Vec<u32>], a: u32, c: u32) -> Option<(u32, [u32; 4])> {
        let (na, nc) = (neighbours.get(a as usize)?, neighbours.get(c as usize)?);
        let x = |p: u32| self.positions[p as usize];
        let middle = 0.5 * (x(a) + x(c));
        let hinge = na
            .iter()
            .filter(|p| nc.binary_search(p).is_ok())
            .min_by(|p, q| {
                x(**p)
                    .distance_squared(middle)
                    .total_cmp(&x(**q).distance_squared(middle))
            })
            .copied()?;
        let along = x(c) - x(a);
        let normal = self.normals[hinge as usize];
        let across = normal.cross(along);
        let side = |p: u32| (x(p) - x(hinge)).dot(across);
        let others = neighbours[hinge as usize]
            .iter()
            .copied()
            .filter(|&p| p != a && p != c);
        let (mut u, mut d) = (hinge, hinge);
        let (mut top, mut bottom) = (0.0f32, 0.0f32);
        for p in others {
            let s = side(p);
            if s > top {
                (top, u) = (s, p);
            } else if s < bottom {
                (bottom, d) = (s, p);
            }
        }
        if u == d {
            return None;
        }
        // (d − u) × (c − a) points along −(across × along)… check the sign
        // on the rest positions rather than trust the algebra.
        if (x(d) - x(u)).cross(along).dot(normal) < 0.0 {
            std::mem::swap(&mut u, &mut d);
        }
        Some((hinge, [a, c, u, d]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::topology::disc;

    #[test]
    fn a_grid_and_its_mesh_have_the_same_rest_surface() {
        let grid = Grid {
            cols: 7,
            rows: 5,
            size: bevy::math::Vec2::new(1.2, 0.8),
        };
        let topology = MeshTopology::from_grid(&grid);
        let (g, m) = (
            RestSurface::grid(&grid),
            RestSurface::mesh(&topology, &topology.connections()),
        );
        for p in 0..grid.len() as u32 {
            assert_eq!(g.position(p), m.position(p));
            assert!(g.normal(p).distance(m.normal(p)) < 1e-6, "{p}");
        }
    }

    #[test]
    fn a_mesh_hinge_is_the_particle_between_the_ends_and_its_normal_points_up() {
        let (positions, indices) = disc(0.5, 6);
        let topology = MeshTopology::new(&positions, Some(&indices)).unwrap();
        let connections = topology.connections();
        let surface = RestSurface::mesh(&topology, &connections);
        let mut checked = 0;
        for l in connections.type2() {
            let Some((hinge, [l_, r, u, d])) = surface.hinge(l.a, l.b) else {
                continue;
            };
            let x = |p: u32| surface.position(p);
            let middle = 0.5 * (x(l.a) + x(l.b));
            assert!(x(hinge).distance(middle) < 0.5 * x(l.a).distance(x(l.b)));
            let n = (x(d) - x(u)).cross(x(r) - x(l_));
            assert!(n.dot(surface.normal(hinge)) > 0.0);
            checked += 1;
        }
        assert!(checked > 100, "{checked}");
    }
}
