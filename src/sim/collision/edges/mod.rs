//! Links against colliders: the contacts that keep a link from cutting
//! through a collider's edge or corner while both its particles are
//! outside it (a tablecloth's skirt over a table's rim).
//!
//! Particle contacts ([`predict`](super::predict)) hold each particle on
//! the surface; a straight link between two of them can still pass through
//! a corner between them. Each Type 1 link whose nearest point to a
//! collider lies between its ends, nearer than both ends by [`EDGE_DIP`]
//! of the thickness, within
//! [`EDGE_THICKNESS`] of the contact thickness (or reaching it within the
//! step), is listed as an *edge contact* on each of its free particles:
//! the surface's outward normal at the link's nearest point, and that
//! point's gap. Each particle is then held so that it does not move into
//! the surface along that normal by more than the gap, so the link's point
//! stays outside too, and the corner carries the load a cloth wrapping it
//! would put there.
//!
//! The corner holds without friction. Its normal force acts on the link's
//! ends, which lie on the faces on either side of it: as friction there it
//! would pin a particle on the table's side against the pull of a link
//! over the rim (a tablecloth yanked off a round table then stays caught
//! on the rim, stretched several times over). The particles' own contacts
//! with the faces keep their friction, except at a corner a link of theirs
//! wraps ([`keep_nearest`](super::predict::keep_nearest)). A link over a
//! large round collider
//! sags into the thickness by its sagitta (`L²/8R`: 0.6 mm for a 5 cm link
//! over a 0.5 m ball) and lists nothing. A link with a pinned end inside
//! the collider (a grab dragged into a table), or farther inside than
//! twice its length and its ends' travel in a step, lists nothing either:
//! no move of its ends within a step takes it out, and the try would
//! fling them.
//!
//! Links are tested against analytic shapes exactly: their signed distance
//! is convex along a segment, and a minimum between the ends needs both
//! ends' normals to face against the link, which culls a cloth lying on a
//! surface at the cost of two dot products a link. Triangle meshes are
//! tested against the triangles near the link. Colliders with a free body
//! behind them get no edge contacts.

use bevy::math::{Affine3A, Vec3};

use super::contact::{Geometry, MovingCollider};
use super::predict::mesh_distance;
use super::shapes::Shape;
use super::trimesh::{TriMesh, closest_point_on_triangle, segment_triangle};
use crate::sim::connections::Link;
use crate::sim::integrate::implicit::{NO_BODY, SolveContact};

/// The fraction of the contact thickness a link keeps from a surface
/// (dimensionless): it may sag a quarter of the thickness into it, so that
/// a link over a gently curved surface lists no contact.
pub const EDGE_THICKNESS: f32 = 0.75;

/// How much nearer than both its ends a link's nearest point must be, as a
/// fraction of the contact thickness (dimensionless), for the link to be
/// held by it: a link resting across a corner, its end on a face at the
/// thickness and its point at [`EDGE_THICKNESS`], is 0.25 nearer; a 5 cm
/// link over a 0.5 m ball, 0.6 mm nearer, 0.12 of a 5 mm thickness.
pub const EDGE_DIP: f32 = 0.15;

/// How far outside the edge thickness (m) a link still counts as
/// touching.
const TOUCH: f32 = 1e-4;

/// The smallest share (dimensionless) of a link's point that its free
/// particle carries when the other one is pinned: nearer the pinned end,
/// the pin holds the link.
const MIN_SHARE: f32 = 0.25;

/// Golden-section iterations for a link's nearest point to a shape: the
/// bracket shrinks to 0.618²⁴ ≈ 10⁻⁵ of the link.
const SECTIONS: usize = 24;

/// The golden section's ratio, `(√5 − 1)/2`.
const R: f32 = 0.618_034;

/// The longest of the `links` (m) between particles at `x` (m), and the
/// fastest particle's speed (m/s): how far a link's point can lie from its
/// ends, and how far it can move within a step, for
/// [`predict_edge_contacts`]. The same for every collider of a step.
pub fn link_extent(links: &[&[Link]], x: &[Vec3], v: &[Vec3]) -> (f32, f32) {
    let longest = links
        .iter()
        .flat_map(|l| l.iter())
        .map(|l| x[l.a as usize].distance(x[l.b as usize]))
        .fold(0.0f32, f32::max);
    let fastest = v.iter().map(|v| v.length()).fold(0.0f32, f32::max);
    (longest, fastest)
}

