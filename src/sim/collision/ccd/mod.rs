//! Continuous collision within one cloth: no particle passes through one of
//! its triangles and no edge through another edge during a step, however
//! fast the cloth folds.
//!
//! Each particle moves on a straight line from where it was at the step's
//! start to where the step put it. A particle and a triangle cross when the
//! particle goes through the triangle's plane inside the triangle; two edges
//! cross when, at the moment their four ends are coplanar, the segments meet.
//! The moment is the root in `[0, 1]` of the cubic that says the four points
//! are coplanar, found in double precision.
//!
//! [`prevent_crossings`] resolves what it finds in two stages:
//! 1. **Pushes**, for a few rounds: each crossing pair is pushed apart at the
//!    step's end along the normal of the moment they met, to the thickness on
//!    the side they came from, split by inverse mass, and their approach
//!    (m/s) along it is removed.
//! 2. **Impact zones**, if crossings remain: the particles of each crossing
//!    pair, merged with every zone they touch, move as one rigid piece over
//!    the step: from where they were at its start by their mass-weighted
//!    mean displacement, on at their mean velocity (a held particle's
//!    motion when the zone holds one). Repeated until nothing crosses, as
//!    zones merge: a zone that moves as one cannot cross itself, so the step
//!    ends without a crossing if it began without one (and its held
//!    particles move alike), within 16 passes.

use bevy::math::{DVec3, Vec3};

use super::cells::{cell_of, key};
use super::contact::Counts;
use crate::sim::grid::Faces;

mod exact;

use exact::wide;
pub use exact::{edge_edge, point_triangle};

/// Rounds of pushes before the impact zones.
const PUSH_ROUNDS: usize = 3;

/// Most passes of the impact zones; each merges zones or moves particles
/// not moved before, so a pass without either ends them sooner.
const ZONE_PASSES: usize = 16;

/// Largest number of hash cells a box spans along one axis; a box spanning
/// more is tested against every element of the other kind.
const MAX_SPAN: i32 = 8;

/// Reusable buffers of [`prevent_crossings`] (no allocation once warm).
#[derive(Clone, Debug, Default)]
pub struct CrossingBuffers {
    /// The cloth's triangle edges.
    edges: EdgeList,
    /// `(cell key, triangle)` of the triangles' swept boxes, sorted.
    triangles: Vec<(u64, u32)>,
    /// `(cell key, edge)` of the edges' swept boxes, sorted.
    edge_cells: Vec<(u64, u32)>,
    /// Triangles and edges whose swept box spans more than [`MAX_SPAN`] cells.
    big_triangles: Vec<u32>,
    big_edges: Vec<u32>,
    /// Swept boxes: of the particles, the triangles, the edges (m).
    point_boxes: Vec<(Vec3, Vec3)>,
    triangle_boxes: Vec<(Vec3, Vec3)>,
    edge_boxes: Vec<(Vec3, Vec3)>,
    /// The crossings found in one pass.
    found: Vec<Crossing>,
    /// Scratch: displacements for the cell size.
    scratch: Vec<f32>,
    /// The impact zones: union–find parents, particles moved with a zone,
    /// the zones touched in a pass and their sums.
    zone: Vec<u32>,
    stopped: Vec<bool>,
    touched: Vec<u32>,
    sums: Vec<ZoneSums>,
}

/// Two features of the cloth that crossed during the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// The four particles: a particle and a triangle's corners, or the two
    /// ends of one edge and the two of the other.
    pub particles: [u32; 4],
    /// Weights of the four particles' positions whose sum is the separation
    /// (m) of the two features: `1, -b0, -b1, -b2` for a particle and a
    /// triangle, `1 - s, s, -(1 - u), -u` for two edges.
    pub weights: [f32; 4],
    /// The unit normal at the moment they met, turned towards the side the
    /// first feature came from.
    pub normal: Vec3,
    /// The moment they met, as a fraction of the step.
    pub at: f32,
}

