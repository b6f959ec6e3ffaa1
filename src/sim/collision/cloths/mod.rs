//! Collision between separate cloths, held inside each cloth's own step.
//!
//! A cloth that collides with others sees each cloth it yields to as a
//! [`ClothObstacle`]: that cloth's triangles at the start of the fixed
//! step, moving on at their velocities, as a moving collider. Each cloth's
//! step moves only its own particles, so cloths still step independently
//! (and in parallel); of a pair, one is kept off the other, which moves as
//! if the first were not there (the plugin orders pairs by layer):
//!
//! - **Particle against triangle.** A free particle within reach of the
//!   other cloth's triangle (the thickness, m, plus both motions over the
//!   step) is held by the implicit solve off that triangle, at the
//!   thickness, with the triangle's velocity as the surface's, like a
//!   particle on a collider ([`predict`](super::predict)).
//! - **Triangle against particle.** The corners of a triangle within reach
//!   of the other cloth's particle are held off it the same way, so a
//!   corner of the other cloth poking into the middle of this one's
//!   triangle pushes the triangle away.
//! - **Sides.** A particle is held on the side of the triangle it is on at
//!   the start of the step; one lying on the triangle's plane exactly (two
//!   cloths spawned on top of each other) goes to the side the pair's
//!   [`rank`](Pair::rank) gives, along the triangle's normal turned towards
//!   its largest component.
//! - **Crossings.** After each substep, a particle that passed through a
//!   triangle of the other cloth (moving at its velocity over the substep)
//!   is put back on its side at the thickness and takes the triangle's
//!   normal velocity ([`undo_crossings`]); a step without the implicit
//!   solve also pushes particles within the thickness out there.
//! - **Edges.** Two ribbons crossing, or a hem over a hem, meet edge to
//!   edge with no particle near a triangle: an edge of this cloth near an
//!   edge of the other is held off it by the solve through its ends
//!   ([`predict_edge_contacts`]), and one that passed through an edge of
//!   the other over the substep all the same (found exactly, as in
//!   [`ccd`](super::ccd)) is put back on its side at the thickness
//!   ([`undo_edge_crossings`]).
//!
//! A spatial hash over each obstacle's triangles, swept over the step,
//! finds the candidates.

use bevy::math::Vec3;

use super::ccd::EdgeList;
use super::cells::{CellTable, cell_of, key};
use super::self_collision::barycentric;
use super::trimesh::closest_point_on_triangle;
use crate::sim::integrate::implicit::{Hold, NO_BODY, SolveContact};

/// [`SolveContact::source`] of a contact with another cloth: not a scene
/// collider.
pub const CLOTH_SOURCE: u32 = u32::MAX - 1;

/// How far outside the thickness (m) a particle still counts as touching.
const TOUCH: f32 = 1e-4;

/// How far (m) beyond the thickness an obstacle's triangles are hashed: a
/// point moving less than this in a step finds the triangles near it in
/// its own cell.
const SLACK: f32 = 0.005;

/// Most hash cells a side a triangle's sweep is entered in (own triangles,
/// against the other cloth's particles); an obstacle's triangle whose sweep
/// spans more is kept in a list every query takes.
const MAX_SPAN: i32 = 4;

/// Most hash cells a query of an obstacle visits; a larger box (a particle
/// or edge flicked across the step) takes every triangle.
const MAX_QUERY_CELLS: i64 = 512;

/// A corner of a triangle takes a contact at a point of the triangle when
/// its barycentric weight there is at least this (dimensionless), or it
/// is the heaviest corner.
const CORNER_SHARE: f32 = 0.25;