/// Adds to `out` the edge contacts of the Type 1 `links` with `collider`
/// (its poses at the start and end of a step of `dt` s), for particles at
/// `x` (m) moving at `v` (m/s) with inverse masses `w` (1/kg, 0 pinned), at
/// a contact thickness of `thickness` m; `extent` is [`link_extent`] of
/// them. `near` is scratch: each particle's local position, distance (m),
/// normal, and the collider's surface speed there (m/s).
///
/// Each contact is marked [`SolveContact::edge`]; its `source` is 0.
pub fn predict_edge_contacts(
    collider: &MovingCollider,
    links: &[&[Link]],
    (x, v, w): (&[Vec3], &[Vec3], &[f32]),
    (thickness, dt): (f32, f32),
    (longest, fastest): (f32, f32),
    near: &mut Vec<(Vec3, f32, Vec3, f32)>,
    out: &mut Vec<SolveContact>,
) {
    let edge = EDGE_THICKNESS * thickness;
    let to_local = Affine3A::from(collider.start.inverse());
    let (start, end) = (Affine3A::from(collider.start), Affine3A::from(collider.end));
    // A link reaches at most `longest` from its ends.
    let cap = thickness + longest + 2.0 * fastest * dt + TOUCH;
    // Only the particles within reach of the collider are measured; the
    // others are at an infinite distance. A plane's distance is linear
    // along a link, whose nearest point is then an end.
    let (lo, hi) = match collider.geometry {
        Geometry::Shape(Shape::Plane) => return,
        Geometry::Shape(ref shape) => (
            Vec3::splat(-shape.bounding_radius()),
            Vec3::splat(shape.bounding_radius()),
        ),
        Geometry::Mesh(mesh) => mesh.bounds(),
    };
    let bounds = (lo - Vec3::splat(cap), hi + Vec3::splat(cap));
    measure(collider, x, (to_local, end), (bounds, cap, dt), near);
    for link in links.iter().flat_map(|l| l.iter()) {
        let (a, b) = (link.a as usize, link.b as usize);
        let (Some(&(la, da, na, ua)), Some(&(lb, db, nb, ub))) = (near.get(a), near.get(b)) else {
            continue;
        };
        if !(da.is_finite() && db.is_finite()) {
            continue;
        }
        let (wa, wb) = (w[a], w[b]);
        // A pinned end inside the shape (a grab dragged into a table) keeps
        // its link inside whatever the free end does.
        let pinned_inside = |w: f32, d: f32| w == 0.0 && d < 0.0;
        if wa == 0.0 && wb == 0.0 || pinned_inside(wa, da) || pinned_inside(wb, db) {
            continue;
        }
        // A nearest point between the ends needs both ends' normals to face
        // against the link (exactly so for a convex shape).
        let ab = lb - la;
        let (sa, sb) = (na.dot(ab), -nb.dot(ab));
        if sa >= 0.0 || sb >= 0.0 {
            continue;
        }
        let reach = edge + TOUCH + (v[a].length() + v[b].length() + ua.max(ub)) * dt;
        let nearest = match collider.geometry {
            Geometry::Shape(ref shape) => {
                // Convex along the link, the distance stays above its
                // tangent lines at the ends and its secants: too far, or
                // not nearer than the ends by the dip.
                let far = |low: f32| low > reach || low >= da.min(db) - EDGE_DIP * thickness;
                if far(lower_bound((da, sa), (db, sb), None)) {
                    continue;
                }
                let middle = shape.distance(la.lerp(lb, 0.5)).0;
                if far(lower_bound((da, sa), (db, sb), Some(middle))) {
                    continue;
                }
                shape_nearest(shape, la, lb)
            }
            Geometry::Mesh(mesh) => mesh_nearest(mesh, la, lb, reach),
        };
        let Some((t, d, n)) = nearest else {
            continue;
        };
        if da.min(db) - d < EDGE_DIP * thickness || !(t > 0.0 && t < 1.0) {
            continue;
        }
        let normal = start.transform_vector3(n).normalize_or_zero();
        if normal == Vec3::ZERO {
            continue;
        }
        let q = la.lerp(lb, t);
        let point = start.transform_point3(q);
        let velocity = (end.transform_point3(q) - point) / dt;
        let gap = d - edge;
        let moving = v[a].lerp(v[b], t);
        let approach = gap + dt * (moving - velocity).dot(normal);
        if gap > TOUCH && approach >= 0.0 {
            continue;
        }
        // A link farther in than twice its length and its ends' travel in
        // a step did not cut a rim in a step or two: something dragged it
        // there (a grab through a table top). Out over the rim, its ends
        // would be flung; their own contacts bring them out instead.
        if -gap > 2.0 * ab.length() + (v[a].length() + v[b].length()) * dt {
            continue;
        }
        let ends = [(a, wa, 1.0 - t, b, wb), (b, wb, t, a, wa)];
        push_ends(ends, (normal, gap, velocity), (v, dt), out);
    }
}

