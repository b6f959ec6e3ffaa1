//! Edges of one cloth against edges of another, where no particle of
//! either comes near a triangle of the other (two ribbons crossing, a towel
//! over a ribbon, a hem sliding over a hem):
//!
//! - **Held in the solve.** An edge of this cloth whose nearest point to an
//!   edge of the other lies between the ends of both, and which the two
//!   edges' speeds could bring within [`EDGE_THICKNESS`] of the pair's
//!   thickness in the substep (moving apart or not while within the
//!   thickness, only approaching beyond it), is listed as an *edge
//!   contact* on each of its free ends
//!   ([`SolveContact::edge`]): the normal from the other edge's nearest
//!   point to this one's, that point's gap and the other edge's velocity
//!   there. The solve holds each end from moving along the normal into the
//!   other edge by more than the gap, so the edge's point stays off it;
//!   friction acts after the solve, as on the particles' contacts
//!   ([`rub`](super::rub)). Edges of two sheets lying still on each other
//!   are the thickness apart, a quarter of it out of reach of their edge
//!   contacts ([`predict_edge_contacts`]).
//! - **Put back.** An edge that passed through an edge of the other over a
//!   substep all the same is put back on the side it came from
//!   ([`undo_edge_crossings`]).

use bevy::math::Vec3;

use super::{ClothObstacle, Marks, ObstacleBuffers, Pair, SLACK, TOUCH, cloth_contact};
use crate::sim::collision::ccd::{Crossing, edge_edge};
use crate::sim::collision::edges::segments_nearest;
use crate::sim::integrate::implicit::{Hold, SolveContact};

/// The fraction of the pair's thickness (dimensionless) an edge keeps from
/// another cloth's edge in the solve: two sheets lying on each other, their
/// particles the thickness off the other's triangles, have their edges the
/// thickness apart too, a quarter of it short of their edge contacts.
pub const EDGE_THICKNESS: f32 = 0.75;

/// The other cloth's edges near each edge of this cloth over one
/// substep: listed by [`predict_edge_contacts`] for a box a little larger
/// than it needs, and taken again by [`undo_edge_crossings`] for every edge
/// whose path over the substep stayed inside that box (the others are
/// looked up again), so that a substep looks each edge up once.
#[derive(Clone, Debug, Default)]
pub(super) struct EdgePairs {
    /// The [`stamp`](ClothObstacle::stamp) of the take they were listed
    /// against (0: none).
    stamp: u64,
    /// The substep they were listed for, s into the fixed step.
    window: (f32, f32),
    /// Per own edge, the box (m) its list holds every edge of the other
    /// cloth that reaches into over the substep.
    boxes: Vec<(Vec3, Vec3)>,
    /// Per own edge, its list's range in `theirs`.
    spans: Vec<(u32, u32)>,
    /// The lists: edges of the other cloth as `[low, high]` particles,
    /// each once a list.
    pub(super) theirs: Vec<[u32; 2]>,
    /// Per particle of the other cloth, the box of its path over the
    /// window, m.
    paths: Vec<(Vec3, Vec3)>,
}

/// How many neighbours' lists a cloth keeps.
const KEPT: usize = 4;