impl Crossing {
    /// The separation along the normal of the features at positions `x`
    /// (m), or their relative velocity along it for velocities (m/s).
    fn gap(&self, x: &[Vec3]) -> f32 {
        (0..4)
            .map(|i| self.weights[i] * x[self.particles[i] as usize])
            .sum::<Vec3>()
            .dot(self.normal)
    }
}

/// What [`prevent_crossings`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CrossingCounts {
    /// Particle–triangle and edge–edge pairs tested exactly.
    pub tests: u32,
    /// Crossings found in the first pass.
    pub crossings: u32,
    /// Particles moved with an impact zone.
    pub stopped: u32,
}

/// The edges of a set of triangles, each once, listed again only when the
/// triangles change (a tear).
#[derive(Clone, Debug, Default)]
pub(super) struct EdgeList {
    /// The edges as `[low, high]` particles, sorted.
    pub(super) edges: Vec<[u32; 2]>,
    /// Face count and a hash of the faces the edges were listed for.
    tag: (usize, u64),
    /// The generation ([`Faces::generation`]) and face count of the faces
    /// the edges were listed for, if they had one.
    generation: Option<(u64, usize)>,
    /// The largest particle index of the edges, or `None` without edges.
    pub(super) largest: Option<u32>,
}

impl EdgeList {
    /// Lists the edges of the `count` triangles `faces()` gives, unless
    /// they are the ones listed last: the same `generation` (see
    /// [`Faces::generation`]) and count, or else the same hash.
    pub(super) fn update<I: Iterator<Item = [u32; 3]>>(
        &mut self,
        faces: impl Fn() -> I,
        count: usize,
        generation: Option<u64>,
    ) {
        let generation = generation.map(|g| (g, count));
        if generation.is_some() && generation == self.generation && !self.edges.is_empty() {
            return;
        }
        self.generation = generation;
        let hash = faces().fold(0u64, |h, [a, b, c]| {
            let face = (a as u64) | (b as u64) << 21 | (c as u64) << 42;
            (h ^ face)
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .rotate_left(29)
        });
        let tag = (count, hash);
        if self.tag == tag && !self.edges.is_empty() {
            return;
        }
        self.edges.clear();
        for [a, b, c] in faces() {
            for (p, q) in [(a, b), (b, c), (c, a)] {
                self.edges.push([p.min(q), p.max(q)]);
            }
        }
        self.edges.sort_unstable();
        self.edges.dedup();
        self.largest = self.edges.iter().map(|e| e[1]).max();
        self.tag = tag;
    }
}

fn swept(a: Vec3, b: Vec3) -> (Vec3, Vec3) {
    (a.min(b), a.max(b))
}

fn union((lo, hi): (Vec3, Vec3), (l, h): (Vec3, Vec3)) -> (Vec3, Vec3) {
    (lo.min(l), hi.max(h))
}

fn overlap((lo, hi): (Vec3, Vec3), (l, h): (Vec3, Vec3)) -> bool {
    lo.cmple(h).all() && l.cmple(hi).all()
}

/// Enters `(key, item)` for each cell of `bx` into `cells`, or `item` into
/// `big` when the box spans more than [`MAX_SPAN`] cells along an axis.
fn enter(bx: (Vec3, Vec3), inv: f32, item: u32, cells: &mut Vec<(u64, u32)>, big: &mut Vec<u32>) {
    let (lo, hi) = (cell_of(bx.0, inv), cell_of(bx.1, inv));
    if (0..3).any(|a| hi[a].saturating_sub(lo[a]) >= MAX_SPAN) {
        big.push(item);
        return;
    }
    for i in lo[0]..=hi[0] {
        for j in lo[1]..=hi[1] {
            for k in lo[2]..=hi[2] {
                cells.push((key([i, j, k]), item));
            }
        }
    }
}

/// Hashed items: `(cell key, item)` sorted by key, every item's box (m),
/// and the items too large to hash.
type Table<'a> = (&'a [(u64, u32)], &'a [(Vec3, Vec3)], &'a [u32]);