/// Each particle's local position in the collider's frame at the start
/// (`to_local`), its distance (m) and normal there, and the speed (m/s) at
/// which the collider's surface moves there over the step (to `end`), into
/// `near`; a particle outside `bounds` (local, m) is infinitely far.
fn measure(
    collider: &MovingCollider,
    x: &[Vec3],
    (to_local, end): (Affine3A, Affine3A),
    ((lo, hi), cap, dt): ((Vec3, Vec3), f32, f32),
    near: &mut Vec<(Vec3, f32, Vec3, f32)>,
) {
    near.clear();
    near.extend(x.iter().map(|&p| {
        let local = to_local.transform_point3(p);
        if local.cmplt(lo).any() || local.cmpgt(hi).any() {
            return (local, f32::INFINITY, Vec3::ZERO, 0.0);
        }
        let (d, n) = match collider.geometry {
            Geometry::Shape(ref shape) => shape.distance(local),
            Geometry::Mesh(mesh) => {
                mesh_distance(mesh, local, cap).unwrap_or((f32::INFINITY, Vec3::ZERO))
            }
        };
        let surface = (end.transform_point3(local) - p).length() / dt;
        (local, d, n, surface)
    }));
}

/// The contacts of a link's two `ends` (each: particle, inverse mass,
/// share of the link's point, the other end and its inverse mass) with the
/// surface at its point (`normal`, `gap` m, the surface's `velocity` m/s).
/// Each free end moves the link's point by its share: with both free, each
/// keeps the gap; with one pinned, the free one carries what the pin's own
/// motion (`v`, m/s, over `dt` s) does not.
fn push_ends(
    ends: [(usize, f32, f32, usize, f32); 2],
    (normal, gap, velocity): (Vec3, f32, Vec3),
    (v, dt): (&[Vec3], f32),
    out: &mut Vec<SolveContact>,
) {
    for (p, wp, share, other, wo) in ends {
        if wp == 0.0 {
            continue;
        }
        let gap = if wo == 0.0 {
            if share < MIN_SHARE {
                continue;
            }
            let pin = (1.0 - share) * dt * (v[other] - velocity).dot(normal);
            (gap + pin) / share
        } else {
            gap
        };
        out.push(SolveContact {
            particle: p as u32,
            normal,
            gap,
            velocity,
            friction: 0.0,
            source: 0,
            body: NO_BODY,
            edge: true,
        });
    }
}

/// A lower bound (m) on a convex distance along a link from its ends'
/// distances `d` (m) and slopes `s` (m, the normal at the end dotted with
/// the link, pointing from that end), and, given, its distance at the
/// middle: over each half, the larger of the end's tangent line and the
/// other half's secant extended, at its lowest. A convex function lies
/// above both.
fn lower_bound((da, sa): (f32, f32), (db, sb): (f32, f32), middle: Option<f32>) -> f32 {
    // Lines as (value at t = 0, slope in t).
    let tangent_a = (da, sa);
    let tangent_b = (db + sb, -sb);
    match middle {
        None => lowest_of_two(tangent_a, tangent_b, (0.0, 1.0)),
        Some(dm) => {
            let secant_a = (da, 2.0 * (dm - da));
            let secant_b = (2.0 * dm - db, 2.0 * (db - dm));
            lowest_of_two(tangent_a, secant_b, (0.0, 0.5)).min(lowest_of_two(
                tangent_b,
                secant_a,
                (0.5, 1.0),
            ))
        }
    }
}