impl EdgePairs {
    /// The lists kept in `kept` for the take `stamp`, emptied for the
    /// substep `window` (s) and `count` own edges unless they are for it.
    fn slot<'a>(
        kept: &'a mut Vec<Self>,
        other: &ClothObstacle,
        window: (f32, f32),
        count: usize,
    ) -> &'a mut Self {
        let stamp = other.stamp;
        let at = match kept.iter().position(|p| p.stamp == stamp) {
            Some(at) => at,
            None if kept.len() < KEPT => {
                kept.push(Self::default());
                kept.len() - 1
            }
            // The oldest take: stamps grow.
            None => (0..kept.len()).min_by_key(|&i| kept[i].stamp).unwrap_or(0),
        };
        let this = &mut kept[at];
        if this.stamp != stamp || this.window != window || this.boxes.len() != count {
            this.stamp = stamp;
            this.window = window;
            this.boxes.clear();
            this.boxes.resize(count, (Vec3::MAX, Vec3::MIN));
            this.spans.clear();
            this.spans.resize(count, (0, 0));
            this.theirs.clear();
            this.paths.clear();
            let (t0, t1) = window;
            this.paths.extend((0..other.x.len() as u32).map(|q| {
                let (a, b) = (other.at(q, t0), other.at(q, t1));
                (a.min(b), a.max(b))
            }));
        }
        this
    }

    /// Lists the edges of `other` whose path over the window reaches into
    /// the box `lo..hi` (m) as own edge `edge`'s, and returns them.
    fn list(
        &mut self,
        edge: usize,
        (lo, hi): (Vec3, Vec3),
        other: &ClothObstacle,
        (marks, candidates): (&mut Marks, &mut Vec<u32>),
    ) -> &[[u32; 2]] {
        other.gather_marked((lo, hi), marks.next(other.faces.len()), candidates);
        let from = self.theirs.len();
        let meets = |(l, h): (Vec3, Vec3)| l.cmple(hi).all() && lo.cmple(h).all();
        let path = |q: u32| self.paths[q as usize];
        let union = |(a, b): (Vec3, Vec3), (c, d): (Vec3, Vec3)| (a.min(c), b.max(d));
        for &t in candidates.iter() {
            let [p, q, r] = other.faces[t as usize];
            let (pp, pq, pr) = (path(p), path(q), path(r));
            if !meets(union(union(pp, pq), pr)) {
                continue;
            }
            for ((c, pc), (d, pd)) in [((p, pp), (q, pq)), ((q, pq), (r, pr)), ((r, pr), (p, pp))] {
                if meets(union(pc, pd)) {
                    self.theirs.push([c.min(d), c.max(d)]);
                }
            }
        }
        let listed = &mut self.theirs[from..];
        listed.sort_unstable();
        let mut kept = 0;
        for i in 0..listed.len() {
            if kept == 0 || listed[i] != listed[kept - 1] {
                listed[kept] = listed[i];
                kept += 1;
            }
        }
        self.theirs.truncate(from + kept);
        self.boxes[edge] = (lo, hi);
        self.spans[edge] = (from as u32, self.theirs.len() as u32);
        &self.theirs[from..]
    }

    /// Own edge `edge`'s list, if it was listed for the substep `window`
    /// (s) and holds every edge reaching into the box `lo..hi` (m). The
    /// caller picks the lists of the take it asks about.
    fn listed(
        &self,
        window: (f32, f32),
        edge: usize,
        (lo, hi): (Vec3, Vec3),
    ) -> Option<&[[u32; 2]]> {
        let (blo, bhi) = *self.boxes.get(edge)?;
        let inside = blo.cmple(lo).all() && hi.cmple(bhi).all();
        let (from, to) = self.spans[edge];
        (self.window == window && inside).then(|| &self.theirs[from as usize..to as usize])
    }
}

impl ClothObstacle {
    /// The edges of its triangles that may reach into the box `lo..hi`
    /// (m) into `out`: each triangle's once, so an edge two of them share
    /// twice (testing it again costs less than a sort). `candidates`:
    /// scratch for the triangles.
    fn edges_near(
        &self,
        (lo, hi): (Vec3, Vec3),
        (marks, candidates): (&mut Marks, &mut Vec<u32>),
        out: &mut Vec<[u32; 2]>,
    ) {
        self.gather_marked((lo, hi), marks.next(self.faces.len()), candidates);
        out.clear();
        for &t in candidates.iter() {
            let [p, q, r] = self.faces[t as usize];
            out.extend([[p, q], [q, r], [r, p]]);
        }
    }
}

