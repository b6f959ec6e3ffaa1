//! Cloth of any shape: the particles and Choi–Ko links of a triangle mesh,
//! by a rule that gives a grid's links back on a grid (`docs/mesh_links.md`
//! draws it).
//!
//! 1. **Particles.** Vertices at the same position (within
//!    `WELD_TOLERANCE` of the mesh's size) are welded into one particle; triangles with a repeated particle or no area are dropped,
//!    and so are vertices no triangle uses.
//! 2. **Type 1** is every mesh edge. An edge shared by two triangles that
//!    form a near-planar convex quad, and that is the longest edge of both
//!    by `DIAGONAL_RATIO`, is the quad's diagonal: the quad's other
//!    diagonal is added too. Diagonals go to the `shear` family, the other
//!    edges to `structural` (on a grid: the (1,1) links and the axial ones).
//! 3. **Type 2** links each particle `v`, across each Type 1 link `v–w`, to
//!    the Type 1 neighbour `u` of `w` that best continues the line `v → w`,
//!    if the turn from `v → w` to `w → u` is at most
//!    `MAX_CONTINUATION_ANGLE`. Across a `structural` link it is a `bend`
//!    link, across a `shear` link a `bend_diagonal` one.
//!
//! Rest lengths are the mesh's as modelled. Each unordered pair is stored
//! once, and each family is sorted by its first particle, then its second.

use std::collections::HashMap;

use bevy::math::Vec3;

use crate::error::ClothError;
use crate::sim::connections::{Connections, Link};
use crate::sim::grid::{Faces, Grid, MAX_PARTICLES};

/// How much longer than every other edge of its two triangles an edge must
/// be to count as a quad's diagonal (dimensionless). A grid's diagonal is
/// √2 times its sides; an equilateral mesh has no quads and gets no
/// diagonals.
pub(crate) const DIAGONAL_RATIO: f32 = 1.2;

/// How close two vertices weld, as a fraction of the mesh's size (its
/// bounding box's diagonal): 10⁻⁶, enough for a seam whose two sides were
/// computed separately (a UV sphere's, where `sin 2π ≠ 0`).
pub(crate) const WELD_TOLERANCE: f32 = 1e-6;

/// The largest angle between two triangles' normals (rad) for them to form
/// a near-planar quad: 20°.
pub(crate) const MAX_QUAD_FOLD: f32 = 20.0 * std::f32::consts::PI / 180.0;

/// The largest turn (rad) from `v → w` to `w → u` for a Type 2 link `v–u`:
/// 40°. A grid's continuation is straight and its next candidates turn
/// 45°; around a mesh vertex of valence 5 (72° apart) the best one turns at
/// most 36°.
pub(crate) const MAX_CONTINUATION_ANGLE: f32 = 40.0 * std::f32::consts::PI / 180.0;

/// The particles of a triangle mesh after welding, and its triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshTopology {
    /// Rest positions of the particles, m.
    pub positions: Vec<Vec3>,
    /// The triangles that have area, as particle indices, in the mesh's
    /// winding.
    pub triangles: Vec<[u32; 3]>,
    /// For each vertex of the mesh, its particle (`None` for a vertex no
    /// triangle with area uses).
    pub particle_of: Vec<Option<u32>>,
    /// Edges shared by more than two triangles. They are kept (each is one
    /// Type 1 link) and never a quad's diagonal.
    pub non_manifold_edges: usize,
    /// Triangles dropped for a repeated particle or no area.
    pub degenerate_triangles: usize,
}

impl MeshTopology {
    /// The particles of the mesh whose vertices rest at `positions` (m)
    /// with triangles `indices` (three per triangle), or consecutive
    /// triples of vertices when `indices` is `None`.
    ///
    /// Errors: no triangles ([`ClothError::NoTriangles`]), a non-finite
    /// vertex, an index out of range, only degenerate triangles, more
    /// particles than [`MAX_PARTICLES`].
    pub fn new(positions: &[Vec3], indices: Option<&[u32]>) -> Result<Self, ClothError> {
        Self::with_limit(positions, indices, MAX_PARTICLES as usize)
    }