/// Calls `each` once for every item of `cells` (and of `big`) whose box may
/// overlap `bx`: in the first cell the two boxes share.
fn candidates(bx: (Vec3, Vec3), inv: f32, (cells, boxes, big): Table, mut each: impl FnMut(u32)) {
    for &item in big {
        if overlap(bx, boxes[item as usize]) {
            each(item);
        }
    }
    let (lo, hi) = (cell_of(bx.0, inv), cell_of(bx.1, inv));
    let span = (0..3)
        .map(|a| hi[a].saturating_sub(lo[a]))
        .max()
        .unwrap_or(0);
    if span >= MAX_SPAN {
        // A large box: test it against every box of the other kind.
        for (item, other) in boxes.iter().enumerate() {
            if overlap(bx, *other) && !big.contains(&(item as u32)) {
                each(item as u32);
            }
        }
        return;
    }
    for i in lo[0]..=hi[0] {
        for j in lo[1]..=hi[1] {
            for k in lo[2]..=hi[2] {
                let cell = key([i, j, k]);
                let from = cells.partition_point(|e| e.0 < cell);
                for &(_, item) in cells[from..].iter().take_while(|e| e.0 == cell) {
                    let other = boxes[item as usize];
                    if !overlap(bx, other) {
                        continue;
                    }
                    // Only in the first cell both boxes are entered in.
                    let first = cell_of(bx.0.max(other.0), inv);
                    if first == [i, j, k] {
                        each(item);
                    }
                }
            }
        }
    }
}

impl CrossingBuffers {
    /// Lists every crossing from `start` to `x` into `found`; returns the
    /// pairs tested.
    fn find(&mut self, cloth: &impl Faces, start: &[Vec3], x: &[Vec3], thickness: f32) -> u32 {
        self.found.clear();
        let n = x.len();
        self.point_boxes.clear();
        self.point_boxes
            .extend((0..n).map(|p| swept(start[p], x[p])));
        if self
            .point_boxes
            .iter()
            .any(|b| !(b.0.is_finite() && b.1.is_finite()))
        {
            // A cloth with a non-finite particle: the guard deals with it.
            return 0;
        }
        // Cells as large as most particles' paths, and at least the
        // cloth's own cell.
        self.scratch.clear();
        self.scratch.extend(
            self.point_boxes
                .iter()
                .map(|(lo, hi)| (*hi - *lo).max_element()),
        );
        let k = (self.scratch.len() * 9 / 10).min(self.scratch.len().saturating_sub(1));
        let typical = if self.scratch.is_empty() {
            0.0
        } else {
            *self.scratch.select_nth_unstable_by(k, f32::total_cmp).1
        };
        let cell = cloth.cell_size().max(2.0 * thickness).max(2.0 * typical);
        let inv = 1.0 / cell;
        let pb = &self.point_boxes;
        self.triangle_boxes.clear();
        self.triangle_boxes.extend(
            cloth
                .faces()
                .map(|[a, b, c]| union(union(pb[a as usize], pb[b as usize]), pb[c as usize])),
        );
        self.edge_boxes.clear();
        self.edge_boxes.extend(
            self.edges
                .edges
                .iter()
                .map(|&[a, b]| union(pb[a as usize], pb[b as usize])),
        );
        self.triangles.clear();
        self.big_triangles.clear();
        for (t, &bx) in self.triangle_boxes.iter().enumerate() {
            enter(
                bx,
                inv,
                t as u32,
                &mut self.triangles,
                &mut self.big_triangles,
            );
        }
        self.triangles.sort_unstable();
        self.edge_cells.clear();
        self.big_edges.clear();
        for (e, &bx) in self.edge_boxes.iter().enumerate() {
            enter(bx, inv, e as u32, &mut self.edge_cells, &mut self.big_edges);
        }
        self.edge_cells.sort_unstable();
        let mut tests = 0;
        let found = &mut self.found;
        for p in 0..n as u32 {
            let table = (
                &self.triangles[..],
                &self.triangle_boxes[..],
                &self.big_triangles[..],
            );
            candidates(self.point_boxes[p as usize], inv, table, |t| {
                let tri = cloth.face(t);
                if tri.contains(&p) {
                    return;
                }
                tests += 1;
                if let Some(c) = point_triangle(p, tri, start, x) {
                    found.push(c);
                }
            });
        }
        for (e, &edge) in self.edges.edges.iter().enumerate() {
            let table = (
                &self.edge_cells[..],
                &self.edge_boxes[..],
                &self.big_edges[..],
            );
            candidates(self.edge_boxes[e], inv, table, |f| {
                let other = self.edges.edges[f as usize];
                if f as usize <= e || other.contains(&edge[0]) || other.contains(&edge[1]) {
                    return;
                }
                tests += 1;
                if let Some(c) = edge_edge(edge, other, start, x) {
                    found.push(c);
                }
            });
        }
        tests
    }