/// The lowest (m) over `t ∈ [lo, hi]` of the larger of two lines (each its
/// value at `t = 0` and slope).
fn lowest_of_two((c1, k1): (f32, f32), (c2, k2): (f32, f32), (lo, hi): (f32, f32)) -> f32 {
    let upper = |t: f32| (c1 + k1 * t).max(c2 + k2 * t);
    let mut low = upper(lo).min(upper(hi));
    let cross = (c2 - c1) / (k1 - k2);
    if cross.is_finite() && (lo..=hi).contains(&cross) {
        low = low.min(upper(cross));
    }
    low
}

/// The point of the segment `a → b` (local, m) nearest `shape`: its
/// fraction `t`, signed distance (m) and the normal pushing it out. The
/// signed distance to a convex solid is convex along a segment, so a
/// golden section finds its minimum. A segment that passes inside comes
/// out by [`line_exit`].
fn shape_nearest(shape: &Shape, a: Vec3, b: Vec3) -> Option<(f32, f32, Vec3)> {
    let at = |t: f32| shape.distance(a.lerp(b, t)).0;
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    let (mut t1, mut t2) = (hi - R * (hi - lo), lo + R * (hi - lo));
    let (mut f1, mut f2) = (at(t1), at(t2));
    for _ in 0..SECTIONS {
        if f1 < f2 {
            hi = t2;
            (t2, f2) = (t1, f1);
            t1 = hi - R * (hi - lo);
            f1 = at(t1);
        } else {
            lo = t1;
            (t1, f1) = (t2, f2);
            t2 = lo + R * (hi - lo);
            f2 = at(t2);
        }
    }
    let t = 0.5 * (lo + hi);
    let (d, n) = shape.distance(a.lerp(b, t));
    if !(d.is_finite() && n.is_finite()) {
        return None;
    }
    if d < 0.0 {
        return line_exit(shape, a, b).map(|(d, n)| (t, d, n));
    }
    Some((t, d, n))
}

/// Directions tried around a link for [`line_exit`], before refining.
const EXIT_DIRECTIONS: usize = 32;