/// Reusable lists of the contact passes (no allocation once warm).
#[derive(Clone, Debug, Default)]
pub struct ObstacleBuffers {
    candidates: Vec<u32>,
    /// Own triangles by cell.
    own: CellTable,
    /// Own triangles' edges.
    own_edges: EdgeList,
    /// The generation of the own triangles passed
    /// ([`Faces::generation`](crate::sim::grid::Faces::generation)), if known.
    faces_generation: Option<u64>,
    /// The other cloth's edges near one of this cloth's.
    their_edges: Vec<[u32; 2]>,
    /// Which of the other cloth's triangles a query of its edges listed.
    marks: Marks,
    /// The other cloths' edges near each own edge over the substep, per
    /// neighbour.
    pairs: Vec<EdgePairs>,
}

impl ObstacleBuffers {
    /// Names the own triangles the next calls pass by their generation
    /// ([`Faces::generation`](crate::sim::grid::Faces::generation); `None`: compare them).
    pub(crate) fn set_faces_generation(&mut self, generation: Option<u64>) {
        self.faces_generation = generation;
    }
}

/// Per triangle, the number of the last query that listed it: a query lists
/// each triangle once without sorting.
#[derive(Clone, Debug, Default)]
struct Marks {
    seen: Vec<u32>,
    query: u32,
}

impl Marks {
    /// Starts a query over `len` triangles; returns the marks and its number.
    fn next(&mut self, len: usize) -> (&mut [u32], u32) {
        if self.seen.len() < len {
            self.seen.resize(len, 0);
        }
        self.query = self.query.wrapping_add(1);
        if self.query == 0 {
            self.seen.fill(0);
            self.query = 1;
        }
        (&mut self.seen, self.query)
    }
}

/// The unit normal of `[a, b, c]` (zero for a degenerate one).
fn face_normal([a, b, c]: [Vec3; 3]) -> Vec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

/// The direction, from a triangle of normal `face` towards a point whose
/// signed distance along it is `signed` m, that the point is held on; a
/// point on the plane goes below it for a pair's `rank`, above otherwise
/// (along `face` turned towards its largest component).
fn side_of(face: Vec3, signed: f32, below: bool) -> Vec3 {
    if signed.abs() > 1e-6 {
        return face * signed.signum();
    }
    let a = face.abs();
    let largest = if a.x >= a.y && a.x >= a.z {
        face.x
    } else if a.y >= a.z {
        face.y
    } else {
        face.z
    };
    let up = face * largest.signum();
    if below { -up } else { up }
}

/// Whether point `p` lies within `reach` m of the box of `corners` (m): a
/// cheap test before the exact distance.
fn near_box(p: Vec3, corners: [Vec3; 3], reach: f32) -> bool {
    let lo = corners[0].min(corners[1]).min(corners[2]) - reach;
    let hi = corners[0].max(corners[1]).max(corners[2]) + reach;
    p.cmpge(lo).all() && p.cmple(hi).all()
}

/// Where point `p` is held off triangle `corners` (thickness `h` m): the
/// unit normal from the triangle towards `p`, the gap (m, distance less
/// `h`) and the barycentric weights of the nearest point. `below` is the
/// side a point on the plane goes to, as [`side_of`].
fn point_off_triangle(
    p: Vec3,
    corners: [Vec3; 3],
    h: f32,
    below: bool,
) -> Option<(Vec3, f32, [f32; 3])> {
    let face = face_normal(corners);
    if face == Vec3::ZERO {
        return None;
    }
    let c = closest_point_on_triangle(p, corners);
    let bary = barycentric(c, corners);
    let off = p - c;
    let d = off.length();
    let inside = bary.iter().all(|&b| b > 1e-4);
    let normal = if inside || d < 1e-7 {
        side_of(face, off.dot(face), below)
    } else {
        off / d
    };
    Some((normal, d - h, bary))
}

/// A contact of `particle` with another cloth: the surface's unit
/// `normal`, the `gap` (m) and the surface's `velocity` (m/s) there, an
/// [`edge`](SolveContact::edge) contact or not.
fn cloth_contact(
    particle: usize,
    (normal, gap, velocity): (Vec3, f32, Vec3),
    edge: bool,
) -> SolveContact {
    SolveContact {
        particle: particle as u32,
        normal,
        gap,
        velocity,
        // Friction between cloths acts after the solve ([`rub`]): held in
        // it, against a surface whose particles the contact does not
        // carry, it shook the resting sheets.
        friction: 0.0,
        source: CLOTH_SOURCE,
        body: NO_BODY,
        edge,
    }
}