/// Adds to `out` the edge contacts ([`cloths`](super)) that hold the
/// edges of this cloth's triangles (`faces`; positions `x` m, velocities
/// `v` m/s, inverse masses `w` 1/kg, at `time` s into the fixed step) off
/// `other`'s edges over a substep of `dt` s: for each edge, its nearest
/// point to the other's edges that lies between the ends of both and that
/// the two edges' speeds could bring within [`EDGE_THICKNESS`] of the
/// pair's thickness in the substep (beyond the thickness, only while it
/// approaches); one contact on each free end, with that point's normal,
/// gap (m) and the other edge's velocity there (m/s).
/// Where the nearest point is an end of either edge, the particle–triangle
/// contacts hold it.
pub fn predict_edge_contacts(
    faces: &[[u32; 3]],
    (x, v, w): (&[Vec3], &[Vec3], &[f32]),
    (time, dt): (f32, f32),
    other: &ClothObstacle,
    pair: Pair,
    buffers: &mut ObstacleBuffers,
    out: &mut Vec<SolveContact>,
) {
    let h = EDGE_THICKNESS * pair.thickness;
    let n = x.len();
    if !(h.is_finite() && h > 0.0 && dt > 0.0) || v.len() != n || w.len() != n {
        return;
    }
    let ObstacleBuffers {
        own_edges,
        marks,
        candidates,
        pairs,
        faces_generation,
        ..
    } = buffers;
    own_edges.update(|| faces.iter().copied(), faces.len(), *faces_generation);
    let window = (time, time + dt);
    let listed = EdgePairs::slot(pairs, other, window, own_edges.edges.len());
    // The boxes listed are this much (m) larger than the substep's
    // prediction needs, so that the crossings after it find their edges
    // listed.
    let spare = SLACK;
    for (edge, &[a, b]) in own_edges.edges.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        if a >= n || b >= n || w[a] + w[b] == 0.0 {
            continue;
        }
        let ends = [x[a], x[b], v[a], v[b]];
        if !ends.iter().all(|p| p.is_finite()) {
            continue;
        }
        let reach = h + TOUCH + (v[a].length().max(v[b].length()) + other.speed) * dt;
        let (lo, hi) = (x[a].min(x[b]) - reach, x[a].max(x[b]) + reach);
        if !other.overlaps(lo - spare, hi + spare) {
            continue;
        }
        let scratch = (&mut *marks, &mut *candidates);
        let near = listed.list(edge, (lo - spare, hi + spare), other, scratch);
        let mut best: Option<(f32, Vec3, Vec3)> = None;
        for &[c, d] in near {
            let (qc, qd) = (other.at(c, time), other.at(d, time));
            if !(qc.min(qd).cmple(hi).all() && lo.cmple(qc.max(qd)).all()) {
                continue;
            }
            let (s, p, q) = segments_nearest((x[a], x[b]), (qc, qd));
            let along = qd - qc;
            let u = (q - qc).dot(along) / along.length_squared().max(1e-12);
            if !(s > 0.0 && s < 1.0 && u > 1e-4 && u < 1.0 - 1e-4) {
                continue;
            }
            let off = p - q;
            let distance = off.length();
            if distance <= 1e-7 {
                // Touching exactly: the crossing pass decides its side.
                continue;
            }
            let normal = off / distance;
            let gap = distance - h;
            if gap > reach - h {
                continue;
            }
            // Within the pair's thickness it is listed moving apart or not
            // (within reach): the links of a cloth hanging over the other
            // edge can pull one rising off it back onto it within the
            // substep, and the solve lets go of a contact its forces carry
            // clear. Farther, only while it approaches.
            let (vc, vd) = (other.v[c as usize], other.v[d as usize]);
            let vs = vc.lerp(vd, u);
            let approach = dt * (v[a].lerp(v[b], s) - vs).dot(normal);
            if distance > pair.thickness + TOUCH && gap + approach >= 0.0 {
                continue;
            }
            if best.is_none_or(|(g, _, _)| gap < g) {
                best = Some((gap, normal, vs));
            }
        }
        let Some((gap, normal, velocity)) = best else {
            continue;
        };
        for end in [a, b] {
            if w[end] == 0.0 {
                continue;
            }
            out.push(cloth_contact(end, (normal, gap, velocity), true));
        }
    }
}