/// How a segment from `q` to `b` (local, m) with both ends outside a convex `shape`
/// and its middle inside comes out of it by the shortest move across
/// itself: the move clears the line of the segment, whose points in the
/// shape lie between the ends. Across the segment the shape's extent is
/// its support `h(u)`, and the line is out once `h(u) − q·u` (q on the
/// line) is passed: the least of that over directions `u` across the
/// segment is the depth (returned negative, m), and `u` the normal. A
/// link through a table's corner comes out over the corner; one through a
/// table top, with an end above and an end below, comes out over the
/// nearest rim rather than back through a face.
fn line_exit(shape: &Shape, q: Vec3, b: Vec3) -> Option<(f32, Vec3)> {
    let e = (b - q).normalize_or_zero();
    if e == Vec3::ZERO {
        return None;
    }
    let (u0, u1) = e.any_orthonormal_pair();
    let direction = |angle: f32| u0 * angle.cos() + u1 * angle.sin();
    let depth = |angle: f32| {
        let u = direction(angle);
        shape.support(u) - q.dot(u)
    };
    let step = std::f32::consts::TAU / EXIT_DIRECTIONS as f32;
    let (best, _) = (0..EXIT_DIRECTIONS)
        .map(|k| (k as f32 * step, depth(k as f32 * step)))
        .min_by(|x, y| x.1.total_cmp(&y.1))?;
    // Refine within a step either side by golden section.
    let (mut lo, mut hi) = (best - step, best + step);
    for _ in 0..SECTIONS / 2 {
        let (m1, m2) = (hi - R * (hi - lo), lo + R * (hi - lo));
        if depth(m1) < depth(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let angle = 0.5 * (lo + hi);
    let out = depth(angle);
    (out.is_finite() && out >= 0.0).then_some((-out, direction(angle)))
}

/// Where the segment `a → b` (m) is deepest in the wedge of two planes
/// (each a point and a unit normal, the first facing `a`, the second
/// facing `b`): its fraction `t`, its depth (m, negative) measured along
/// the normals' mean, which is the direction it leaves the wedge by, and
/// that direction. `None` for planes facing apart (a sheet passed through,
/// not a corner).
fn wedge(
    a: Vec3,
    b: Vec3,
    (p1, n1): (Vec3, Vec3),
    (p2, n2): (Vec3, Vec3),
) -> Option<(f32, f32, Vec3)> {
    let n = (n1 + n2).normalize_or_zero();
    let along = n.dot(n1);
    if n == Vec3::ZERO || along < 1e-3 {
        return None;
    }
    // The heights over the two planes along the segment, g₁ + t k₁ and
    // g₂ + t k₂: it is out of the wedge where either is positive, and
    // deepest where they are equal. Moving it by s n raises both by s·along.
    let ab = b - a;
    let (g1, k1) = ((a - p1).dot(n1), ab.dot(n1));
    let (g2, k2) = ((a - p2).dot(n2), ab.dot(n2));
    let t = ((g1 - g2) / (k2 - k1)).clamp(0.0, 1.0);
    let depth = (g1 + t * k1).max(g2 + t * k2);
    (t.is_finite() && depth.is_finite()).then_some((t, depth / along, n))
}

/// The point of the segment `a → b` (local, m) nearest the triangles of
/// `mesh` within `reach` m: its fraction `t`, distance (m, negative where
/// the segment passes through the mesh) and the normal pushing it out.
///
/// A segment that enters the mesh through one triangle and leaves through
/// another, its ends outside, has cut a corner: it comes out of the
/// [`wedge`] of the two triangles' planes.
fn mesh_nearest(mesh: &TriMesh, a: Vec3, b: Vec3, reach: f32) -> Option<(f32, f32, Vec3)> {
    let pad = Vec3::splat(reach);
    // The first and last crossings (fraction, triangle); the nearest point
    // to a triangle (fraction, distance, direction out).
    let mut first: Option<(f32, usize)> = None;
    let mut last: Option<(f32, usize)> = None;
    let mut nearest: Option<(f32, f32, Vec3)> = None;
    let mut keep = |t: f32, d: f32, out: Vec3| {
        if nearest.is_none_or(|(_, best, _)| d < best) {
            nearest = Some((t, d, out));
        }
    };
    mesh.query(a.min(b) - pad, a.max(b) + pad, |i| {
        let tri = mesh.triangles[i];
        if let Some(t) = segment_triangle(a, b, tri) {
            if first.is_none_or(|(best, _)| t < best) {
                first = Some((t, i));
            }
            if last.is_none_or(|(best, _)| t > best) {
                last = Some((t, i));
            }
        }
        for k in 0..3 {
            let (t, q, e) = segments_nearest((a, b), (tri[k], tri[(k + 1) % 3]));
            keep(t, q.distance(e), q - e);
        }
        for (t, p) in [(0.0, a), (1.0, b)] {
            let c = closest_point_on_triangle(p, tri);
            keep(t, p.distance(c), p - c);
        }
    });
    if let (Some((t1, i1)), Some((t2, i2))) = (first, last) {
        if i1 == i2 {
            return None;
        }
        // Each plane's normal faces the end on its side.
        let facing = |i: usize, towards: Vec3| {
            let n = mesh.normals[i];
            if (towards - mesh.triangles[i][0]).dot(n) < 0.0 {
                -n
            } else {
                n
            }
        };
        return wedge(
            a,
            b,
            (a.lerp(b, t1), facing(i1, a)),
            (a.lerp(b, t2), facing(i2, b)),
        );
    }
    let (t, d, out) = nearest?;
    let n = out.normalize_or_zero();
    (n != Vec3::ZERO).then_some((t, d, n))
}

/// The nearest points of segments `p0 → p1` and `q0 → q1` (m): the
/// fraction along the first, its point, and the second's point.
pub(crate) fn segments_nearest(
    (p0, p1): (Vec3, Vec3),
    (q0, q1): (Vec3, Vec3),
) -> (f32, Vec3, Vec3) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let tiny = 1e-12;
    let (s, u) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > tiny * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut u = (b * s + f) / e;
            if u < 0.0 {
                u = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if u > 1.0 {
                u = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, u)
        }
    };
    (s, p0 + d1 * s, q0 + d2 * u)
}

#[cfg(test)]
mod tests;
