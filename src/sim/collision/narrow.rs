//! The paper's triangle–triangle test (MODEL.md §8.1) and the collision
//! response of MODEL.md §8.2, as pure functions.

use bevy::math::Vec3;

/// Whether an edge of `b` pierces triangle `a`: the paper's test in one
/// direction (MODEL.md §8.1, after Kaiser).
///
/// 1. The plane of `a`: `N = (a₁ − a₀) × (a₂ − a₀)`, `d = −N·a₀`.
/// 2. An edge `(p, q)` of `b` pierces the plane when `s_p·s_q < 0` with
///    `s = N·x + d` (strictly: an edge that only touches the plane does not).
/// 3. The crossing point `r = p + s_p/(s_p − s_q)·(q − p)` is inside `a` when
///    it is on the inner side of all three edges.
pub fn edges_pierce(a: [Vec3; 3], b: [Vec3; 3]) -> bool {
    let n = (a[1] - a[0]).cross(a[2] - a[0]);
    if n.length_squared() < 1e-24 {
        return false;
    }
    let d = -n.dot(a[0]);
    for (p, q) in [(b[0], b[1]), (b[1], b[2]), (b[2], b[0])] {
        let (sp, sq) = (n.dot(p) + d, n.dot(q) + d);
        if sp * sq >= 0.0 {
            continue;
        }
        let r = p + (q - p) * (sp / (sp - sq));
        let inside = (0..3).all(|k| (a[(k + 1) % 3] - a[k]).cross(r - a[k]).dot(n) >= 0.0);
        if inside {
            return true;
        }
    }
    false
}

/// The paper's triangle–triangle intersection test, run in both directions
/// as MODEL.md §8.1 requires (an edge of either triangle piercing the
/// other). Touching without crossing (an edge lying in the other's plane, a
/// shared edge) and coplanar overlap are not intersections for this test.
pub fn triangles_intersect(a: [Vec3; 3], b: [Vec3; 3]) -> bool {
    edges_pierce(a, b) || edges_pierce(b, a)
}

/// The velocity after a contact, per MODEL.md §8.2, and the friction factor
/// it applied to the tangential relative velocity.
///
/// With `v_r = v − v_obj` and `n` the surface's outward unit normal, acting
/// only when `v_r·n < 0` (approaching):
/// `v_r' = −e·v_n + max(0, 1 − μ(1 + e)|v_n|/|v_t|)·v_t`, `v' = v_obj + v_r'`.
/// When separating the velocity is returned unchanged with factor 1.
///
/// Why not the paper's `V' = 2(V·N)N − V`: that mirrors `V` about the normal
/// *line* (the optics formula for a vector pointing away from the surface),
/// so it keeps the normal component and negates the tangential one: a
/// particle moving into the object keeps moving into it. The mirror about
/// the *plane* is `V − 2(V·N)N`; the formula here is that mirror with
/// restitution `e` ∈ [0, 1] and Coulomb friction `μ` ≥ 0, relative to a
/// moving object. Velocities in m/s.
pub fn respond(v: Vec3, v_obj: Vec3, n: Vec3, friction: f32, restitution: f32) -> (Vec3, f32) {
    let vr = v - v_obj;
    let vn_mag = vr.dot(n);
    if vn_mag >= 0.0 {
        return (v, 1.0);
    }
    let vn = vn_mag * n;
    let vt = vr - vn;
    let vt_len = vt.length();
    let factor = if vt_len > 1e-9 {
        (1.0 - friction * (1.0 + restitution) * (-vn_mag) / vt_len).max(0.0)
    } else {
        0.0
    };
    (v_obj - restitution * vn + factor * vt, factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [Vec3; 3] {
        [Vec3::from(a), Vec3::from(b), Vec3::from(c)]
    }

    /// Every case both ways round and with both windings: the answer must
    /// not depend on argument order or orientation.
    fn check(a: [Vec3; 3], b: [Vec3; 3], want: bool) {
        let flip = |t: [Vec3; 3]| [t[0], t[2], t[1]];
        for (x, y) in [
            (a, b),
            (b, a),
            (flip(a), b),
            (a, flip(b)),
            (flip(b), flip(a)),
        ] {
            assert_eq!(triangles_intersect(x, y), want, "{x:?} vs {y:?}");
        }
    }

    #[test]
    fn crossing_triangles_intersect() {
        // A horizontal triangle and a vertical one through its middle.
        let floor = tri([-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]);
        let wall = tri([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.2, 0.0, 0.1]);
        check(floor, wall, true);
        // Two links of a chain: each pierces the other only along one edge.
        let a = tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 2.0, 0.0]);
        let b = tri([1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [1.0, 3.0, 0.0]);
        check(a, b, true);
    }

    #[test]
    fn touching_coplanar_and_disjoint_do_not() {
        let floor = tri([-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]);
        // Standing on the floor, touching it along an edge.
        let on_edge = tri([-0.3, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 1.0, 0.0]);
        check(floor, on_edge, false);
        // Sharing an edge at an angle (a fold of the cloth).
        let hinge = tri([-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.5]);
        check(floor, hinge, false);
        // Coplanar and overlapping: the paper's test cannot see it.
        let coplanar = tri([-0.5, 0.0, -0.5], [0.5, 0.0, -0.5], [0.0, 0.0, 0.5]);
        check(floor, coplanar, false);
        // Above the floor, or beside it.
        let above = tri([-0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 1.5, 0.0]);
        check(floor, above, false);
        let beside = tri([3.0, -1.0, 0.0], [3.0, 1.0, 0.0], [3.2, 0.0, 0.1]);
        check(floor, beside, false);
    }

    #[test]
    fn response_reverses_the_normal_part_unlike_the_seed_formula() {
        let n = Vec3::Y;
        let v = Vec3::new(1.0, -1.0, 0.0);
        // The paper's formula keeps the particle going into the surface.
        let seed = 2.0 * v.dot(n) * n - v;
        assert!(seed.dot(n) < 0.0);
        // The mirror about the plane (e = 1, μ = 0) bounces it out.
        let (out, factor) = respond(v, Vec3::ZERO, n, 0.0, 1.0);
        assert_eq!(out, Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(factor, 1.0);
        // Inelastic: the normal part is removed, the tangential one kept.
        assert_eq!(respond(v, Vec3::ZERO, n, 0.0, 0.0).0, Vec3::X);
        // Friction: μ|v_n| = 0.5 of 1 m/s tangential is taken away.
        let (out, factor) = respond(v, Vec3::ZERO, n, 0.5, 0.0);
        assert!((out - Vec3::X * 0.5).length() < 1e-6 && (factor - 0.5).abs() < 1e-6);
        // Enough friction sticks it; separating velocities are untouched.
        assert_eq!(respond(v, Vec3::ZERO, n, 2.0, 0.0).0, Vec3::ZERO);
        assert_eq!(
            respond(Vec3::ONE, Vec3::ZERO, n, 2.0, 0.0),
            (Vec3::ONE, 1.0)
        );
    }

    #[test]
    fn response_is_relative_to_a_moving_object() {
        // A wall moving at 2 m/s along +X hits a particle at rest: it leaves
        // with the wall's speed (inelastic) or twice it (elastic).
        let (out, _) = respond(Vec3::ZERO, Vec3::X * 2.0, Vec3::X, 0.0, 0.0);
        assert_eq!(out, Vec3::X * 2.0);
        let (out, _) = respond(Vec3::ZERO, Vec3::X * 2.0, Vec3::X, 0.0, 1.0);
        assert_eq!(out, Vec3::X * 4.0);
    }
}