    fn with_limit(
        positions: &[Vec3],
        indices: Option<&[u32]>,
        limit: usize,
    ) -> Result<Self, ClothError> {
        let count = indices.map_or(positions.len(), <[u32]>::len);
        if count < 3 || !count.is_multiple_of(3) {
            return Err(ClothError::NoTriangles { indices: count });
        }
        if let Some((vertex, &position)) =
            positions.iter().enumerate().find(|(_, p)| !p.is_finite())
        {
            return Err(ClothError::NonFiniteVertex {
                vertex: vertex as u32,
                position,
            });
        }
        let vertex_count = positions.len();
        let index = |k: usize| -> Result<usize, ClothError> {
            let i = indices.map_or(k as u32, |ix| ix[k]);
            if (i as usize) < vertex_count {
                Ok(i as usize)
            } else {
                Err(ClothError::ParticleOutOfRange {
                    index: i,
                    count: vertex_count.min(u32::MAX as usize) as u32,
                })
            }
        };
        let (weld, welds) = weld(positions);
        let mut welded_triangles = Vec::with_capacity(count / 3);
        let mut degenerate = 0;
        for t in 0..count / 3 {
            let v = [index(3 * t)?, index(3 * t + 1)?, index(3 * t + 2)?];
            let w = v.map(|i| weld[i]);
            let (a, b, c) = (positions[v[0]], positions[v[1]], positions[v[2]]);
            let longest = (b - a)
                .length_squared()
                .max((c - b).length_squared())
                .max((a - c).length_squared());
            let area2 = (b - a).cross(c - a).length_squared();
            // Not finite for coordinates near f32::MAX: no area either.
            let has_area = area2.is_finite() && area2 > 1e-12 * longest * longest;
            if w[0] == w[1] || w[1] == w[2] || w[2] == w[0] || !has_area {
                degenerate += 1;
                continue;
            }
            welded_triangles.push(w);
        }
        if welded_triangles.is_empty() {
            return Err(ClothError::DegenerateMesh {
                triangles: count / 3,
            });
        }
        // Particles: the welded vertices the triangles use, in the order of
        // the mesh's vertices (which keeps the mesh's locality).
        let mut used = vec![false; welds];
        for w in &welded_triangles {
            for &i in w {
                used[i as usize] = true;
            }
        }
        let particles = used.iter().filter(|&&u| u).count();
        if particles > limit {
            return Err(ClothError::MeshTooLarge {
                particles,
                max: limit.min(u32::MAX as usize) as u32,
            });
        }
        let mut particle_of_weld = vec![None; welds];
        let mut out = Self {
            positions: Vec::with_capacity(particles),
            degenerate_triangles: degenerate,
            ..Self::default()
        };
        for (vertex, &w) in weld.iter().enumerate() {
            let slot = &mut particle_of_weld[w as usize];
            if used[w as usize] && slot.is_none() {
                *slot = Some(out.positions.len() as u32);
                out.positions.push(positions[vertex]);
            }
            out.particle_of.push(*slot);
        }
        out.triangles = welded_triangles
            .iter()
            .map(|w| w.map(|i| particle_of_weld[i as usize].unwrap_or_default()))
            .collect();
        out.non_manifold_edges = edges(&out.triangles)
            .iter()
            .filter(|(_, e)| e.count > 2)
            .count();
        Ok(out)
    }

