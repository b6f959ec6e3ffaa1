//! Edges of one cloth against edges of another, over a substep: a link of
//! this cloth that passed through a link of the other (two ribbons crossing,
//! a hem sliding over a hem) is put back on the side it came from, even
//! where no particle of either came near a triangle of the other.

use bevy::math::Vec3;

use super::{ClothObstacle, ObstacleBuffers, Pair};
use crate::sim::collision::ccd::{Crossing, edge_edge};
use crate::sim::integrate::implicit::Hold;

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
        other.gather(lo - h, hi + h, &mut buffers.candidates);
        buffers.their_edges.clear();
        for &t in &buffers.candidates {
            let [p, q, r] = other.faces[t as usize];
            for (i, j) in [(p, q), (q, r), (r, p)] {
                buffers.their_edges.push([i.min(j), i.max(j)]);
            }
        }
        buffers.their_edges.sort_unstable();
        buffers.their_edges.dedup();
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