/// Adds to `out` the contacts that hold this cloth (`faces` for its
/// triangles, positions `x` m, velocities `v` m/s, inverse masses `w`
/// 1/kg, at `time` s into the fixed step) off `other` over a substep of
/// `dt` s: its free particles against `other`'s triangles, and its
/// triangles' corners against `other`'s particles ([module docs](self)).
/// Several contacts may name one particle; the solve's
/// [`keep_nearest`](super::predict::keep_nearest) keeps the nearest.
#[expect(
    clippy::too_many_arguments,
    reason = "a plain function over the cloth's slices"
)]
pub fn predict_cloth_contacts(
    faces: &[[u32; 3]],
    (x, v, w): (&[Vec3], &[Vec3], &[f32]),
    (time, dt): (f32, f32),
    cell: f32,
    other: &ClothObstacle,
    pair: Pair,
    buffers: &mut ObstacleBuffers,
    out: &mut Vec<SolveContact>,
) {
    let h = pair.thickness;
    if !(h.is_finite() && h > 0.0 && dt > 0.0) {
        return;
    }
    let contact =
        |particle, normal, gap, velocity| cloth_contact(particle, (normal, gap, velocity), false);
    let speed = other.speed;
    // This cloth's particles against the other's triangles.
    for p in 0..x.len() {
        let (xp, vp, wp) = (x[p], v[p], w[p]);
        if wp == 0.0 || !(xp.is_finite() && vp.is_finite()) {
            continue;
        }
        let reach = h + TOUCH + (vp.length() + speed) * dt;
        if !other.overlaps(xp - reach, xp + reach) {
            continue;
        }
        let motion = reach - h;
        other.gather_around(xp, (motion, h), &mut buffers.candidates);
        let mut best: Option<SolveContact> = None;
        for &t in &buffers.candidates {
            let corners = other.corners(t, time);
            if !near_box(xp, corners, reach) {
                continue;
            }
            let Some((n, gap, bary)) = point_off_triangle(xp, corners, h, pair.rank) else {
                continue;
            };
            let tri = other.faces[t as usize];
            let vs: Vec3 = (0..3).map(|i| bary[i] * other.v[tri[i] as usize]).sum();
            if gap > reach - h || (gap > TOUCH && gap + dt * (vp - vs).dot(n) >= 0.0) {
                continue;
            }
            if best.is_some_and(|b| b.gap <= gap) {
                continue;
            }
            best = Some(contact(p, n, gap, vs));
        }
        out.extend(best);
    }
    // This cloth's triangles against the other's particles.
    let pad = h + TOUCH + SLACK;
    let inv_cell = 1.0 / cell.max(2.0 * pad).max(1e-4);
    hash_own(faces, x, v, (dt, pad, inv_cell), &mut buffers.own);
    let own_travel = v.iter().map(|v| v.length()).fold(0.0, f32::max) * dt;
    for q in 0..other.x.len() {
        let (xq, vq) = (other.at(q as u32, time), other.v[q]);
        let motion = vq.length() * dt;
        let (own, candidates) = (&buffers.own, &mut buffers.candidates);
        if motion <= SLACK {
            single_cell(own, key(cell_of(xq, inv_cell)), candidates);
        } else {
            let reach = Vec3::splat(h + TOUCH + motion);
            gather_own(own, (xq - reach, xq + reach), inv_cell, candidates);
        }
        for &t in &buffers.candidates {
            let tri = faces[t as usize];
            let corners = tri.map(|i| x[i as usize]);
            // The other cloth's particle is held off this triangle as a
            // particle of the other side: the opposite rank.
            if !near_box(xq, corners, h + TOUCH + motion + own_travel) {
                continue;
            }
            let Some((n, gap, bary)) = point_off_triangle(xq, corners, h, !pair.rank) else {
                continue;
            };
            let vs: Vec3 = (0..3).map(|i| bary[i] * v[tri[i] as usize]).sum();
            let ws: f32 = (0..3).map(|i| bary[i] * bary[i] * w[tri[i] as usize]).sum();
            if ws == 0.0 || gap > TOUCH + (vq.length() + vs.length()) * dt {
                continue;
            }
            if gap > TOUCH && gap + dt * (vq - vs).dot(n) >= 0.0 {
                continue;
            }
            // The triangle is pushed along −n, away from the particle
            // moving at its own velocity.
            let heaviest = (0..3).fold(0, |m, i| if bary[i] > bary[m] { i } else { m });
            for i in 0..3 {
                let corner = tri[i] as usize;
                if w[corner] == 0.0 || (bary[i] < CORNER_SHARE && i != heaviest) {
                    continue;
                }
                let corner_gap = (xq - x[corner]).dot(n) - h;
                out.push(contact(corner, -n, corner_gap, vq));
            }
        }
    }
}

