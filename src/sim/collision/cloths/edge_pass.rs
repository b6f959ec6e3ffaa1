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

use super::{ClothObstacle, Marks, ObstacleBuffers, Pair, TOUCH, cloth_contact};
use crate::sim::collision::ccd::{Crossing, edge_edge};
use crate::sim::collision::edges::segments_nearest;
use crate::sim::integrate::implicit::{Hold, SolveContact};

/// The fraction of the pair's thickness (dimensionless) an edge keeps from
/// another cloth's edge in the solve: two sheets lying on each other, their
/// particles the thickness off the other's triangles, have their edges the
/// thickness apart too, a quarter of it short of their edge contacts.
pub const EDGE_THICKNESS: f32 = 0.75;

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
    buffers
        .own_edges
        .update(|| faces.iter().copied(), faces.len());
    for &[a, b] in &buffers.own_edges.edges {
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
        if !other.overlaps(lo, hi) {
            continue;
        }
        let scratch = (&mut buffers.marks, &mut buffers.candidates);
        other.edges_near((lo, hi), scratch, &mut buffers.their_edges);
        let mut best: Option<(f32, Vec3, Vec3)> = None;
        for &[c, d] in buffers.their_edges.iter() {
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
    let own = &mut buffers.own_edges;
    own.update(|| faces.iter().copied(), faces.len());
    let mut moved = 0;
    for &[a, b] in &buffers.own_edges.edges {
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
        let scratch = (&mut buffers.marks, &mut buffers.candidates);
        other.edges_near((lo - h, hi + h), scratch, &mut buffers.their_edges);
        let mut deepest: Option<(Crossing, [Vec3; 4], f32)> = None;
        for &[c, d] in &buffers.their_edges {
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