/// After a substep from `from` to `to` s into the fixed step: puts each
/// edge of this cloth's triangles (`faces`; `start` → `x`,
/// m; velocities `v`, m/s; inverse masses `w`, 1/kg) that passed through
/// an edge of `other` (moving at its velocities from where it was at
/// `from`) back on the side it came from, at the pair's thickness from that
/// edge along the normal of the moment they met, and removes its approach
/// (m/s) along that normal. Of several edges an edge passed through, the
/// deepest is undone. Only this cloth's particles move, by their share of
/// the correction (exactly, between two free ends; beside a held end the
/// free one moves at most twice the correction, and the edge may be left
/// short of the thickness). A particle the implicit solve held this substep
/// (`held` not free) is not pushed into what held it (`support`: the sum of
/// the unit normals of the contacts listed for each particle, colliders'
/// and other cloths'); both are empty without the solve. Returns how many
/// edges were put back.
#[expect(
    clippy::too_many_arguments,
    reason = "a plain function over the cloth's slices"
)]
pub fn undo_edge_crossings(
    faces: &[[u32; 3]],
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    w: &[f32],
    (held, support): (&[Hold], &[Vec3]),
    (from, to): (f32, f32),
    other: &ClothObstacle,
    pair: Pair,
    buffers: &mut ObstacleBuffers,
) -> u32 {
    let h = pair.thickness;
    let n = x.len();
    if !(h.is_finite() && h > 0.0 && to > from) || start.len() != n || v.len() != n {
        return 0;
    }
    let lying = held.len() == n && support.len() == n;
    if w.len() != n || !(lying || held.is_empty()) {
        return 0;
    }
    let ObstacleBuffers {
        own_edges,
        marks,
        candidates,
        their_edges,
        pairs,
        faces_generation,
        ..
    } = buffers;
    own_edges.update(|| faces.iter().copied(), faces.len(), *faces_generation);
    let listed = pairs.iter().find(|p| p.stamp == other.stamp);
    let mut moved = 0;
    for (edge, &[a, b]) in own_edges.edges.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        if a >= n || b >= n {
            continue;
        }
        if w[a] + w[b] == 0.0 {
            continue;
        }
        let ends = [start[a], start[b], x[a], x[b]];
        if !ends.iter().all(|p| p.is_finite()) {
            continue;
        }
        let lo = ends.iter().fold(Vec3::MAX, |m, &p| m.min(p));
        let hi = ends.iter().fold(Vec3::MIN, |m, &p| m.max(p));
        if !other.overlaps(lo - h, hi + h) {
            continue;
        }
        let near = match listed.and_then(|l| l.listed((from, to), edge, (lo, hi))) {
            Some(near) => near,
            None => {
                let scratch = (&mut *marks, &mut *candidates);
                other.edges_near((lo - h, hi + h), scratch, their_edges);
                &their_edges[..]
            }
        };
        let mut deepest: Option<(Crossing, [Vec3; 4], f32)> = None;
        for &[c, d] in near {
            let begin = [start[a], start[b], other.at(c, from), other.at(d, from)];
            let end = [x[a], x[b], other.at(c, to), other.at(d, to)];
            let (olo, ohi) = (begin[2].min(begin[3]), begin[2].max(begin[3]));
            let (olo, ohi) = (olo.min(end[2]).min(end[3]), ohi.max(end[2]).max(end[3]));
            if !(olo.cmple(hi).all() && lo.cmple(ohi).all()) {
                continue;
            }
            let Some(crossing) = edge_edge([0, 1], [2, 3], &begin, &end) else {
                continue;
            };
            let depth = h
                - (0..4)
                    .map(|i| crossing.weights[i] * end[i])
                    .sum::<Vec3>()
                    .dot(crossing.normal);
            if depth > 0.0 && deepest.is_none_or(|(_, _, d)| depth > d) {
                let velocities = [v[a], v[b], other.v[c as usize], other.v[d as usize]];
                deepest = Some((crossing, velocities, depth));
            }
        }
        let Some((crossing, velocities, depth)) = deepest else {
            continue;
        };
        // The other cloth does not give way: all of the correction is this
        // edge's. Split exactly between two free ends; beside a held end the
        // free one moves at most twice the correction.
        let (c, normal) = (crossing.weights, crossing.normal);
        let into = |p: usize| lying && held[p] != Hold::Free && support[p].dot(normal) < 0.0;
        let (wa, wb) = (
            if into(a) { 0.0 } else { w[a] },
            if into(b) { 0.0 } else { w[b] },
        );
        if wa + wb == 0.0 {
            continue;
        }
        let exact = c[0] * c[0] * wa + c[1] * c[1] * wb;
        let share = exact.max(0.5 * (c[0] * wa).max(c[1] * wb));
        if share.is_nan() || share <= 0.0 {
            continue;
        }
        let s = depth / share;
        x[a] += c[0] * wa * s * normal;
        x[b] += c[1] * wb * s * normal;
        let approach = (0..4)
            .map(|i| c[i] * velocities[i])
            .sum::<Vec3>()
            .dot(normal);
        if approach < 0.0 {
            let j = -approach / share;
            v[a] += c[0] * wa * j * normal;
            v[b] += c[1] * wb * j * normal;
        }
        moved += 1;
    }
    moved
}