    fn root(&mut self, mut p: u32) -> u32 {
        while self.zone[p as usize] != p {
            let up = self.zone[self.zone[p as usize] as usize];
            self.zone[p as usize] = up;
            p = up;
        }
        p
    }
}

/// The denominator that splits a change of the separation `Σ cᵢ xᵢ` (m or
/// m/s) between particles of inverse masses `wᵢ`: `Σ cᵢ² wᵢ`, but never less
/// than the largest `|cᵢ| wᵢ`, so that no particle moves farther than the
/// change itself. (A contact beside a held corner would otherwise throw the
/// triangle's one free corner `1 / cᵢ` times as far.)
pub(super) fn split(c: [f32; 4], w: [f32; 4]) -> f32 {
    let share: f32 = (0..4).map(|i| c[i] * c[i] * w[i]).sum();
    (0..4).map(|i| c[i].abs() * w[i]).fold(share, f32::max)
}

/// Pushes the two features of `c` apart at the step's end to `thickness`
/// m along its normal and removes their approach along it (m/s), split by
/// the inverse masses `w`.
fn push(c: &Crossing, x: &mut [Vec3], v: &mut [Vec3], w: &[f32], thickness: f32) {
    let ids = c.particles.map(|p| p as usize);
    let share = split(c.weights, ids.map(|i| w[i]));
    if share.is_nan() || share <= 0.0 {
        return;
    }
    let depth = thickness - c.gap(x);
    if depth > 0.0 {
        let s = depth / share;
        for i in 0..4 {
            x[ids[i]] += c.weights[i] * w[ids[i]] * s * c.normal;
        }
    }
    let approach = c.gap(v);
    if approach < 0.0 {
        let j = -approach / share;
        for i in 0..4 {
            v[ids[i]] += c.weights[i] * w[ids[i]] * j * c.normal;
        }
    }
}

/// Keeps `cloth` from passing through itself during a step from `start` to
/// `x` (m): see the [module](self). `v` (m/s) is changed with `x`; particles
/// with inverse mass `w == 0` are not moved. `thickness` (m) is the distance
/// a push leaves between the features.
pub fn prevent_crossings(
    cloth: &impl Faces,
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    w: &[f32],
    thickness: f32,
    buffers: &mut CrossingBuffers,
) -> CrossingCounts {
    let mut counts = CrossingCounts::default();
    let n = x.len();
    if start.len() != n || v.len() != n || w.len() != n {
        return counts;
    }
    if !(thickness.is_finite() && thickness > 0.0) {
        return counts;
    }
    buffers
        .edges
        .update(|| cloth.faces(), cloth.face_count(), cloth.generation());
    if buffers.edges.largest.is_some_and(|p| p as usize >= n) {
        // Triangles of another cloth's particles: nothing to keep apart.
        return counts;
    }
    for round in 0..PUSH_ROUNDS {
        counts.tests += buffers.find(cloth, start, x, thickness);
        if round == 0 {
            counts.crossings = buffers.found.len() as u32;
        }
        if buffers.found.is_empty() {
            return counts;
        }
        for c in &buffers.found {
            push(c, x, v, w, thickness);
        }
    }
    let state = (start, x, v);
    counts.stopped = stop_zones(cloth, state, w, thickness, &mut counts.tests, buffers);
    counts
}