    /// The topology of `grid`: its particles in the grid's order, at rest
    /// in the xz plane (`(u, 0, v)` of [`Grid::rest_uv`], m), and its
    /// triangles ([`Grid::triangle`]). On square cells its
    /// [`connections`](Self::connections) are the grid's own
    /// ([`Connections::grid`]); on long cells the continuation rule picks
    /// some other Type 2 links.
    pub fn from_grid(grid: &Grid) -> Self {
        let positions: Vec<Vec3> = (0..grid.len() as u32)
            .map(|p| {
                let uv = grid.rest_uv(p);
                Vec3::new(uv.x, 0.0, uv.y)
            })
            .collect();
        Self {
            particle_of: (0..positions.len() as u32).map(Some).collect(),
            positions,
            triangles: grid.triangles(),
            non_manifold_edges: 0,
            degenerate_triangles: 0,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no particles (never for a built topology).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The particles whose rest position (m) satisfies `pin`, in increasing
    /// order: the pins of a mesh cloth chosen by place (`|p| p.y > 0.99`
    /// pins a top edge at 1 m). Pins by vertex go through
    /// [`particle_of`](Self::particle_of).
    pub fn particles_where(&self, mut pin: impl FnMut(Vec3) -> bool) -> Vec<u32> {
        (0..self.positions.len() as u32)
            .filter(|&p| pin(self.positions[p as usize]))
            .collect()
    }

    /// Particle masses (kg) for a sheet of `density` kg/m²: each triangle's
    /// mass split equally between its corners.
    pub fn lumped_masses(&self, density: f32) -> Vec<f32> {
        let mut masses = vec![0.0; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let share = density * 0.5 * (b - a).cross(c - a).length() / 3.0;
            for &i in t {
                masses[i as usize] += share;
            }
        }
        masses
    }

    /// The Type 1 and Type 2 links of the mesh (module docs), with rest
    /// lengths from [`positions`](Self::positions) (m). `columns` is 0: a
    /// mesh cloth's forces are evaluated link by link, never in grid bands.
    pub fn connections(&self) -> Connections {
        let x = &self.positions;
        let edges = edges(&self.triangles);
        // Every mesh edge first, so that a quad's other diagonal that is
        // also a mesh edge keeps that edge's family.
        let mut type1: Vec<((u32, u32), bool)> = Vec::with_capacity(2 * edges.len());
        let mut added = Vec::new();
        for &((a, b), edge) in &edges {
            let diagonal = edge.count == 2 && self.is_diagonal(a, b, edge.opposite);
            type1.push(((a, b), diagonal));
            if diagonal {
                let [c, d] = edge.opposite;
                added.push((c.min(d), c.max(d)));
            }
        }
        added.sort_unstable();
        added.dedup();
        added.retain(|pair| edges.binary_search_by_key(pair, |&(e, _)| e).is_err());
        type1.extend(added.into_iter().map(|pair| (pair, true)));
        let mut out = Connections::default();
        // Each particle's Type 1 neighbours `(u, diagonal, direction to u)`,
        // sorted: `around[start[v]..start[v + 1]]`.
        let mut start = vec![0usize; x.len() + 1];
        for &((a, b), _) in &type1 {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
        for v in 0..x.len() {
            start[v + 1] += start[v];
        }
        let mut around = vec![(0u32, false, Vec3::ZERO); start[x.len()]];
        let mut fill = start.clone();
        for &((a, b), diagonal) in &type1 {
            let link = Link::from_rest(a, b, x);
            if diagonal {
                out.shear.push(link);
            } else {
                out.structural.push(link);
            }
            let along = (x[b as usize] - x[a as usize]).normalize_or_zero();
            for (p, q, d) in [(a, b, along), (b, a, -along)] {
                around[fill[p as usize]] = (q, diagonal, d);
                fill[p as usize] += 1;
            }
        }
        let row = |v: u32| start[v as usize]..start[v as usize + 1];
        for v in 0..x.len() as u32 {
            around[row(v)].sort_unstable_by_key(|&(u, diagonal, _)| (u, diagonal));
        }
        let cos_max = MAX_CONTINUATION_ANGLE.cos();
        // Each Type 2 pair with the family of the first link it continues
        // across, in the order of `v` and its neighbours.
        let mut type2: Vec<((u32, u32), bool)> = Vec::new();
        for v in 0..x.len() as u32 {
            for &(w, diagonal, along) in &around[row(v)] {
                let best = around[row(w)]
                    .iter()
                    .filter(|&&(u, _, _)| u != v)
                    .map(|&(u, _, next)| (u, along.dot(next)))
                    .filter(|&(_, cos)| cos >= cos_max)
                    .max_by(|p, q| p.1.total_cmp(&q.1).then(q.0.cmp(&p.0)));
                if let Some((u, _)) = best {
                    let joined = around[row(v)]
                        .binary_search_by_key(&u, |&(n, _, _)| n)
                        .is_ok();
                    if !joined {
                        type2.push(((v.min(u), v.max(u)), diagonal));
                    }
                }
            }
        }
        type2.sort_by_key(|&(pair, _)| pair);
        type2.dedup_by_key(|&mut (pair, _)| pair);
        for &((a, b), diagonal) in &type2 {
            let link = Link::from_rest(a, b, x);
            if diagonal {
                out.bend_diagonal.push(link);
            } else {
                out.bend.push(link);
            }
        }
        for family in [
            &mut out.structural,
            &mut out.shear,
            &mut out.bend,
            &mut out.bend_diagonal,
        ] {
            family.sort_unstable_by_key(|l| (l.a, l.b));
        }
        out
    }

    /// Whether edge `a–b`, shared by the triangles whose third particles are
    /// `c` and `d`, is the diagonal of a near-planar convex quad and the
    /// longest edge of both triangles by [`DIAGONAL_RATIO`].
    fn is_diagonal(&self, a: u32, b: u32, [c, d]: [u32; 2]) -> bool {
        let x = |i: u32| self.positions[i as usize];
        let (a, b, c, d) = (x(a), x(b), x(c), x(d));
        let shared = (b - a).length();
        let others = [(c - a), (c - b), (d - a), (d - b)].map(Vec3::length);
        if others.iter().any(|&o| shared < DIAGONAL_RATIO * o) {
            return false;
        }
        let e = b - a;
        let (n1, n2) = (
            e.cross(c - a).normalize_or_zero(),
            (d - a).cross(e).normalize_or_zero(),
        );
        if n1.dot(n2) < MAX_QUAD_FOLD.cos() {
            return false;
        }
        // Convex: the other diagonal crosses the shared edge inside it.
        let across = (n1 + n2).cross(e);
        let (sc, sd) = ((c - a).dot(across), (d - a).dot(across));
        if sc * sd >= 0.0 {
            return false;
        }
        let hit = c + (d - c) * (sc / (sc - sd));
        let t = (hit - a).dot(e) / e.length_squared();
        t > 0.0 && t < 1.0
    }
}

impl Faces for MeshTopology {
    fn face_count(&self) -> usize {
        self.triangles.len()
    }

    fn face(&self, t: u32) -> [u32; 3] {
        self.triangles[t as usize]
    }

    /// The longest rest edge, m.
    fn cell_size(&self) -> f32 {
        let x = &self.positions;
        self.triangles
            .iter()
            .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
            .map(|(a, b)| x[a as usize].distance(x[b as usize]))
            .fold(0.0, f32::max)
    }
}

/// A disc of `radius` m in the xz plane, centred on the origin, as a
/// triangle mesh: a centre and `rings` rings of 6, 12, 18, … vertices
/// (`1 + 3·rings·(rings + 1)` in all), each ring turned against the one
/// inside it, joined by triangles close to equilateral. Positions (m) and
/// indices, counter-clockwise seen from +y.
///
/// ```
/// use bevy_cloth::sim::topology::{MeshTopology, disc};
/// let (positions, indices) = disc(0.5, 8);
/// assert_eq!(positions.len(), 1 + 3 * 8 * 9);
/// let links = MeshTopology::new(&positions, Some(&indices)).unwrap().connections();
/// assert!(links.type2_count() > 0);
/// ```
pub fn disc(radius: f32, rings: u32) -> (Vec<Vec3>, Vec<u32>) {
    let rings = rings.max(1) as usize;
    let spacing = radius / rings as f32;
    let mut positions = vec![Vec3::ZERO];
    let mut starts = vec![0u32];
    for r in 1..=rings {
        starts.push(positions.len() as u32);
        let count = 6 * r;
        positions.extend((0..count).map(|k| {
            let a = (k as f32 + 0.4 * (r % 2) as f32) * std::f32::consts::TAU / count as f32;
            Vec3::new(a.cos(), 0.0, a.sin()) * (r as f32 * spacing)
        }));
    }
    let at = |r: usize, k: usize| -> u32 {
        if r == 0 {
            0
        } else {
            starts[r] + (k % (6 * r)) as u32
        }
    };
    let mut indices = Vec::with_capacity(3 * 6 * rings * rings);
    for r in 0..rings {
        // Walk ring r (6r vertices, the centre for r = 0) and ring r + 1
        // around together, always advancing the one that lags.
        let (inner, outer) = ((6 * r).max(1), 6 * (r + 1));
        let (mut i, mut o) = (0, 0);
        while i < inner || o < outer {
            if i >= inner || (o as f32 / outer as f32) <= (i as f32 / inner as f32) {
                indices.extend([at(r, i), at(r + 1, o + 1), at(r + 1, o)]);
                o += 1;
            } else {
                if r > 0 {
                    indices.extend([at(r, i), at(r, i + 1), at(r + 1, o)]);
                }
                i += 1;
            }
        }
    }
    (positions, indices)
}

/// For each vertex its weld, and the number of welds: vertices within
/// [`WELD_TOLERANCE`] of the mesh's size of an earlier vertex join its
/// weld. Positions are finite.
fn weld(positions: &[Vec3]) -> (Vec<u32>, usize) {
    let lo = positions.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
    let hi = positions.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
    let eps = WELD_TOLERANCE * (hi - lo).length();
    if !(eps.is_finite() && eps > 0.0) {
        // One position, or a size past f32: weld equal positions only.
        let mut of_key: HashMap<[u32; 3], u32> = HashMap::new();
        let weld = positions
            .iter()
            .map(|p| {
                let next = of_key.len() as u32;
                *of_key
                    .entry((*p + Vec3::ZERO).to_array().map(f32::to_bits))
                    .or_insert(next)
            })
            .collect();
        return (weld, of_key.len());
    }
    // Cells of side `eps`: a weld within `eps` is in the 27 around.
    let cell = |p: Vec3| ((p - lo) / eps).floor().as_i64vec3().to_array();
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut representative: Vec<Vec3> = Vec::new();
    let weld = positions
        .iter()
        .map(|&p| {
            let [i, j, k] = cell(p);
            let near = (-1..=1)
                .flat_map(|a| {
                    (-1..=1).flat_map(move |b| (-1..=1).map(move |c| [i + a, j + b, k + c]))
                })
                .filter_map(|key| cells.get(&key))
                .flatten()
                .copied()
                .filter(|&w| representative[w as usize].distance(p) <= eps)
                .min();
            near.unwrap_or_else(|| {
                let w = representative.len() as u32;
                representative.push(p);
                cells.entry([i, j, k]).or_default().push(w);
                w
            })
        })
        .collect();
    (weld, representative.len())
}

/// A mesh edge: how many triangles share it, and the third particle of the
/// first two.
#[derive(Clone, Copy, Debug)]
struct Edge {
    count: u32,
    opposite: [u32; 2],
}

/// How many edges of `triangles` more than two of them share.
pub(crate) fn non_manifold_edges(triangles: &[[u32; 3]]) -> usize {
    edges(triangles).iter().filter(|(_, e)| e.count > 2).count()
}

/// Every edge of `triangles`, keyed by its particles in increasing order,
/// sorted by key; the opposite particles in the triangles' order.
fn edges(triangles: &[[u32; 3]]) -> Vec<((u32, u32), Edge)> {
    let mut sides: Vec<((u32, u32), u32)> = Vec::with_capacity(3 * triangles.len());
    for t in triangles {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            sides.push(((a.min(b), a.max(b)), c));
        }
    }
    // Stable: the sides of one edge stay in their triangles' order.
    sides.sort_by_key(|&(pair, _)| pair);
    let mut out: Vec<((u32, u32), Edge)> = Vec::with_capacity(sides.len() / 2 + 1);
    for (pair, c) in sides {
        match out.last_mut() {
            Some((last, edge)) if *last == pair => {
                if edge.count == 1 {
                    edge.opposite[1] = c;
                }
                edge.count += 1;
            }
            _ => out.push((
                pair,
                Edge {
                    count: 1,
                    opposite: [c; 2],
                },
            )),
        }
    }
    out
}

#[cfg(test)]
mod tests;