/// Coulomb friction after a substep of `dt` s between the particles of
/// this cloth the solve held on another cloth (`held`; `contacts` as
/// [`predict_cloth_contacts`] listed them, with their pair's friction
/// coefficient) and that cloth: each one's sliding velocity relative to
/// the surface (`v`, m/s) loses up to the coefficient times the normal
/// velocity gravity (`gravity`, m/s²) presses it with over the substep
/// (the sheet's own weight as its load). Returns how many were slowed.
pub fn rub(
    contacts: &[(SolveContact, f32)],
    v: &mut [Vec3],
    held: &[Hold],
    (gravity, dt): (Vec3, f32),
) -> u32 {
    let mut slowed = 0;
    for &(ref c, friction) in contacts {
        let p = c.particle as usize;
        if held.get(p).is_none_or(|&h| h == Hold::Free) || p >= v.len() {
            continue;
        }
        let load = -gravity.dot(c.normal) * dt;
        if load.is_nan() || load <= 0.0 {
            continue;
        }
        let relative = v[p] - c.velocity;
        let slide = relative - relative.dot(c.normal) * c.normal;
        let speed = slide.length();
        if speed > 0.0 {
            v[p] -= slide * (friction * load / speed).min(1.0);
            slowed += 1;
        }
    }
    slowed
}

/// Hashes this cloth's triangles (positions `x` m moving at `v` m/s over
/// `dt` s, grown by `pad` m) in cells of `1 / inv_cell` m into `entries`.
fn hash_own(
    faces: &[[u32; 3]],
    x: &[Vec3],
    v: &[Vec3],
    (dt, pad, inv_cell): (f32, f32, f32),
    entries: &mut CellTable,
) {
    entries.clear();
    for (t, tri) in faces.iter().enumerate() {
        let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
        for &q in tri {
            let (s, e) = (x[q as usize], x[q as usize] + v[q as usize] * dt);
            lo = lo.min(s).min(e);
            hi = hi.max(s).max(e);
        }
        if lo.is_finite() && hi.is_finite() {
            cells(lo - pad, hi + pad, inv_cell, |k| entries.enter(k, t as u32));
        }
    }
    entries.finish();
}

/// The triangles of `entries` in cell `k`, into `out`.
pub(super) fn single_cell(entries: &CellTable, k: u64, out: &mut Vec<u32>) {
    out.clear();
    out.extend_from_slice(entries.cell(k));
}

/// The triangles of `entries` in the cells of the box `lo..hi` (m), each
/// once.
fn gather_own(entries: &CellTable, (lo, hi): (Vec3, Vec3), inv_cell: f32, out: &mut Vec<u32>) {
    out.clear();
    if !(lo.is_finite() && hi.is_finite()) {
        return;
    }
    cells(lo, hi, inv_cell, |k| {
        out.extend_from_slice(entries.cell(k));
    });
    out.sort_unstable();
    out.dedup();
}