/// The impact zones' stage of [`prevent_crossings`]: returns the particles
/// moved with their zone.
fn stop_zones(
    cloth: &impl Faces,
    (start, x, v): (&[Vec3], &mut [Vec3], &mut [Vec3]),
    w: &[f32],
    thickness: f32,
    tests: &mut u32,
    buffers: &mut CrossingBuffers,
) -> u32 {
    let n = x.len();
    buffers.zone.clear();
    buffers.zone.extend(0..n as u32);
    buffers.stopped.clear();
    buffers.stopped.resize(n, false);
    let mut stopped = 0;
    for _ in 0..ZONE_PASSES {
        *tests += buffers.find(cloth, start, x, thickness);
        if buffers.found.is_empty() {
            break;
        }
        let mut changed = false;
        for i in 0..buffers.found.len() {
            let [a, rest @ ..] = buffers.found[i].particles;
            for b in rest {
                let (ra, rb) = (buffers.root(a), buffers.root(b));
                if ra != rb {
                    buffers.zone[ra as usize] = rb;
                    changed = true;
                }
            }
        }
        // The zones touched in this pass, by their roots.
        buffers.touched.clear();
        for i in 0..buffers.found.len() {
            for p in buffers.found[i].particles {
                let r = buffers.root(p);
                buffers.touched.push(r);
            }
        }
        buffers.touched.sort_unstable();
        buffers.touched.dedup();
        // Each zone's motion: its held particles' mean, or the
        // mass-weighted mean of all.
        buffers.sums.clear();
        buffers.sums.resize(n, Default::default());
        for p in 0..n as u32 {
            let r = buffers.root(p);
            if buffers.touched.binary_search(&r).is_err() {
                continue;
            }
            let s = &mut buffers.sums[r as usize];
            let q = p as usize;
            let moved = wide(x[q] - start[q]);
            if w[q] > 0.0 {
                let m = 1.0 / w[q] as f64;
                s.free += (wide(v[q]) * m, moved * m);
                s.mass += m;
            } else {
                s.held += (wide(v[q]), moved);
                s.holds += 1;
            }
        }
        for p in 0..n as u32 {
            let q = p as usize;
            let r = buffers.root(p);
            if w[q] == 0.0 || buffers.touched.binary_search(&r).is_err() {
                continue;
            }
            let s = buffers.sums[r as usize];
            let (velocity, moved) = if s.holds > 0 {
                (s.held.0 / s.holds as f64, s.held.1 / s.holds as f64)
            } else {
                (s.free.0 / s.mass, s.free.1 / s.mass)
            };
            if !buffers.stopped[q] {
                buffers.stopped[q] = true;
                stopped += 1;
                changed = true;
            }
            x[q] = start[q] + moved.as_vec3();
            v[q] = velocity.as_vec3();
        }
        if !changed {
            // Only held particles cross: nothing this pass can move.
            break;
        }
    }
    stopped
}

/// Momentum and mass-weighted displacement of an impact zone's free
/// particles, and the summed velocity and displacement of its held ones.
#[derive(Clone, Copy, Debug, Default)]
struct ZoneSums {
    /// Σ m v (kg m/s) and Σ m (x − start) (kg m) over the free particles.
    free: Pair,
    /// Σ m over the free particles, kg.
    mass: f64,
    /// Σ v (m/s) and Σ (x − start) (m) over the held particles.
    held: Pair,
    /// Held particles.
    holds: u32,
}

/// A velocity and a displacement, summed together.
#[derive(Clone, Copy, Debug, Default)]
struct Pair(DVec3, DVec3);

impl std::ops::AddAssign<(DVec3, DVec3)> for Pair {
    fn add_assign(&mut self, (a, b): (DVec3, DVec3)) {
        self.0 += a;
        self.1 += b;
    }
}

impl From<CrossingCounts> for Counts {
    fn from(c: CrossingCounts) -> Self {
        Counts {
            tests: c.tests,
            contacts: c.crossings,
        }
    }
}

#[cfg(test)]
mod tests;