/// After a substep from `from` to `to` s into the fixed step: puts each
/// free particle of this cloth (`start` → `x`, m; velocities `v`, m/s;
/// inverse masses `w`, 1/kg) that passed through a triangle of `other`
/// back on the side it started on, at the thickness, with the triangle's
/// normal velocity. The triangle is taken from where it was at `from`,
/// moving as the pair would meet (the particle at its path's velocity, the
/// triangle's point at its own, as the solve holds them): a particle the
/// solve held on a triangle that gave way with it has not passed through.
/// When `held` is empty (no implicit solve held this substep's contacts)
/// or says a particle was free, one within the thickness of a triangle is
/// also pushed out to it and loses its approaching normal velocity. Only
/// this cloth's particles move. Returns how many were moved.
#[expect(
    clippy::too_many_arguments,
    reason = "a plain function over the cloth's slices"
)]
pub fn undo_crossings(
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    w: &[f32],
    held: &[Hold],
    (from, to): (f32, f32),
    other: &ClothObstacle,
    pair: Pair,
    buffers: &mut ObstacleBuffers,
) -> u32 {
    let h = pair.thickness;
    let span = to - from;
    if !(h.is_finite() && h > 0.0 && span > 0.0) {
        return 0;
    }
    let mut moved = 0;
    for p in 0..x.len() {
        let (s, e) = (start[p], x[p]);
        if w[p] == 0.0 || !(s.is_finite() && e.is_finite()) {
            continue;
        }
        let (lo, hi) = (s.min(e) - h, s.max(e) + h);
        if !other.overlaps(lo, hi) {
            continue;
        }
        other.gather_around(e, (s.distance(e), h), &mut buffers.candidates);
        let free = held.get(p).is_none_or(|&k| k == Hold::Free);
        let mut push: Option<(Vec3, f32, Vec3)> = None;
        for &t in &buffers.candidates {
            let before = other.corners(t, from);
            let face = face_normal(before);
            if face == Vec3::ZERO {
                continue;
            }
            let was = (s - before[0]).dot(face);
            let tri = other.faces[t as usize];
            let bary = barycentric(closest_point_on_triangle(s, before), before);
            let vs: Vec3 = (0..3).map(|i| bary[i] * other.v[tri[i] as usize]).sum();
            let n = side_of(face, was, pair.rank);
            let now = before.map(|c| c + vs * span);
            let is = (e - now[0]).dot(face);
            if was * is < 0.0 && was.abs() > 1e-6 {
                // Crossed the plane: through the inside?
                let f = was / (was - is);
                let at = s.lerp(e, f);
                let then = before.map(|c| c + vs * span * f);
                if barycentric(at, then).iter().all(|&b| b >= -1e-4) {
                    let c = closest_point_on_triangle(e, now);
                    let depth = h - (e - c).dot(n);
                    if push.is_none_or(|(_, d, _)| depth > d) {
                        push = Some((n, depth, vs));
                    }
                }
                continue;
            }
            if !free {
                continue;
            }
            let Some((n, gap, _)) = point_off_triangle(e, now, h, pair.rank) else {
                continue;
            };
            if gap < 0.0 && push.is_none_or(|(_, d, _)| -gap > d) {
                push = Some((n, -gap, vs));
            }
        }
        if let Some((n, depth, vs)) = push
            && depth > 0.0
        {
            x[p] += n * depth;
            let un = (v[p] - vs).dot(n);
            if un < 0.0 {
                v[p] -= un * n;
            }
            moved += 1;
        }
    }
    moved
}

mod edge_pass;
mod neighbours;
mod obstacle;
use edge_pass::EdgePairs;
pub use edge_pass::{predict_edge_contacts, undo_edge_crossings};
pub(crate) use neighbours::{Neighbour, NeighbourContacts, NeighbourScratch};
use obstacle::cells;
#[cfg(test)]
use obstacle::finite_box;
pub use obstacle::{ClothObstacle, Pair};

#[cfg(test)]
mod tests;
